//! Schemes written once over the number type ([`KernelScheme`], run by [`Kernelized`]): the
//! untruncated half-explicit step written as one gives the built-in stepper's numbers bit for
//! bit, path by path and in lanes at every width (the sphere's closed form, Newton over the
//! lane forms of a chain molecule and a rigid triatomic); its first step on a circle is the
//! closed form; a system without a lane form steps path by path with the same numbers; a
//! failing path stops with the typed one-path failure while the others go on in lanes; bad
//! input is a typed error.

use crate::common::ensemble_bits;
use sdae_lanes::{LaneWidth, Real};
use sdae_manifold::{ClosureConstraint, IdentityMass, Sphere};
use sdae_model::{
    AdditiveNoise, FailureKind, KernelNext, KernelOutcome, KernelScheme, KernelState, Kernelized,
    LaneEnsemble, MechanicalSystem, NoNoise, PathEnsemble, Scheme, StepFailure, StepKernel, System,
    ZeroDrift,
};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{
    ChainMoleculeParams, PendulumParams, RigidTriatomicParams, chain_molecule, pendulum,
    rigid_triatomic,
};

const PATHS: usize = 21;
const STEPS: usize = 150;

/// Seed eq. 3.1 with eta = 1 written over `T`: y = r + h v, v~ = v + M^-1 (h a + B dw), then
/// the constrained update; mu' = mu + lambda.
#[derive(Debug, Clone)]
struct UntruncatedHalfExplicit<S> {
    system: S,
}

impl<S: System + Clone + Send + Sync + 'static> KernelScheme for UntruncatedHalfExplicit<S> {
    type System = S;
    fn system(&self) -> &S {
        &self.system
    }
    #[inline(always)]
    fn step<T: Real, K: StepKernel<T>>(
        &self, kernel: &mut K, h: f64, state: KernelState<'_, T>, next: KernelNext<'_, T>,
    ) -> Result<KernelOutcome<T>, StepFailure> {
        let (r, v, tau) = (state.r, state.v, kernel.splat(h));
        for ((y, ri), vi) in next.work.iter_mut().zip(r).zip(v) {
            *y = *ri + tau * *vi;
        }
        kernel.free_velocity(r, v, state.dw, tau, next.v);
        let update = kernel.constrain(r, next.work, next.v, next.r, next.dmu)?;
        Ok(KernelOutcome::untruncated(update))
    }
}

/// Steps an ensemble through [`lane_increments`]; every path's bits and failure
/// ([`ensemble_bits`]).
fn run<E: PathEnsemble + ?Sized>(ensemble: &mut E, h: f64) -> Vec<(Vec<u64>, Option<String>)> {
    ensemble_bits(ensemble, STEPS, 17, h)
}

/// The kernel scheme in lanes at every width and path by path (W = 1 of the per-path loop is
/// the scheme's own step) against the built-in untruncated stepper in lanes; returns the
/// path-steps the lanes left to the one-path step at the widest width.
fn check_against_the_stepper<S: System + Clone + Send + Sync + 'static>(
    what: &str, system: &S, r0: &[f64], v0: &[f64], h: f64,
) -> usize {
    let config = StepperConfig::new(1.0, f64::INFINITY)
        .unwrap()
        .untruncated();
    let stepper = Stepper::new(system.clone(), config).unwrap();
    let mut built_in = Ensemble::new(stepper, PATHS, r0, v0).unwrap();
    let expected = run(&mut built_in, h);
    let scheme = UntruncatedHalfExplicit {
        system: system.clone(),
    };
    let mut path_loop =
        sdae_model::PathLoop::new(Kernelized::new(scheme.clone()).unwrap(), PATHS, r0, v0).unwrap();
    assert_eq!(run(&mut path_loop, h), expected, "{what}, path by path");
    let mut left = 0;
    for width in LaneWidth::ALL {
        let kernelized = Kernelized::new(scheme.clone()).unwrap();
        let mut lanes = LaneEnsemble::new(kernelized, PATHS, r0, v0)
            .unwrap()
            .with_width(width);
        assert_eq!(run(&mut lanes, h), expected, "{what}, {width:?}");
        left = lanes.scalar_steps();
    }
    left
}

#[test]
fn the_half_explicit_step_as_a_kernel_scheme_is_the_stepper_s_bit_for_bit() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let (r0, v0) = (vec![1.0, 0.0], vec![0.0, 0.5]);
    let left = check_against_the_stepper("pendulum", &system, &r0, &v0, 0.01);
    assert_eq!(
        left, 0,
        "the sphere's closed form decides every step in lanes"
    );

    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let (r0, v0) = molecule.initial_state();
    let left = check_against_the_stepper("chain molecule", &molecule, &r0, &v0, 5e-3);
    assert!(left < PATHS * STEPS / 100, "{left} one-path steps");

    let triatomic = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let (r0, v0) = triatomic.initial_state();
    let left = check_against_the_stepper("rigid triatomic", &triatomic, &r0, &v0, 5e-3);
    assert!(left < PATHS * STEPS / 100, "{left} one-path steps");
}

