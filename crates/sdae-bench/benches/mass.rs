//! What a mass matrix costs a step: the planar unit pendulum with the same unit mass given as
//! `IdentityMass` (no solves: M^-1 is the identity at compile time), as `DiagonalMass` (one
//! multiplication per coordinate) and as `DenseMass` (Cholesky solves).
//!
//! Run with `cargo bench -p sdae-bench --bench mass`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use sdae_manifold::{DenseMass, DiagonalMass, IdentityMass, Mass, Sphere};
use sdae_model::{AdditiveNoise, MechanicalSystem, Scheme};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::PendulumDrift;

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Steps of one state between resets to the initial state.
const RESET_EVERY: u64 = 1000;
const H: f64 = 1e-3;

fn bench_mass<M: Mass + Clone>(c: &mut Criterion, name: &str, mass: M) {
    let system = MechanicalSystem::new(
        Sphere::unit_circle(),
        mass,
        PendulumDrift {
            gravity: 1.0,
            friction: 0.0,
        },
        AdditiveNoise::new(1.0, 2).expect("unit noise"),
    )
    .expect("a valid pendulum");
    let config = StepperConfig::new(1.0, f64::INFINITY).expect("valid constants");
    let mut stepper = Stepper::new(system, config).expect("a valid stepper");
    let mut noise = GaussianIncrements::for_path(7, 0, 2);
    let (r0, v0) = ([0.0, -1.0], [1.0, 0.0]);
    let (mut r, mut v, mut dw) = (r0, v0, [0.0; 2]);
    let mut k = 0u64;
    c.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            if k.is_multiple_of(RESET_EVERY) {
                (r, v) = (r0, v0);
            }
            noise.next_increment(H, &mut dw);
            black_box(
                stepper
                    .step(&mut r, &mut v, H, &dw)
                    .expect("a pendulum step"),
            );
        })
    });
}

fn masses(c: &mut Criterion) {
    bench_mass(c, "pendulum_step_identity_mass", IdentityMass);
    bench_mass(
        c,
        "pendulum_step_diagonal_mass",
        DiagonalMass::new(vec![1.0, 1.0]).expect("positive diagonal"),
    );
    bench_mass(
        c,
        "pendulum_step_dense_mass",
        DenseMass::new(2, vec![1.0, 0.0, 0.0, 1.0]).expect("SPD"),
    );
}

criterion_group!(benches, masses);
criterion_main!(benches);
