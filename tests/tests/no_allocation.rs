//! The step allocates nothing in steady state: all buffers are created with the stepper.

mod common;

use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::cell::Cell;

use sdae_scheme::{
    GaussianIncrements, IncrementSource, PendulumParams, Stepper, StepperConfig, pendulum,
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

#[test]
fn steps_do_not_allocate() {
    // Pendulum (scalar Gram matrix) and chain (tridiagonal), with the certificate computed.
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut pendulum_stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
    let mut noise = GaussianIncrements::for_path(1, 0, 2);
    let mut dw = vec![0.0; 2];

    let chain_system = common::chain_system(50, 1.0);
    let chain = *sdae_scheme::System::constraint(&chain_system);
    let mut chain_stepper = Stepper::new(
        chain_system,
        StepperConfig::new(1.0, f64::INFINITY).unwrap(),
    )
    .unwrap();
    let (mut cr, mut cv) = (chain.zigzag(0.5), vec![0.0; 150]);
    let mut chain_noise = GaussianIncrements::for_path(1, 1, 150);
    let mut cdw = vec![0.0; 150];

    let before = allocations();
    for _ in 0..1000 {
        noise.next_increment(1e-3, &mut dw);
        pendulum_stepper.step(&mut r, &mut v, 1e-3, &dw).unwrap();
        chain_noise.next_increment(1e-4, &mut cdw);
        chain_stepper.step(&mut cr, &mut cv, 1e-4, &cdw).unwrap();
    }
    assert_eq!(allocations() - before, 0);
    // The counter works: a vector allocates.
    let probe = std::hint::black_box(vec![1.0_f64; 4]);
    assert_eq!(allocations() - before, 1);
    drop(probe);
}
