//! The local size functional (`StepperConfig::local`, beyond the seed): on the benchmark's
//! 1000-bead chain at h = 1e-4 (ten times the benchmark's step) it takes every step with
//! C_eta = 0.5, a value that needs no scaling with the number of beads; on a unit sphere it is
//! the seed's functional, step for step.

use crate::common;

use sdae_model::{Scheme, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

/// Steps taken (of `steps`) before the first failure, from the benchmark's start.
fn steps_taken(config: StepperConfig, steps: usize, h: f64) -> usize {
    let system = common::chain_system(1000, 0.1);
    let mut r = system.constraint().zigzag(0.3);
    let mut v = vec![0.0; r.len()];
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let mut noise = GaussianIncrements::for_path(2026, 0, system.noise_dim());
    let mut dw = vec![0.0; system.noise_dim()];
    for k in 0..steps {
        noise.next_increment(h, &mut dw);
        if stepper.step(&mut r, &mut v, h, &dw).is_err() {
            return k;
        }
    }
    steps
}

#[test]
fn the_chain_benchmark_runs_at_a_tenfold_step_with_the_local_size() {
    let local = StepperConfig::new(0.5, f64::INFINITY).unwrap().local();
    assert_eq!(steps_taken(local, 1000, 1e-4), 1000);
}

#[test]
fn on_the_unit_circle_it_is_the_seeds_functional() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let seed = StepperConfig::new(0.5, f64::INFINITY).unwrap();
    let mut a = Stepper::new(system.clone(), seed).unwrap();
    let mut b = Stepper::new(system.clone(), seed.local()).unwrap();
    let (mut r1, mut v1) = (vec![0.6, -0.8], vec![2.4, 1.8]);
    let (mut r2, mut v2) = (r1.clone(), v1.clone());
    let mut noise = GaussianIncrements::for_path(7, 0, 2);
    let mut dw = [0.0; 2];
    let mut truncated = 0;
    for _ in 0..200 {
        noise.next_increment(0.05, &mut dw);
        let eta = a.step(&mut r1, &mut v1, 0.05, &dw).unwrap().eta;
        assert_eq!(eta, b.step(&mut r2, &mut v2, 0.05, &dw).unwrap().eta);
        truncated += usize::from(eta < 1.0);
    }
    assert_eq!((r1, v1), (r2, v2));
    assert!(truncated > 0);
}
