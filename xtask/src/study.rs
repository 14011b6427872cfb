//! `cargo xtask study`: builds the study binary in release mode and runs it.
//!
//! The work runs in `sdae-study` compiled with optimizations, not inside this debug-built task.
//! Without `--out`, results go to `<target>/study`. All options are passed on (`--help` lists
//! them).

use std::process::Command;

use crate::{TaskError, target_dir, workspace_root};

/// Runs `cargo run --release -p sdae-study -- <args>` from the workspace root.
pub fn run(args: &[String]) -> Result<(), TaskError> {
    let root = workspace_root()?;
    let target = target_dir()?;
    let mut pass_on: Vec<String> = args.to_vec();
    let wants_help = args.iter().any(|a| a == "--help" || a == "-h");
    if !wants_help && !args.iter().any(|a| a == "--out") {
        pass_on.push("--out".into());
        pass_on.push(target.join("study").display().to_string());
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(&root)
        .args(["run", "--release", "--quiet", "-p", "sdae-study", "--"])
        .args(&pass_on)
        .env("CARGO_TARGET_DIR", &target)
        .status()
        .map_err(|e| TaskError::Failed(format!("cannot start cargo: {e}")))?;
    match status.code() {
        Some(0) => Ok(()),
        Some(2) => Err(TaskError::Usage(
            "the study rejected its options (see above)".into(),
        )),
        _ => Err(TaskError::Failed(format!("the study failed ({status})"))),
    }
}
