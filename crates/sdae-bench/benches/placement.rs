//! How the speed of one path's step depends on where the heap puts the scheme's buffers.
//!
//! A path-by-path scheme keeps a dozen small work buffers (the force, the parts of a step, the
//! proposal, the projection's points), each allocated on its own. Where the allocator puts
//! them depends on everything the program allocated and freed before, and the same binary
//! steps at different speeds from one placement to the next (up to 2x on an AMD EPYC,
//! docs/performance.md). A criterion figure of such a step is the speed of one placement; this
//! benchmark reports the spread over many.
//!
//! For each scheme (the stepper on the planar unit pendulum and the four inherent-SDE solvers)
//! and each of [`PLACEMENTS`] placements: a spacer of 24 i + 1 bytes is allocated and kept
//! (so that the next allocations land elsewhere), the scheme is cloned (its buffers are
//! allocated anew), and the clone takes [`ROUNDS`] runs of [`STEPS`] steps of one path on
//! increments drawn beforehand (the state put back every [`RESET_EVERY`] steps); the fastest
//! run is the placement's time per step. Before each clone, a few small blocks are allocated
//! and every other one freed, leaving holes where the clone's buffers land scattered, as in a
//! program that has run for a while. Printed: minimum, quartiles and maximum over the
//! placements, and how many are more than 10% slower than the median; written, with every
//! placement's time, to `target/bench/placement.json`.
//!
//! Run with `cargo bench -p sdae-bench --bench placement` (about 10 s), or with a number of
//! placements: `cargo bench -p sdae-bench --bench placement -- 128`.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use sdae_model::Scheme;
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_reference::{
    EulerMaruyama, ProjectedEulerMaruyama, StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};
use serde_json::{Value, json};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Placements per scheme, unless given on the command line.
const PLACEMENTS: usize = 48;
/// Timed runs per placement (the fastest counts).
const ROUNDS: usize = 3;
/// Steps per run.
const STEPS: usize = 100_000;
/// Steps between resets of the state to its initial value.
const RESET_EVERY: usize = 1000;
/// Increments drawn beforehand, used in turn.
const DRAWN: usize = 64;
/// Step size.
const H: f64 = 1e-3;
/// The pendulum's initial state.
const R0: [f64; 2] = [1.0, 0.0];
const V0: [f64; 2] = [0.0, 1.0];

/// The spread of one scheme's time per step over the placements, in ns.
struct Spread {
    name: &'static str,
    /// Sorted.
    times: Vec<f64>,
}

impl Spread {
    /// The q-quantile (nearest rank).
    fn quantile(&self, q: f64) -> f64 {
        self.times[((self.times.len() - 1) as f64 * q).round() as usize]
    }

    /// Placements more than 10% slower than the median.
    fn slow(&self) -> usize {
        let median = self.quantile(0.5);
        self.times.iter().filter(|&&t| t > 1.1 * median).count()
    }
}

/// The fastest of [`ROUNDS`] runs of [`STEPS`] steps of `scheme`, in ns per step.
fn time_per_step<S: Scheme>(scheme: &mut S, drawn: &[[f64; 2]]) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..ROUNDS {
        let (mut r, mut v) = (R0, V0);
        let start = Instant::now();
        for k in 0..STEPS {
            if k % RESET_EVERY == 0 {
                (r, v) = (R0, V0);
            }
            let outcome = scheme.step(&mut r, &mut v, H, &drawn[k % DRAWN]);
            black_box(outcome.unwrap_or_else(|e| panic!("step {k} failed: {e}")));
        }
        best = best.min(start.elapsed().as_nanos() as f64 / STEPS as f64);
    }
    best
}

/// Small blocks, every other one freed: holes among live blocks where the next small
/// allocations land, scattered as in a program that has run for a while (i chooses how many
/// and how large).
fn small_holes(i: usize) -> Vec<Vec<u8>> {
    let blocks: Vec<Vec<u8>> = (0..2 * (i % 16))
        .map(|k| vec![0u8; 8 + 8 * ((i + k) % 5)])
        .collect();
    blocks.into_iter().skip(1).step_by(2).collect()
}

