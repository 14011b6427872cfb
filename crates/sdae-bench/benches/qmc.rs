//! Speed of quasi-random against pseudo-random Brownian increments: every increment of a path of
//! N = [`STEPS`] steps of an l = 2 dimensional Brownian motion (the pendulum's noise), per path.
//!
//! - `qmc_increments/pseudo_one_path`: one path's own streams, one path at a time
//!   (`GaussianIncrements::for_path`, N calls of `next_increment`).
//! - `qmc_increments/pseudo_lanes`: [`PATHS`] paths' streams drawn W paths at once
//!   (`EnsembleIncrements::for_paths`, then `fill` of all N steps).
//! - `qmc_increments/quasi_one_path`: one quasi-random path (`QuasiBrownian::path`: scrambled
//!   Sobol' coordinates, the inverse normal, the Brownian bridge per component; then N calls of
//!   `next_increment`). The scrambled direction numbers are made once, outside the loop, as a
//!   study makes them once per randomization.
//! - `qmc_increments/quasi_lanes`: [`PATHS`] quasi-random paths W at once
//!   (`QuasiBrownian::ensemble`, then `fill` of all N steps): the same numbers as
//!   `quasi_one_path`'s.
//! - `qmc_increments/pseudo_lanes_four`, `qmc_increments/quasi_lanes_four`: the same at W = 4
//!   (AVX2), whatever the processor's widest.
//!
//! Criterion's time per iteration is for every path of the iteration; the throughput is in
//! paths. Run with `cargo bench -p sdae-bench --bench qmc`, or `cargo xtask bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sdae_lanes::LaneWidth;
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource, QuasiBrownian};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Steps of a path (2^10: level 10 of a multilevel study).
const STEPS: usize = 1024;

/// Components of the Brownian motion.
const DIM: usize = 2;

/// Paths of the ensembles, drawn together.
const PATHS: usize = 64;

/// Step size (T = 1).
const H: f64 = 1.0 / STEPS as f64;

/// Seed of the study.
const SEED: u64 = 2026;

/// Sums a path's N increments from `source`, so that none of them is optimized away.
fn draw_path(mut source: impl IncrementSource) -> f64 {
    let mut dw = [0.0; DIM];
    let mut sum = 0.0;
    for _ in 0..STEPS {
        source.next_increment(H, &mut dw);
        sum += dw[0] + dw[1];
    }
    sum
}

fn bench_qmc_increments(c: &mut Criterion) {
    eprintln!(
        "qmc_increments: {STEPS} steps of {DIM} components, {PATHS} paths, {} lanes at once",
        LaneWidth::Best.lanes()
    );
    let quasi = QuasiBrownian::new(SEED, 0, DIM, STEPS).expect("quasi-random paths");
    let indices: Vec<u64> = (0..PATHS as u64).collect();
    let mut group = c.benchmark_group("qmc_increments");
    group.throughput(Throughput::Elements(1));
    let mut path = 0;
    let mut next_path = || {
        path = (path + 1) % PATHS as u64;
        path
    };
    group.bench_function("pseudo_one_path", |b| {
        b.iter(|| {
            black_box(draw_path(GaussianIncrements::for_path(
                SEED,
                next_path(),
                DIM,
            )))
        })
    });
    group.bench_function("quasi_one_path", |b| {
        b.iter(|| black_box(draw_path(quasi.path(next_path()).expect("path index"))))
    });
    group.throughput(Throughput::Elements(PATHS as u64));
    let mut dw = vec![0.0; STEPS * DIM * sdae_lanes::lane_stride(PATHS)];
    for (suffix, width) in [("", LaneWidth::Best), ("_four", LaneWidth::Four)] {
        group.bench_function(format!("pseudo_lanes{suffix}"), |b| {
            b.iter(|| {
                let mut noise =
                    EnsembleIncrements::for_paths(SEED, &indices, DIM).with_width(width);
                noise.fill(H, &mut dw).expect("increments buffer");
                black_box(dw[0])
            })
        });
        group.bench_function(format!("quasi_lanes{suffix}"), |b| {
            b.iter(|| {
                let mut noise = quasi
                    .ensemble_with_width(&indices, width)
                    .expect("path indices");
                noise.fill(H, &mut dw).expect("increments buffer");
                black_box(dw[0])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_qmc_increments);
criterion_main!(benches);
