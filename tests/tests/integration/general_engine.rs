//! The sphere's fixed-size path in lanes (its closed-form kernels per dimension) is a path for
//! speed only: the general engine that every other constraint steps on (Newton over lanes,
//! with the closed form of a quadratic kappa system) gives the same numbers bit for bit on the
//! same sphere ([`NewtonOnly`]), with identity and diagonal masses, every branch of the step
//! (truncated or not, rescaled noise, the local measure, the theory's ball) and the failures.
//! The time each takes is in `pendulum_ensemble/step_only_general_engine`.

use crate::common::{ensemble_bits, lane_configs, noisy_pendulum};
use sdae_manifold::{DiagonalMass, IdentityMass, Mass, NewtonOnly, Sphere};
use sdae_model::{AdditiveNoise, MechanicalSystem, System};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::PendulumDrift;

/// Paths: not a multiple of any lane width, so that a group is partly filled.
const PATHS: usize = 37;

/// The pendulum of [`noisy_pendulum`] on `sphere` with `mass`.
fn pendulum_on<C, M>(
    sphere: C, mass: M, dim: usize,
) -> MechanicalSystem<C, M, PendulumDrift, AdditiveNoise>
where
    C: sdae_manifold::Constraint,
    M: Mass,
{
    let drift = PendulumDrift {
        gravity: 1.0,
        friction: 0.5,
    };
    MechanicalSystem::new(sphere, mass, drift, AdditiveNoise::new(3.0, dim).unwrap()).unwrap()
}

/// Every path's final state and failure after `steps` steps of `system` in an ensemble.
fn run<S: System + Clone>(
    system: S, config: StepperConfig, dim: usize, steps: usize,
) -> Vec<(Vec<u64>, Option<String>)> {
    let (mut r0, mut v0) = (vec![0.0; dim], vec![0.0; dim]);
    r0[0] = 1.5;
    v0[1] = 0.7;
    let stepper = Stepper::new(system, config).unwrap();
    let mut ensemble = Ensemble::new(stepper, PATHS, &r0, &v0).unwrap();
    ensemble_bits(&mut ensemble, steps, 11, 0.02)
}

#[test]
fn the_general_engine_steps_a_sphere_with_its_fixed_size_numbers() {
    for dim in [2, 3] {
        let sphere = Sphere::new(dim, 1.5).unwrap();
        for (name, config) in lane_configs(&noisy_pendulum(dim)) {
            let what = format!("{name}, d = {dim}");
            let fixed = run(pendulum_on(sphere, IdentityMass, dim), config, dim, 400);
            let general = run(
                pendulum_on(NewtonOnly(sphere), IdentityMass, dim),
                config,
                dim,
                400,
            );
            assert_eq!(fixed, general, "{what}");
            let masses: Vec<f64> = [2.0, 0.5, 1.0][..dim].to_vec();
            let mass = DiagonalMass::new(masses).unwrap();
            let fixed = run(pendulum_on(sphere, mass.clone(), dim), config, dim, 400);
            let general = run(pendulum_on(NewtonOnly(sphere), mass, dim), config, dim, 400);
            assert_eq!(fixed, general, "{what}, diagonal mass");
        }
    }
}

#[test]
fn the_untruncated_runaway_fails_alike_on_both_engines() {
    let sphere = Sphere::new(2, 1.5).unwrap();
    let config = StepperConfig::for_system(&noisy_pendulum(2))
        .unwrap()
        .untruncated();
    let fixed = run(pendulum_on(sphere, IdentityMass, 2), config, 2, 3000);
    let general = run(
        pendulum_on(NewtonOnly(sphere), IdentityMass, 2),
        config,
        2,
        3000,
    );
    assert!(
        fixed.iter().any(|(_, failure)| failure.is_some()),
        "no path failed"
    );
    assert_eq!(fixed, general);
}
