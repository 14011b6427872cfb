//! Many paths of a scene with one scheme, recorded every k-th step: the states, each path's
//! diagnostics and its failure, as flat arrays for a user's own plots and statistics (the
//! Python package's `simulate`). Path i draws its increments from the stream (seed, i), as in
//! every study, so its numbers do not depend on the number of paths, the threads or the
//! blocks.
//!
//! ```
//! use sdae_study::integrator::SchemeKind;
//! use sdae_study::scene::Scene;
//! use sdae_study::simulate::{SimulateSettings, simulate};
//! let scene = Scene::built_in("pendulum")?;
//! let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 16, 256, 7)?.every(64)?;
//! let paths = simulate(&scene, &settings, &|| false)?;
//! assert_eq!(paths.times.len(), 5);
//! assert_eq!(paths.positions.len(), 16 * 5 * paths.n);
//! assert!(paths.failures.iter().all(Option::is_none));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use rayon::prelude::*;
use sdae_lanes::LineVec;
use sdae_manifold::Constraint;
use sdae_model::{PathDiagnostics, TimeGrid};
use sdae_noise::EnsembleIncrements;
use sdae_reference::CurvedSystem;

use sdae_stats::memory;

use crate::convergence::MAX_THREADS;
use crate::error::StudyError;
use crate::integrator::{SchemeKind, StudyScheme};
use crate::scene::{Prepared, Scene, SceneRunner};

/// Paths stepped together in one ensemble (a multiple of every lane width).
const BLOCK_PATHS: usize = 64;

/// Steps of a block between two looks at the stop check.
pub const STOP_CHECK: usize = 256;

/// What [`simulate`] runs: the scheme, P paths of N steps from the scene's initial state, the
/// seed of the increments, the recording stride k and the worker threads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulateSettings {
    /// The scheme.
    pub scheme: SchemeKind,
    /// P.
    pub paths: usize,
    /// N: the step is h = T / N.
    pub steps: usize,
    /// Path i's increments come from the stream (seed, i).
    pub seed: u64,
    /// k: t_0, every k-th step and t_N are recorded.
    pub every: usize,
    /// Worker threads (1 or more).
    pub threads: usize,
}

impl SimulateSettings {
    /// P paths of N steps with `scheme` and `seed`, every step recorded, on one thread.
    /// Refuses P = 0 or N = 0.
    pub fn new(
        scheme: SchemeKind, paths: usize, steps: usize, seed: u64,
    ) -> Result<Self, StudyError> {
        Self {
            scheme,
            paths,
            steps,
            seed,
            every: 1,
            threads: 1,
        }
        .validated()
    }

    /// Records t_0, every k-th step and t_N; refuses k = 0.
    pub fn every(self, every: usize) -> Result<Self, StudyError> {
        Self { every, ..self }.validated()
    }

    /// Runs on `threads` worker threads; refuses 0 and more than [`MAX_THREADS`].
    pub fn threads(self, threads: usize) -> Result<Self, StudyError> {
        Self { threads, ..self }.validated()
    }

    /// Fails, naming the setting, unless P, N and k are at least 1 and the threads in
    /// 1..=[`MAX_THREADS`] ([`simulate`] checks settings built field by field too).
    pub fn validate(&self) -> Result<(), StudyError> {
        positive("paths", self.paths)?;
        positive("steps", self.steps)?;
        positive("every", self.every)?;
        if self.threads == 0 || self.threads > MAX_THREADS {
            return Err(StudyError::Setting {
                key: "threads",
                value: self.threads.to_string(),
                rule: format!("must be in 1..={MAX_THREADS}"),
            });
        }
        Ok(())
    }

    fn validated(self) -> Result<Self, StudyError> {
        self.validate()?;
        Ok(self)
    }

    /// T, the number of recorded steps.
    pub fn records(&self) -> usize {
        self.steps / self.every + 1 + usize::from(!self.steps.is_multiple_of(self.every))
    }

    /// The recorded steps: 0, k, 2k, ... and N.
    pub fn recorded_steps(&self) -> Vec<usize> {
        let mut steps: Vec<usize> = (0..=self.steps).step_by(self.every).collect();
        if steps.last() != Some(&self.steps) {
            steps.push(self.steps);
        }
        steps
    }
}

/// A refusal of a setting that must be at least 1.
fn positive(name: &'static str, value: usize) -> Result<(), StudyError> {
    if value == 0 {
        return Err(StudyError::Setting {
            key: name,
            value: "0".into(),
            rule: "must be at least 1".into(),
        });
    }
    Ok(())
}

