//! Running the study binary in tests that stop it: the command, its messages, its report's
//! numbers, signals, and what a stopped and resumed run may not leave behind.

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The study binary with the test's environment cleared of what would change its output.
pub fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_sdae-study"));
    command
        .env_remove("SDAE_STUDY_OUT")
        .env_remove("SLURM_JOB_ID")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    command
}

/// What the run printed on standard error.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A report's numbers: its JSON without timings and the thread count.
pub fn numbers(file: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{file:?}: {e}"));
    sdae_cli::compare::numbers_of(&text).unwrap()
}

/// Sends the signal `name` (TERM, INT, KILL, ...) to the child.
pub fn signal(child: &Child, name: &str) {
    let sent = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
}

/// Waits until `file` exists (the child saved a checkpoint) or the child ended.
pub fn wait_for(file: &Path, child: &mut Child) {
    let start = Instant::now();
    while !file.exists() && child.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(60), "no {file:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The checkpoint, lock and temporary files left in `dir`.
pub fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("checkpoint") || n.ends_with(".tmp"))
        .collect()
}

/// Asserts that the resumed run's `report` has the numbers of the uninterrupted run's `whole`
/// and that `folder` holds no checkpoint, lock or temporary file; then removes `dir`.
pub fn same_numbers_nothing_left(whole: &Path, report: &Path, folder: &Path, dir: &Path) {
    assert_eq!(numbers(whole), numbers(report));
    let left = leftovers(folder);
    assert!(left.is_empty(), "{left:?}");
    let _ = std::fs::remove_dir_all(dir);
}

/// The quick weak study on one thread over `paths` paths into `out`, with `extra` arguments.
pub fn quick_weak(out: &Path, paths: usize, extra: &[&str]) -> Command {
    let mut command = binary();
    let paths = paths.to_string();
    command
        .args(["weak", "--quick", "--threads", "1", "--paths", &paths])
        .args(extra)
        .arg("--out")
        .arg(out);
    command
}
