//! Exact law of the free rotor (planar unit pendulum, no gravity or friction, unit noise): the
//! angular velocity omega = r x v / |r|^2 is a standard Brownian motion, omega(T) ~ N(omega0, T),
//! and the unwrapped angle has theta(T) ~ N(theta0 + omega0 T, T^3 / 3) (as in the workspace's
//! tests/tests/free_rotor.rs for the scheme). Tolerances are 4.5 standard errors.

mod common;

use sdae_reference::{
    ProjectedEulerMaruyama, ReferenceSolver, StochasticHeun, TruncatedEulerMaruyama,
    run_reference_path,
};
use sdae_scheme::{GaussianIncrements, Observer};

/// Accumulates the unwrapped angle from consecutive positions.
struct Angle {
    theta: f64,
    previous: [f64; 2],
}

impl Observer for Angle {
    fn observe(&mut self, k: usize, _t: f64, r: &[f64], _v: &[f64], _mu: &[f64]) {
        if k > 0 {
            let [x, y] = self.previous;
            self.theta += (x * r[1] - y * r[0]).atan2(x * r[0] + y * r[1]);
        }
        self.previous = [r[0], r[1]];
    }
}

/// Checks the law; returns the largest |g(r_k)| and |Dg(r_k) v_k| over all paths.
fn check_law<S: ReferenceSolver>(
    name: &str,
    solver: &mut S,
    paths: usize,
    steps: usize,
) -> (f64, f64) {
    let mut residuals = (0.0_f64, 0.0_f64);
    let (theta0, omega0, t_end) = (0.3_f64, 0.5_f64, 1.0_f64);
    let (mut thetas, mut omegas) = (Vec::with_capacity(paths), Vec::with_capacity(paths));
    for i in 0..paths {
        let mut r = vec![theta0.cos(), theta0.sin()];
        let mut v = vec![-omega0 * theta0.sin(), omega0 * theta0.cos()];
        let mut angle = Angle {
            theta: theta0,
            previous: [0.0; 2],
        };
        let mut noise = GaussianIncrements::for_path(11, i as u64, 2);
        let d = run_reference_path(solver, &mut r, &mut v, t_end, steps, &mut noise, &mut angle)
            .unwrap();
        residuals.0 = residuals.0.max(d.max_position_residual);
        residuals.1 = residuals.1.max(d.max_velocity_residual);
        thetas.push(angle.theta);
        omegas.push((r[0] * v[1] - r[1] * v[0]) / (r[0] * r[0] + r[1] * r[1]));
    }
    let n = paths as f64;
    let mean = |x: &[f64]| x.iter().sum::<f64>() / n;
    let var = |x: &[f64], m: f64| x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0);
    let (mt, mo) = (mean(&thetas), mean(&omegas));
    let (vt, vo) = (var(&thetas, mt), var(&omegas, mo));
    let z = 4.5;
    let check = |what: &str, estimate: f64, exact: f64, se: f64| {
        println!("{name}: {what} = {estimate:.4} (exact {exact:.4}, se {se:.4})");
        assert!(
            (estimate - exact).abs() <= z * se,
            "{name}: {what}: {estimate} vs {exact} (se {se})"
        );
    };
    let (exact_vt, exact_vo) = (t_end.powi(3) / 3.0, t_end);
    check("E omega", mo, omega0, (exact_vo / n).sqrt());
    check(
        "E theta",
        mt,
        theta0 + omega0 * t_end,
        (exact_vt / n).sqrt(),
    );
    check(
        "Var omega",
        vo,
        exact_vo,
        exact_vo * (2.0 / (n - 1.0)).sqrt(),
    );
    check(
        "Var theta",
        vt,
        exact_vt,
        exact_vt * (2.0 / (n - 1.0)).sqrt(),
    );
    residuals
}

#[test]
fn reference_solvers_reproduce_the_free_rotor_law() {
    let (paths, steps) = (4000, 200);
    let system = || common::planar(0.0, 1.0);
    let (position, _) = check_law(
        "truncated EM",
        &mut TruncatedEulerMaruyama::new(system()).unwrap(),
        paths,
        steps,
    );
    // Unprojected: the constraint drifts by O(h), but not more.
    println!("truncated EM: max |g(r)| = {position:e}");
    assert!(position > 1e-8 && position < 0.05, "{position}");
    check_law(
        "stochastic Heun",
        &mut StochasticHeun::new(system()).unwrap(),
        paths,
        steps,
    );
    let (position, velocity) = check_law(
        "projected EM",
        &mut ProjectedEulerMaruyama::new(system()).unwrap(),
        paths,
        steps,
    );
    println!("projected EM: max |g(r)| = {position:e}, max |Dg(r) v| = {velocity:e}");
    assert!(
        position < 1e-13 && velocity < 1e-13,
        "{position} {velocity}"
    );
}
