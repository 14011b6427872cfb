//! Speed of one step of the half-explicit scheme on the fiber of seed Section 5.3 with every
//! force switched on (bending, gravity, linear and quadratic drag in a sheared wind) and the
//! turbulent multiplicative noise (3K Gaussian numbers per step), at K = 10 .. 10^4 beads.
//! Throughput is reported per bead: a flat time per bead shows the O(K) cost.
//!
//! - `fiber_step/K`: draw 3K normals and take one step;
//! - `fiber_forces/K`: the fiber's own share of it, one drift a(r, v) and one B(r, v) dw;
//! - `fiber_ensemble/K` (K <= 1000): [`ENSEMBLE_PATHS`] fibers stepped together by the ensemble
//!   engine (`sdae_scheme::Ensemble`, W paths in SIMD lanes), each path's 3K numbers from its
//!   own stream, the forces and the turbulence from the fiber's lane forms; throughput per
//!   bead and path;
//! - `fiber_ensemble_path_by_path/K`: the same with the fiber's forces evaluated path by path
//!   inside the lanes (a system without lane forms, as a user's system is), for comparison.
//!
//! Every K has the same bead physics (segment 0.01, bead mass 0.01, the same coefficients), so
//! only the length of the fiber changes. The state is put back to the initial zigzag every
//! [`RESET_EVERY`] steps so that the fiber neither drifts away nor crumples during the run;
//! a failed step panics with the step index and the error.
//!
//! Run with `cargo bench -p sdae-bench --bench fiber`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sdae_model::{Scheme, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{AirFlow, Fiber, FiberParams, Masses};

mod common;
use common::{EnsembleBench, PathByPath};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Steps between resets of the state to its initial value.
const RESET_EVERY: u64 = 1000;

/// Seed of the noise.
const SEED: u64 = 2025;

/// Bead counts.
const SIZES: [usize; 4] = [10, 100, 1000, 10_000];

/// Bead counts of `fiber_ensemble`.
const ENSEMBLE_SIZES: [usize; 3] = [10, 100, 1000];

/// Paths of `fiber_ensemble`: one AVX-512 register's width.
const ENSEMBLE_PATHS: usize = 8;

/// Step size: the stiffest bending mode (omega^2 ~ 16 EI / (m ds^4) = 1.6e6) turns by
/// omega h ~ 0.013 per step.
const H: f64 = 1e-5;

/// A fiber of `beads` beads with all forces and noise, its stepper and its state.
struct Bench<I> {
    stepper: Stepper<Fiber>,
    r0: Vec<f64>,
    r: Vec<f64>,
    v: Vec<f64>,
    noise: I,
    dw: Vec<f64>,
    steps: u64,
}

impl<I: IncrementSource> Bench<I> {
    /// One step (after a reset every RESET_EVERY steps); returns the Newton iterations.
    #[inline]
    fn step(&mut self) -> usize {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.r.copy_from_slice(&self.r0);
            self.v.fill(0.0);
        }
        self.steps += 1;
        self.noise.next_increment(H, &mut self.dw);
        match self.stepper.step(&mut self.r, &mut self.v, H, &self.dw) {
            Ok(report) => report.certificate.unwrap().iterations,
            Err(e) => panic!("step {} failed: {e}", self.steps),
        }
    }
}

/// The benchmarks' fiber of `beads` beads.
fn fiber(beads: usize) -> Fiber {
    Fiber::new(&FiberParams {
        beads,
        segment: 0.01,
        masses: Masses::Uniform(0.01),
        bending_stiffness: 1e-5,
        gravity: [0.0, 0.0, -9.81],
        air: AirFlow::sheared([1.0, 0.0, 0.0], 0.5),
        linear_drag: 0.01,
        quadratic_drag: 0.01,
        turbulence: 0.002,
        turbulence_gain: 1.5,
    })
    .expect("fiber parameters")
}

fn fiber_bench(beads: usize) -> Bench<impl IncrementSource> {
    let fiber = fiber(beads);
    let (r0, v) = fiber.zigzag(0.2);
    let l = fiber.noise_dim();
    let config = StepperConfig::new(1.0, f64::INFINITY).expect("stepper config");
    Bench {
        stepper: Stepper::new(fiber, config).expect("fiber stepper"),
        r: r0.clone(),
        r0,
        v,
        noise: GaussianIncrements::for_path(SEED, 0, l),
        dw: vec![0.0; l],
        steps: 0,
    }
}

fn bench_fiber(c: &mut Criterion) {
    let mut group = c.benchmark_group("fiber_step");
    for beads in SIZES {
        let mut bench = fiber_bench(beads);
        group.throughput(Throughput::Elements(beads as u64));
        group.bench_function(BenchmarkId::from_parameter(beads), |b| {
            // One reset period first, inside the routine so that a filter that leaves this
            // benchmark out skips it too.
            if bench.steps == 0 {
                let iterations: usize = (0..RESET_EVERY).map(|_| bench.step()).sum();
                eprintln!(
                    "fiber_step/{beads}: {RESET_EVERY} steps ok, \
                     mean Newton iterations per step = {:.2}",
                    iterations as f64 / RESET_EVERY as f64
                );
            }
            b.iter(|| black_box(bench.step()))
        });
    }
    group.finish();
}

fn bench_forces(c: &mut Criterion) {
    let mut group = c.benchmark_group("fiber_forces");
    for beads in SIZES {
        let bench = fiber_bench(beads);
        let fiber = bench.stepper.system();
        let (r, v, dw) = (&bench.r, &bench.v, vec![1e-3; bench.dw.len()]);
        let mut out = vec![0.0; r.len()];
        group.throughput(Throughput::Elements(beads as u64));
        group.bench_function(BenchmarkId::from_parameter(beads), |b| {
            b.iter(|| {
                fiber.drift(black_box(r), black_box(v), &mut out);
                fiber.add_noise(r, v, &dw, &mut out);
                black_box(out[0])
            })
        });
    }
    group.finish();
}

fn bench_ensemble<S: System>(c: &mut Criterion, name: &str, system: impl Fn(Fiber) -> S) {
    let mut group = c.benchmark_group(name);
    for beads in ENSEMBLE_SIZES {
        let fiber = fiber(beads);
        let (r0, v0) = fiber.zigzag(0.2);
        let config = StepperConfig::new(1.0, f64::INFINITY).expect("stepper config");
        let mut bench = EnsembleBench::new(system(fiber), config, ENSEMBLE_PATHS, (r0, v0), H);
        group.throughput(Throughput::Elements((beads * ENSEMBLE_PATHS) as u64));
        group.bench_function(BenchmarkId::from_parameter(beads), |b| {
            b.iter(|| black_box(bench.step()))
        });
        bench.report(&format!("{name}/{beads}"));
    }
    group.finish();
}

fn bench_fiber_ensemble(c: &mut Criterion) {
    bench_ensemble(c, "fiber_ensemble", |fiber| fiber);
    bench_ensemble(c, "fiber_ensemble_path_by_path", PathByPath);
}

criterion_group!(benches, bench_fiber, bench_forces, bench_fiber_ensemble);
criterion_main!(benches);
