//! Exact law of the free rotor: the planar unit pendulum without gravity and friction, with unit
//! noise in R^2. The angular velocity omega = r x v is a standard Brownian motion (Ito: d(r x v) =
//! r x P dw = t.dw), so omega(T) ~ N(omega0, T), theta(T) ~ N(theta0 + omega0 T, T^3/3) and
//! Cov(theta(T), omega(T)) = T^2/2. Tolerances are 4.5 standard errors of the estimators.

use sdae_scheme::{
    GaussianIncrements, Observer, PendulumParams, Stepper, StepperConfig, TimeGrid, pendulum,
    run_path,
};

/// Accumulates the unwrapped angle from consecutive positions.
struct Angle {
    theta: f64,
    previous: [f64; 2],
}

impl Observer for Angle {
    fn observe(&mut self, k: usize, _t: f64, r: &[f64], _v: &[f64], _mu: &[f64]) {
        if k > 0 {
            let [x, y] = self.previous;
            let cross = x * r[1] - y * r[0];
            let dot = x * r[0] + y * r[1];
            self.theta += cross.atan2(dot);
        }
        self.previous = [r[0], r[1]];
    }
}

#[test]
fn free_rotor_matches_its_gaussian_law() {
    let params = PendulumParams {
        gravity: 0.0,
        friction: 0.0,
        noise: 1.0,
        ..PendulumParams::default()
    };
    let system = pendulum(params).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (theta0, omega0, t_end) = (0.3_f64, 0.5_f64, 1.0_f64);
    let grid = TimeGrid::new(t_end, 500).unwrap();
    let paths = 6000;
    let (mut thetas, mut omegas) = (Vec::with_capacity(paths), Vec::with_capacity(paths));
    for i in 0..paths {
        let mut r = vec![theta0.cos(), theta0.sin()];
        let mut v = vec![-omega0 * theta0.sin(), omega0 * theta0.cos()];
        let mut angle = Angle {
            theta: theta0,
            previous: [0.0; 2],
        };
        let mut noise = GaussianIncrements::for_path(7, i as u64, 2);
        run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut angle).unwrap();
        thetas.push(angle.theta);
        omegas.push(r[0] * v[1] - r[1] * v[0]);
    }
    let n = paths as f64;
    let mean = |x: &[f64]| x.iter().sum::<f64>() / n;
    let (mt, mo) = (mean(&thetas), mean(&omegas));
    let var = |x: &[f64], m: f64| x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0);
    let (vt, vo) = (var(&thetas, mt), var(&omegas, mo));
    let cov = thetas
        .iter()
        .zip(&omegas)
        .map(|(a, b)| (a - mt) * (b - mo))
        .sum::<f64>()
        / (n - 1.0);

    let exact_vt = t_end.powi(3) / 3.0;
    let exact_vo = t_end;
    let exact_cov = t_end * t_end / 2.0;
    let z = 4.5;
    // Standard errors for Gaussian data: mean sqrt(s2/n), variance s2 sqrt(2/(n-1)),
    // covariance sqrt((s_x^2 s_y^2 + c^2)/(n-1)).
    let check = |what: &str, estimate: f64, exact: f64, se: f64| {
        assert!(
            (estimate - exact).abs() <= z * se,
            "{what}: {estimate} vs {exact} (se {se})"
        );
    };
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
    check(
        "Cov",
        cov,
        exact_cov,
        ((exact_vt * exact_vo + exact_cov * exact_cov) / (n - 1.0)).sqrt(),
    );
}
