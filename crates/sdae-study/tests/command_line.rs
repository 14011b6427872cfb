//! The study binary on good and bad command lines: exit codes (0 ran, 1 ran but nothing to
//! compare, 2 usage), and messages that name the option and the nearest valid name.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The built-in pendulum scene under another name (so that its results get their own folder).
fn scene() -> String {
    include_str!("../scenes/pendulum.toml").replace("name = \"pendulum\"", "name = \"test\"")
}

fn study(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sdae-study"))
        .args(args)
        .env_remove("SDAE_STUDY_OUT")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("the study binary starts")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Asserts a usage error (exit code 2) whose message contains every one of `words`.
fn usage_error(args: &[&str], words: &[&str]) {
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

/// Runs the study, requires exit code 1 (it ran, nothing to compare) and returns stderr.
fn ran_but_failed(args: &[&str]) -> String {
    let out = study(args);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    stderr
}

/// A fresh folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn misspelled_subcommands_options_and_values_name_the_nearest_valid_one() {
    usage_error(&["stabilty", "--quick"], &["'stabilty'", "'stability'"]);
    usage_error(&["--path", "5"], &["'--path'", "--paths"]);
    usage_error(&["--scene", "pendulm"], &["'pendulm'", "'pendulum'"]);
    usage_error(&["--schemes", "euler"], &["'euler'", "'euler-maruyama'"]);
}

#[test]
fn options_a_subcommand_does_not_take_are_errors() {
    usage_error(&["stability", "--levels", "3..5"], &["'--levels'"]);
    usage_error(&["trace", "--paths", "5"], &["'--paths'"]);
    usage_error(&["merge"], &["DIR"]);
}

#[test]
fn values_are_checked_and_a_missing_value_is_named() {
    usage_error(&["--threads", "0"], &["--threads", "at least 1"]);
    usage_error(&["--paths"], &["--paths"]);
    usage_error(&["--paths", "--out", "x"], &["--paths"]);
    usage_error(&["--levels", "8..3"], &["--levels", "A..B"]);
    // --quick puts its reference above the levels given, and the levels are named.
    usage_error(&["--quick", "--levels", "3..70"], &["--levels 3..70"]);
    usage_error(&["--shard", "4/4"], &["--shard"]);
    // Settings the library checks are named by their flags.
    usage_error(&["--paths", "1", "--quick"], &["--paths 1: must be >= 2"]);
    usage_error(
        &["--shard", "auto", "--quick"],
        &["SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT"],
    );
}

#[test]
fn version_help_and_list_exit_0() {
    let out = study(&["--version"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).contains(env!("CARGO_PKG_VERSION")));
    let out = study(&["--help"]);
    assert_eq!(out.status.code(), Some(0));
    let help = text(&out.stdout);
    for word in [
        "stability",
        "equipartition",
        "merge",
        "trace",
        "--t-end",
        "--resume",
    ] {
        assert!(help.contains(word), "help lacks {word}:\n{help}");
    }
    let out = study(&["list"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).contains("stochastic-heun"));
}

#[test]
fn a_good_run_exits_0_and_t_end_has_its_old_spelling() {
    let dir = folder("good");
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene()).unwrap();
    for t in ["--t-end", "--T"] {
        let out = study(&[
            "--scene-file",
            path(&file),
            "--quick",
            "--paths",
            "4",
            t,
            "0.5",
            "--levels",
            "2..4",
            "--out",
            path(&dir),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        assert!(
            text(&out.stderr).contains("T = 0.5"),
            "{}",
            text(&out.stderr)
        );
        let report = std::fs::read_to_string(dir.join("test").join("report.json")).unwrap();
        assert!(report.contains("\"T\": 0.5,"), "{report}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_study_with_nothing_to_compare_exits_1_naming_the_failures() {
    let dir = folder("uncompared");
    let file = dir.join("fast.toml");
    // |v|^2 overflows: the reference fails on its first step, on every path.
    let fast = scene().replace("velocity = [1.0, 0.0]", "velocity = [1e200, 0.0]");
    assert_ne!(fast, scene());
    std::fs::write(&file, fast).unwrap();
    let args = ["--quick", "--paths", "4", "--scene-file", path(&file)];
    let stderr = ran_but_failed(&[&args[..], &["--out", path(&dir)]].concat());
    assert!(stderr.contains("failed on all 4 paths"), "{stderr}");
    assert!(stderr.contains("non-finite 4"), "{stderr}");
    // The report is still written.
    assert!(dir.join("test").join("report.json").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_huge_final_time_is_printed_readably_and_its_failures_exit_1() {
    let dir = folder("huge-t");
    let args = [
        "--quick",
        "--paths",
        "2",
        "--t-end",
        "1e300",
        "--out",
        path(&dir),
    ];
    let stderr = ran_but_failed(&args);
    assert!(stderr.contains("T = 1e300"), "{stderr}");
    assert!(stderr.contains("failed on all 2 paths"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}
