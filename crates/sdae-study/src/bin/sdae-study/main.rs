//! `sdae-study`: convergence, stability and equipartition studies of the schemes on built-in or
//! user scenes (run by `cargo xtask study`; `sdae-study --help` lists the options).

mod args;
mod runs;
mod shard;

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use sdae_study::StudyError;

use args::{Cli, Command};

/// Raised by Ctrl-C or SIGTERM: no new path starts, and the finished ones are saved.
static STOP: AtomicBool = AtomicBool::new(false);

/// Why the program stops with a non-zero exit code.
#[derive(Debug)]
pub enum Failure {
    /// The command line or a setting is wrong (exit code 2).
    Usage(String),
    /// The study ran and something could not be compared or saved (exit code 1).
    Failed(String),
    /// Stopped by a signal; the finished paths are saved (exit code 130).
    Interrupted(String),
}

impl Failure {
    /// A library error: wrong input is a usage error, the rest a failure. Settings are named
    /// by their command-line flags.
    pub fn from_study(e: StudyError) -> Failure {
        match e {
            StudyError::Setting { key, value, rule } => {
                Failure::Usage(format!("{} {value}: {rule}", flag(key)))
            }
            StudyError::Format { .. }
            | StudyError::Io { .. }
            | StudyError::Invalid { .. }
            | StudyError::Unknown(_)
            | StudyError::UnknownObservable { .. }
            | StudyError::ObservableNeedsOutput { .. }
            | StudyError::SchemeNotApplicable { .. }
            | StudyError::Resume { .. } => Failure::Usage(e.to_string()),
            other => Failure::Failed(other.to_string()),
        }
    }

    /// The same failure with `context` (a scene's name, say) in front.
    pub fn within(self, context: &str) -> Failure {
        match self {
            Failure::Usage(m) => Failure::Usage(format!("{context}: {m}")),
            Failure::Failed(m) => Failure::Failed(format!("{context}: {m}")),
            Failure::Interrupted(m) => Failure::Interrupted(m),
        }
    }
}

impl From<StudyError> for Failure {
    fn from(e: StudyError) -> Failure {
        Failure::from_study(e)
    }
}

/// The command line's flag for a setting the library names by its scene-file key or settings
/// field.
fn flag(key: &str) -> &str {
    match key {
        "study.paths" => "--paths",
        "study.levels" => "--levels",
        "study.reference" => "--ref-level",
        "T" => "--t-end",
        "p" => "--p",
        "threads" => "--threads",
        "schemes" => "--schemes",
        other => other,
    }
}

/// Ctrl-C or SIGTERM raises [`STOP`]; a second one ends the program at once.
fn stop_on_signals() {
    let installed = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\nstopping: the paths in progress finish and are saved (again to abort)");
    });
    if let Err(e) = installed {
        eprintln!(
            "sdae-study: warning: cannot catch Ctrl-C and SIGTERM ({e}); an interrupted run saves nothing"
        );
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => {
            stop_on_signals();
            runs::convergence(&cli.convergence, &STOP)
        }
        Some(Command::Convergence(args)) => {
            stop_on_signals();
            runs::convergence(&args, &STOP)
        }
        Some(Command::Stability(args)) => {
            stop_on_signals();
            runs::stability(&args, &STOP)
        }
        Some(Command::Equipartition(args)) => {
            stop_on_signals();
            runs::equipartition(&args, &STOP)
        }
        Some(Command::Weak(args)) => {
            stop_on_signals();
            runs::weak(&args, &STOP)
        }
        Some(Command::Merge(args)) => runs::merge(&args.dirs, &args.out.out),
        Some(Command::Trace(args)) => runs::trace(&args),
        Some(Command::List) => {
            runs::list();
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Usage(message)) => {
            eprintln!("error: {message}\n\nFor more information, try '--help'.");
            ExitCode::from(2)
        }
        Err(Failure::Failed(message)) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
        Err(Failure::Interrupted(message)) => {
            eprintln!("{message}");
            ExitCode::from(130)
        }
    }
}