/// On the unit circle from r = (1, 0), v = (0, 1), without forces, one step is the closed
/// form r' = (sqrt(1 - h^2), h), v' = (-h / sqrt(1 - h^2), 1), one path and in lanes.
#[test]
fn a_step_on_the_circle_is_the_closed_form() {
    let circle = MechanicalSystem::new(
        Sphere::new(2, 1.0).unwrap(),
        IdentityMass,
        ZeroDrift,
        NoNoise,
    )
    .unwrap();
    let scheme = UntruncatedHalfExplicit { system: circle };
    let h = 0.1;
    let c = (1.0 - h * h).sqrt();
    let expected = [c, h, -h / c, 1.0];
    let mut one = Kernelized::new(scheme.clone()).unwrap();
    let (mut r, mut v) = ([1.0, 0.0], [0.0, 1.0]);
    one.step(&mut r, &mut v, h, &[]).unwrap();
    for (got, want) in r.iter().chain(&v).zip(expected) {
        assert!((got - want).abs() < 4.0 * f64::EPSILON, "{got} vs {want}");
    }
    let mut lanes = LaneEnsemble::new(
        Kernelized::new(scheme).unwrap(),
        5,
        &[1.0, 0.0],
        &[0.0, 1.0],
    )
    .unwrap()
    .with_width(LaneWidth::Four);
    lanes.step(h, &[]).unwrap();
    assert_eq!(lanes.scalar_steps(), 0);
    for p in 0..5 {
        let (mut rp, mut vp, mut mu) = ([0.0; 2], [0.0; 2], [0.0]);
        lanes.state(p, &mut rp, &mut vp, &mut mu).unwrap();
        assert_eq!((rp, vp), (r, v), "path {p}");
    }
}

/// A constraint given by closures has no lane form: the ensemble steps every path through the
/// one-path step, with its numbers.
#[test]
fn a_system_without_a_lane_form_steps_path_by_path() {
    let ellipse = ClosureConstraint::new(
        2,
        1,
        |x: &[f64], g: &mut [f64]| g[0] = 0.5 * (x[0] * x[0] / 4.0 + x[1] * x[1] - 1.0),
        |x: &[f64], u: &[f64], out: &mut [f64]| out[0] = x[0] * u[0] / 4.0 + x[1] * u[1],
        |x: &[f64], z: &[f64], out: &mut [f64]| {
            out[0] = x[0] * z[0] / 4.0;
            out[1] = x[1] * z[0];
        },
    )
    .unwrap();
    let noise = AdditiveNoise::new(0.5, 2).unwrap();
    let system = MechanicalSystem::new(ellipse, IdentityMass, ZeroDrift, noise).unwrap();
    let scheme = UntruncatedHalfExplicit { system };
    let (r0, v0) = ([0.0, -1.0], [0.8, 0.0]);
    let h = 0.01;
    let mut path_loop =
        sdae_model::PathLoop::new(Kernelized::new(scheme.clone()).unwrap(), PATHS, &r0, &v0)
            .unwrap();
    let expected = run(&mut path_loop, h);
    let mut lanes = LaneEnsemble::new(Kernelized::new(scheme).unwrap(), PATHS, &r0, &v0).unwrap();
    assert_eq!(run(&mut lanes, h), expected);
    assert_eq!(lanes.scalar_steps(), PATHS * STEPS);
}

/// A path started far too fast for its step has no kappa root: it fails with the one-path
/// failure (the fold of seed Fig. 1b), path by path and in lanes, while the others go on in
/// lanes; a step with the wrong number of increments is a typed input error.
#[test]
fn a_failing_path_stops_with_the_typed_failure_and_bad_input_is_an_error() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let scheme = UntruncatedHalfExplicit { system };
    let (r0, v0) = (vec![1.0, 0.0], vec![0.0, 0.5]);
    let too_fast = [0.0, 1e3];
    let mut one = Kernelized::new(scheme.clone()).unwrap();
    let (mut r, mut v) = (r0.clone(), too_fast.to_vec());
    let failure = one.step(&mut r, &mut v, 0.01, &[0.0, 0.0]).unwrap_err();
    assert_eq!(failure.kind(), FailureKind::NoRoot, "{failure}");
    assert_eq!(
        (r.as_slice(), v.as_slice()),
        (&r0[..], &too_fast[..]),
        "unchanged"
    );
    let bad = one
        .step(&mut r, &mut v, 0.01, &[0.0, 0.0, 0.0])
        .unwrap_err();
    assert!(matches!(bad, StepFailure::Input(_)), "{bad}");

    let mut lanes = LaneEnsemble::new(Kernelized::new(scheme).unwrap(), 8, &r0, &v0)
        .unwrap()
        .with_width(LaneWidth::Four);
    lanes.set_state(3, &r0, &too_fast).unwrap();
    let dw = vec![0.0; 2 * lanes.stride()];
    assert_eq!(lanes.step(0.01, &dw).unwrap(), 1);
    assert_eq!(
        lanes.failure(3).unwrap().map(|f| f.to_string()),
        Some(failure.to_string())
    );
    for p in (0..8).filter(|&p| p != 3) {
        assert!(lanes.failure(p).unwrap().is_none(), "path {p}");
    }
    assert_eq!(
        lanes.scalar_steps(),
        1,
        "only the failing path left the lanes"
    );
}
