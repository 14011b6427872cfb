//! Speed of the ensemble engine: many paths of the planar unit pendulum stepped together in SIMD
//! lanes, per path-step (the work of one `pendulum_step` in benches/step.rs).
//!
//! - `pendulum_ensemble/with_normals`: each step draws every path's two Gaussian numbers from
//!   its own stream, W paths at once (`EnsembleIncrements`), and steps all paths at the
//!   processor's widest lane width: the same work as `pendulum_step`, random numbers included.
//! - `pendulum_ensemble/normals_only`: the increments alone (`EnsembleIncrements::fill` into
//!   the ensemble's layout).
//! - `pendulum_ensemble/normals_one_path_at_a_time`: the same numbers drawn path by path
//!   (`GaussianIncrements`, the same ziggurat one path at a time) and written into the layout:
//!   what the lanes gain.
//! - `pendulum_ensemble/step_only`: the step alone, on increments drawn beforehand.
//! - `pendulum_ensemble/step_only_one_lane`: the same in plain f64, one path at a time: what
//!   the lanes gain.
//! - `pendulum_ensemble/step_only_general_engine`: `step_only` on the general engine that
//!   every other constraint steps on (`NewtonOnly`: Newton over lanes with the closed form of
//!   the quadratic kappa system, the same numbers bit for bit): what the sphere's fixed-size
//!   kernels save.
//! - `pendulum_ensemble/step_only_closure_drift`: `step_only` for the same pendulum with its
//!   drift given as a function (a user's system without a lane form): the lanes evaluate it
//!   path by path (`sdae_lanes::per_lane`) and do the rest of the step in lanes.
//!
//! The states are put back to the initial state every [`RESET_EVERY`] steps, as in
//! benches/step.rs. Throughput is reported per path-step (criterion's elements).
//!
//! Run with `cargo bench -p sdae-bench --bench ensemble`, or `cargo xtask bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sdae_lanes::LaneWidth;
use sdae_manifold::{IdentityMass, NewtonOnly, Sphere, TheoryBound};
use sdae_model::{AdditiveNoise, MechanicalSystem, PathEnsemble, System};
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{PendulumDrift, PendulumParams, pendulum};

mod pendulum_paths;
use pendulum_paths::{DRAWN_STEPS, H, PATHS, R0, RESET_EVERY, SEED, V0, drawn_increments};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// The pendulum with its drift (gravity 1, no friction) given as a function: a user's system
/// without a lane form, whose drift the ensemble evaluates lane by lane.
type ClosurePendulum = MechanicalSystem<Sphere, IdentityMass, DriftFn, AdditiveNoise>;
type DriftFn = fn(&[f64], &[f64], &mut [f64]);

fn closure_pendulum() -> ClosurePendulum {
    let gravity: DriftFn = |_r, _v, out| {
        out[0] = 0.0;
        out[1] = -1.0;
    };
    let sphere = Sphere::new(2, 1.0).expect("unit circle");
    let noise = AdditiveNoise::new(1.0, 2).expect("unit noise");
    MechanicalSystem::new(sphere, IdentityMass, gravity, noise).expect("closure pendulum")
}

/// The seed's pendulum (gravity 1, unit noise, no friction) on the general engine of every
/// other constraint ([`NewtonOnly`]): what the sphere's fixed-size path saves.
fn general_engine_pendulum()
-> MechanicalSystem<NewtonOnly<Sphere>, IdentityMass, PendulumDrift, AdditiveNoise> {
    let params = PendulumParams::default();
    let drift = PendulumDrift {
        gravity: params.gravity,
        friction: params.friction,
    };
    let noise = AdditiveNoise::new(params.noise, 2).expect("unit noise");
    MechanicalSystem::new(
        NewtonOnly(Sphere::unit_circle()),
        IdentityMass,
        drift,
        noise,
    )
    .expect("pendulum on the general engine")
}

/// An ensemble, its paths' streams and a buffer of increments.
struct Bench<S: System> {
    ensemble: Ensemble<S>,
    noise: EnsembleIncrements,
    per_path: Vec<GaussianIncrements<sdae_noise::PathStreams>>,
    drawn: Vec<Vec<f64>>,
    steps: usize,
}

