//! The runaway bound of truncated steps (`sdae_scheme::runaway_bound`, beyond the seed): a fast
//! free rotor with friction, no noise. Below C_eta = 2 gamma L^2 / m its speed decays, above it
//! the speed grows without bound, with no failure and no warning but the truncated share.

use sdae_model::{NoObserver, TimeGrid, run_path};
use sdae_noise::IncrementSource;
use sdae_scheme::{Stepper, StepperConfig, runaway_bound};
use sdae_systems::{PendulumParams, pendulum};

/// No random numbers: the rotor is deterministic.
struct Quiet;

impl IncrementSource for Quiet {
    fn dim(&self) -> usize {
        0
    }
    fn next_increment(&mut self, _h: f64, _dw: &mut [f64]) {}
}

/// The speed after `steps` steps of h = 0.02 from speed 30, and the truncated share.
fn final_speed(c_eta: f64, friction: f64, steps: usize) -> (f64, f64) {
    let params = PendulumParams {
        gravity: 0.0,
        noise: 0.0,
        friction,
        ..PendulumParams::default()
    };
    let system = pendulum(params).unwrap();
    let config = StepperConfig::new(c_eta, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 30.0]);
    let grid = TimeGrid::new(0.02 * steps as f64, steps).unwrap();
    let d = run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut Quiet,
        &mut NoObserver,
    )
    .unwrap();
    ((v[0] * v[0] + v[1] * v[1]).sqrt(), d.truncated_fraction())
}

#[test]
fn truncated_steps_keep_a_rotor_bounded_only_below_the_bound() {
    // A unit rotor with gamma = 1: the bound is 2.
    let bound = runaway_bound(1.0, 1.0, 1.0);
    assert_eq!(bound, 2.0);
    for c_eta in [0.5, 1.5] {
        let (speed, _) = final_speed(c_eta, 1.0, 20_000);
        assert!(speed < 1.0, "C_eta = {c_eta} < {bound}: speed {speed}");
    }
    for c_eta in [2.5, 10.0] {
        let (speed, truncated) = final_speed(c_eta, 1.0, 20_000);
        assert!(speed > 100.0, "C_eta = {c_eta} > {bound}: speed {speed}");
        assert!(
            truncated > 0.99,
            "a runaway is truncation-dominated: {truncated}"
        );
    }
    // Twice the friction doubles the bound: C_eta = 2.5 is then inside it.
    assert_eq!(runaway_bound(2.0, 1.0, 1.0), 4.0);
    assert!(final_speed(2.5, 2.0, 20_000).0 < 1.0);
}
