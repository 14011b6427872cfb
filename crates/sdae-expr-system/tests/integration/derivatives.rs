//! Every derivative the compiler forms against central differences of what it differentiates:
//! Dg u, Dg^T z, D^2 g(u, w), the force -grad V and the observables, on the double pendulum,
//! the torus and the three-atom molecule, at points off the initial state.

use sdae_expr_system::ExpressionSystem;

use crate::{near, systems};

/// Step of the central differences (error O(h^2) ~ 1e-10 relative to the second derivative).
const H: f64 = 1e-5;

/// Central differences have error h^2 |f'''| / 6 plus rounding eps |f| / h: both ~1e-10 here.
const TOLERANCE: f64 = 1e-7;

fn assert_close(what: &str, found: &[f64], expected: &[f64]) {
    let scale = expected.iter().fold(1.0f64, |s, x| s.max(x.abs()));
    for (i, (a, b)) in found.iter().zip(expected).enumerate() {
        assert!(
            (a - b).abs() <= TOLERANCE * scale,
            "{what}[{i}]: {a} against the central difference {b}"
        );
    }
}

/// (f(x + h d) - f(x - h d)) / 2h for a vector-valued f.
fn central(f: impl Fn(&[f64]) -> Vec<f64>, x: &[f64], d: &[f64]) -> Vec<f64> {
    let shifted =
        |s: f64| -> Vec<f64> { x.iter().zip(d).map(|(xi, di)| xi + s * H * di).collect() };
    let (plus, minus) = (f(&shifted(1.0)), f(&shifted(-1.0)));
    plus.iter()
        .zip(minus)
        .map(|(p, m)| (p - m) / (2.0 * H))
        .collect()
}

/// Unit vector j of length n.
fn unit(n: usize, j: usize) -> Vec<f64> {
    (0..n).map(|k| if k == j { 1.0 } else { 0.0 }).collect()
}

/// The test points of a system: near its initial position.
fn points(system: &ExpressionSystem) -> Vec<Vec<f64>> {
    let r0 = system.initial_state().0;
    (1..4).map(|seed| near(r0, seed, 0.05)).collect()
}

#[test]
fn jacobian_products_are_central_differences_of_g() {
    for (name, system) in systems() {
        let g = system.expression_constraint();
        let (n, m) = (g.dim(), g.n_constraints());
        let value = |x: &[f64]| {
            let mut out = vec![0.0; m];
            g.value(x, &mut out);
            out
        };
        for (k, x) in points(&system).iter().enumerate() {
            let u = near(&vec![0.0; n], k + 7, 1.0);
            let mut product = vec![0.0; m];
            g.jacobian_mul(x, &u, &mut product);
            assert_close(&format!("{name}: Dg u"), &product, &central(value, x, &u));
            // Dg^T z: column j is d (z . g) / d x_j.
            let z = near(&vec![0.0; m], k + 3, 1.0);
            let mut transpose = vec![f64::NAN; n];
            g.jacobian_transpose_mul(x, &z, &mut transpose);
            let weighted = |y: &[f64]| vec![value(y).iter().zip(&z).map(|(a, b)| a * b).sum()];
            let columns: Vec<f64> = (0..n)
                .map(|j| central(weighted, x, &unit(n, j))[0])
                .collect();
            assert_close(&format!("{name}: Dg^T z"), &transpose, &columns);
        }
    }
}

#[test]
fn second_derivatives_are_central_differences_of_the_jacobian() {
    for (name, system) in systems() {
        let g = system.expression_constraint();
        let (n, m) = (g.dim(), g.n_constraints());
        for (k, x) in points(&system).iter().enumerate() {
            let (u, w) = (
                near(&vec![0.0; n], k + 11, 1.0),
                near(&vec![0.0; n], k + 5, 1.0),
            );
            let mut second = vec![0.0; m];
            g.second_derivative(x, &u, &w, &mut second);
            let along_w = |y: &[f64]| {
                let mut out = vec![0.0; m];
                g.jacobian_mul(y, &w, &mut out);
                out
            };
            assert_close(
                &format!("{name}: D^2 g(u, w)"),
                &second,
                &central(along_w, x, &u),
            );
            // Symmetric in (u, w).
            let mut swapped = vec![0.0; m];
            g.second_derivative(x, &w, &u, &mut swapped);
            assert_close(&format!("{name}: D^2 g(w, u)"), &swapped, &second);
        }
    }
}

