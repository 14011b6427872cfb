//! The study binary run on a command line, for the tests of its command line: its output, the
//! check of a usage error and of a refusal before anything ran.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the study binary with `args`, without the environment that would change its output.
pub fn study(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sdae-study"))
        .args(args)
        .env_remove("SDAE_STUDY_OUT")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("the study binary starts")
}

/// Runs the study binary with `args`, asserts exit code 0 (naming the arguments and stderr if
/// not) and returns its output.
pub fn ran(args: &[&str]) -> Output {
    let out = study(args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        text(&out.stderr)
    );
    out
}

/// Bytes the program wrote, as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Asserts a usage error (exit code 2) whose message contains every one of `words`, with at
/// most one help text.
pub fn usage_error(args: &[&str], words: &[&str]) {
    let out = study(args);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    for word in words {
        assert!(stderr.contains(word), "{args:?}: '{word}' not in\n{stderr}");
    }
    assert!(
        stderr.matches("Usage:").count() <= 1,
        "two help texts:\n{stderr}"
    );
}

/// Asserts exit code 2 with every one of `words` in the message, and that no MLMC study ran:
/// no run header, no report in `out`.
pub fn refused_before_running(args: &[&str], words: &[&str], out: &Path) {
    usage_error(args, words);
    let stderr = text(&study(args).stderr);
    assert!(!stderr.contains("MLMC of"), "{args:?} ran: {stderr}");
    assert!(
        !out.join("mlmc/pendulum/report.json").exists(),
        "{args:?} wrote a report"
    );
}
