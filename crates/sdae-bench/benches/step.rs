//! Speed of one step of the half-explicit drift-truncated Euler scheme, random numbers included.
//!
//! - `pendulum_step`: the planar unit pendulum (2 Gaussian numbers per step).
//! - `chain_step/K`: an inextensible bead chain of K beads and length ~1 under gravity with
//!   additive noise (3K Gaussian numbers per step); throughput is reported per bead.
//!
//! - `chain_ensemble/K`: the same chain, [`ENSEMBLE_PATHS`] paths of it stepped together by the
//!   ensemble engine (`sdae_scheme::Ensemble`), each path's 3K numbers from its own stream
//!   every step, W paths at once (`EnsembleIncrements`), the chain's step (Newton for kappa,
//!   the tridiagonal solves, gravity and the additive noise) in W lanes; throughput is
//!   reported per bead and path.
//! - `chain_ensemble/normals_only/1000`: the increments of `chain_ensemble/1000` alone
//!   (`EnsembleIncrements::fill`): the part of its time that goes to random numbers.
//!
//! The benchmarks keep stepping one state and put it back to the initial state every
//! [`RESET_EVERY`] steps, so that the chain does not fall (and speed up) for the whole run and
//! the pendulum's energy does not random-walk away; the reset costs one copy of (r, v) per
//! [`RESET_EVERY`] steps. A failed step panics with the step index and the error.
//!
//! Run with `cargo bench -p sdae-bench --bench step`, or `cargo xtask bench` for a summary.

mod verify;

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sdae_lanes::Real;
use sdae_manifold::{BeadChain, IdentityMass};
use sdae_model::PathEnsemble;
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem, Scheme, System};
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Steps between resets of the state to its initial value.
const RESET_EVERY: u64 = 1000;

/// Seed of the benchmarks' random-number streams.
const SEED: u64 = 2024;

/// Bead counts of `chain_step`.
const CHAIN_SIZES: [usize; 4] = [10, 100, 1000, 10000];

/// Bead counts of `chain_ensemble`.
const ENSEMBLE_CHAIN_SIZES: [usize; 3] = [10, 100, 1000];

/// Paths of `chain_ensemble`: one AVX-512 register's width.
const ENSEMBLE_PATHS: usize = 8;

/// Step size of `chain_step`. With h = 1e-4 the 10000-bead chain (ds = 1e-4) crumples within
/// ~150 steps (t ~ 0.015: the relative velocity of neighbouring beads grows until a segment turns
/// by ~1 rad per step and Newton for kappa diverges); at h = 1e-5 that happens near t ~ 0.056,
/// well after the reset at t = RESET_EVERY h = 0.01. The same h is used for every K.
const CHAIN_H: f64 = 1e-5;

/// Step size of `pendulum_step`.
const PENDULUM_H: f64 = 1e-3;

/// Gravity on every bead: a = (0, 0, -1) per bead.
#[derive(Debug, Clone, Copy)]
struct Gravity;

impl Drift for Gravity {
    /// For one path or W lanes, for a chain of any length.
    #[inline(always)]
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        let (zero, down) = (v[0].splat_like(0.0), v[0].splat_like(-1.0));
        for bead in out.chunks_exact_mut(3) {
            bead[0] = zero;
            bead[1] = zero;
            bead[2] = down;
        }
        true
    }
}

type Chain = MechanicalSystem<BeadChain, IdentityMass, Gravity, AdditiveNoise>;

/// A path being stepped: stepper, state, initial state and noise.
struct Bench<S: System> {
    name: String,
    stepper: Stepper<S>,
    r0: Vec<f64>,
    v0: Vec<f64>,
    r: Vec<f64>,
    v: Vec<f64>,
    h: f64,
    noise: GaussianIncrements<sdae_noise::PathStreams>,
    dw: Vec<f64>,
    steps: u64,
    last_iterations: usize,
}

impl<S: System> Bench<S> {
    fn new(name: String, stepper: Stepper<S>, r0: Vec<f64>, v0: Vec<f64>, h: f64) -> Self {
        let l = stepper.system().noise_dim();
        Self {
            name,
            stepper,
            r: r0.clone(),
            v: v0.clone(),
            r0,
            v0,
            h,
            noise: GaussianIncrements::for_path(SEED, 0, l),
            dw: vec![0.0; l],
            steps: 0,
            last_iterations: 0,
        }
    }

    /// Draws the increment and takes one step (resetting the state every RESET_EVERY steps).
    /// Returns max |g(r')|.
    #[inline]
    fn step(&mut self) -> f64 {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.r.copy_from_slice(&self.r0);
            self.v.copy_from_slice(&self.v0);
        }
        self.steps += 1;
        self.noise.next_increment(self.h, &mut self.dw);
        match self
            .stepper
            .step(&mut self.r, &mut self.v, self.h, &self.dw)
        {
            Ok(report) => {
                self.last_iterations = report.newton_iterations;
                report.position_residual.unwrap_or(0.0)
            }
            Err(e) => panic!(
                "{}: step {} (since reset: {}) failed: {e}",
                self.name,
                self.steps,
                (self.steps - 1) % RESET_EVERY
            ),
        }
    }

    /// Before the first step (later calls do nothing): runs one full reset period, checks that
    /// every step stays on the manifold and prints the mean number of Newton iterations per step
    /// (the main reason the cost per bead varies). Called inside the benchmark's routine, so that
    /// a benchmark a filter leaves out does not run it.
    fn verify(&mut self) {
        if self.steps > 0 {
            return;
        }
        let mut worst: f64 = 0.0;
        let mut iterations = 0;
        for _ in 0..RESET_EVERY {
            worst = worst.max(self.step());
            iterations += self.last_iterations;
        }
        verify::report_verification(&self.name, worst, iterations, RESET_EVERY as usize, 1e-10);
    }
}

