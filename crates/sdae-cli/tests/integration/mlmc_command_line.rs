//! The `mlmc` subcommand on good and bad command lines: a quick run writes its report, bad
//! input is a named error with exit code 2, and a plan run merged from shards gives exactly
//! the unsharded estimate.

use crate::cli;
use crate::common::scratch;

use std::path::Path;

use cli::{ran, refused_before_running, study, text, usage_error};
use sdae_study::mlmc::report::REPORT_FILES;

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
        &["--coarsest 0", "at least 2 steps"],
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
    ran(&[
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
    let report = dir.join("mlmc/pendulum");
    for file in REPORT_FILES {
        assert!(report.join(file).exists(), "{file} missing");
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("alpha = ") && md.contains("| eps |"), "{md}");
    // The plan at once, and in two shards merged.
    ran(&["mlmc", "--plan", plan.to_str().unwrap(), "--out", out]);
    let unsharded = std::fs::read_to_string(report.join("plan-report.json")).unwrap();
    let shards = dir.join("shards");
    for shard in ["0/2", "1/2"] {
        ran(&[
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
    }
    let merged_out = dir.join("merged");
    ran(&[
        "mlmc-merge",
        shards.join("mlmc/pendulum").to_str().unwrap(),
        "--out",
        merged_out.to_str().unwrap(),
    ]);
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

#[test]
fn counts_levels_and_threads_are_bounded_before_anything_runs() {
    let dir = scratch("mlmc-bounds");
    let out = dir.to_str().unwrap();
    let run = |extra: &[&str], words: &[&str]| {
        let mut args = vec!["mlmc", "--out", out];
        args.extend(extra);
        refused_before_running(&args, words, &dir);
    };
    run(
        &["--eps", "1e-300"],
        &["--eps 1e-300", "not a normal float", "2^-511"],
    );
    run(
        &["--test-samples", "1000000000000"],
        &["--test-samples 1000000000000", "available"],
    );
    run(
        &["--coarsest", "4294967295", "--max-level", "2"],
        &[
            "--coarsest 4294967295",
            "2^4294967297 steps",
            "above the 2^24",
        ],
    );
    run(&["--threads", "2000"], &["--threads", "at most 1024"]);
    run(&["--threads", "0"], &["--threads", "at least 1"]);
    run(&["--t-end", "5e-324"], &["--t-end 5e-324", "2^-511"]);
    // The same values from a scene's [mlmc] table are named by their keys and the file.
    std::fs::create_dir_all(&dir).unwrap();
    for (table, words) in [
        (
            "test_samples = 1000000000000",
            &["mlmc.test_samples = 1000000000000", "available"][..],
        ),
        ("eps = [1e-300]", &["mlmc.eps = 1e-300"][..]),
        (
            "coarsest = 4294967295\nmax_level = 2",
            &["mlmc.coarsest = 4294967295"][..],
        ),
    ] {
        let file = dir.join("scene.toml");
        let scene = include_str!("../../../sdae-study/scenes/pendulum.toml")
            .replace("name = \"pendulum\"", "name = \"test\"");
        std::fs::write(&file, format!("{scene}\n[mlmc]\n{table}\n")).unwrap();
        let mut all = words.to_vec();
        all.push(file.to_str().unwrap());
        refused_before_running(
            &["mlmc", "--scene-file", file.to_str().unwrap(), "--out", out],
            &all,
            &dir,
        );
    }
}

#[test]
fn an_accuracy_the_machine_cannot_hold_is_refused_by_name() {
    // Found from the convergence test's variances (seconds), before the adaptive runs.
    let dir = scratch("mlmc-tiny-eps");
    let out = dir.to_str().unwrap();
    let args = [
        "mlmc",
        "--eps",
        "1e-12",
        "--test-levels",
        "2",
        "--test-samples",
        "64",
        "--threads",
        "1",
        "--out",
        out,
    ];
    usage_error(&args, &["--eps 1e-12", "optimal N_l", "available"]);
    assert!(!dir.join("mlmc/pendulum/report.json").exists());
}

#[test]
fn plans_and_plan_files_are_checked_before_anything_runs() {
    let dir = scratch("mlmc-plans");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let plan = |name: &str, json: &str| {
        let file = dir.join(name);
        std::fs::write(&file, json).unwrap();
        file.to_str().unwrap().to_string()
    };
    let cases = [
        (
            plan("empty.json", r#"{"eps": 0.01, "samples": []}"#),
            vec!["plan.samples = []", "names no level"],
        ),
        (
            plan("negative.json", r#"{"eps": -1, "samples": [64, 64, 64]}"#),
            vec!["plan.eps = -1", "finite and > 0"],
        ),
        (
            plan(
                "huge.json",
                r#"{"eps": 0.01, "samples": [1000000000000000000, 64]}"#,
            ),
            vec!["plan.samples", "available"],
        ),
        (
            plan(
                "deep.json",
                &format!(r#"{{"eps": 0.01, "samples": {:?}}}"#, vec![64; 40]),
            ),
            vec!["plan.samples = 40 levels", "at most 23 levels"],
        ),
        (
            plan("garbage.json", "not a plan"),
            vec!["cannot read", "garbage.json"],
        ),
        (
            dir.join("missing.json").to_str().unwrap().to_string(),
            vec!["cannot read", "missing.json"],
        ),
    ];
    for (file, words) in &cases {
        let mut words = words.clone();
        words.push(file.rsplit('/').next().unwrap());
        usage_error(&["mlmc", "--plan", file, "--out", out], &words);
        usage_error(
            &["mlmc", "--plan", file, "--shard", "0/2", "--out", out],
            &words,
        );
    }
    // --write-plan into a folder that cannot be made (its parent is a file): refused first.
    let file = dir.join("a-file");
    std::fs::write(&file, "").unwrap();
    let target = file.join("plan.json");
    refused_before_running(
        &[
            "mlmc",
            "--write-plan",
            target.to_str().unwrap(),
            "--out",
            out,
        ],
        &["--write-plan", "a-file", "nothing was run"],
        Path::new(out),
    );
    // A truncated shard is refused by name (exit code 2).
    let shards = dir.join("shards");
    std::fs::create_dir_all(&shards).unwrap();
    std::fs::write(
        shards.join("mlmc-shard-0-of-1.json"),
        r#"{"identity": {"sce"#,
    )
    .unwrap();
    usage_error(
        &["mlmc-merge", shards.to_str().unwrap(), "--out", out],
        &["refusing", "mlmc-shard-0-of-1.json", "checksum"],
    );
}

/// `--qmc` adds the randomized QMC part to every file of the report, `mlqmc.svg` beside the
/// other plots; bad designs are named errors, and `--randomizations` needs `--qmc`.
#[test]
fn a_quasi_monte_carlo_run_writes_its_part_of_the_report() {
    let dir = scratch("mlmc-qmc");
    let out = dir.to_str().unwrap();
    let output = ran(&[
        "mlmc",
        "--scene",
        "rotor",
        "--observable",
        "cos_turn",
        "--quick",
        "--qmc",
        "--randomizations",
        "8",
        "--out",
        out,
    ]);
    assert!(
        text(&output.stdout).contains("MLQMC eps"),
        "{}",
        text(&output.stdout)
    );
    let report = dir.join("mlmc/rotor");
    assert!(report.join("mlqmc.svg").exists());
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(
        md.contains("## Multilevel quasi-Monte Carlo") && md.contains("R = 8"),
        "{md}"
    );
    let csv = std::fs::read_to_string(report.join("report.csv")).unwrap();
    assert!(csv.contains("mlqmc_eps,"), "{csv}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["qmc"]["settings"]["randomizations"], 8);
    usage_error(
        &[
            "mlmc",
            "--qmc",
            "--randomizations",
            "1",
            "--quick",
            "--out",
            out,
        ],
        &["--randomizations 1", "at least 2"],
    );
    usage_error(
        &[
            "mlmc",
            "--qmc",
            "--initial-points",
            "24",
            "--quick",
            "--out",
            out,
        ],
        &["--initial-points 24", "power of two"],
    );
    let refused = study(&["mlmc", "--randomizations", "8", "--quick", "--out", out]);
    assert_eq!(refused.status.code(), Some(2), "{}", text(&refused.stderr));
}
