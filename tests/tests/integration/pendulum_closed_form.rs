//! One step of the planar unit pendulum against its closed form (seed Section 5.1): for r on the
//! unit circle and v tangent, r' = (1 - kappa) r + eta h v with kappa = 1 - sqrt(1 - eta^2 h^2 |v|^2),
//! and v' = v + eta a h + dw - r lambda with lambda = r'.(v + eta a h + dw) / (r'.r).

use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use sdae_model::Scheme;
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

#[test]
fn one_step_matches_the_closed_form() {
    let params = PendulumParams {
        gravity: 1.3,
        friction: 0.4,
        noise: 1.0,
        ..PendulumParams::default()
    };
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2024);
    let mut truncated_steps = 0;
    for trial in 0..2000 {
        let c_eta = [0.25, 1.0, 4.0][trial % 3];
        let config = StepperConfig::new(c_eta, f64::INFINITY).unwrap();
        let mut stepper = Stepper::new(pendulum(params).unwrap(), config).unwrap();
        let theta: f64 = rng.random::<f64>() * std::f64::consts::TAU;
        let omega: f64 = (rng.random::<f64>() - 0.5) * 40.0;
        let h: f64 = 10f64.powf(-4.0 + 3.0 * rng.random::<f64>());
        let dw = [
            (rng.random::<f64>() - 0.5) * 2.0 * h.sqrt(),
            (rng.random::<f64>() - 0.5) * 2.0 * h.sqrt(),
        ];
        let r0 = [theta.cos(), theta.sin()];
        let v0 = [-omega * theta.sin(), omega * theta.cos()];
        let a = [
            -params.friction * v0[0],
            -params.gravity - params.friction * v0[1],
        ];

        let v_norm = omega.abs();
        let a_norm = a[0].hypot(a[1]);
        let eta = (c_eta / (v_norm.max(v_norm * v_norm).max(a_norm) * h)).min(1.0);
        let s = eta * h * v_norm;
        let kappa = 1.0 - (1.0 - s * s).sqrt();
        let r1 = [
            r0[0] + eta * h * v0[0] - r0[0] * kappa,
            r0[1] + eta * h * v0[1] - r0[1] * kappa,
        ];
        let p = [
            v0[0] + eta * a[0] * h + dw[0],
            v0[1] + eta * a[1] * h + dw[1],
        ];
        let lambda = (r1[0] * p[0] + r1[1] * p[1]) / (r1[0] * r0[0] + r1[1] * r0[1]);
        let v1 = [p[0] - r0[0] * lambda, p[1] - r0[1] * lambda];

        let (mut r, mut v) = (r0, v0);
        let report = stepper.step(&mut r, &mut v, h, &dw).unwrap();
        if report.eta < 1.0 {
            truncated_steps += 1;
        }
        let tol = 1e-13;
        assert!((report.eta - eta).abs() <= tol, "trial {trial}: eta");
        assert!(
            (stepper.kappa()[0] - kappa).abs() <= tol,
            "trial {trial}: kappa {} vs {kappa}",
            stepper.kappa()[0]
        );
        assert!(
            (stepper.multiplier_increment()[0] - lambda).abs() <= tol * (1.0 + lambda.abs()),
            "trial {trial}: lambda"
        );
        for i in 0..2 {
            assert!((r[i] - r1[i]).abs() <= tol, "trial {trial}: r[{i}]");
            assert!(
                (v[i] - v1[i]).abs() <= tol * (1.0 + v_norm),
                "trial {trial}: v[{i}]"
            );
        }
    }
    // Both branches of eq. 3.2 were exercised.
    assert!(
        truncated_steps > 100 && truncated_steps < 1900,
        "{truncated_steps}"
    );
}
