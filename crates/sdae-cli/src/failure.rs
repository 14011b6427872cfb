//! Why the program stops with a non-zero exit code, and how a library error names what the
//! user typed.

use sdae_study::StudyError;
use sdae_study::scene::escaped;

use crate::args;

/// Why the program stops with a non-zero exit code.
#[derive(Debug)]
pub enum Failure {
    /// The command line or a setting is wrong, or the run is refused before anything runs (an
    /// unusable or locked output folder, a bad checkpoint or shard) (exit code 2).
    Usage(String),
    /// The study ran and something could not be compared or saved (exit code 1).
    Failed(String),
    /// Stopped by a signal; the finished paths are saved (exit code 130).
    Interrupted(String),
    /// Stopped by a signal before any path finished, or the finished paths could not be saved
    /// (exit code 131).
    Unsaved(String),
}

impl Failure {
    /// A library error: wrong input is a usage error, the rest a failure. A setting is named
    /// by the command-line flags the user typed that make it ([`named`]), else by its
    /// scene-file key (or settings field); the names the user typed are shown escaped
    /// ([`shown`]).
    pub fn from_study(e: StudyError) -> Failure {
        let e = shown(e);
        match e {
            StudyError::Setting { key, value, rule } => {
                Failure::Usage(format!("{}: {rule}", named(key, &value)))
            }
            StudyError::Format { .. }
            | StudyError::Io { .. }
            | StudyError::Invalid { .. }
            | StudyError::Unknown(_)
            | StudyError::UnknownObservable { .. }
            | StudyError::ObservableNeedsOutput { .. }
            | StudyError::SchemeNotApplicable { .. }
            | StudyError::Resume { .. }
            | StudyError::Checksum { .. } => Failure::Usage(e.to_string()),
            other => Failure::Failed(other.to_string()),
        }
    }

    /// The same failure with `context` (a scene's name, say) in front, unless the message
    /// already begins with it (errors that name their scene themselves).
    pub fn within(self, context: &str) -> Failure {
        let prefixed = |m: String| {
            if m.starts_with(&format!("{context}: ")) {
                m
            } else {
                format!("{context}: {m}")
            }
        };
        match self {
            Failure::Usage(m) => Failure::Usage(prefixed(m)),
            Failure::Failed(m) => Failure::Failed(prefixed(m)),
            Failure::Interrupted(m) => Failure::Interrupted(m),
            Failure::Unsaved(m) => Failure::Unsaved(m),
        }
    }
}

impl From<StudyError> for Failure {
    fn from(e: StudyError) -> Failure {
        Failure::from_study(e)
    }
}

/// `e` with what the user typed in it (a scene's or an observable's name, a setting's value, a
/// scene file's name) shown with its control characters escaped ([`escaped`]): a name with a
/// newline or a NUL prints as `pend\nulum`, on one line.
fn shown(e: StudyError) -> StudyError {
    match e {
        StudyError::Setting { key, value, rule } => StudyError::Setting {
            key,
            value: escaped(&value),
            rule,
        },
        StudyError::Unknown(name) => StudyError::Unknown(escaped(&name)),
        StudyError::UnknownObservable {
            scene,
            name,
            nearest,
            known,
            refusal,
        } => StudyError::UnknownObservable {
            scene: escaped(&scene),
            name: escaped(&name),
            nearest,
            known,
            refusal,
        },
        StudyError::Invalid { scene, message } => StudyError::Invalid {
            scene: escaped(&scene),
            message,
        },
        StudyError::Io { file, message } => StudyError::Io {
            file: escaped(&file),
            message,
        },
        StudyError::Format { file, message } => StudyError::Format {
            file: escaped(&file),
            message,
        },
        other => other,
    }
}

/// How a refusal names the setting `key` of `value`: by the flags the user typed that make it,
/// its own with `value` (`--eps 0`) and those of the other values it is made of with the values
/// typed (`--max-level 30 with --coarsest 4`); by those others alone, the setting's key beside
/// them, when its own flag was not typed (`--initial-points 1099511627776 (with
/// mlqmc.randomizations = 32)`); else by its key (`mlmc.eps = 0`).
fn named(key: &str, value: &str) -> String {
    let others: Vec<String> = made_of(key)
        .iter()
        .filter_map(|f| args::typed_value(f).map(|v| format!("{f} {}", escaped(&v))))
        .collect();
    let others = others.join(" and ");
    match (flag(key), others.is_empty()) {
        (Some(flag), true) => format!("{flag} {value}"),
        (Some(flag), false) => format!("{flag} {value} with {others}"),
        (None, false) => format!("{others} (with {key} = {value})"),
        (None, true) => format!("{key} = {value}"),
    }
}

/// The flags of the other values a setting the library refuses as `key` is made of: the
/// samples of R randomizations of n_0 points (`mlqmc.randomizations`), a weak QMC run's paths R n
/// rounded from the scene's (`weak.paths`, when --paths is not typed), the finest level's
/// 2^(k0 + L_max) steps (`mlmc.max_level`).
fn made_of(key: &str) -> &'static [&'static str] {
    match key {
        "mlqmc.randomizations" => &["--initial-points"],
        "weak.paths" => &["--randomizations"],
        "mlmc.max_level" => &["--coarsest"],
        _ => &[],
    }
}

/// The command-line flag the user typed for a setting the library names by its scene-file key
/// or settings field; `None` when the value did not come from the command line (a scene file,
/// a default, or a flag of another subcommand).
pub fn flag(key: &str) -> Option<&'static str> {
    let flags: &[&'static str] = match key {
        "study.paths" => &["--paths"],
        "study.levels" => &["--levels"],
        "study.reference" => &["--ref-level"],
        "T" => &["--t-end", "--T"],
        "p" => &["--p"],
        "threads" => &["--threads"],
        "schemes" => &["--schemes"],
        "mlmc.eps" => &["--eps"],
        "mlmc.coarsest" => &["--coarsest"],
        "mlmc.max_level" => &["--max-level"],
        "mlmc.test_levels" => &["--test-levels"],
        "mlmc.test_samples" => &["--test-samples"],
        "mlmc.scheme" => &["--scheme"],
        "mlqmc.randomizations" => &["--randomizations"],
        "mlqmc.initial_points" => &["--initial-points"],
        "weak.randomizations" => &["--randomizations"],
        _ => &[],
    };
    flags.iter().copied().find(|flag| args::typed(flag))
}