/// P recorded paths: T recorded times, n coordinates, m constraints. Arrays are row-major:
/// `positions[(p * T + j) * n + i]` is coordinate i of path p at `times[j]`. A path that
/// failed holds NaN from the first recorded time after its failure on; its failure says why
/// and its diagnostics at which step.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedPaths {
    /// The scheme's name.
    pub scheme: String,
    /// n.
    pub n: usize,
    /// m.
    pub m: usize,
    /// The step size h = T / N.
    pub h: f64,
    /// The recorded times t_{k_j} of the grid (k h, and T at k = N; grid times also for a
    /// time-changed scheme).
    pub times: Vec<f64>,
    /// r, P x T x n.
    pub positions: Vec<f64>,
    /// v, P x T x n.
    pub velocities: Vec<f64>,
    /// mu, P x T x m (mu_0 = 0).
    pub multipliers: Vec<f64>,
    /// What each path's steps did.
    pub diagnostics: Vec<PathDiagnostics>,
    /// Why a path stopped, or `None`.
    pub failures: Vec<Option<String>>,
}

/// Simulates `settings.paths` paths of `scene` (see [`SimulateSettings`]); ends with
/// [`StudyError::Stopped`] within [`STOP_CHECK`] steps of `stop` returning true.
pub fn simulate(
    scene: &Scene, settings: &SimulateSettings, stop: &(dyn Fn() -> bool + Sync),
) -> Result<SimulatedPaths, StudyError> {
    simulate_with_progress(scene, settings, stop, &|_| {})
}

/// [`simulate`], calling `progress` with the number of paths of each block as it finishes.
pub fn simulate_with_progress(
    scene: &Scene, settings: &SimulateSettings, stop: &(dyn Fn() -> bool + Sync),
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SimulatedPaths, StudyError> {
    settings.validate()?;
    scene.run(Simulator {
        settings,
        stop,
        progress,
    })?
}

struct Simulator<'a> {
    settings: &'a SimulateSettings,
    stop: &'a (dyn Fn() -> bool + Sync),
    progress: &'a (dyn Fn(usize) + Sync),
}

impl SceneRunner for Simulator<'_> {
    type Output = Result<SimulatedPaths, StudyError>;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: CurvedSystem + Clone + Send + Sync + 'static,
    {
        let settings = self.settings;
        let grid = TimeGrid::new(scene.t_end, settings.steps).map_err(StudyError::from)?;
        fits_in_memory(settings, &prepared)?;
        let scheme = StudyScheme::built_in(settings.scheme, &prepared.system, &prepared.constants);
        let recorded = settings.recorded_steps();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(settings.threads)
            .build()
            .map_err(|e| StudyError::Threads {
                threads: settings.threads,
                message: e.to_string(),
            })?;
        let blocks = pool.install(|| {
            (0..settings.paths.div_ceil(BLOCK_PATHS))
                .into_par_iter()
                .map(|b| {
                    if (self.stop)() {
                        return Err(StudyError::Stopped);
                    }
                    let end = settings.paths.min((b + 1) * BLOCK_PATHS);
                    let indices: Vec<u64> = (b * BLOCK_PATHS..end).map(|i| i as u64).collect();
                    let block = Block {
                        indices: &indices,
                        seed: settings.seed,
                        stop: self.stop,
                    };
                    let records = run_block(&scheme, &prepared, grid.h(), &recorded, block)?;
                    (self.progress)(indices.len());
                    Ok(records)
                })
                .collect::<Result<Vec<_>, StudyError>>()
        })?;
        Ok(gather(settings, &prepared, &grid, &recorded, blocks))
    }
}

/// Refuses, naming `paths`, a run whose recorded states (held twice: the blocks' rows and
/// the arrays) would not fit in the available memory.
fn fits_in_memory<S: CurvedSystem>(
    settings: &SimulateSettings, prepared: &Prepared<S>,
) -> Result<(), StudyError> {
    let row = 2 * prepared.position.len() + prepared.system.constraint().n_constraints();
    let needed = [settings.records(), row, 2 * std::mem::size_of::<f64>()]
        .into_iter()
        .fold(settings.paths as u64, |bytes, k| {
            bytes.saturating_mul(k as u64)
        });
    match memory::exceeded(needed, "the recorded states") {
        Some(rule) => Err(StudyError::Setting {
            key: "paths",
            value: settings.paths.to_string(),
            rule,
        }),
        None => Ok(()),
    }
}

