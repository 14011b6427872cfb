//! The `expect` subcommand and `mlmc --method mlqmc`: a run writes its report and says which
//! estimator ran and why; bad input is a named error with exit code 2.

use std::path::Path;

use crate::cli::{ran, text, usage_error};

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn expect_writes_its_report_with_every_estimator_s_prediction() {
    let dir = scratch("expect-rotor");
    let out = dir.to_str().unwrap();
    let args = [
        "expect",
        "--scene",
        "rotor",
        "--observable",
        "cos_turn",
        "--eps",
        "2e-2",
        "--test-samples",
        "512",
        "--out",
        out,
    ];
    let stdout = text(&ran(&args).stdout);
    assert!(stdout.contains("rotor: E[cos_turn(X_T)] = "), "{stdout}");
    assert!(
        stdout.contains("the cheapest predicted by work"),
        "{stdout}"
    );
    let report = dir.join("expect/rotor");
    for file in ["report.json", "report.md", "report.csv"] {
        assert!(report.join(file).exists(), "{file}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["predicted"].as_array().unwrap().len(), 4);
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("## Why the others lost"), "{md}");
    // Asked for one estimator, it runs that one.
    let mut asked = args.to_vec();
    asked.extend(["--method", "rqmc"]);
    let stdout = text(&ran(&asked).stdout);
    assert!(stdout.contains("(rqmc), as asked"), "{stdout}");
}

#[test]
fn mlmc_runs_multilevel_qmc_alone_with_method_mlqmc() {
    let dir = scratch("mlmc-mlqmc-alone");
    let out = dir.to_str().unwrap();
    let stdout = text(
        &ran(&[
            "mlmc",
            "--scene",
            "rotor",
            "--observable",
            "cos_turn",
            "--eps",
            "2e-2",
            "--method",
            "mlqmc",
            "--randomizations",
            "8",
            "--out",
            out,
        ])
        .stdout,
    );
    assert!(stdout.contains("(mlqmc), as asked"), "{stdout}");
    assert!(dir.join("mlmc/rotor/mlqmc.json").exists());
    assert!(dir.join("mlmc/rotor/mlqmc.md").exists());
}

#[test]
fn bad_expect_input_is_a_named_error_with_exit_code_2() {
    let dir = scratch("expect-bad");
    let out = dir.to_str().unwrap();
    usage_error(
        &["expect", "--eps", "0", "--out", out],
        &["eps = 0", "finite and > 0"],
    );
    usage_error(
        &["expect", "--method", "mlqmcc", "--out", out],
        &["mlqmcc", "mlmc, mlqmc, standard, rqmc"],
    );
    usage_error(&["expect", "--pick-by", "time", "--out", out], &["time"]);
    usage_error(
        &["expect", "--initial-points", "3", "--out", out],
        &["--initial-points 3", "power of two"],
    );
    usage_error(
        &["mlmc", "--randomizations", "8", "--out", out],
        &["--randomizations", "--qmc or --method mlqmc"],
    );
}
