//! The seed's pendulum written as expressions against the built-in one
//! (`sdae_systems::pendulum`): drift, noise, constraint, Gram matrix, kappa coefficients and
//! second derivative within 1e-13 relative at the same states.

use std::collections::BTreeMap;

use sdae_expr_system::{ExpressionSpec, ExpressionSystem, MassSpec};
use sdae_lanes::LaneWidth;
use sdae_manifold::{Constraint, Curvature, Equations, GramStructure, Scalar};
use sdae_model::{PathEnsemble, System};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

use crate::{base_spec, near, parameters};

const PARAMS: PendulumParams = PendulumParams {
    dim: 2,
    length: 1.3,
    gravity: 1.7,
    noise: 0.8,
    friction: 0.3,
};

/// The pendulum of `PARAMS` as expressions: the sphere's own g = (1 - |r|^2 / L^2) / 2, the
/// potential c y, friction and the temperature of the built-in noise.
fn spec() -> ExpressionSpec {
    let mut spec = base_spec(&[], &["(1 - (x1^2 + y1^2) / L^2) / 2"], &[0.0, -1.3]);
    spec.coordinates = None;
    spec.particles = Some(1);
    spec.dimension = Some(2);
    spec.mass = MassSpec::One(1.0);
    spec.parameters = parameters(&[("L", PARAMS.length), ("c", PARAMS.gravity)]);
    spec.potential = Some("c * y1".into());
    spec.friction = Some(PARAMS.friction);
    spec.kt = Some(PARAMS.noise * PARAMS.noise / (2.0 * PARAMS.friction));
    spec.observables = BTreeMap::from([("height".into(), "y1".into())]);
    spec
}

/// |a - b| <= 1e-13 max |b|, or 1e-13 for g, whose value on the circle is a cancellation of
/// terms of size 1/2.
fn assert_relative(what: &str, a: &[f64], b: &[f64]) {
    let floor = if what == "g" { 0.5 } else { f64::MIN_POSITIVE };
    let scale = b.iter().fold(floor, |s, x| s.max(x.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-13 * scale,
            "{what}[{i}]: {x} against {y}"
        );
    }
}

/// States on and off the circle, with velocities.
fn states() -> Vec<(Vec<f64>, Vec<f64>)> {
    (0..6)
        .map(|k| {
            let t = 0.4 + 0.9 * k as f64;
            let radius = 1.3 * (1.0 + 0.01 * k as f64);
            let r = vec![radius * t.sin(), -radius * t.cos()];
            (r, near(&[0.0, 0.0], k, 1.5))
        })
        .collect()
}

#[test]
fn the_pendulum_as_expressions_is_the_built_in_pendulum() {
    let built_in = pendulum(PARAMS).unwrap();
    let expressions = ExpressionSystem::compile(&spec()).unwrap();
    let scalar = expressions.with_shape::<Scalar>().unwrap();
    assert_eq!(
        expressions.expression_constraint().structure(),
        GramStructure::Scalar
    );
    assert!(Equations::is_quadratic(scalar.constraint()));
    // The rounding floor is the sphere's.
    let (found, expected) = (
        Equations::roundoff(scalar.constraint()),
        Constraint::roundoff(built_in.constraint()),
    );
    let floor = |r: sdae_manifold::Roundoff| r.floor(1.3);
    assert_relative("rounding floor", &[floor(found)], &[floor(expected)]);
    assert_eq!(expressions.noise_dim(), built_in.noise_dim());
    let (a, b) = (
        expressions.langevin().unwrap(),
        built_in.langevin().unwrap(),
    );
    assert_eq!(a.friction, b.friction);
    assert_relative("sigma", &[a.noise], &[b.noise]);
    for (r, v) in states() {
        let (mut da, mut db) = ([0.0; 2], [0.0; 2]);
        expressions.drift(&r, &v, &mut da);
        built_in.drift(&r, &v, &mut db);
        assert_relative("drift", &da, &db);
        let dw = [0.3, -0.7];
        let (mut na, mut nb) = ([0.1, 0.2], [0.1, 0.2]);
        expressions.add_noise(&r, &v, &dw, &mut na);
        built_in.add_noise(&r, &v, &dw, &mut nb);
        assert_relative("noise", &na, &nb);
        compare_constraints(scalar.constraint(), built_in.constraint(), &r, &v);
        let (ea, eb) = (
            Constraint::kappa_quadratic(scalar.constraint(), &r, &v, scalar.mass()),
            Constraint::kappa_quadratic(built_in.constraint(), &r, &v, built_in.mass()),
        );
        assert_relative("kappa coefficients", &ea.unwrap(), &eb.unwrap());
    }
}