fn pendulum_bench() -> Bench<sdae_systems::Pendulum> {
    let system = pendulum(PendulumParams::default()).expect("pendulum parameters");
    let config = StepperConfig::for_system(&system)
        .and_then(|c| c.with_c_eta(1.0))
        .expect("pendulum stepper config");
    let stepper = Stepper::new(system, config).expect("pendulum stepper");
    Bench::new(
        "pendulum_step".into(),
        stepper,
        vec![1.0, 0.0],
        vec![0.0, 1.0],
        PENDULUM_H,
    )
}

/// The stepper of the K-bead chain and its initial state (a zigzag at rest).
fn chain_stepper(beads: usize) -> (Stepper<Chain>, Vec<f64>, Vec<f64>) {
    let chain = BeadChain::new(beads, 1.0 / beads as f64).expect("chain parameters");
    let r0 = chain.zigzag(0.3);
    let v0 = vec![0.0; r0.len()];
    let noise = AdditiveNoise::new(0.1, 3 * beads).expect("noise amplitude");
    let system = MechanicalSystem::new(chain, IdentityMass, Gravity, noise).expect("chain system");
    // The theory's C_kappa = 1/(8 C_g^4) with C_g ~ 4/ds^2 is far below the size of kappa at
    // this h (the root would be rejected as outside the ball), so only C_eta = 1 is set and the
    // ball is left to the solver's plausibility check.
    let config = StepperConfig::new(1.0, f64::INFINITY).expect("chain stepper config");
    let stepper = Stepper::new(system, config).expect("chain stepper");
    (stepper, r0, v0)
}

fn chain_bench(beads: usize) -> Bench<Chain> {
    let (stepper, r0, v0) = chain_stepper(beads);
    Bench::new(format!("chain_step/{beads}"), stepper, r0, v0, CHAIN_H)
}

/// [`ENSEMBLE_PATHS`] paths of the K-bead chain in an ensemble, each with its own stream.
struct ChainEnsemble {
    ensemble: Ensemble<Chain>,
    r0: Vec<f64>,
    v0: Vec<f64>,
    noise: EnsembleIncrements,
    /// Every path's increment in the ensemble's layout.
    dw: Vec<f64>,
    steps: u64,
}

impl ChainEnsemble {
    fn new(beads: usize) -> Self {
        let (stepper, r0, v0) = chain_stepper(beads);
        let l = stepper.system().noise_dim();
        let ensemble = Ensemble::new(stepper, ENSEMBLE_PATHS, &r0, &v0).expect("chain ensemble");
        let stride = ensemble.stride();
        let indices: Vec<u64> = (0..ENSEMBLE_PATHS as u64).collect();
        Self {
            ensemble,
            r0,
            v0,
            noise: EnsembleIncrements::for_paths(SEED, &indices, l),
            dw: vec![0.0; l * stride],
            steps: 0,
        }
    }

    /// Draws every path's increment and steps every path (all restarted every RESET_EVERY
    /// steps). Returns the number of failed paths, which must stay 0.
    fn step(&mut self) -> usize {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.ensemble.restart(&self.r0, &self.v0).expect("restart");
        }
        self.steps += 1;
        self.noise
            .fill(CHAIN_H, &mut self.dw)
            .expect("increments buffer");
        self.ensemble.step(CHAIN_H, &self.dw).expect("step input")
    }
}

fn bench_pendulum(c: &mut Criterion) {
    let mut bench = pendulum_bench();
    c.bench_function("pendulum_step", |b| {
        bench.verify();
        b.iter(|| black_box(bench.step()))
    });
}

fn bench_chain(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain_step");
    for beads in CHAIN_SIZES {
        let mut bench = chain_bench(beads);
        group.throughput(Throughput::Elements(beads as u64));
        group.bench_function(BenchmarkId::from_parameter(beads), |b| {
            bench.verify();
            b.iter(|| black_box(bench.step()))
        });
    }
    group.finish();
}

fn bench_chain_ensemble(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain_ensemble");
    for beads in ENSEMBLE_CHAIN_SIZES {
        let mut bench = ChainEnsemble::new(beads);
        group.throughput(Throughput::Elements((beads * ENSEMBLE_PATHS) as u64));
        group.bench_function(BenchmarkId::from_parameter(beads), |b| {
            b.iter(|| black_box(bench.step()))
        });
        if beads == 1000 {
            group.bench_function(BenchmarkId::new("normals_only", beads), |b| {
                b.iter(|| {
                    bench
                        .noise
                        .fill(CHAIN_H, &mut bench.dw)
                        .expect("increments buffer");
                    black_box(bench.dw[0])
                })
            });
        }
        assert_eq!(bench.ensemble.failed_paths(), 0, "a chain path failed");
        if bench.steps == 0 {
            // Left out by a filter.
            continue;
        }
        println!(
            "chain_ensemble/{beads}: {} of {} path-steps through the scalar stepper",
            bench.ensemble.scalar_steps(),
            bench.steps as usize * ENSEMBLE_PATHS
        );
    }
    group.finish();
}

criterion_group!(benches, bench_pendulum, bench_chain, bench_chain_ensemble);
criterion_main!(benches);
