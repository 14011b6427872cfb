//! `cargo xtask study`: builds the study binary in release mode and runs it.
//!
//! The work runs in `sdae-study` compiled with optimizations, not inside this debug-built task.
//! All options are passed on unchanged (`--help` lists them); the default output folder,
//! `<target>/study`, goes through `SDAE_STUDY_OUT`, so that the study reads the command line
//! exactly as typed (a missing value is reported for the option that lacks it).

use std::process::Command;

use crate::{TaskError, target_dir, workspace_root};

/// The study's default output folder (its `--out` overrides it).
const OUT: &str = "SDAE_STUDY_OUT";

/// Runs `cargo run --release -p sdae-cli -- <args>` from the workspace root.
pub fn run(args: &[String]) -> Result<(), TaskError> {
    let root = workspace_root()?;
    let target = target_dir()?;
    let out = std::env::var_os(OUT).unwrap_or_else(|| target.join("study").into_os_string());
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(&root)
        .args(["run", "--release", "--quiet", "-p", "sdae-cli", "--"])
        .args(args)
        .env("CARGO_TARGET_DIR", &target)
        .env(OUT, out)
        .status()
        .map_err(|e| TaskError::Failed(format!("cannot start cargo: {e}")))?;
    match status.code() {
        Some(0) => Ok(()),
        // The study has said what went wrong (and printed its one help text).
        Some(code) => Err(TaskError::Reported(u8::try_from(code).unwrap_or(1))),
        None => Err(TaskError::Failed(format!(
            "the study was stopped ({status})"
        ))),
    }
}
