//! Speed of the splitting schemes against the half-explicit scheme on the same scenes, per
//! path-step, increments drawn beforehand:
//!
//! - `half-explicit`: `sdae_scheme::Stepper` with the practical constants (C_eta = 1; for the
//!   molecules no ball either, C_kappa = inf, as benches/molecule.rs);
//! - `baoab`: `sdae_splitting::Splitting` with `SplittingConfig::baoab()` (one SHAKE/RATTLE
//!   drift per half-step);
//! - `g-baoab`: the same with `SplittingConfig::g_baoab()` (K_r = 3 geodesic substeps per
//!   half-step).
//!
//! The scenes: `pendulum`, the thermal planar pendulum (`PendulumParams { friction: 0.5,
//! ..Default::default() }`: gravity 1, sigma = 1, kT = 1) from r = (1, 0), v = (0, 1);
//! `chain`, the chain molecule (`ChainMoleculeParams::default()`: 8 atoms, 7 rigid bonds,
//! bond angles and torsions) and `triatomic`, the rigid triatomic
//! (`RigidTriatomicParams::default()`), each from its `initial_state()`. h = 1e-2 everywhere.
//!
//! - `splitting_step/<scene>/<scheme>`: one path through the scalar `Scheme::step`; one
//!   iteration is P consecutive steps of the path.
//! - `splitting_ensemble/<scene>/<scheme>`: P paths in a `LaneEnsemble`
//!   (`sdae_scheme::Ensemble` for the half-explicit scheme), W paths at once where the scheme
//!   has a lane form for the scene: the sphere's closed form for the pendulum, Newton over
//!   lanes for the molecules (the kappa root for the half-explicit scheme, the SHAKE
//!   projections for the splitting schemes). One iteration is one step of every path.
//!
//! P is [`PENDULUM_PATHS`] for the pendulum and [`MOLECULE_PATHS`] for the molecules, so an
//! iteration is P path-steps in both; throughput is reported per path-step (criterion's
//! elements).
//!
//! Every scheme gets the same increments: [`DRAWN_STEPS`] steps of each path's N(0, h I)
//! increments (path p's own stream, the same numbers in the scalar and the ensemble's
//! layout), drawn before measuring and cycled, so that the figures are the steps alone. The
//! states are put back to the start every [`RESET_EVERY`] steps (a multiple of
//! [`DRAWN_STEPS`]: every period replays the same trajectories). Before measuring, each
//! benchmark runs one period, asserts that no step fails and that max |g| < 1e-10, and prints
//! the mean number of Newton iterations per step (one path; for the splitting schemes the sum
//! over the step's 2 K_r SHAKE projections, 0 where the sphere's closed form takes the step)
//! and, for the ensembles, how many path-steps went through the scalar step.
//!
//! Run with `cargo bench -p sdae-bench --bench splitting`.

mod verify;

use std::hint::black_box;

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use sdae_manifold::TheoryBound;
use sdae_model::{LaneEnsemble, LaneScheme, PathEnsemble, Scheme, System};
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_splitting::{Splitting, SplittingConfig};
use sdae_systems::{
    ChainMolecule, ChainMoleculeParams, Pendulum, PendulumParams, RigidTriatomic,
    RigidTriatomicParams, chain_molecule, pendulum, rigid_triatomic,
};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Step size of every scene.
const H: f64 = 1e-2;

/// Steps between resets of the states to the start (a multiple of the paths of every scene,
/// so that the iterations of `splitting_step` cover fixed stretches of a period).
const RESET_EVERY: usize = 1024;

/// Steps of increments drawn beforehand (cycled).
const DRAWN_STEPS: usize = 128;

/// Paths of the pendulum ensembles (as benches/ensemble.rs).
const PENDULUM_PATHS: usize = 512;

/// Paths of the molecule ensembles (as benches/molecule.rs).
const MOLECULE_PATHS: usize = 64;

const _: () = assert!(
    RESET_EVERY.is_multiple_of(PENDULUM_PATHS) && RESET_EVERY.is_multiple_of(MOLECULE_PATHS)
);

