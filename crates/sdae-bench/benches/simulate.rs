//! What [`sdae_study::simulate`] costs through the Rust API: 10 000 paths of the `pendulum`
//! scene, 1 024 steps of the half-explicit scheme (practical C_eta), the end state recorded
//! (`simulate/pendulum_end_state`) or every step (`simulate/pendulum_every_step`), one thread.
//! The Python package's `crates/sdae-python/benchmarks/simulate.py` times the same runs from
//! Python.
//!
//! Run with `cargo bench -p sdae-bench --bench simulate`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use sdae_study::integrator::SchemeKind;
use sdae_study::scene::Scene;
use sdae_study::simulate::{SimulateSettings, simulate};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

const PATHS: usize = 10_000;
const STEPS: usize = 1024;

fn bench_simulate(c: &mut Criterion) {
    let scene = Scene::built_in("pendulum").expect("built-in scene");
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    for (name, every) in [("pendulum_end_state", STEPS), ("pendulum_every_step", 1)] {
        let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, PATHS, STEPS, 1)
            .and_then(|s| s.every(every))
            .expect("settings");
        group.bench_function(name, |b| {
            b.iter(|| black_box(simulate(&scene, &settings, &|| false).expect("simulate")))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_simulate);
criterion_main!(benches);
