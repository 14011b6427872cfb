//! The `expect` subcommand and `mlmc --method mlqmc`: a run writes its report and says which
//! estimator ran and why; bad input is a named error with exit code 2.

use crate::cli::{ran, text, usage_error};
use crate::common::scratch;

/// Runs `command` (expect or mlmc) on the rotor's cos_turn to eps = 0.02 with `extra`
/// arguments, writing into `out`; requires exit code 0 and returns stdout.
fn rotor(command: &str, extra: &[&str], out: &str) -> String {
    let scene = [
        "--scene",
        "rotor",
        "--observable",
        "cos_turn",
        "--eps",
        "2e-2",
    ];
    let args = [&[command][..], &scene, extra, &["--out", out]].concat();
    text(&ran(&args).stdout)
}

#[test]
fn expect_writes_its_report_with_every_estimator_s_prediction() {
    let dir = scratch("expect-rotor");
    let out = dir.to_str().unwrap();
    let samples = ["--test-samples", "512"];
    let stdout = rotor("expect", &samples, out);
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
    let stdout = rotor(
        "expect",
        &[&samples[..], &["--method", "rqmc"]].concat(),
        out,
    );
    assert!(stdout.contains("(rqmc), as asked"), "{stdout}");
}

#[test]
fn mlmc_runs_multilevel_qmc_alone_with_method_mlqmc() {
    let dir = scratch("mlmc-mlqmc-alone");
    let out = dir.to_str().unwrap();
    let stdout = rotor("mlmc", &["--method", "mlqmc", "--randomizations", "8"], out);
    assert!(stdout.contains("(mlqmc), as asked"), "{stdout}");
    assert!(dir.join("mlmc/rotor/mlqmc.json").exists());
    assert!(dir.join("mlmc/rotor/mlqmc.md").exists());
}

#[test]
fn bad_expect_input_is_a_named_error_with_exit_code_2() {
    let dir = scratch("expect-bad");
    let out = dir.to_str().unwrap();
    let refusals: [(&[&str], &[&str]); 5] = [
        (&["expect", "--eps", "0"], &["eps = 0", "finite and > 0"]),
        (
            &["expect", "--method", "mlqmcc"],
            &["mlqmcc", "mlmc, mlqmc, standard, rqmc"],
        ),
        (&["expect", "--pick-by", "time"], &["time"]),
        (
            &["expect", "--initial-points", "3"],
            &["--initial-points 3", "power of two"],
        ),
        (
            &["mlmc", "--randomizations", "8"],
            &["--randomizations", "--qmc or --method mlqmc"],
        ),
    ];
    for (args, words) in refusals {
        usage_error(&[args, &["--out", out]].concat(), words);
    }
}
