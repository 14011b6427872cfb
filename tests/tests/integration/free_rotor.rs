//! Exact law of the free rotor, for every scheme: the planar unit pendulum without gravity and
//! friction, with unit noise in R^2. The angular velocity omega = r x v / |r|^2 is a standard
//! Brownian motion (Ito: d(r x v) = r x P dw = t.dw), so omega(T) ~ N(omega0, T),
//! theta(T) ~ N(theta0 + omega0 T, T^3/3) and Cov(theta(T), omega(T)) = T^2/2. Tolerances are
//! 4.5 standard errors of the estimators. Schemes that keep the constraint must hold it to
//! rounding; the unprojected inherent-SDE solvers drift off it by O(h), not more.

use sdae_model::{Observer, Scheme, TimeGrid, run_path};
use sdae_noise::GaussianIncrements;
use sdae_reference::{
    EulerMaruyama, ProjectedEulerMaruyama, StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{Pendulum, PendulumParams, pendulum};

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

/// One scheme of the table: how to build it, its sample, and whether it keeps the constraint.
struct Case {
    name: &'static str,
    build: fn(Pendulum) -> Box<dyn Scheme<System = Pendulum>>,
    seed: u64,
    paths: usize,
    steps: usize,
    keeps_constraint: bool,
}

fn stepper(config: fn(&Pendulum) -> StepperConfig) -> impl Fn(Pendulum) -> Stepper<Pendulum> {
    move |system| {
        let config = config(&system);
        Stepper::new(system, config).unwrap()
    }
}

const CASES: [Case; 6] = [
    Case {
        name: "half-explicit, theory constants",
        build: |s| Box::new(stepper(|s| StepperConfig::for_system(s).unwrap())(s)),
        seed: 7,
        paths: 6000,
        steps: 500,
        keeps_constraint: true,
    },
    Case {
        name: "half-explicit, untruncated",
        build: |s| {
            Box::new(stepper(|s| {
                StepperConfig::for_system(s).unwrap().untruncated()
            })(s))
        },
        seed: 8,
        paths: 4000,
        steps: 200,
        keeps_constraint: true,
    },
    Case {
        name: "Euler-Maruyama",
        build: |s| Box::new(EulerMaruyama::new(s).unwrap()),
        seed: 11,
        paths: 4000,
        steps: 200,
        keeps_constraint: false,
    },
    Case {
        name: "truncated Euler-Maruyama",
        build: |s| Box::new(TruncatedEulerMaruyama::new(s).unwrap()),
        seed: 11,
        paths: 4000,
        steps: 200,
        keeps_constraint: false,
    },
    Case {
        name: "projected Euler-Maruyama",
        build: |s| Box::new(ProjectedEulerMaruyama::new(s).unwrap()),
        seed: 11,
        paths: 4000,
        steps: 200,
        keeps_constraint: true,
    },
    Case {
        name: "stochastic Heun",
        build: |s| Box::new(StochasticHeun::new(s).unwrap()),
        seed: 11,
        paths: 4000,
        steps: 200,
        keeps_constraint: false,
    },
];

/// Checks the law for one case; returns the largest |g(r_k)| and |Dg(r_k) v_k| over all paths.
fn check_law(case: &Case) -> (f64, f64) {
    let system = pendulum(PendulumParams {
        gravity: 0.0,
        friction: 0.0,
        noise: 1.0,
        ..PendulumParams::default()
    })
    .unwrap();
    let mut scheme = (case.build)(system);
    let (theta0, omega0, t_end) = (0.3_f64, 0.5_f64, 1.0_f64);
    let grid = TimeGrid::new(t_end, case.steps).unwrap();
    let mut residuals = (0.0_f64, 0.0_f64);
    let (mut thetas, mut omegas) = (Vec::new(), Vec::new());
    for i in 0..case.paths {
        let mut r = vec![theta0.cos(), theta0.sin()];
        let mut v = vec![-omega0 * theta0.sin(), omega0 * theta0.cos()];
        let mut angle = Angle {
            theta: theta0,
            previous: [0.0; 2],
        };
        let mut noise = GaussianIncrements::for_path(case.seed, i as u64, 2);
        let d = run_path(&mut scheme, &mut r, &mut v, grid, &mut noise, &mut angle).unwrap();
        residuals.0 = residuals.0.max(d.max_position_residual);
        residuals.1 = residuals.1.max(d.max_velocity_residual);
        thetas.push(angle.theta);
        omegas.push((r[0] * v[1] - r[1] * v[0]) / (r[0] * r[0] + r[1] * r[1]));
    }
    let n = case.paths as f64;
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
    let (exact_vt, exact_vo, exact_cov) = (t_end.powi(3) / 3.0, t_end, t_end * t_end / 2.0);
    let z = 4.5;
    // Standard errors for Gaussian data: mean sqrt(s2/n), variance s2 sqrt(2/(n-1)),
    // covariance sqrt((s_x^2 s_y^2 + c^2)/(n-1)).
    let check = |what: &str, estimate: f64, exact: f64, se: f64| {
        assert!(
            (estimate - exact).abs() <= z * se,
            "{}: {what}: {estimate} vs {exact} (se {se})",
            case.name
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
    residuals
}

#[test]
fn every_scheme_reproduces_the_free_rotor_law() {
    for case in &CASES {
        let (position, velocity) = check_law(case);
        if case.keeps_constraint {
            assert!(
                position < 1e-13 && velocity < 1e-13,
                "{}: |g| = {position:e}, |Dg v| = {velocity:e}",
                case.name
            );
        } else {
            assert!(
                position > 1e-8 && position < 0.05,
                "{}: |g| = {position:e}",
                case.name
            );
        }
    }
}
