//! Developer tasks: `cargo xtask <task> [options]` (the alias is in `.cargo/config.toml`).
//!
//! - `study`: the convergence study (the project's main job), results in `target/study/`.
//! - `bench`: speed benchmarks of the stepper and a summary in `target/bench/summary.json`.
//! - `cluster-check`: the Slurm job-array recipe of docs/cluster.md on a one-node cluster.
//! - `docs-check`: every page of `docs/` within its limit in lines.

mod bench;
mod cluster;
mod docs;
mod study;

use std::fmt;
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask <task> [options]

tasks:
  study [options]
        the convergence study (default: the seed's stochastic pendulum, all schemes), built
        in release mode; writes target/study/<scene>/report.json, .csv, .md and SVG plots
        (`cargo xtask study --help` lists the options, --quick runs in seconds)
  study merge DIR... [--out DIR]
        merge the shard files of `study --shard I/N` runs into the unsharded report
  study stability [--quick]
        the stability study of the stiff and extreme scenes: target/study/stability/
  study equipartition [--quick]
        kinetic temperature of the Langevin scenes against h and C_eta:
        target/study/equipartition/
  study weak [--quick] [--shard I/N|auto]
        weak errors of the scene's observables, weak orders and Richardson-Romberg
        extrapolation (default: the pendulum): target/study/<scene>/weak.md
  study mlmc [--quick] [--scene NAME] [--eps LIST] [--antithetic] [--resume|--fresh]
        multilevel Monte Carlo of E[f(X_T)] (default: the pendulum's E[cos phi_T]):
        convergence test, alpha, beta, gamma, complexity table; target/study/mlmc/<scene>/;
        an interrupted run saves its finished samples, --resume carries on from them
  study trace
        one path of each built-in scene as a picture: target/study/trace/
  study list
        the built-in scenes and the schemes
  cluster-check
        (as root) install Slurm and munge if missing, start a one-node cluster, run the
        quick study as a 4-task job array, merge, compare with the unsharded run, stop
        the daemons (docs/cluster.md)
  docs-check
        every page of docs/ within its limit in lines (performance.md 200, stability.md
        300, the others 600; xtask/src/docs.rs); exit code 1 names the pages over
  bench [--quick] [-- <criterion options>]
        run every benchmark of sdae-scheme and sdae-systems and write target/bench/summary.json
        (--quick: short warm-up and measurement times)
  help  print this message";

/// Why a task stopped.
#[derive(Debug)]
pub enum TaskError {
    /// The command line was wrong (exit code 2).
    Usage(String),
    /// The task ran and failed (exit code 1).
    Failed(String),
    /// A program the task ran has reported its failure; exit with its code.
    Reported(u8),
}

impl fmt::Display for TaskError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TaskError::Usage(message) | TaskError::Failed(message) => f.write_str(message),
            TaskError::Reported(code) => write!(f, "exit code {code}"),
        }
    }
}

impl std::error::Error for TaskError {}

/// The workspace root: the parent of this crate's directory.
pub fn workspace_root() -> Result<PathBuf, TaskError> {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.parent().map(PathBuf::from).ok_or_else(|| {
        TaskError::Failed(format!(
            "cannot find the workspace root: {} has no parent directory",
            manifest_dir.display()
        ))
    })
}

/// Cargo's target directory: `$CARGO_TARGET_DIR` (relative to the current directory, as cargo
/// reads it) or `<workspace root>/target`.
pub fn target_dir() -> Result<PathBuf, TaskError> {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) if !dir.is_empty() => {
            let dir = PathBuf::from(dir);
            if dir.is_absolute() {
                Ok(dir)
            } else {
                std::env::current_dir()
                    .map(|cwd| cwd.join(dir))
                    .map_err(|e| {
                        TaskError::Failed(format!("cannot read the current directory: {e}"))
                    })
            }
        }
        _ => Ok(workspace_root()?.join("target")),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((task, rest)) = args.split_first() else {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    };
    let result = match task.as_str() {
        "study" => study::run(rest),
        "bench" => bench::run(rest),
        "cluster-check" => cluster::run_check(rest),
        "docs-check" => docs::run(rest),
        "help" | "-h" | "--help" => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        other => Err(TaskError::Usage(format!("unknown task `{other}`"))),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(TaskError::Usage(message)) => {
            eprintln!("error: {message}\n\n{USAGE}");
            ExitCode::from(2)
        }
        Err(TaskError::Failed(message)) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
        Err(TaskError::Reported(code)) => ExitCode::from(code),
    }
}
