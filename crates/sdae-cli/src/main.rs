//! `sdae-study`: convergence, stability and equipartition studies of the schemes on built-in or
//! user scenes (run by `cargo xtask study`; `sdae-study --help` lists the options).

/// Prints a line on standard output; a closed output (`| head`) ends the printing, never the
/// study.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// Prints a line on standard error; a closed stream ends the printing, never the study.
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod args;
mod mlmc_cli;
mod runs;
mod shard;
mod stopping;

use clap::Parser;
use sdae_study::StudyError;
use std::process::ExitCode;

use args::{Cli, Command};
use stopping::{STOP, catch_signals};

/// Lane buffers start on cache lines: the lane ensembles run up to 20% faster
/// (docs/performance.md, "Where lane buffers start").
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

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
    /// by its command-line flag when the user typed that flag, else by its scene-file key (or
    /// settings field).
    pub fn from_study(e: StudyError) -> Failure {
        match e {
            StudyError::Setting { key, value, rule } => match flag(key) {
                Some(flag) => Failure::Usage(format!("{flag} {value}: {rule}")),
                None => Failure::Usage(format!("{key} = {value}: {rule}")),
            },
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

/// The command-line flag the user typed for a setting the library names by its scene-file key
/// or settings field; `None` when the value did not come from the command line (a scene file,
/// a default, or a flag of another subcommand).
fn flag(key: &str) -> Option<&'static str> {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => {
            catch_signals();
            runs::convergence(&cli.convergence, &STOP)
        }
        Some(Command::Convergence(args)) => {
            catch_signals();
            runs::convergence(&args, &STOP)
        }
        Some(Command::Stability(args)) => {
            catch_signals();
            runs::stability(&args, &STOP)
        }
        Some(Command::Equipartition(args)) => {
            catch_signals();
            runs::equipartition(&args, &STOP)
        }
        Some(Command::Weak(args)) => {
            catch_signals();
            runs::weak(&args, &STOP)
        }
        Some(Command::Merge(args)) => runs::merge(&args.dirs, &args.out.out),
        Some(Command::Trace(args)) => runs::trace(&args),
        Some(Command::Mlmc(args)) => {
            catch_signals();
            mlmc_cli::mlmc(&args, &STOP)
        }
        Some(Command::MlmcMerge(args)) => mlmc_cli::mlmc_merge(&args),
        Some(Command::Compare(args)) => runs::compare(&args.first, &args.second),
        Some(Command::List) => {
            runs::list();
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Usage(message)) => {
            note!("error: {message}\n\nFor more information, try '--help'.");
            ExitCode::from(2)
        }
        Err(Failure::Failed(message)) => {
            note!("error: {message}");
            ExitCode::FAILURE
        }
        Err(Failure::Interrupted(message)) => {
            note!("{message}");
            ExitCode::from(130)
        }
        Err(Failure::Unsaved(message)) => {
            note!("{message}");
            ExitCode::from(131)
        }
    }
}