/// The force is -grad V, V evaluated as an observable of the same text; the forces and
/// friction are off where v = 0 (the double pendulum's drag vanishes with v).
#[test]
fn forces_are_minus_central_differences_of_the_potential() {
    for (name, spec) in [
        ("double pendulum", crate::double_pendulum()),
        ("torus", crate::torus()),
        ("molecule", crate::molecule()),
    ] {
        let system = ExpressionSystem::compile(&spec).unwrap();
        let potential = system
            .compile_observable(spec.potential.as_deref().unwrap())
            .unwrap();
        let n = system.coordinates().len();
        let rest = vec![0.0; n];
        for x in points(&system) {
            let mut force = vec![0.0; n];
            system.evaluate_drift(&x, &rest, &mut force);
            let v = |y: &[f64]| vec![-potential.value(y, &rest)];
            let expected: Vec<f64> = (0..n).map(|j| central(v, &x, &unit(n, j))[0]).collect();
            assert_close(&format!("{name}: -grad V"), &force, &expected);
        }
    }
}

/// The double pendulum's drag -k v |v| and the torus' friction -gamma v, by their formulas.
#[test]
fn velocity_forces_are_their_formulas() {
    let systems = systems();
    let (_, pendulum) = &systems[0];
    let x = pendulum.initial_state().0.to_vec();
    let v = [0.3, -0.2, 1.1, 0.4];
    let (mut with_v, mut at_rest) = ([0.0; 4], [0.0; 4]);
    pendulum.evaluate_drift(&x, &v, &mut with_v);
    pendulum.evaluate_drift(&x, &[0.0; 4], &mut at_rest);
    let speed = (v[2] * v[2] + v[3] * v[3]).sqrt();
    for j in 2..4 {
        let drag = with_v[j] - at_rest[j];
        assert!((drag + 0.3 * v[j] * speed).abs() < 1e-14, "{drag}");
    }
    assert_eq!(pendulum.langevin_form(), None, "the drag reads v");
    let (_, torus) = &systems[1];
    let x = torus.initial_state().0.to_vec();
    let v = [0.0, 0.7, 0.2];
    let (mut with_v, mut at_rest) = ([0.0; 3], [0.0; 3]);
    torus.evaluate_drift(&x, &v, &mut with_v);
    torus.evaluate_drift(&x, &[0.0; 3], &mut at_rest);
    for j in 0..3 {
        assert!((with_v[j] - at_rest[j] + 0.5 * v[j]).abs() < 1e-15);
    }
    let form = torus.langevin_form().unwrap();
    assert_eq!(form.friction, 0.5);
    assert_eq!(form.noise, (2.0f64 * 0.5 * 0.8).sqrt());
}

/// Observables against their formulas, and the energy's velocity gradient (M v) against
/// central differences.
#[test]
fn observables_are_their_formulas() {
    let systems = systems();
    let (_, pendulum) = &systems[0];
    let x = near(pendulum.initial_state().0, 2, 0.1);
    let v = [0.3, -0.2, 1.1, 0.4];
    assert_eq!(pendulum.observable("height").unwrap().value(&x, &v), x[3]);
    let energy = pendulum.observable("energy").unwrap();
    let kinetic = (v[0] * v[0] + v[1] * v[1]) / 2.0 + (v[2] * v[2] + v[3] * v[3]);
    let expected = kinetic + 9.81 * (x[1] + 2.0 * x[3]);
    assert!((energy.value(&x, &v) - expected).abs() < 1e-13);
    let of_v = |w: &[f64]| vec![energy.value(&x, w)];
    let momentum: Vec<f64> = (0..4).map(|j| central(of_v, &v, &unit(4, j))[0]).collect();
    assert_close(
        "energy's d/dv",
        &momentum,
        &[v[0], v[1], 2.0 * v[2], 2.0 * v[3]],
    );
    let (_, torus) = &systems[1];
    let angle = torus.observable("angle").unwrap();
    assert_eq!(
        angle.value(&[0.0, 2.5, 0.0], &[0.0; 3]),
        std::f64::consts::FRAC_PI_2
    );
    let (_, molecule) = &systems[2];
    let r0 = molecule.initial_state().0;
    let bond_angle = molecule.observable("angle").unwrap().value(r0, &[0.0; 9]);
    assert!((bond_angle - 1.8).abs() < 1e-14, "{bond_angle}");
}