impl<S: System> Bench<S>
where
    S::Constraint: TheoryBound,
{
    fn new(system: S) -> Self {
        let config = StepperConfig::for_system(&system)
            .and_then(|c| c.with_c_eta(1.0))
            .expect("pendulum stepper config");
        let stepper = Stepper::new(system, config).expect("pendulum stepper");
        let ensemble = Ensemble::new(stepper, PATHS, &R0, &V0).expect("ensemble");
        let indices: Vec<u64> = (0..PATHS as u64).collect();
        let mut noise = EnsembleIncrements::for_paths(SEED, &indices, 2);
        let per_path = indices
            .iter()
            .map(|&p| GaussianIncrements::for_path(SEED, p, 2))
            .collect();
        let drawn = drawn_increments(&mut noise, ensemble.stride());
        Self {
            ensemble,
            noise,
            per_path,
            drawn,
            steps: 0,
        }
    }

    fn reset_if_due(&mut self) {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.ensemble.restart(&R0, &V0).expect("reset");
        }
        self.steps += 1;
    }

    /// One step of every path on increments drawn beforehand.
    fn step_drawn(&mut self, width: LaneWidth) -> usize {
        self.reset_if_due();
        self.ensemble.set_width(width);
        let dw = &self.drawn[self.steps % DRAWN_STEPS];
        self.ensemble.step(H, dw).expect("step input")
    }

    /// Draws every path's increment, then steps every path.
    fn step_with_normals(&mut self, dw: &mut [f64]) -> usize {
        self.reset_if_due();
        self.noise.fill(H, dw).expect("increments buffer");
        self.ensemble.set_width(LaneWidth::Best);
        self.ensemble.step(H, dw).expect("step input")
    }
}

/// dw[j * stride + p] = increment j of path p, from path p's own stream, one path at a time.
fn draw_per_path(
    noise: &mut [GaussianIncrements<sdae_noise::PathStreams>], stride: usize, dw: &mut [f64],
) {
    let mut one = [0.0; 2];
    for (p, source) in noise.iter_mut().enumerate() {
        source.next_increment(H, &mut one);
        dw[p] = one[0];
        dw[stride + p] = one[1];
    }
}

fn bench_pendulum_ensemble(c: &mut Criterion) {
    eprintln!(
        "pendulum_ensemble: {PATHS} paths, {} lanes at once",
        LaneWidth::Best.lanes()
    );
    let mut group = c.benchmark_group("pendulum_ensemble");
    group.throughput(Throughput::Elements(PATHS as u64));
    let pendulum = || pendulum(PendulumParams::default()).expect("pendulum parameters");
    let mut bench = Bench::new(pendulum());
    let mut dw = vec![0.0; 2 * bench.ensemble.stride()];
    group.bench_function("with_normals", |b| {
        b.iter(|| black_box(bench.step_with_normals(&mut dw)))
    });
    group.bench_function("normals_only", |b| {
        b.iter(|| {
            bench.noise.fill(H, &mut dw).expect("increments buffer");
            black_box(dw[0])
        })
    });
    group.bench_function("normals_one_path_at_a_time", |b| {
        b.iter(|| {
            let stride = bench.ensemble.stride();
            draw_per_path(&mut bench.per_path, stride, &mut dw);
            black_box(dw[0])
        })
    });
    let mut bench = Bench::new(pendulum());
    group.bench_function("step_only", |b| {
        b.iter(|| black_box(bench.step_drawn(LaneWidth::Best)))
    });
    let mut bench = Bench::new(pendulum());
    group.bench_function("step_only_one_lane", |b| {
        b.iter(|| black_box(bench.step_drawn(LaneWidth::One)))
    });
    let mut general = Bench::new(general_engine_pendulum());
    group.bench_function("step_only_general_engine", |b| {
        b.iter(|| black_box(general.step_drawn(LaneWidth::Best)))
    });
    let mut closure = Bench::new(closure_pendulum());
    group.bench_function("step_only_closure_drift", |b| {
        b.iter(|| black_box(closure.step_drawn(LaneWidth::Best)))
    });
    group.finish();
    assert_eq!(closure.ensemble.failed_paths(), 0, "a closure path failed");
    assert_eq!(
        general.ensemble.scalar_steps(),
        0,
        "the general engine left steps"
    );
    assert_eq!(
        closure.ensemble.scalar_steps(),
        0,
        "the lanes left closure steps to the scalar stepper"
    );
    assert_eq!(bench.ensemble.failed_paths(), 0, "a pendulum path failed");
    assert_eq!(
        bench.ensemble.scalar_steps(),
        0,
        "the lanes left steps to the scalar stepper"
    );
}

criterion_group!(benches, bench_pendulum_ensemble);
criterion_main!(benches);
