//! Hostile command lines are refused before anything runs (exit code 2), each refusal naming
//! the flags typed with their values: combinations the command cannot honour, a product of
//! values too large for memory, an output folder that cannot be written, and names with
//! control characters, shown escaped. A failure after the study ran is exit code 1, never 2.

use crate::cli;
use crate::common::scratch;

use std::path::{Path, PathBuf};

use cli::{ran, refused_before_running, study, text, usage_error};

#[test]
fn multilevel_qmc_is_not_sharded_and_plan_runs_take_no_qmc_flags() {
    let dir = scratch("refused-qmc-shard");
    let out = dir.to_str().unwrap();
    for shard in ["0/2", "auto"] {
        refused_before_running(
            &["mlmc", "--quick", "--qmc", "--shard", shard, "--out", out],
            &["--qmc", "--shard"],
            &dir,
        );
    }
    std::fs::create_dir_all(&dir).unwrap();
    let plan = dir.join("plan.json");
    std::fs::write(&plan, r#"{"eps": 0.01, "samples": [64, 64, 64]}"#).unwrap();
    let plan = plan.to_str().unwrap();
    for flag in ["--randomizations", "--initial-points"] {
        usage_error(
            &["mlmc", "--plan", plan, flag, "64", "--out", out],
            &["--plan", flag],
        );
    }
    usage_error(
        &["mlmc", "--plan", plan, "--write-plan", plan, "--out", out],
        &["--plan", "--write-plan"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_plan_is_refused_with_quick_and_a_test_too_short_for_it_is_a_failure_after_the_study() {
    let dir = scratch("refused-write-plan");
    let out = dir.to_str().unwrap();
    let plan = dir.join("plan.json");
    let plan = plan.to_str().unwrap();
    refused_before_running(
        &["mlmc", "--quick", "--write-plan", plan, "--out", out],
        &["--write-plan", "--quick", "nothing was run"],
        &dir,
    );
    // Levels 0..=2 do not bring the bias below eps / sqrt(2) at eps = 5e-3: the study ran and
    // wrote its report, no plan is written, and the exit code is 1 (not a refusal).
    let args = [
        "mlmc",
        "--test-levels",
        "2",
        "--test-samples",
        "256",
        "--eps",
        "5e-3",
        "--no-standard",
        "--write-plan",
        plan,
        "--out",
        out,
    ];
    let failed = study(&args);
    let stderr = text(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "{stderr}");
    for word in ["--write-plan", "no plan written", "--test-levels"] {
        assert!(stderr.contains(word), "'{word}' not in\n{stderr}");
    }
    assert!(dir.join("mlmc/pendulum/report.json").exists());
    assert!(!Path::new(plan).exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sets the permission bits of `path`.
fn set_mode(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// A folder that cannot be written: under a file (refused even for root), and a read-only
/// folder where permissions hold (not for root).
fn unwritable_folders(dir: &Path) -> Vec<PathBuf> {
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let mut folders = vec![file.join("out")];
    let read_only = dir.join("read-only");
    std::fs::create_dir_all(&read_only).unwrap();
    set_mode(&read_only, 0o555);
    if std::fs::write(read_only.join("probe"), "x").is_err() {
        folders.push(read_only);
    }
    folders
}

#[test]
fn merges_into_a_folder_that_cannot_be_written_are_refused_naming_out() {
    let dir = scratch("refused-merge-out");
    let shards = dir.join("shards");
    let s = shards.to_str().unwrap();
    ran(&[
        "--paths",
        "8",
        "--levels",
        "2..3",
        "--ref-level",
        "5",
        "--threads",
        "1",
        "--shard",
        "0/1",
        "--out",
        s,
    ]);
    std::fs::create_dir_all(&dir).unwrap();
    let plan = dir.join("plan.json");
    std::fs::write(&plan, r#"{"eps": 0.01, "samples": [64, 64, 64]}"#).unwrap();
    let plan = plan.to_str().unwrap();
    let args = ["mlmc", "--plan", plan, "--shard", "0/1", "--threads", "1"];
    ran(&[&args[..], &["--out", s]].concat());
    for out in unwritable_folders(&dir) {
        let out = out.to_str().unwrap();
        let scene = shards.join("pendulum");
        usage_error(
            &["merge", scene.to_str().unwrap(), "--out", out],
            &["--out", "cannot write"],
        );
        let mlmc = shards.join("mlmc/pendulum");
        usage_error(
            &["mlmc-merge", mlmc.to_str().unwrap(), "--out", out],
            &["--out", "cannot write"],
        );
    }
    set_mode(&dir.join("read-only"), 0o755);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_refusal_names_the_flag_typed_with_its_value() {
    let dir = scratch("refused-flags");
    let out = dir.to_str().unwrap();
    let run = |args: &[&str], words: &[&str]| {
        let args = [&["mlmc"][..], args, &["--out", out]].concat();
        refused_before_running(&args, words, &dir);
    };
    // R n_0 samples beyond memory: blamed on the factor typed, not on the default R.
    run(
        &["--qmc", "--initial-points", "1099511627776"],
        &[
            "scene pendulum: --initial-points 1099511627776",
            "available",
        ],
    );
    run(
        &[
            "--qmc",
            "--randomizations",
            "4000000000",
            "--initial-points",
            "1024",
        ],
        &["--randomizations 4000000000", "--initial-points 1024"],
    );
    // Level 0 alone above 2^24 steps, or with the scene's L_max: blamed on --coarsest.
    run(
        &["--coarsest", "60"],
        &["scene pendulum: --coarsest 60", "2^60 steps", "above"],
    );
    run(
        &["--coarsest", "20"],
        &["scene pendulum: --coarsest 20", "2^32 steps"],
    );
    // A weak QMC run's paths R n, rounded from the scene's: blamed on --randomizations.
    usage_error(
        &[
            "weak",
            "--qmc",
            "--randomizations",
            "1000000000000",
            "--out",
            out,
        ],
        &[
            "scene pendulum: --randomizations 1000000000000",
            "available",
        ],
    );
    assert!(!dir.join("pendulum").exists());
}

#[test]
fn typed_names_with_control_characters_are_shown_escaped() {
    let dir = scratch("refused-names");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.to_str().unwrap();
    let shown = |args: &[&str], escaped: &str| {
        let output = study(args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(escaped), "'{escaped}' not in\n{stderr}");
        let first = stderr.lines().next().unwrap_or("");
        assert!(first.contains(escaped), "not on one line:\n{stderr}");
        assert!(
            !stderr.contains('\0') && !stderr.contains('\u{1b}'),
            "{stderr:?}"
        );
    };
    shown(
        &["mlmc", "--scene", "pend\nulum", "--out", out],
        "'pend\\nulum'",
    );
    shown(
        &["mlmc", "--scene", "pend\u{1b}[2Julum", "--out", out],
        "'pend\\u{1b}[2Julum'",
    );
    shown(&["--schemes", "a\nb", "--out", out], "'a\\nb'");
    shown(
        &[
            "mlmc",
            "--quick",
            "--observable",
            "cos\nangle",
            "--out",
            out,
        ],
        "'cos\\nangle'",
    );
    shown(
        &["mlmc", "--quick", "--scheme", "g-\nbaoab", "--out", out],
        "--scheme g-\\nbaoab",
    );
    let scene = include_str!("../../../sdae-study/scenes/pendulum.toml");
    for (name, escaped) in [
        ("pend\\nulum", "pend\\nulum"),
        ("pend\\u0000ulum", "pend\\0ulum"),
    ] {
        let file = dir.join("scene.toml");
        let text = scene.replace("name = \"pendulum\"", &format!("name = \"{name}\""));
        std::fs::write(&file, text).unwrap();
        shown(
            &["mlmc", "--scene-file", file.to_str().unwrap(), "--out", out],
            &format!("name = '{escaped}'"),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
