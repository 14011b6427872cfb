//! The reference solvers allocate nothing per step: all buffers are created with the solver.
//! Pendulum (scalar Gram matrix) and a bead chain (tridiagonal Gram matrix, m > 1).

use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::cell::Cell;

use sdae_manifold::{BeadChain, IdentityMass};
use sdae_reference::{
    CurvedSystem, EulerMaruyama, InherentSde, ProjectedEulerMaruyama, ReferenceSolver,
    StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_scheme::{
    AdditiveNoise, GaussianIncrements, IncrementSource, MechanicalSystem, PendulumParams,
    ZeroDrift, pendulum,
};

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

/// Runs 500 steps from (r, v) and returns the allocations they made.
fn allocations_of_steps<S: ReferenceSolver>(solver: &mut S, r: &[f64], v: &[f64]) -> usize {
    let (mut r, mut v) = (r.to_vec(), v.to_vec());
    let l = solver.sde().noise_dim();
    let mut noise = GaussianIncrements::for_path(3, 0, l);
    let mut dw = vec![0.0; l];
    let h = 1e-3;
    let before = allocations();
    for _ in 0..500 {
        noise.next_increment(h, &mut dw);
        solver.step(&mut r, &mut v, h, &dw).unwrap();
    }
    allocations() - before
}

fn check_all<S: CurvedSystem + Clone>(name: &str, system: S, r: &[f64], v: &[f64]) {
    let counts = [
        allocations_of_steps(&mut EulerMaruyama::new(system.clone()).unwrap(), r, v),
        allocations_of_steps(
            &mut TruncatedEulerMaruyama::new(system.clone()).unwrap(),
            r,
            v,
        ),
        allocations_of_steps(
            &mut ProjectedEulerMaruyama::new(system.clone()).unwrap(),
            r,
            v,
        ),
        allocations_of_steps(&mut StochasticHeun::new(system.clone()).unwrap(), r, v),
    ];
    assert_eq!(
        counts, [0; 4],
        "{name}: EM, truncated EM, projected EM, Heun"
    );
    // The one-shot evaluations do not allocate either.
    let mut sde = InherentSde::new(system).unwrap();
    let (n, m, l) = (sde.dim(), sde.n_constraints(), sde.noise_dim());
    let (mut out, mut mu, dw) = (vec![0.0; n], vec![0.0; m], vec![0.1; l]);
    let before = allocations();
    sde.drift(r, v, &mut out, &mut mu).unwrap();
    sde.diffusion(r, v, &dw, &mut out).unwrap();
    sde.multiplier_increment(r, v, 1e-3, &dw, &mut out, &mut mu)
        .unwrap();
    assert_eq!(allocations() - before, 0, "{name}: one-shot evaluations");
}

#[test]
fn steps_do_not_allocate() {
    let system = pendulum(PendulumParams::default()).unwrap();
    check_all("pendulum", system, &[1.0, 0.0], &[0.0, 1.0]);

    let beads = 20;
    let chain = BeadChain::new(beads, 1.0 / (beads - 1) as f64).unwrap();
    let r = chain.zigzag(0.5);
    let system = MechanicalSystem::new(
        chain,
        IdentityMass,
        ZeroDrift,
        AdditiveNoise::new(0.5, 3 * beads).unwrap(),
    )
    .unwrap();
    check_all("chain", system, &r, &vec![0.0; 3 * beads]);
}
