//! No scheme allocates per step: all buffers are created with it. Every scheme on the pendulum
//! (scalar Gram matrix) and on bead chains (tridiagonal Gram matrix, m > 1), and the one-shot
//! evaluations of the inherent SDE; and an ensemble's step in SIMD lanes (sphere, bead chain,
//! rigid bonds) once its first step has made the lanes' buffers.

// The helpers of the `integration` suite; this binary uses only `chain_system`.
#[allow(dead_code)]
#[path = "integration/common/mod.rs"]
mod common;

use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::cell::Cell;

use sdae_manifold::{BeadChain, IdentityMass};
use sdae_model::{AdditiveNoise, MechanicalSystem, PathEnsemble, Scheme, System, ZeroDrift};
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
use sdae_reference::{
    CurvedSystem, EulerMaruyama, InherentSde, ProjectedEulerMaruyama, StochasticHeun,
    TruncatedEulerMaruyama,
};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{PendulumParams, RigidTriatomicParams, pendulum, rigid_triatomic};

struct Counting;

thread_local! {
    /// Allocations made by this thread (the test harness allocates on other threads).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { SystemAlloc.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { SystemAlloc.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `steps` steps of size h from (r, v).
fn allocations_of_steps<S: Scheme>(scheme: &mut S, r: &[f64], v: &[f64], h: f64) -> usize {
    let (mut r, mut v) = (r.to_vec(), v.to_vec());
    let l = scheme.system().noise_dim();
    let mut noise = GaussianIncrements::for_path(3, 0, l);
    let mut dw = vec![0.0; l];
    let before = allocations();
    for _ in 0..500 {
        noise.next_increment(h, &mut dw);
        scheme.step(&mut r, &mut v, h, &dw).unwrap();
    }
    allocations() - before
}

/// Every scheme on `system` from `state` with step h: the half-explicit stepper with
/// `config`, and the inherent-SDE solvers where `inherent`.
fn check_all<S: CurvedSystem + Clone>(
    name: &str, system: S, config: StepperConfig, state: (&[f64], &[f64]), h: f64, inherent: bool,
) {
    let (r, v) = state;
    let mut counts = vec![(
        "half-explicit",
        allocations_of_steps(&mut Stepper::new(system.clone(), config).unwrap(), r, v, h),
    )];
    if inherent {
        counts.extend([
            (
                "Euler-Maruyama",
                allocations_of_steps(&mut EulerMaruyama::new(system.clone()).unwrap(), r, v, h),
            ),
            (
                "truncated Euler-Maruyama",
                allocations_of_steps(
                    &mut TruncatedEulerMaruyama::new(system.clone()).unwrap(),
                    r,
                    v,
                    h,
                ),
            ),
            (
                "projected Euler-Maruyama",
                allocations_of_steps(
                    &mut ProjectedEulerMaruyama::new(system.clone()).unwrap(),
                    r,
                    v,
                    h,
                ),
            ),
            (
                "stochastic Heun",
                allocations_of_steps(&mut StochasticHeun::new(system.clone()).unwrap(), r, v, h),
            ),
        ]);
        // The one-shot evaluations of the inherent SDE do not allocate either.
        let mut sde = InherentSde::new(system).unwrap();
        let (n, m, l) = (sde.dim(), sde.n_constraints(), sde.noise_dim());
        let (mut out, mut mu, dw) = (vec![0.0; n], vec![0.0; m], vec![0.1; l]);
        let before = allocations();
        sde.drift(r, v, &mut out, &mut mu).unwrap();
        sde.diffusion(r, v, &dw, &mut out).unwrap();
        sde.multiplier_increment(r, v, 1e-3, &dw, &mut out, &mut mu)
            .unwrap();
        counts.push(("one-shot inherent SDE", allocations() - before));
    }
    for (scheme, count) in counts {
        assert_eq!(count, 0, "{name}: {scheme}");
    }
}

#[test]
fn steps_do_not_allocate() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    check_all(
        "pendulum",
        system,
        config,
        (&[1.0, 0.0], &[0.0, 1.0]),
        1e-3,
        true,
    );

    // A 50-bead chain under gravity, with the certificate computed.
    let system = common::chain_system(50, 1.0);
    let chain = *system.constraint();
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let state = (&chain.zigzag(0.5)[..], &vec![0.0; 150][..]);
    check_all("50-bead chain", system, config, state, 1e-4, false);

    // A 20-bead chain with additive noise only.
    let beads = 20;
    let chain = BeadChain::new(beads, 1.0 / (beads - 1) as f64).unwrap();
    let r = chain.zigzag(0.5);
    let noise = AdditiveNoise::new(0.5, 3 * beads).unwrap();
    let system = MechanicalSystem::new(chain, IdentityMass, ZeroDrift, noise).unwrap();
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    check_all(
        "20-bead chain",
        system,
        config,
        (&r, &vec![0.0; 3 * beads]),
        1e-3,
        true,
    );

    // The counter works: a vector allocates.
    let before = allocations();
    let probe = std::hint::black_box(vec![1.0_f64; 4]);
    assert_eq!(allocations() - before, 1);
    drop(probe);
}

/// Allocations made by the ensemble steps of 11 paths of `system` from `state`, after the first
/// step (which makes the lanes' buffers); panics unless every path-step was decided in lanes.
fn allocations_of_ensemble_steps<S: System>(
    system: S, config: StepperConfig, r: &[f64], v: &[f64], h: f64,
) -> usize {
    const PATHS: usize = 11;
    let l = system.noise_dim();
    let mut ensemble = Ensemble::new(Stepper::new(system, config).unwrap(), PATHS, r, v).unwrap();
    let indices: Vec<u64> = (0..PATHS as u64).collect();
    let mut noise = EnsembleIncrements::for_paths(3, &indices, l);
    let mut dw = vec![0.0; l * ensemble.stride()];
    let mut count = 0;
    for step in 0..200 {
        noise.fill(h, &mut dw).unwrap();
        let before = allocations();
        ensemble.step(h, &dw).unwrap();
        if step > 0 {
            count += allocations() - before;
        }
    }
    assert_eq!((ensemble.failed_paths(), ensemble.scalar_steps()), (0, 0));
    count
}

#[test]
fn ensemble_steps_in_lanes_do_not_allocate() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system)
        .unwrap()
        .with_c_eta(1.0)
        .unwrap();
    assert_eq!(
        allocations_of_ensemble_steps(system, config, &[1.0, 0.0], &[0.0, 1.0], 1e-3),
        0,
        "pendulum"
    );

    let system = common::chain_system(50, 1.0);
    let chain = *system.constraint();
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let (r, v) = (chain.zigzag(0.5), vec![0.0; 150]);
    assert_eq!(
        allocations_of_ensemble_steps(system, config, &r, &v, 1e-4),
        0,
        "50-bead chain"
    );

    let molecule = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let config = StepperConfig::for_system(&molecule)
        .unwrap()
        .with_c_eta(1.0)
        .unwrap()
        .with_c_kappa(f64::INFINITY)
        .unwrap();
    let (r, v) = molecule.initial_state();
    assert_eq!(
        allocations_of_ensemble_steps(molecule, config, &r, &v, 1e-3),
        0,
        "rigid triatomic"
    );
}