/// Seed of the paths' streams.
const SEED: u64 = 2024;

/// Bound on max |g| over a verification period.
const RESIDUAL_BOUND: f64 = 1e-10;

/// A scene of the benchmarks: its system, start and the half-explicit scheme's settings.
trait Scene: System<Constraint: TheoryBound> + Clone {
    /// The scene's part of the benchmark IDs.
    const NAME: &'static str;
    /// Paths of its ensembles.
    const PATHS: usize;
    fn build() -> Self;
    fn start(&self) -> (Vec<f64>, Vec<f64>);
    /// The practical configuration: C_eta = 1.
    fn stepper_config(&self) -> StepperConfig {
        StepperConfig::for_system(self)
            .and_then(|c| c.with_c_eta(1.0))
            .expect("stepper config")
    }
}

impl Scene for Pendulum {
    const NAME: &'static str = "pendulum";
    const PATHS: usize = PENDULUM_PATHS;
    fn build() -> Self {
        pendulum(PendulumParams {
            friction: 0.5,
            ..Default::default()
        })
        .expect("pendulum parameters")
    }
    fn start(&self) -> (Vec<f64>, Vec<f64>) {
        (vec![1.0, 0.0], vec![0.0, 1.0])
    }
}

impl Scene for ChainMolecule {
    const NAME: &'static str = "chain";
    const PATHS: usize = MOLECULE_PATHS;
    fn build() -> Self {
        chain_molecule(&ChainMoleculeParams::default()).expect("molecule parameters")
    }
    fn start(&self) -> (Vec<f64>, Vec<f64>) {
        self.initial_state()
    }
    fn stepper_config(&self) -> StepperConfig {
        molecule_config(self)
    }
}

impl Scene for RigidTriatomic {
    const NAME: &'static str = "triatomic";
    const PATHS: usize = MOLECULE_PATHS;
    fn build() -> Self {
        rigid_triatomic(&RigidTriatomicParams::default()).expect("triatomic parameters")
    }
    fn start(&self) -> (Vec<f64>, Vec<f64>) {
        self.initial_state()
    }
    fn stepper_config(&self) -> StepperConfig {
        molecule_config(self)
    }
}

/// The half-explicit scheme's settings for a molecule: C_eta = 1 and no ball (C_kappa = inf),
/// as benches/molecule.rs.
fn molecule_config<S: System<Constraint: TheoryBound>>(system: &S) -> StepperConfig {
    StepperConfig::for_system(system)
        .and_then(|c| c.with_c_eta(1.0))
        .and_then(|c| c.with_c_kappa(f64::INFINITY))
        .expect("stepper config")
}

fn half_explicit<S: Scene>(system: S) -> Stepper<S> {
    let config = system.stepper_config();
    Stepper::new(system, config).expect("half-explicit stepper")
}

fn splitting<S: Scene>(system: S, config: SplittingConfig) -> Splitting<S> {
    Splitting::new(system, config).expect("splitting scheme")
}

/// One path of a scheme on increments drawn beforehand.
struct OnePath<Sch: Scheme> {
    name: String,
    scheme: Sch,
    r0: Vec<f64>,
    v0: Vec<f64>,
    r: Vec<f64>,
    v: Vec<f64>,
    /// Path 0's increments, step k at `k * l..(k + 1) * l`.
    drawn: Vec<f64>,
    l: usize,
    steps: usize,
}

impl<Sch: Scheme> OnePath<Sch> {
    fn new(name: String, scheme: Sch, (r0, v0): (Vec<f64>, Vec<f64>)) -> Self {
        let l = scheme.system().noise_dim();
        let mut noise = GaussianIncrements::for_path(SEED, 0, l);
        let mut drawn = vec![0.0; DRAWN_STEPS * l];
        for dw in drawn.chunks_exact_mut(l.max(1)) {
            noise.next_increment(H, dw);
        }
        Self {
            name,
            scheme,
            r: r0.clone(),
            v: v0.clone(),
            r0,
            v0,
            drawn,
            l,
            steps: 0,
        }
    }

