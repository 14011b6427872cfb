//! Every refusal of a specification, each naming its entry (`SpecError::key`) and saying what
//! and by how much.

use sdae_expr_system::{
    ExpressionSpec, ExpressionSystem, MAX_COORDINATES, MassSpec, NoiseSpec, SpecError,
    SpecErrorKind,
};

use crate::{base_spec, double_pendulum, torus};

/// The refusal of `spec`, checked to name `key` and to say each of `words`.
fn refused(spec: &ExpressionSpec, key: &str, words: &[&str]) -> SpecError {
    let error = ExpressionSystem::compile(spec).expect_err("refused");
    let message = error.to_string();
    assert_eq!(error.key, key, "{message}");
    assert!(message.starts_with(key), "{message}");
    for word in words {
        assert!(message.contains(word), "`{word}` not in: {message}");
    }
    error
}

#[test]
fn a_parse_error_shows_the_expression_with_a_caret() {
    let mut spec = double_pendulum();
    spec.constraints[1] = "((x2 - x1)^2 + (y2 - y1)^2 - L2^2) / ".into();
    let error = refused(&spec, "constraints[1]", &["expected"]);
    let message = error.to_string();
    let lines: Vec<&str> = message.lines().collect();
    assert_eq!(lines.len(), 3, "{message}");
    assert_eq!(lines[0], "constraints[1]:");
    assert_eq!(lines[1], spec.constraints[1]);
    assert_eq!(
        lines[2].find('^'),
        Some(spec.constraints[1].len()),
        "{message}"
    );
}

#[test]
fn an_unknown_symbol_is_named_with_the_nearest_name() {
    let mut spec = double_pendulum();
    spec.potential = Some("c * (y1 + 2 * y3)".into());
    refused(&spec, "potential", &["unknown symbol `y3`", "did you mean"]);
    let mut spec = double_pendulum();
    spec.observables
        .insert("speed".into(), "sqrt(v_x2^2 + v_yy2^2)".into());
    refused(
        &spec,
        "observables.speed",
        &["`v_yy2`", "did you mean `v_y2`?"],
    );
    let mut spec = double_pendulum();
    spec.forces.as_mut().unwrap()[2] = "-kk * v_x2".into();
    refused(&spec, "forces[2]", &["`kk`", "did you mean `k`?"]);
    let mut spec = double_pendulum();
    spec.noise = Some(NoiseSpec::Expressions(vec![
        "0".into(),
        "0".into(),
        "t".into(),
        "0".into(),
    ]));
    refused(&spec, "noise[2]", &["unknown symbol `t`"]);
    let system = ExpressionSystem::compile(&double_pendulum()).unwrap();
    let error = system.compile_observable("x1 + z9").unwrap_err();
    assert_eq!(error.key, "observable");
    assert!(error.to_string().contains("`z9`"), "{error}");
}

#[test]
fn a_constraint_or_potential_that_reads_a_velocity_is_refused() {
    let mut spec = double_pendulum();
    spec.constraints[0] = "x1^2 + y1^2 - L1^2 + v_x1".into();
    refused(
        &spec,
        "constraints[0]",
        &["velocity `v_x1`", "coordinates alone"],
    );
    let mut spec = double_pendulum();
    spec.potential = Some("v_y1^2".into());
    refused(&spec, "potential", &["velocity `v_y1`"]);
}

#[test]
fn duplicate_and_reserved_names_are_refused() {
    let mut spec = double_pendulum();
    spec.coordinates.as_mut().unwrap()[2] = "x1".into();
    refused(&spec, "coordinates[2]", &["`x1`", "twice"]);
    let mut spec = double_pendulum();
    spec.coordinates.as_mut().unwrap()[0] = "t".into();
    refused(&spec, "coordinates[0]", &["`t`", "reserved"]);
    let mut spec = double_pendulum();
    spec.coordinates.as_mut().unwrap()[1] = "v_a".into();
    refused(&spec, "coordinates[1]", &["`v_a`", "velocities"]);
    let mut spec = double_pendulum();
    spec.coordinates.as_mut().unwrap()[3] = "sin".into();
    refused(&spec, "coordinates[3]", &["`sin`", "function"]);
    let mut spec = double_pendulum();
    spec.parameters.insert("x2".into(), 1.0);
    refused(&spec, "parameters.x2", &["`x2`", "twice"]);
    let mut spec = double_pendulum();
    spec.parameters.insert("pi".into(), 3.0);
    refused(&spec, "parameters.pi", &["`pi`"]);
    let mut spec = double_pendulum();
    spec.parameters.insert("big".into(), f64::INFINITY);
    refused(&spec, "parameters.big", &["inf", "finite"]);
}

#[test]
fn lists_of_the_wrong_length_are_refused() {
    let mut spec = double_pendulum();
    spec.mass = MassSpec::Each(vec![1.0, 2.0, 3.0]);
    refused(&spec, "mass", &["3 given, 4 expected"]);
    let mut spec = double_pendulum();
    spec.position.pop();
    refused(&spec, "position", &["3 given, 4 expected"]);
    let mut spec = double_pendulum();
    spec.velocity = Some(vec![0.0; 5]);
    refused(&spec, "velocity", &["5 given, 4 expected"]);
    let mut spec = double_pendulum();
    spec.forces = Some(vec!["0".into()]);
    refused(&spec, "forces", &["1 given, 4 expected"]);
    let mut spec = double_pendulum();
    spec.noise = Some(NoiseSpec::Intensities(vec![0.1, 0.2]));
    refused(&spec, "noise", &["2 given, 4 expected"]);
    let mut spec = double_pendulum();
    spec.noise = Some(NoiseSpec::Expressions(vec!["1".into(); 6]));
    refused(&spec, "noise", &["6 given, 4 expected"]);
}

