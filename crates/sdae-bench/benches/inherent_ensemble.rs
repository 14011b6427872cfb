//! Speed of the inherent-SDE solvers on many paths of the planar unit pendulum, per path-step:
//! `inherent_ensemble/<solver>` steps a [`LaneEnsemble`] (W paths at once in SIMD lanes, the
//! processor's widest), `inherent_ensemble/<solver>_path_by_path` the same paths one at a time
//! ([`PathLoop`], what the studies did before the lane forms), on the same increments drawn
//! beforehand. The solvers are Euler-Maruyama, truncated Euler-Maruyama (c = 1), projected
//! Euler-Maruyama and stochastic Heun. The states are put back to the initial state every [`RESET_EVERY`] steps.
//!
//! Run with `cargo bench -p sdae-bench --bench inherent_ensemble`, or `cargo xtask bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sdae_model::{LaneEnsemble, LaneScheme, PathEnsemble, PathLoop};
use sdae_noise::EnsembleIncrements;
use sdae_reference::{
    EulerMaruyama, ProjectedEulerMaruyama, StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_systems::{Pendulum, PendulumParams, pendulum};

mod pendulum_paths;
use pendulum_paths::{DRAWN_STEPS, H, PATHS, R0, RESET_EVERY, SEED, V0, drawn_increments};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Steps `ensemble` on the drawn increments, one step of every path per iteration.
fn bench_ensemble<E: PathEnsemble>(c: &mut Criterion, name: &str, mut ensemble: E) {
    let stride = ensemble.stride();
    let indices: Vec<u64> = (0..PATHS as u64).collect();
    let mut noise = EnsembleIncrements::for_paths(SEED, &indices, 2);
    let drawn = drawn_increments(&mut noise, stride);
    let mut group = c.benchmark_group("inherent_ensemble");
    group.throughput(Throughput::Elements(PATHS as u64));
    let mut steps = 0usize;
    group.bench_function(name, |b| {
        b.iter(|| {
            if steps.is_multiple_of(RESET_EVERY) {
                ensemble.restart(&R0, &V0).expect("reset");
            }
            steps += 1;
            let stopped = ensemble
                .step(H, &drawn[steps % DRAWN_STEPS])
                .expect("step input");
            black_box(stopped)
        })
    });
    group.finish();
}

/// The solver's lanes and its path-by-path loop.
fn bench_solver<Sch: LaneScheme + Clone>(c: &mut Criterion, name: &str, solver: Sch) {
    let lanes = LaneEnsemble::new(solver.clone(), PATHS, &R0, &V0).expect("ensemble");
    bench_ensemble(c, name, lanes);
    let looped = PathLoop::new(solver, PATHS, &R0, &V0).expect("ensemble");
    bench_ensemble(c, &format!("{name}_path_by_path"), looped);
}

fn unit_pendulum() -> Pendulum {
    pendulum(PendulumParams {
        dim: 2,
        length: 1.0,
        gravity: 1.0,
        noise: 1.0,
        friction: 0.0,
    })
    .expect("pendulum")
}

fn inherent_ensemble(c: &mut Criterion) {
    let system = unit_pendulum();
    let em = EulerMaruyama::new(system.clone()).expect("solver");
    bench_solver(c, "euler_maruyama", em);
    let tem = TruncatedEulerMaruyama::new(system.clone()).expect("solver");
    bench_solver(c, "truncated_euler_maruyama", tem);
    let projected = ProjectedEulerMaruyama::new(system.clone()).expect("solver");
    bench_solver(c, "projected_euler_maruyama", projected);
    let heun = StochasticHeun::new(system).expect("solver");
    bench_solver(c, "stochastic_heun", heun);
}

criterion_group!(benches, inherent_ensemble);
criterion_main!(benches);
