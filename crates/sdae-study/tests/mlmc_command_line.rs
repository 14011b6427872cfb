//! The `mlmc` subcommand on good and bad command lines: a quick run writes its report, bad
//! input is a named error with exit code 2, and a plan run merged from shards gives exactly
//! the unsharded estimate.

mod cli;

use std::path::Path;

use cli::{study, text, usage_error};

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn bad_input_is_a_named_error_with_exit_code_2() {
    let out = scratch("mlmc-bad");
    let out = out.to_str().unwrap();
    usage_error(
        &["mlmc", "--eps", "0", "--out", out],
        &["eps = 0", "finite and > 0"],
    );
    usage_error(&["mlmc", "--eps=-1e-3", "--out", out], &["eps = -0.001"]);
    usage_error(&["mlmc", "--eps", "nan", "--out", out], &["eps = NaN"]);
    usage_error(
        &["mlmc", "--observable", "energie", "--quick", "--out", out],
        &["energie", "did you mean 'energy'?", "cos_angle"],
    );
    // Refused before the run's header line, and the scene named once.
    let refused = study(&["mlmc", "--observable", "energie", "--quick", "--out", out]);
    let stderr = text(&refused.stderr);
    assert!(!stderr.contains("MLMC of"), "{stderr}");
    assert_eq!(stderr.matches("scene pendulum").count(), 1, "{stderr}");
    usage_error(
        &["mlmc", "--coarsest", "0", "--quick", "--out", out],
        &["coarsest = 0", "at least 2 steps"],
    );
    usage_error(
        &[
            "mlmc",
            "--coarsest",
            "20",
            "--max-level",
            "10",
            "--out",
            out,
        ],
        &["levels", "2^30"],
    );
    usage_error(
        &[
            "mlmc",
            "--observable",
            "end_to_end",
            "--quick",
            "--out",
            out,
        ],
        &["end_to_end", "cos_angle"],
    );
}

#[test]
fn a_small_run_writes_its_report_and_a_merged_plan_equals_the_unsharded_run() {
    let dir = scratch("mlmc-quick");
    let out = dir.to_str().unwrap();
    let plan = dir.join("plan.json");
    let ran = study(&[
        "mlmc",
        "--test-samples",
        "512",
        "--eps",
        "2e-2",
        "--threads",
        "2",
        "--out",
        out,
        "--write-plan",
        plan.to_str().unwrap(),
    ]);
    assert_eq!(ran.status.code(), Some(0), "{}", text(&ran.stderr));
    let report = dir.join("mlmc/pendulum");
    for file in [
        "report.json",
        "report.csv",
        "report.md",
        "levels.svg",
        "samples.svg",
        "cost.svg",
    ] {
        assert!(report.join(file).exists(), "{file} missing");
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("alpha = ") && md.contains("| eps |"), "{md}");
    // The plan at once, and in two shards merged.
    let whole = study(&["mlmc", "--plan", plan.to_str().unwrap(), "--out", out]);
    assert_eq!(whole.status.code(), Some(0), "{}", text(&whole.stderr));
    let unsharded = std::fs::read_to_string(report.join("plan-report.json")).unwrap();
    let shards = dir.join("shards");
    for shard in ["0/2", "1/2"] {
        let ran = study(&[
            "mlmc",
            "--plan",
            plan.to_str().unwrap(),
            "--shard",
            shard,
            "--threads",
            "1",
            "--out",
            shards.to_str().unwrap(),
        ]);
        assert_eq!(ran.status.code(), Some(0), "{}", text(&ran.stderr));
    }
    let merged_out = dir.join("merged");
    let merged = study(&[
        "mlmc-merge",
        shards.join("mlmc/pendulum").to_str().unwrap(),
        "--out",
        merged_out.to_str().unwrap(),
    ]);
    assert_eq!(merged.status.code(), Some(0), "{}", text(&merged.stderr));
    let merged =
        std::fs::read_to_string(merged_out.join("mlmc/pendulum/plan-report.json")).unwrap();
    // Everything but the measured times is the same.
    let strip = |json: &str| {
        let mut v: serde_json::Value = serde_json::from_str(json).unwrap();
        strip_times(&mut v);
        v
    };
    assert_eq!(strip(&unsharded), strip(&merged));
}

/// Removes the measured run times (fields with "seconds" in their name).
fn strip_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(map) => {
            map.retain(|k, _| !k.contains("seconds"));
            map.values_mut().for_each(strip_times);
        }
        serde_json::Value::Array(items) => items.iter_mut().for_each(strip_times),
        _ => {}
    }
}