/// `scheme`'s time per step at `placements` placements of its buffers.
fn spread<S: Scheme + Clone>(
    name: &'static str, scheme: &S, drawn: &[[f64; 2]], placements: usize,
) -> Spread {
    let mut spacers = Vec::with_capacity(placements);
    let mut times = Vec::with_capacity(placements);
    for i in 0..placements {
        spacers.push(vec![0u8; 24 * i + 1]);
        let holes = small_holes(i);
        let mut clone = scheme.clone();
        drop(holes);
        times.push(time_per_step(&mut clone, drawn));
    }
    black_box(spacers);
    times.sort_by(f64::total_cmp);
    Spread { name, times }
}

/// The placements asked for on the command line (the first argument that is a number).
fn placements() -> usize {
    std::env::args()
        .skip(1)
        .find_map(|arg| arg.parse().ok())
        .filter(|&p| p > 0)
        .unwrap_or(PLACEMENTS)
}

/// The spreads as JSON.
fn json(spreads: &[Spread]) -> String {
    let schemes: Vec<Value> = spreads
        .iter()
        .map(|s| {
            json!({
                "name": s.name,
                "placements": s.times.len(),
                "min": s.quantile(0.0),
                "median": s.quantile(0.5),
                "max": s.quantile(1.0),
                "slower_than_1.1_median": s.slow(),
                "times": s.times,
            })
        })
        .collect();
    let report = json!({ "unit": "ns per step of one path", "schemes": schemes });
    serde_json::to_string_pretty(&report).expect("a JSON value")
}

/// Where the report goes: target/bench/placement.json of the workspace (the bench runs in
/// its package's directory).
fn report_path() -> PathBuf {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2);
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .or_else(|| workspace.map(|root| root.join("target")))
        .unwrap_or_else(|| PathBuf::from("target"));
    target.join("bench").join("placement.json")
}

fn main() {
    let placements = placements();
    let system = pendulum(PendulumParams::default()).expect("pendulum parameters");
    let mut noise = GaussianIncrements::for_path(2024, 0, 2);
    let mut drawn = [[0.0; 2]; DRAWN];
    for dw in &mut drawn {
        noise.next_increment(H, dw);
    }
    let config = StepperConfig::new(1.0, f64::INFINITY).expect("stepper configuration");
    let stepper = Stepper::new(system.clone(), config).expect("stepper");
    eprintln!("placement: {placements} placements of each scheme's buffers");
    let spreads = [
        spread("stepper", &stepper, &drawn, placements),
        spread(
            "euler_maruyama",
            &EulerMaruyama::new(system.clone()).expect("Euler-Maruyama"),
            &drawn,
            placements,
        ),
        spread(
            "truncated_euler_maruyama",
            &TruncatedEulerMaruyama::new(system.clone()).expect("truncated Euler-Maruyama"),
            &drawn,
            placements,
        ),
        spread(
            "projected_euler_maruyama",
            &ProjectedEulerMaruyama::new(system.clone()).expect("projected Euler-Maruyama"),
            &drawn,
            placements,
        ),
        spread(
            "stochastic_heun",
            &StochasticHeun::new(system).expect("stochastic Heun"),
            &drawn,
            placements,
        ),
    ];
    println!(
        "{:26} {:>8} {:>8} {:>8} {:>8} {:>8}  slower than 1.1 x median",
        "ns per step of one path", "min", "q1", "median", "q3", "max"
    );
    for s in &spreads {
        println!(
            "{:26} {:8.1} {:8.1} {:8.1} {:8.1} {:8.1}  {}/{}",
            s.name,
            s.quantile(0.0),
            s.quantile(0.25),
            s.quantile(0.5),
            s.quantile(0.75),
            s.quantile(1.0),
            s.slow(),
            s.times.len()
        );
    }
    let path = report_path();
    let written = std::fs::create_dir_all(path.parent().expect("a directory"))
        .and_then(|()| std::fs::write(&path, json(&spreads)));
    match written {
        Ok(()) => eprintln!("placement: wrote {}", path.display()),
        Err(e) => eprintln!("placement: could not write {}: {e}", path.display()),
    }
}