/// One block's records: the rows (r, v, mu) of each path at each recorded step, each path's
/// diagnostics and failure.
struct BlockRecords {
    /// Row of path i of the block at recorded step j: `rows[(j * paths + i) * (2n + m) ..]`.
    rows: Vec<f64>,
    /// Steps completed by each path (a failed path's records after them are NaN).
    diagnostics: Vec<PathDiagnostics>,
    failures: Vec<Option<String>>,
}

/// A block of paths: their indices, the seed of their streams and the stop check.
struct Block<'a> {
    indices: &'a [u64],
    seed: u64,
    stop: &'a (dyn Fn() -> bool + Sync),
}

/// Steps the block's paths in one ensemble from the scene's initial state, reading the rows
/// at the recorded steps.
fn run_block<S>(
    scheme: &StudyScheme<S>, prepared: &Prepared<S>, h: f64, recorded: &[usize], block: Block<'_>,
) -> Result<BlockRecords, StudyError>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let (r0, v0) = (&prepared.position[..], &prepared.velocity[..]);
    let indices = block.indices;
    let mut ensemble = scheme.build_ensemble(indices.len(), r0, v0)?;
    let l = prepared.system.noise_dim();
    let mut noise = EnsembleIncrements::for_paths(block.seed, indices, l);
    let mut dw = LineVec::from_elem(0.0, l * ensemble.stride());
    let (n, m) = (r0.len(), prepared.system.constraint().n_constraints());
    let row = 2 * n + m;
    let all: Vec<usize> = (0..indices.len()).collect();
    let mut rows = vec![0.0; recorded.len() * indices.len() * row];
    let mut step = 0;
    for (j, &k) in recorded.iter().enumerate() {
        while step < k {
            if step % STOP_CHECK == 0 && (block.stop)() {
                return Err(StudyError::Stopped);
            }
            ensemble.step_drawing(h, &mut noise, &mut dw)?;
            step += 1;
        }
        let block_rows = &mut rows[j * indices.len() * row..(j + 1) * indices.len() * row];
        ensemble.read_rows(&all, m, block_rows)?;
    }
    let mut diagnostics = Vec::with_capacity(indices.len());
    let mut failures = Vec::with_capacity(indices.len());
    for p in 0..indices.len() {
        diagnostics.push(ensemble.diagnostics(p)?);
        failures.push(ensemble.failure(p)?.map(|f| f.to_string()));
    }
    Ok(BlockRecords {
        rows,
        diagnostics,
        failures,
    })
}

/// The blocks' records in the layout of [`SimulatedPaths`], NaN after a failed path's last
/// completed step.
fn gather<S: CurvedSystem>(
    settings: &SimulateSettings, prepared: &Prepared<S>, grid: &TimeGrid, recorded: &[usize],
    blocks: Vec<BlockRecords>,
) -> SimulatedPaths {
    let n = prepared.position.len();
    let m = prepared.system.constraint().n_constraints();
    let (paths, times) = (settings.paths, recorded.len());
    let mut out = SimulatedPaths {
        scheme: settings.scheme.name().into(),
        n,
        m,
        h: grid.h(),
        times: recorded.iter().map(|&k| grid.time(k)).collect(),
        positions: vec![f64::NAN; paths * times * n],
        velocities: vec![f64::NAN; paths * times * n],
        multipliers: vec![f64::NAN; paths * times * m],
        diagnostics: Vec::with_capacity(paths),
        failures: Vec::with_capacity(paths),
    };
    let mut p = 0;
    for block in blocks {
        let width = block.diagnostics.len();
        for (i, (diagnostics, failure)) in block
            .diagnostics
            .into_iter()
            .zip(block.failures)
            .enumerate()
        {
            for (j, &k) in recorded.iter().enumerate() {
                if failure.is_some() && k > diagnostics.steps {
                    break;
                }
                let row = &block.rows[(j * width + i) * (2 * n + m)..][..2 * n + m];
                let at = p * times + j;
                out.positions[at * n..][..n].copy_from_slice(&row[..n]);
                out.velocities[at * n..][..n].copy_from_slice(&row[n..2 * n]);
                out.multipliers[at * m..][..m].copy_from_slice(&row[2 * n..]);
            }
            out.diagnostics.push(diagnostics);
            out.failures.push(failure);
            p += 1;
        }
    }
    out
}
