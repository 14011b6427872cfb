//! The one error type of the studies: scene files, settings, schemes, shards and output.
//!
//! Settings are named by their key in a scene file (`study.paths`) or, for those a scene file
//! does not hold, by their field in `ConvergenceSettings`
//! (`p`, `threads`); the command line names them by its flags where the user typed the value
//! there.

use std::path::PathBuf;

use sdae_model::ModelError;
use thiserror::Error;

use crate::catalog::BUILT_IN;

/// Why a study cannot run, or cannot save what it computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StudyError {
    /// The file is not valid TOML or does not fit the scene format (the message names the key).
    #[error("scene file {file}: {message}")]
    Format {
        /// The file (or `"<inline>"`).
        file: String,
        /// What is wrong, naming the key.
        message: String,
    },
    /// The file cannot be read.
    #[error("cannot read scene file {file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A value is out of range or the parts do not fit together.
    #[error("scene {scene}: {message}")]
    Invalid {
        /// The scene's name.
        scene: String,
        /// What is wrong.
        message: String,
    },
    /// No built-in scene of that name.
    #[error("no built-in scene '{0}' (built-in: {list})", list = BUILT_IN.map(|(n, _)| n).join(", "))]
    Unknown(String),
    /// A study setting is out of range.
    #[error("{key} = {value}: {rule}")]
    Setting {
        /// The setting's key in a scene file (`study.paths`) or its settings field (`p`).
        key: &'static str,
        /// The offending value, as written.
        value: String,
        /// What it must satisfy.
        rule: String,
    },
    /// A scheme does not apply to the scene's system.
    #[error("scheme {scheme} does not apply: {reason}")]
    SchemeNotApplicable {
        /// The scheme's name.
        scheme: String,
        /// Why.
        reason: String,
    },
    /// Shards that do not make up one study.
    #[error("cannot merge the shards: {reason}")]
    Merge {
        /// What does not fit.
        reason: String,
    },
    /// A report, shard or plot could not be written.
    #[error("cannot write {}: {message}", path.display())]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// The system's or the plotting library's message.
        message: String,
    },
    /// A shard or checkpoint file cannot be read, or is not one.
    #[error("cannot read {}: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system's or the JSON reader's message.
        message: String,
    },
    /// A checkpoint or shard file fails its checksum, or has none (written by an older
    /// version): changed after it was written, it is not read.
    #[error("refusing {}: {reason}", path.display())]
    Checksum {
        /// The file.
        path: PathBuf,
        /// Which part fails its checksum, and where.
        reason: String,
    },
    /// The paths saved by an interrupted run belong to another study than the one resumed.
    #[error("cannot resume from {}: {reason}", path.display())]
    Resume {
        /// The checkpoint file.
        path: PathBuf,
        /// What differs.
        reason: String,
    },
    /// Another run holds the lock of the results (the `sdae-study` command's run lock).
    #[error(
        "{} is held by process {pid} on host {host}: another run writes these results (wait \
         for it or use another --out; if that process is gone, remove the lock file)",
        path.display()
    )]
    Locked {
        /// The lock file.
        path: PathBuf,
        /// The process holding it (0 when the file names none).
        pid: u32,
        /// Its host.
        host: String,
    },
    /// The worker threads could not be started.
    #[error("cannot start {threads} worker threads: {message}")]
    Threads {
        /// How many were asked for.
        threads: usize,
        /// The thread pool's message.
        message: String,
    },
    /// A scene names an observable its system does not have.
    #[error(
        "scene {scene}: no observable '{name}'{hint} (observables of this system: {known}){why}",
        hint = nearest.as_ref().map_or(String::new(), |n| format!("; did you mean '{n}'?")),
        why = refusal.as_ref().map_or(String::new(), |r| format!(
            "; as an expression of the coordinates and velocities it is refused:\n{r}"
        ))
    )]
    UnknownObservable {
        /// The scene's name.
        scene: String,
        /// The name given.
        name: String,
        /// The closest known name, if one is close.
        nearest: Option<String>,
        /// The system's observables, comma-separated.
        known: String,
        /// For a system written as expressions: the compiler's refusal of the name as an
        /// expression of the coordinates and velocities (a parse error's text and caret line
        /// on lines of their own).
        refusal: Option<String>,
    },
    /// A scene names an observable that reads an output the scene does not compute.
    #[error(
        "scene {scene}: observable '{observable}' needs \"{output}\" in outputs, which the scene turns off"
    )]
    ObservableNeedsOutput {
        /// The scene's name.
        scene: String,
        /// The observable.
        observable: String,
        /// The output it reads, as a scene file spells it.
        output: &'static str,
    },
    /// A run stopped on request (Ctrl-C) before it finished.
    #[error("stopped before the run finished")]
    Stopped,
    /// A time grid or path plan of a study is invalid.
    #[error(transparent)]
    Model(#[from] ModelError),
}

impl StudyError {
    /// [`StudyError::Write`] for `path` from any error.
    pub fn write(path: impl Into<PathBuf>, error: impl std::fmt::Display) -> Self {
        StudyError::Write {
            path: path.into(),
            message: error.to_string(),
        }
    }
}