    /// One step (the state reset every RESET_EVERY steps); returns the Newton iterations and
    /// max |g| after the step.
    #[inline]
    fn step(&mut self) -> (usize, f64) {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.r.copy_from_slice(&self.r0);
            self.v.copy_from_slice(&self.v0);
        }
        let k = self.steps % DRAWN_STEPS;
        self.steps += 1;
        let dw = &self.drawn[k * self.l..(k + 1) * self.l];
        match self.scheme.step(&mut self.r, &mut self.v, H, dw) {
            Ok(outcome) => (
                outcome.newton_iterations,
                outcome.position_residual.unwrap_or(0.0),
            ),
            Err(e) => panic!(
                "{}: step {} (since reset: {}) failed: {e}",
                self.name,
                self.steps,
                (self.steps - 1) % RESET_EVERY
            ),
        }
    }

    /// `count` steps; returns the sum of their Newton iterations.
    #[inline]
    fn steps(&mut self, count: usize) -> usize {
        (0..count).map(|_| self.step().0).sum()
    }

    /// Before the first step (later calls do nothing): one reset period, checked.
    fn verify(&mut self) {
        if self.steps > 0 {
            return;
        }
        let (mut worst, mut iterations) = (0.0f64, 0);
        for _ in 0..RESET_EVERY {
            let (k, residual) = self.step();
            worst = worst.max(residual);
            iterations += k;
        }
        verify::report_verification(&self.name, worst, iterations, RESET_EVERY, RESIDUAL_BOUND);
    }
}

/// Many paths of a scheme in a `LaneEnsemble` on increments drawn beforehand.
struct ManyPaths<Sch: LaneScheme> {
    name: String,
    ensemble: LaneEnsemble<Sch>,
    r0: Vec<f64>,
    v0: Vec<f64>,
    /// Every path's increments of a step in the ensemble's layout.
    drawn: Vec<Vec<f64>>,
    steps: usize,
}

impl<Sch: LaneScheme> ManyPaths<Sch> {
    fn new(name: String, scheme: Sch, paths: usize, (r0, v0): (Vec<f64>, Vec<f64>)) -> Self {
        let l = scheme.system().noise_dim();
        let ensemble = LaneEnsemble::new(scheme, paths, &r0, &v0).expect("ensemble");
        let indices: Vec<u64> = (0..paths as u64).collect();
        let mut noise = EnsembleIncrements::for_paths(SEED, &indices, l);
        let drawn = (0..DRAWN_STEPS)
            .map(|_| {
                let mut dw = vec![0.0; l * ensemble.stride()];
                noise.fill(H, &mut dw).expect("increments buffer");
                dw
            })
            .collect();
        Self {
            name,
            ensemble,
            r0,
            v0,
            drawn,
            steps: 0,
        }
    }

    /// One step of every path (all restarted every RESET_EVERY steps); returns the number of
    /// paths that failed in it.
    #[inline]
    fn step(&mut self) -> usize {
        if self.steps.is_multiple_of(RESET_EVERY) {
            self.ensemble.restart(&self.r0, &self.v0).expect("restart");
        }
        let dw = &self.drawn[self.steps % DRAWN_STEPS];
        self.steps += 1;
        self.ensemble.step(H, dw).expect("step input")
    }

    /// Before the first step (later calls do nothing): one reset period, checked.
    fn verify(&mut self) {
        if self.steps > 0 {
            return;
        }
        for _ in 0..RESET_EVERY {
            self.step();
        }
        self.check();
        let paths = self.ensemble.paths();
        let (mut worst, mut iterations) = (0.0f64, 0);
        for p in 0..paths {
            let d = self.ensemble.diagnostics(p).expect("path index");
            worst = worst.max(d.max_position_residual);
            iterations += d.newton_iterations;
        }
        assert!(
            worst < RESIDUAL_BOUND,
            "{}: position residual {worst:e} after {RESET_EVERY} steps",
            self.name
        );
        eprintln!(
            "{}: {RESET_EVERY} verification steps of {paths} paths ok, max |g| = {worst:.1e}, \
             mean Newton iterations per path-step = {:.2}, {} of {} path-steps through the \
             scalar step",
            self.name,
            iterations as f64 / (RESET_EVERY * paths) as f64,
            self.ensemble.scalar_steps(),
            RESET_EVERY * paths
        );
    }

