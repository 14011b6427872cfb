//! Integration tests of systems written as expressions, as one test binary: derivatives
//! against central differences, the pendulum against the built-in one, the refusals, the
//! lanes against one path bit for bit, the specification's forms.

mod derivatives;
mod fused;
mod lanes;
mod pendulum;
mod refusals;
mod spec;

use std::collections::BTreeMap;

use sdae_expr_system::{ExpressionSpec, ExpressionSystem, MassSpec, NoiseSpec};

/// A spec with the given coordinates, masses and constraints, at rest at `position`.
pub fn base_spec(coordinates: &[&str], constraints: &[&str], position: &[f64]) -> ExpressionSpec {
    ExpressionSpec {
        coordinates: Some(coordinates.iter().map(|s| s.to_string()).collect()),
        particles: None,
        dimension: None,
        mass: MassSpec::One(1.0),
        parameters: BTreeMap::new(),
        constraints: constraints.iter().map(|s| s.to_string()).collect(),
        potential: None,
        forces: None,
        friction: None,
        kt: None,
        noise: None,
        observables: BTreeMap::new(),
        position: position.to_vec(),
        velocity: None,
        project: false,
    }
}

/// Parameters from pairs.
pub fn parameters(pairs: &[(&str, f64)]) -> BTreeMap<String, f64> {
    pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
}

/// A planar double pendulum: masses 1 and 2 on rods L1 = 1 and L2 = 0.7, gravity c, a
/// velocity-dependent drag on the second mass and multiplicative noise on every coordinate.
pub fn double_pendulum() -> ExpressionSpec {
    let mut spec = base_spec(
        &["x1", "y1", "x2", "y2"],
        &[
            "(x1^2 + y1^2 - L1^2) / 2",
            "((x2 - x1)^2 + (y2 - y1)^2 - L2^2) / 2",
        ],
        &[0.6, -0.8, 0.6 + 0.7 * 0.28, -0.8 - 0.7 * 0.96],
    );
    spec.mass = MassSpec::Each(vec![1.0, 1.0, 2.0, 2.0]);
    spec.parameters = parameters(&[("L1", 1.0), ("L2", 0.7), ("c", 9.81), ("k", 0.3)]);
    spec.potential = Some("c * (y1 + 2 * y2)".into());
    spec.forces = Some(vec![
        "0".into(),
        "0".into(),
        "-k * v_x2 * sqrt(v_x2^2 + v_y2^2)".into(),
        "-k * v_y2 * sqrt(v_x2^2 + v_y2^2)".into(),
    ]);
    spec.noise = Some(NoiseSpec::Expressions(vec![
        "0.1".into(),
        "0.1".into(),
        "0.2 * (1 + v_x2^2)".into(),
        "0.2 * exp(-y2^2)".into(),
    ]));
    spec.observables = BTreeMap::from([
        ("height".into(), "y2".into()),
        (
            "energy".into(),
            "(v_x1^2 + v_y1^2) / 2 + (v_x2^2 + v_y2^2) + c * (y1 + 2 * y2)".into(),
        ),
    ]);
    // Tangent: the first rod turns at unit rate, the second rigidly with it.
    spec.velocity = Some(vec![0.8, 0.6, 0.8, 0.6]);
    spec
}

/// A particle on a torus (major radius R, minor radius a) under gravity, with friction and a
/// temperature: a Langevin system on a surface no built-in system describes.
pub fn torus() -> ExpressionSpec {
    let mut spec = base_spec(
        &["x", "y", "z"],
        &["(sqrt(x^2 + y^2) - R)^2 + z^2 - a^2"],
        &[2.5, 0.0, 0.0],
    );
    spec.mass = MassSpec::One(1.5);
    spec.parameters = parameters(&[("R", 2.0), ("a", 0.5), ("c", 1.0)]);
    spec.potential = Some("c * z".into());
    spec.friction = Some(0.5);
    spec.kt = Some(0.8);
    spec.observables = BTreeMap::from([("angle".into(), "atan2(y, x)".into())]);
    spec
}

/// A bent three-atom molecule (an oxygen-like centre, particle 1, and two light atoms) with
/// rigid bonds of length b and a harmonic potential on the bond angle.
pub fn molecule() -> ExpressionSpec {
    let theta: f64 = 1.8;
    let b = 0.96;
    let mut spec = base_spec(&[], &[], &[]);
    spec.coordinates = None;
    spec.particles = Some(3);
    spec.dimension = Some(3);
    spec.mass = MassSpec::Each(vec![16.0, 1.0, 1.0]);
    spec.parameters = parameters(&[("b", b), ("k", 5.0), ("theta0", 1.9)]);
    spec.constraints = vec![
        "((x2 - x1)^2 + (y2 - y1)^2 + (z2 - z1)^2 - b^2) / 2".into(),
        "((x3 - x1)^2 + (y3 - y1)^2 + (z3 - z1)^2 - b^2) / 2".into(),
    ];
    let (ux, uy, uz) = ("(x2 - x1)", "(y2 - y1)", "(z2 - z1)");
    let (wx, wy, wz) = ("(x3 - x1)", "(y3 - y1)", "(z3 - z1)");
    let dot = format!("({ux} * {wx} + {uy} * {wy} + {uz} * {wz})");
    let cross = format!(
        "sqrt(({uy} * {wz} - {uz} * {wy})^2 + ({uz} * {wx} - {ux} * {wz})^2 + ({ux} * {wy} - {uy} * {wx})^2)"
    );
    spec.potential = Some(format!("k / 2 * (atan2({cross}, {dot}) - theta0)^2"));
    spec.noise = Some(NoiseSpec::Intensities(vec![
        0.1, 0.1, 0.1, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3,
    ]));
    spec.observables = BTreeMap::from([("angle".into(), format!("atan2({cross}, {dot})"))]);
    spec.position = vec![
        0.0,
        0.0,
        0.0,
        b,
        0.0,
        0.0,
        b * theta.cos(),
        b * theta.sin(),
        0.0,
    ];
    spec
}

/// The three test systems, compiled.
pub fn systems() -> Vec<(&'static str, ExpressionSystem)> {
    [
        ("double pendulum", double_pendulum()),
        ("torus", torus()),
        ("molecule", molecule()),
    ]
    .into_iter()
    .map(|(name, spec)| (name, ExpressionSystem::compile(&spec).unwrap()))
    .collect()
}

/// A point near `x`, deterministic in `seed`.
pub fn near(x: &[f64], seed: usize, size: f64) -> Vec<f64> {
    x.iter()
        .enumerate()
        .map(|(i, xi)| xi + size * ((seed * 31 + i * 17) as f64 * 0.37).sin())
        .collect()
}