#[test]
fn bad_masses_and_numbers_are_refused() {
    let mut spec = double_pendulum();
    spec.mass = MassSpec::Each(vec![1.0, 1.0, 0.0, 2.0]);
    refused(&spec, "mass", &["0 at index 2", "> 0"]);
    let mut spec = double_pendulum();
    spec.mass = MassSpec::One(f64::NAN);
    refused(&spec, "mass", &["NaN", "finite"]);
    let mut spec = crate::molecule();
    spec.mass = MassSpec::Each(vec![16.0, -1.0, 1.0]);
    refused(&spec, "mass", &["-1 at index 1"]);
    let mut spec = double_pendulum();
    spec.position[1] = f64::INFINITY;
    refused(&spec, "position", &["inf at index 1"]);
    let mut spec = torus();
    spec.friction = Some(-0.5);
    refused(&spec, "friction", &["-0.5", ">= 0"]);
    let mut spec = torus();
    spec.kt = Some(-1.0);
    refused(&spec, "kT", &["-1", ">= 0"]);
    let mut spec = double_pendulum();
    spec.noise = Some(NoiseSpec::Intensity(-0.1));
    refused(&spec, "noise", &["-0.1"]);
}

#[test]
fn friction_needs_kt_and_excludes_a_noise() {
    let mut spec = torus();
    spec.kt = None;
    refused(&spec, "kT", &["missing", "friction"]);
    let mut spec = torus();
    spec.friction = None;
    refused(&spec, "friction", &["missing", "kT"]);
    let mut spec = torus();
    spec.noise = Some(NoiseSpec::Intensity(1.0));
    refused(&spec, "noise", &["friction", "kT", "one or the other"]);
}

#[test]
fn coordinates_must_be_given_one_way() {
    let mut spec = double_pendulum();
    spec.particles = Some(2);
    spec.dimension = Some(2);
    refused(&spec, "coordinates", &["not both"]);
    let mut spec = double_pendulum();
    spec.coordinates = None;
    refused(&spec, "coordinates", &["missing"]);
    let mut spec = crate::molecule();
    spec.dimension = Some(4);
    refused(&spec, "dimension", &["1, 2 or 3"]);
    let mut spec = double_pendulum();
    spec.constraints.clear();
    refused(&spec, "constraints", &["0 constraints", "1 <= m < n"]);
}

#[test]
fn a_rank_deficient_jacobian_is_named_with_its_rank() {
    // The second constraint is twice the first: Dg has rank 1.
    let spec = base_spec(
        &["x", "y", "z"],
        &["x^2 + y^2 - 1", "2 * x^2 + 2 * y^2 - 2"],
        &[1.0, 0.0, 0.0],
    );
    let error = refused(&spec, "constraints", &["rank 1", "2 constraints"]);
    assert!(matches!(
        error.kind,
        SpecErrorKind::RankDeficient { rank: 1, m: 2, .. }
    ));
    // The torus' constraint on its axis: d sqrt(x^2 + y^2) / dx = 0 / 0.
    let mut spec = torus();
    spec.position = vec![0.0, 0.0, 1.5f64.sqrt()];
    refused(&spec, "constraints[0]", &["coordinate 0 is NaN"]);
    // A circle at its centre has grad g = 0: rank 0.
    let spec = base_spec(&["x", "y"], &["x^2 + y^2"], &[0.0, 0.0]);
    refused(&spec, "constraints", &["rank 0"]);
}

#[test]
fn an_initial_state_off_the_manifold_is_refused_with_its_residual() {
    let mut spec = double_pendulum();
    spec.position[0] = 0.7;
    refused(
        &spec,
        "position",
        &["|g(r0)| = ", "constraint 0", "project = true"],
    );
    let mut spec = double_pendulum();
    spec.velocity = Some(vec![1.0, 0.0, 1.0, 0.0]);
    let error = refused(&spec, "velocity", &["|Dg(r0) v0| = 6e-1", "constraint 0"]);
    assert!(
        matches!(error.kind, SpecErrorKind::OffManifold { index: 0, .. }),
        "{error}"
    );
}

#[test]
fn sizes_beyond_the_limits_are_refused() {
    let mut spec = crate::molecule();
    spec.particles = Some(MAX_COORDINATES);
    refused(&spec, "particles", &["coordinates", "limit of 1024"]);
    let mut spec = crate::molecule();
    spec.particles = Some(usize::MAX);
    refused(&spec, "particles", &["limit"]);
    let mut spec = double_pendulum();
    spec.potential = Some(format!("x1{}", " + x1".repeat(5000)));
    let error = refused(&spec, "potential", &["25002 is beyond the limit of 16384"]);
    assert!(
        error.to_string().len() < 600,
        "a long text is shown in part: {error}"
    );
    let mut spec = double_pendulum();
    spec.observables = (0..300)
        .map(|i| (format!("o{i}"), "x1".to_string()))
        .collect();
    refused(&spec, "observables", &["300 is beyond the limit of 256"]);
}