    /// Panics if a path failed.
    fn check(&self) {
        assert_eq!(
            self.ensemble.failed_paths(),
            0,
            "{}: a path failed: {:?}",
            self.name,
            (0..self.ensemble.paths()).find_map(|p| self.ensemble.failure(p).ok().flatten())
        );
    }
}

/// How a scheme is benchmarked: one path through the scalar step, or many paths in lanes.
trait Kind {
    /// The first part of the benchmark IDs.
    const GROUP: &'static str;
    /// Adds the benchmark `<GROUP>/<scene>/<scheme_name>` of `scheme` to `group`.
    fn bench<Sch: Scheme + LaneScheme>(
        group: &mut BenchmarkGroup<'_, WallTime>, scene: &str, scheme_name: &str, scheme: Sch,
        paths: usize, start: (Vec<f64>, Vec<f64>),
    );
}

/// `splitting_step/<scene>/<scheme>`: an iteration is `paths` steps of one path.
struct StepBench;

impl Kind for StepBench {
    const GROUP: &'static str = "splitting_step";
    fn bench<Sch: Scheme + LaneScheme>(
        group: &mut BenchmarkGroup<'_, WallTime>, scene: &str, scheme_name: &str, scheme: Sch,
        paths: usize, start: (Vec<f64>, Vec<f64>),
    ) {
        let name = format!("{}/{scene}/{scheme_name}", Self::GROUP);
        let mut bench = OnePath::new(name, scheme, start);
        group.bench_function(scheme_name, |b| {
            bench.verify();
            b.iter(|| black_box(bench.steps(paths)))
        });
    }
}

/// `splitting_ensemble/<scene>/<scheme>`: an iteration is one step of `paths` paths.
struct EnsembleBench;

impl Kind for EnsembleBench {
    const GROUP: &'static str = "splitting_ensemble";
    fn bench<Sch: Scheme + LaneScheme>(
        group: &mut BenchmarkGroup<'_, WallTime>, scene: &str, scheme_name: &str, scheme: Sch,
        paths: usize, start: (Vec<f64>, Vec<f64>),
    ) {
        let name = format!("{}/{scene}/{scheme_name}", Self::GROUP);
        let mut bench = ManyPaths::new(name, scheme, paths, start);
        group.bench_function(scheme_name, |b| {
            bench.verify();
            b.iter(|| black_box(bench.step()))
        });
        bench.check();
    }
}

/// The group `<K::GROUP>/<scene>`: the three schemes of the scene `system`, benchmarked as `K`
/// does, from `start`.
fn bench_group<S: Scene, K: Kind>(c: &mut Criterion, system: &S, start: &(Vec<f64>, Vec<f64>)) {
    let paths = S::PATHS;
    let mut group = c.benchmark_group(format!("{}/{}", K::GROUP, S::NAME));
    group.throughput(Throughput::Elements(paths as u64));
    let scheme = half_explicit(system.clone());
    K::bench(
        &mut group,
        S::NAME,
        "half-explicit",
        scheme,
        paths,
        start.clone(),
    );
    for (name, config) in [
        ("baoab", SplittingConfig::baoab()),
        ("g-baoab", SplittingConfig::g_baoab()),
    ] {
        let scheme = splitting(system.clone(), config);
        K::bench(&mut group, S::NAME, name, scheme, paths, start.clone());
    }
    group.finish();
}

/// The three schemes of a scene, one path and many.
fn bench_scene<S: Scene>(c: &mut Criterion) {
    let system = S::build();
    let start = system.start();
    bench_group::<S, StepBench>(c, &system, &start);
    bench_group::<S, EnsembleBench>(c, &system, &start);
}

fn bench_scenes(c: &mut Criterion) {
    bench_scene::<Pendulum>(c);
    bench_scene::<ChainMolecule>(c);
    bench_scene::<RigidTriatomic>(c);
}

criterion_group!(benches, bench_scenes);
criterion_main!(benches);
