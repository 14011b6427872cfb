//! The stepper's own step of one path for a sphere (the pendulums) runs the ensemble's lane
//! form at W = 1; here it is checked against the general path (`Stepper::step_general`: the
//! ball solver's closed form on the constraint as a trait) bit for bit: the state, the outcome
//! with its certificate, kappa and lambda, the failures, and the steps the lane form leaves to
//! the general path (a root outside the theory's ball, a quadratic without a real root).

use crate::common::{lane_configs, noisy_pendulum};
use sdae_manifold::{DiagonalMass, IdentityMass, Sphere};
use sdae_model::{AdditiveNoise, MechanicalSystem, Scheme, StepResult, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};

const STEPS: usize = 3000;

/// A configuration per branch of the step: the lane tests' four ([`lane_configs`]: eta < 1
/// and = 1, rescaled noise, the local measure, the theory's finite ball, which rejects some
/// roots: the general path then decides), no truncation, the velocity monitor off.
fn configs<S: System>(system: &S) -> Vec<(&'static str, StepperConfig)>
where
    S::Constraint: sdae_manifold::TheoryBound,
{
    let mut configs = lane_configs(system);
    let practical = configs[0].1;
    configs.push(("untruncated", practical.untruncated()));
    configs.push(("unmonitored", practical.with_velocity_monitor(false)));
    configs
}

/// What a step leaves: the state, the outcome, kappa and lambda, or the failure, written with
/// `Debug`, which prints every f64 exactly (-0 and NaN included).
fn after<S: System>(stepper: &Stepper<S>, result: &StepResult, r: &[f64], v: &[f64]) -> String {
    match result {
        Ok(outcome) => format!(
            "{r:?} {v:?} {outcome:?} {:?} {:?}",
            stepper.kappa(),
            stepper.multiplier_increment()
        ),
        Err(failure) => format!("{failure:?}"),
    }
}

/// Steps one path with `step` and with `step_general` on the same increments (each from the
/// state the other reached, which is the same) and compares every step. Returns the number of
/// steps decided in one lane and of failed steps.
fn compare<S: System + Clone>(
    system: S, config: StepperConfig, h: f64, what: &str,
) -> (usize, usize) {
    let mut lanes = Stepper::new(system.clone(), config).unwrap();
    let mut general = Stepper::new(system, config).unwrap();
    let n = lanes.system().constraint_dim();
    let l = lanes.system().noise_dim();
    let (mut r, mut v) = (vec![0.0; n], vec![0.0; n]);
    r[0] = 1.5;
    v[1] = 0.7;
    let mut noise = GaussianIncrements::for_path(5, 0, l);
    let mut dw = vec![0.0; l];
    let (mut in_lane, mut failures) = (0, 0);
    for k in 0..STEPS {
        noise.next_increment(h, &mut dw);
        let (mut r1, mut v1) = (r.clone(), v.clone());
        let one = lanes.step(&mut r1, &mut v1, h, &dw);
        let (mut r2, mut v2) = (r.clone(), v.clone());
        let two = general.step_general(&mut r2, &mut v2, h, &dw);
        assert_eq!(
            after(&lanes, &one, &r1, &v1),
            after(&general, &two, &r2, &v2),
            "{what}, step {k}"
        );
        assert!(!general.last_step_in_one_lane());
        if one.is_ok() {
            in_lane += usize::from(lanes.last_step_in_one_lane());
            (r, v) = (r1, v1);
        } else {
            // A failed step leaves the state; the path goes on with the next increment.
            failures += 1;
        }
    }
    (in_lane, failures)
}

trait ConstraintDim {
    fn constraint_dim(&self) -> usize;
}

impl<S: System> ConstraintDim for S {
    fn constraint_dim(&self) -> usize {
        sdae_manifold::Constraint::dim(self.constraint())
    }
}

/// The lane form decides every step, except where roots leave the theory's ball (small at
/// this h: the general path rejects them too) and on the untruncated path (which runs away
/// and fails from some step on).
fn assert_decided(name: &str, in_lane: usize, what: &str) {
    if name == "theory" || name == "untruncated" {
        assert!(in_lane > 0, "{name}, {what}: no step decided in one lane");
    } else {
        assert_eq!(in_lane, STEPS, "{name}, {what}");
    }
}

#[test]
fn the_one_lane_step_is_the_general_step_bit_for_bit() {
    for dim in [2, 3] {
        let system = noisy_pendulum(dim);
        for (name, config) in configs(&system) {
            let (in_lane, _) = compare(system.clone(), config, 0.02, &format!("{name}, d = {dim}"));
            assert_decided(name, in_lane, &format!("d = {dim}"));
        }
    }
}

#[test]
fn a_diagonal_mass_and_a_closure_drift_step_in_one_lane_with_the_general_numbers() {
    let drift = |_r: &[f64], v: &[f64], out: &mut [f64]| {
        out[0] = -0.5 * v[0];
        out[1] = -0.5 * v[1] - 1.0;
        out[2] = -0.5 * v[2];
    };
    let system = MechanicalSystem::new(
        Sphere::new(3, 1.5).unwrap(),
        DiagonalMass::new(vec![2.0, 0.5, 1.0]).unwrap(),
        drift,
        AdditiveNoise::new(3.0, 3).unwrap(),
    )
    .unwrap();
    for (name, config) in configs(&noisy_pendulum(3)) {
        let (in_lane, _) = compare(system.clone(), config, 0.02, name);
        assert_decided(name, in_lane, "diagonal mass");
    }
}

#[test]
fn steps_the_lane_form_does_not_decide_fail_as_the_general_path_says() {
    // Untruncated with a large step: for fast paths y = r + h v leaves the quadratic without
    // a real root (seed Fig. 1b); the theory's ball rejects large roots. Both fail the same
    // way, and the paths go on from the state the failed step left.
    let system = MechanicalSystem::new(
        Sphere::new(2, 1.0).unwrap(),
        IdentityMass,
        sdae_model::ZeroDrift,
        AdditiveNoise::new(30.0, 2).unwrap(),
    )
    .unwrap();
    let untruncated = StepperConfig::new(1.0, f64::INFINITY)
        .unwrap()
        .untruncated();
    for (what, config) in [
        ("untruncated", untruncated),
        (
            "theory ball",
            StepperConfig::for_system(&system).unwrap().untruncated(),
        ),
    ] {
        let (in_lane, failures) = compare(system.clone(), config, 0.1, what);
        assert!(
            failures > 0,
            "{what}: no step failed, the fallback is untested"
        );
        assert!(in_lane > 0, "{what}: no step was decided in one lane");
    }
}
