//! A system written as expressions (`[system.expressions]`) is refused before anything runs
//! (exit code 2) when its spec is wrong: each refusal names the spec's entry as
//! `system.expressions.<key>` with the compiler's message, a parse error with the expression's
//! text and a caret under the position.

use crate::cli;

use std::path::{Path, PathBuf};

use cli::{study, text, usage_error};

/// The double pendulum, the base of the broken scenes below.
const DOUBLE: &str = include_str!("../../../sdae-study/scenes/double-pendulum.toml");

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The double pendulum with `from` replaced by `to`, written to a file in `dir`.
fn broken(dir: &Path, from: &str, to: &str) -> PathBuf {
    assert!(DOUBLE.contains(from), "'{from}' not in the scene");
    let file = dir.join("broken.toml");
    std::fs::write(&file, DOUBLE.replacen(from, to, 1)).unwrap();
    file
}

/// Asserts that `subcommand` on the scene refuses it (exit code 2) with every one of `words`,
/// and that no study ran: no report in the output folder.
fn refused(dir: &Path, file: &Path, subcommand: &str, words: &[&str]) -> String {
    let out = dir.join("out");
    let args = [
        subcommand,
        "--scene-file",
        file.to_str().unwrap(),
        "--quick",
        "--out",
        out.to_str().unwrap(),
    ];
    usage_error(&args, words);
    assert!(
        !out.join("double-pendulum").exists(),
        "{args:?} wrote a report"
    );
    text(&study(&args).stderr)
}

#[test]
fn a_parse_error_names_its_key_and_shows_the_caret() {
    let dir = scratch("expressions-parse");
    let file = broken(
        &dir,
        "\"(x2 - x1)^2 + (y2 - y1)^2 - L2^2\"",
        "\"(x2 - x1)^2 + * (y2 - y1)^2 - L2^2\"",
    );
    let stderr = refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.constraints[1]", "double-pendulum"],
    );
    // The text, and the caret under the `*` on the line below it.
    let lines: Vec<&str> = stderr.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with("(x2 - x1)^2 + * (y2 - y1)^2 - L2^2"))
        .unwrap_or_else(|| panic!("no expression line in\n{stderr}"));
    let caret = lines[at + 1];
    assert_eq!(caret.find('^'), Some("(x2 - x1)^2 + ".len()), "{stderr}");
    // The scene file is named on the first line, not after the caret's message.
    let file_named = format!("(scene file {})", file.display());
    assert!(lines[at - 1].contains(&file_named), "{stderr}");
    assert!(!caret.contains("scene file"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_observable_named_in_a_study_is_compiled_and_a_text_that_does_not_compile_refused() {
    let dir = scratch("expressions-observable-text");
    let file = dir.join("double-pendulum.toml");
    std::fs::write(&file, DOUBLE).unwrap();
    // A text that is no observable's name and does not compile: the unknown name with the
    // nearest one, then the compiler's caret line under the text.
    let out = dir.join("out");
    let args = [
        "mlmc",
        "--scene-file",
        file.to_str().unwrap(),
        "--observable",
        "y2 + * x1",
        "--quick",
        "--out",
        out.to_str().unwrap(),
    ];
    usage_error(&args, &["no observable 'y2 + * x1'", "expected an operand"]);
    let stderr = text(&study(&args).stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    let at = lines
        .iter()
        .position(|l| *l == "y2 + * x1")
        .unwrap_or_else(|| panic!("no expression line in\n{stderr}"));
    assert_eq!(lines[at + 1].find('^'), Some("y2 + ".len()), "{stderr}");
    assert!(
        !out.join("double-pendulum").exists(),
        "a report was written"
    );
    // A text that compiles runs, its name in the report.
    let args = [
        "expect",
        "--scene-file",
        file.to_str().unwrap(),
        "--observable",
        "x2^2 + y2^2",
        "--eps",
        "0.2",
        "--out",
        out.to_str().unwrap(),
    ];
    let output = study(&args);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_symbols_and_parameters_are_named() {
    let dir = scratch("expressions-symbols");
    let file = broken(&dir, "\"g * (y1 + y2)\"", "\"gravity * (y1 + y2)\"");
    refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.potential", "gravity"],
    );
    let file = broken(&dir, "height = \"y2\"", "height = \"y3\"");
    refused(
        &dir,
        &file,
        "weak",
        &["system.expressions.observables.height", "y3"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_keys_and_wrong_types_in_the_table_are_named() {
    let dir = scratch("expressions-keys");
    let file = broken(&dir, "noise = 0.5", "noise = 0.5\nfrictoin = 1.0");
    refused(&dir, &file, "convergence", &["frictoin"]);
    let file = broken(&dir, "particles = 2", "particles = \"two\"");
    refused(&dir, &file, "convergence", &["particles"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn initial_states_off_the_manifold_and_dependent_constraints_are_refused() {
    let dir = scratch("expressions-state");
    let file = broken(
        &dir,
        "position = [0.6, -0.8, 1.4, -1.4]",
        "position = [0.6, -0.9, 1.4, -1.4]",
    );
    refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.position", "|g(r0)|", "project = true"],
    );
    // The same constraint twice: the Jacobian has rank 1 of 2.
    let file = broken(
        &dir,
        "\"(x2 - x1)^2 + (y2 - y1)^2 - L2^2\"",
        "\"2 * x1^2 + 2 * y1^2 - 2 * L1^2\"",
    );
    refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.", "rank 1"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_initial_table_beside_the_spec_is_refused() {
    let dir = scratch("expressions-initial");
    let file = broken(&dir, "[scheme]", "[initial]\nproject = true\n\n[scheme]");
    refused(
        &dir,
        &file,
        "convergence",
        &["initial", "system.expressions gives the initial state"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn observables_are_the_specs_and_the_kinetic_energy_name_is_taken() {
    let dir = scratch("expressions-observables");
    let file = broken(
        &dir,
        "observables = [\"height\", \"cos_angle2\", \"energy\"]",
        "observables = [\"hieght\"]",
    );
    refused(
        &dir,
        &file,
        "weak",
        &[
            "no observable 'hieght'",
            "did you mean 'height'",
            "cos_angle1",
        ],
    );
    let file = broken(&dir, "height = \"y2\"", "kinetic_energy = \"y2\"");
    refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.observables.kinetic_energy", "taken"],
    );
    // The energy reads the velocities, which a scene without "velocity" does not record.
    let file = broken(
        &dir,
        "outputs = [\"position\", \"velocity\", \"multiplier\"]",
        "outputs = [\"position\"]",
    );
    refused(&dir, &file, "weak", &["'energy' needs \"velocity\""]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sizes_beyond_the_limit_are_refused() {
    let dir = scratch("expressions-size");
    let file = broken(&dir, "particles = 2", "particles = 1000000000");
    refused(
        &dir,
        &file,
        "convergence",
        &["system.expressions.particles", "beyond the limit"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}