/// g, Dg u, Dg^T z, Dg M^-1 grad g and D^2 g of two constraints at r (u = v).
fn compare_constraints<A: Curvature, B: Curvature>(a: &A, b: &B, r: &[f64], u: &[f64]) {
    let (mut x, mut y) = ([0.0; 2], [0.0; 2]);
    a.value(r, &mut x[..1]);
    b.value(r, &mut y[..1]);
    assert_relative("g", &x[..1], &y[..1]);
    a.jacobian_mul(r, u, &mut x[..1]);
    b.jacobian_mul(r, u, &mut y[..1]);
    assert_relative("Dg u", &x[..1], &y[..1]);
    a.jacobian_transpose_mul(r, &[0.7], &mut x);
    b.jacobian_transpose_mul(r, &[0.7], &mut y);
    assert_relative("Dg^T z", &x, &y);
    a.second_derivative(r, u, &[0.2, 0.9], &mut x[..1]);
    b.second_derivative(r, u, &[0.2, 0.9], &mut y[..1]);
    assert_relative("D^2 g(u, w)", &x[..1], &y[..1]);
}

#[test]
fn the_gram_matrices_agree() {
    let built_in = pendulum(PARAMS).unwrap();
    let expressions = ExpressionSystem::compile(&spec()).unwrap();
    let scalar = expressions.with_shape::<Scalar>().unwrap();
    for (r, v) in states() {
        let mut scratch = vec![0.0; 16];
        let (mut ga, mut gb) = (
            scalar.constraint().new_gram(),
            built_in.constraint().new_gram(),
        );
        let c = scalar.constraint();
        Constraint::cross_gram(c, &r, &v, scalar.mass(), &mut scratch, &mut ga);
        let b = built_in.constraint();
        Constraint::cross_gram(b, &r, &v, built_in.mass(), &mut scratch, &mut gb);
        assert_relative("Dg M^-1 grad g", &[ga.0], &[gb.0]);
        // The dense form of the same system gives the same number.
        let dense = expressions.constraint();
        let mut gd = dense.new_gram();
        Constraint::cross_gram(dense, &r, &v, expressions.mass(), &mut scratch, &mut gd);
        assert_relative("dense Dg M^-1 grad g", &[gd.get(0, 0)], &[gb.0]);
    }
}

/// Paths of the stepping check: two blocks of the widest lanes and a partial one.
const PATHS: usize = 19;

/// Each path's state after `steps` steps of the half-explicit stepper (practical C_eta = 1)
/// of `system`, in lanes of `width` (the increments the same for every system).
fn stepped<S: System + Clone>(
    system: S, config: StepperConfig, width: LaneWidth, steps: usize,
) -> Vec<Vec<f64>> {
    let stepper = Stepper::new(system, config).unwrap();
    let (r0, v0) = ([0.0, -1.3], [0.9, 0.0]);
    let mut ensemble = Ensemble::new(stepper, PATHS, &r0, &v0)
        .unwrap()
        .with_width(width);
    let stride = ensemble.stride();
    for k in 0..steps {
        let dw: Vec<f64> = (0..2 * stride)
            .map(|i| 0.05 * ((i * 7 + k * 13) as f64 * 0.61).sin())
            .collect();
        ensemble.step(1.0 / 64.0, &dw).unwrap();
    }
    assert_eq!(ensemble.failed_paths(), 0);
    (0..PATHS)
        .map(|p| {
            let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
            ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
            [r, v].concat()
        })
        .collect()
}

/// One step and twenty from the same states, of the built-in pendulum and of the expression
/// pendulum with its scalar and its dense Gram storage: within 1e-13 relative, in lanes and
/// path by path (W = 1).
#[test]
fn the_expression_pendulum_steps_as_the_built_in_one() {
    let built_in = pendulum(PARAMS).unwrap();
    let config = StepperConfig::for_system(&built_in)
        .and_then(|c| c.with_c_eta(1.0))
        .unwrap();
    let expressions = ExpressionSystem::compile(&spec()).unwrap();
    let scalar = expressions.with_shape::<Scalar>().unwrap();
    for width in [LaneWidth::One, LaneWidth::Best] {
        for steps in [1, 20] {
            let expected = stepped(built_in.clone(), config, width, steps);
            let found = stepped(scalar.clone(), config, width, steps);
            let dense = stepped(expressions.clone(), config, width, steps);
            if width == LaneWidth::Best {
                // The lanes step each path with the numbers of one path, bit for bit.
                let one = stepped(scalar.clone(), config, LaneWidth::One, steps);
                assert_eq!(found, one, "lanes against one path, {steps} steps");
            }
            for p in 0..PATHS {
                let what = format!("{width:?}, {steps} steps, path {p}");
                assert_relative(&what, &found[p], &expected[p]);
                assert_relative(&format!("dense, {what}"), &dense[p], &expected[p]);
            }
        }
    }
}
