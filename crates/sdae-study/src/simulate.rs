//! Many paths of a scene with one scheme, recorded every k-th step: the states, each path's
//! diagnostics and its failure, as flat arrays for a user's own plots and statistics (the
//! Python package's `simulate`). Path i draws its increments from the stream (seed, i), as in
//! every study, so its numbers do not depend on the number of paths, the threads or the
//! blocks. [`simulate_streaming`] runs the same paths but hands each recorded state to a sink
//! as it is produced (the trajectory files of the `trajectory` module), so that memory does not
//! grow with the number of steps.
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
    within_memory(settings, needed, "the recorded states")
}

/// Refuses, naming `paths`, a run that needs `needed` bytes for `what` where the machine has
/// less available.
fn within_memory(settings: &SimulateSettings, needed: u64, what: &str) -> Result<(), StudyError> {
    match memory::exceeded(needed, what) {
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

/// The paths of one block stepped together in one ensemble from the scene's initial state:
/// [`simulate`] runs a block to its end, [`simulate_streaming`] a recorded step at a time; the
/// same calls in the same order either way, so the same numbers.
struct BlockRun<S: CurvedSystem> {
    ensemble: crate::integrator::BoxedEnsemble<S>,
    noise: EnsembleIncrements,
    dw: LineVec<f64>,
    /// The steps taken.
    step: usize,
    /// The block's paths, 0..P_b.
    all: Vec<usize>,
    /// m.
    m: usize,
}

impl<S> BlockRun<S>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    /// The block's ensemble at the scene's initial state and its increments' streams.
    fn new(
        scheme: &StudyScheme<S>, prepared: &Prepared<S>, indices: &[u64], seed: u64,
    ) -> Result<Self, StudyError> {
        let (r0, v0) = (&prepared.position[..], &prepared.velocity[..]);
        let ensemble = scheme.build_ensemble(indices.len(), r0, v0)?;
        let l = prepared.system.noise_dim();
        let dw = LineVec::from_elem(0.0, l * ensemble.stride());
        Ok(Self {
            noise: EnsembleIncrements::for_paths(seed, indices, l),
            dw,
            ensemble,
            step: 0,
            all: (0..indices.len()).collect(),
            m: prepared.system.constraint().n_constraints(),
        })
    }

    /// Steps the block on to step `k`, looking at `stop` every [`STOP_CHECK`] steps.
    fn advance_to(
        &mut self, k: usize, h: f64, stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(), StudyError> {
        while self.step < k {
            if self.step.is_multiple_of(STOP_CHECK) && stop() {
                return Err(StudyError::Stopped);
            }
            self.ensemble
                .step_drawing(h, &mut self.noise, &mut self.dw)?;
            self.step += 1;
        }
        Ok(())
    }

    /// Copies each path's (r, v, mu) into its row of `rows` (2n + m each).
    fn read_rows(&self, rows: &mut [f64]) -> Result<(), StudyError> {
        Ok(self.ensemble.read_rows(&self.all, self.m, rows)?)
    }

    /// Whether path p of the block has stopped on a failed step.
    fn failed(&self, p: usize) -> Result<bool, StudyError> {
        Ok(self.ensemble.failure(p)?.is_some())
    }

    /// Each path's diagnostics and failure.
    fn outcomes(&self) -> Result<(Vec<PathDiagnostics>, Vec<Option<String>>), StudyError> {
        let mut diagnostics = Vec::with_capacity(self.all.len());
        let mut failures = Vec::with_capacity(self.all.len());
        for &p in &self.all {
            diagnostics.push(self.ensemble.diagnostics(p)?);
            failures.push(self.ensemble.failure(p)?.map(|f| f.to_string()));
        }
        Ok((diagnostics, failures))
    }
}

/// Steps the block's paths in one ensemble from the scene's initial state, reading the rows
/// at the recorded steps.
fn run_block<S>(
    scheme: &StudyScheme<S>, prepared: &Prepared<S>, h: f64, recorded: &[usize], block: Block<'_>,
) -> Result<BlockRecords, StudyError>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let mut run = BlockRun::new(scheme, prepared, block.indices, block.seed)?;
    let width = block.indices.len() * (2 * prepared.position.len() + run.m);
    let mut rows = vec![0.0; recorded.len() * width];
    for (j, &k) in recorded.iter().enumerate() {
        run.advance_to(k, h, block.stop)?;
        run.read_rows(&mut rows[j * width..(j + 1) * width])?;
    }
    let (diagnostics, failures) = run.outcomes()?;
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

/// Copies of a path's state a streamed path takes in memory, at most: its ensemble's state and
/// workspace, the row read from it, the row waiting to be written and the writer's buffer.
const STREAM_COPIES: u64 = 16;

/// How [`simulate_streaming`] runs: how many paths are in flight at once, the stop check and
/// the progress callback.
#[derive(Clone, Copy)]
pub struct Streaming<'a> {
    /// Paths stepped at once (rounded up to whole blocks of 64): all of them, or fewer when the
    /// sink wants the paths in groups (a file per path open at a time, say).
    pub batch: usize,
    /// Ends the run with [`StudyError::Stopped`] within [`STOP_CHECK`] steps of returning true.
    pub stop: &'a (dyn Fn() -> bool + Sync),
    /// Called with the number of path steps done since its last call (the run does
    /// P N path steps in all).
    pub progress: &'a (dyn Fn(u64) + Sync),
}

impl std::fmt::Debug for Streaming<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Streaming")
            .field("batch", &self.batch)
            .finish_non_exhaustive()
    }
}

/// What [`simulate_streaming`] keeps of its paths: everything [`SimulatedPaths`] holds but
/// the states, which went to the sink.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamedPaths {
    /// The scheme's name.
    pub scheme: String,
    /// n.
    pub n: usize,
    /// m.
    pub m: usize,
    /// The step size h = T / N.
    pub h: f64,
    /// The recorded times.
    pub times: Vec<f64>,
    /// What each path's steps did.
    pub diagnostics: Vec<PathDiagnostics>,
    /// Why a path stopped, or `None`.
    pub failures: Vec<Option<String>>,
}

/// One recorded state of one path, as [`simulate_streaming`] hands it to its sink (and as the
/// trajectory writers take it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame<'a> {
    /// The path's index.
    pub path: usize,
    /// The step k of the grid.
    pub step: usize,
    /// Its time t_k.
    pub time: f64,
    /// r, n coordinates.
    pub position: &'a [f64],
    /// v, n coordinates.
    pub velocity: &'a [f64],
}

/// The sink [`simulate_streaming`] hands each recorded state to.
pub type FrameSink<'a> = dyn FnMut(&Frame<'_>) -> Result<(), StudyError> + 'a;

/// The paths of [`simulate`] (the same numbers for the same settings), each recorded state
/// handed to `sink` as it is produced instead of kept: memory holds the paths in flight, not
/// their records, whatever the number of steps. The paths run in batches of
/// `streaming.batch`; `sink` gets the states of a batch by recorded time, each time's paths in
/// order, and none of a path after it failed (its diagnostics and failure say where).
///
/// ```
/// use sdae_study::integrator::SchemeKind;
/// use sdae_study::scene::Scene;
/// use sdae_study::simulate::{SimulateSettings, Streaming, simulate_streaming};
/// let scene = Scene::built_in("pendulum")?;
/// let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 3, 64, 7)?.every(16)?;
/// let streaming = Streaming { batch: 3, stop: &|| false, progress: &|_| {} };
/// let mut frames = 0;
/// let paths = simulate_streaming(&scene, &settings, &streaming, &mut |_| {
///     frames += 1;
///     Ok(())
/// })?;
/// assert_eq!((frames, paths.times.len()), (3 * 5, 5));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn simulate_streaming(
    scene: &Scene, settings: &SimulateSettings, streaming: &Streaming<'_>, sink: &mut FrameSink<'_>,
) -> Result<StreamedPaths, StudyError> {
    check_streaming(scene, settings, streaming.batch)?;
    scene.run(Streamer {
        settings,
        streaming,
        sink,
    })?
}

/// Refuses what [`simulate_streaming`] would refuse before it runs: bad settings, or paths in
/// flight (a batch of `batch`) beyond the available memory, named by `paths`.
pub fn check_streaming(
    scene: &Scene, settings: &SimulateSettings, batch: usize,
) -> Result<(), StudyError> {
    settings.validate()?;
    positive("batch", batch)?;
    // m <= n: a row of (r, v, mu) is at most 3n long.
    let row = (scene.coordinates().unwrap_or(0) as u64).saturating_mul(3);
    let in_flight = batch_of(batch).min(settings.paths) as u64;
    let needed = in_flight
        .saturating_mul(row)
        .saturating_mul(STREAM_COPIES * std::mem::size_of::<f64>() as u64);
    within_memory(settings, needed, "the paths in flight")
}

/// A batch rounded up to whole blocks, so that the blocks are those of [`simulate`].
fn batch_of(batch: usize) -> usize {
    batch
        .div_ceil(BLOCK_PATHS)
        .max(1)
        .saturating_mul(BLOCK_PATHS)
}

struct Streamer<'a, 'b> {
    settings: &'a SimulateSettings,
    streaming: &'a Streaming<'a>,
    sink: &'b mut FrameSink<'b>,
}

impl SceneRunner for Streamer<'_, '_> {
    type Output = Result<StreamedPaths, StudyError>;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: CurvedSystem + Clone + Send + Sync + 'static,
    {
        let settings = self.settings;
        let grid = TimeGrid::new(scene.t_end, settings.steps).map_err(StudyError::from)?;
        let scheme = StudyScheme::built_in(settings.scheme, &prepared.system, &prepared.constants);
        let recorded = settings.recorded_steps();
        let mut out = StreamedPaths {
            scheme: settings.scheme.name().into(),
            n: prepared.position.len(),
            m: prepared.system.constraint().n_constraints(),
            h: grid.h(),
            times: recorded.iter().map(|&k| grid.time(k)).collect(),
            diagnostics: Vec::with_capacity(settings.paths),
            failures: Vec::with_capacity(settings.paths),
        };
        let batch = batch_of(self.streaming.batch);
        for start in (0..settings.paths).step_by(batch) {
            let job = BatchJob {
                scheme: &scheme,
                prepared: &prepared,
                grid: &grid,
                recorded: &recorded,
                paths: start..settings.paths.min(start + batch),
                settings,
                streaming: self.streaming,
            };
            let (diagnostics, failures) = job.run(&mut *self.sink)?;
            out.diagnostics.extend(diagnostics);
            out.failures.extend(failures);
        }
        Ok(out)
    }
}

/// One batch of paths of a streamed run.
struct BatchJob<'a, S> {
    scheme: &'a StudyScheme<S>,
    prepared: &'a Prepared<S>,
    grid: &'a TimeGrid,
    recorded: &'a [usize],
    paths: std::ops::Range<usize>,
    settings: &'a SimulateSettings,
    streaming: &'a Streaming<'a>,
}

/// What a worker sends for one block: its rows at a recorded step and which paths had failed
/// by then, or at the end its paths' diagnostics and failures.
enum Message {
    Rows { rows: Vec<f64>, failed: Vec<bool> },
    Done(Vec<PathDiagnostics>, Vec<Option<String>>),
}

type Outcomes = (Vec<PathDiagnostics>, Vec<Option<String>>);

impl<S> BatchJob<'_, S>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    /// The batch's blocks of paths.
    fn blocks(&self) -> Vec<std::ops::Range<usize>> {
        (self.paths.clone())
            .step_by(BLOCK_PATHS)
            .map(|b| b..self.paths.end.min(b + BLOCK_PATHS))
            .collect()
    }

    /// Runs the batch: worker w steps blocks w, w + W, ... (each ensemble lives on the thread
    /// that made it) and sends each recorded step's rows through a channel of one message, so
    /// that no worker runs more than a record ahead of the sink.
    fn run(&self, sink: &mut FrameSink<'_>) -> Result<Outcomes, StudyError> {
        let blocks = self.blocks();
        let workers = self.settings.threads.min(blocks.len()).max(1);
        let abandoned = std::sync::atomic::AtomicBool::new(false);
        std::thread::scope(|scope| {
            let mut receivers = Vec::with_capacity(workers);
            for w in 0..workers {
                let (sender, receiver) = std::sync::mpsc::sync_channel(1);
                let mine: Vec<_> = blocks.iter().skip(w).step_by(workers).cloned().collect();
                let abandoned = &abandoned;
                std::thread::Builder::new()
                    .spawn_scoped(scope, move || self.work(&mine, abandoned, &sender))
                    .map_err(|e| StudyError::Threads {
                        threads: workers,
                        message: e.to_string(),
                    })?;
                receivers.push(receiver);
            }
            let delivered = self.deliver(&blocks, &receivers, sink);
            if delivered.is_err() {
                abandoned.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            delivered
        })
    }

    /// A worker: steps its blocks record by record, sending their rows; ends quietly when the
    /// receiving side has gone (it failed or was stopped), sends its error otherwise.
    fn work(
        &self, blocks: &[std::ops::Range<usize>], abandoned: &std::sync::atomic::AtomicBool,
        sender: &std::sync::mpsc::SyncSender<Result<Message, StudyError>>,
    ) {
        let stop =
            || (self.streaming.stop)() || abandoned.load(std::sync::atomic::Ordering::Relaxed);
        let sent = |message: Message| sender.send(Ok(message)).is_ok();
        let result = (|| -> Result<(), StudyError> {
            let mut runs = Vec::with_capacity(blocks.len());
            for block in blocks {
                let indices: Vec<u64> = block.clone().map(|i| i as u64).collect();
                runs.push(BlockRun::new(
                    self.scheme,
                    self.prepared,
                    &indices,
                    self.settings.seed,
                )?);
            }
            let row = 2 * self.prepared.position.len() + runs.first().map_or(0, |r| r.m);
            for &k in self.recorded {
                for run in &mut runs {
                    run.advance_to(k, self.grid.h(), &stop)?;
                    let mut rows = vec![0.0; run.all.len() * row];
                    run.read_rows(&mut rows)?;
                    let failed = (0..run.all.len())
                        .map(|p| run.failed(p))
                        .collect::<Result<_, _>>()?;
                    if !sent(Message::Rows { rows, failed }) {
                        return Ok(());
                    }
                }
            }
            for run in &runs {
                let (diagnostics, failures) = run.outcomes()?;
                if !sent(Message::Done(diagnostics, failures)) {
                    return Ok(());
                }
            }
            Ok(())
        })();
        if let Err(e) = result {
            let _ = sender.send(Err(e));
        }
    }

    /// Receives the blocks' rows in the order of the paths, record by record, and hands each
    /// living path's state to `sink`; then gathers the paths' outcomes.
    fn deliver(
        &self, blocks: &[std::ops::Range<usize>],
        receivers: &[std::sync::mpsc::Receiver<Result<Message, StudyError>>],
        sink: &mut FrameSink<'_>,
    ) -> Result<Outcomes, StudyError> {
        let n = self.prepared.position.len();
        let row = 2 * n + self.prepared.system.constraint().n_constraints();
        let workers = receivers.len();
        let mut previous = 0;
        for &k in self.recorded {
            for (b, block) in blocks.iter().enumerate() {
                let Message::Rows { rows, failed } = receive(&receivers[b % workers])? else {
                    return Err(ended_early());
                };
                for (i, path) in block.clone().enumerate().filter(|&(i, _)| !failed[i]) {
                    let state = &rows[i * row..][..row];
                    sink(&Frame {
                        path,
                        step: k,
                        time: self.grid.time(k),
                        position: &state[..n],
                        velocity: &state[n..2 * n],
                    })?;
                }
            }
            (self.streaming.progress)(self.paths.len() as u64 * (k - previous) as u64);
            previous = k;
        }
        let (mut diagnostics, mut failures) = (Vec::new(), Vec::new());
        for b in 0..blocks.len() {
            let Message::Done(d, f) = receive(&receivers[b % workers])? else {
                return Err(ended_early());
            };
            diagnostics.extend(d);
            failures.extend(f);
        }
        Ok((diagnostics, failures))
    }
}

/// The next message of a worker: its rows, its outcomes or its error.
fn receive(
    receiver: &std::sync::mpsc::Receiver<Result<Message, StudyError>>,
) -> Result<Message, StudyError> {
    receiver.recv().map_err(|_| ended_early())?
}

/// A worker that ended without its messages (it panicked).
fn ended_early() -> StudyError {
    StudyError::Threads {
        threads: 1,
        message: "a worker thread ended before it sent its paths".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame as the tests keep it: path, step, time, r and v.
    type Recorded = (usize, usize, f64, Vec<f64>, Vec<f64>);

    /// Every frame a streamed run hands its sink, with the states as arrays.
    fn streamed(
        scene: &Scene, settings: &SimulateSettings, batch: usize,
    ) -> (StreamedPaths, Vec<Recorded>) {
        let mut frames = Vec::new();
        let streaming = Streaming {
            batch,
            stop: &|| false,
            progress: &|_| {},
        };
        let out = simulate_streaming(scene, settings, &streaming, &mut |f| {
            frames.push((
                f.path,
                f.step,
                f.time,
                f.position.to_vec(),
                f.velocity.to_vec(),
            ));
            Ok(())
        })
        .unwrap();
        (out, frames)
    }

    #[test]
    fn streamed_paths_are_the_arrays_bit_for_bit_in_batches_and_threads() {
        // 70 paths in batches of 64 (blocks 0..64 and 64..70) on two threads, and in one batch
        // of 128 on one thread.
        let scene = Scene::built_in("spherical-pendulum").unwrap();
        let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 70, 40, 11)
            .unwrap()
            .every(16)
            .unwrap();
        let arrays = simulate(&scene, &settings, &|| false).unwrap();
        let (times, n) = (arrays.times.len(), arrays.n);
        for (batch, threads) in [(64, 2), (128, 1), (1, 2)] {
            let settings = settings.threads(threads).unwrap();
            let (out, frames) = streamed(&scene, &settings, batch);
            assert_eq!(out.times, arrays.times);
            assert_eq!(out.diagnostics, arrays.diagnostics);
            assert_eq!(frames.len(), 70 * times);
            for (k, (p, step, t, r, v)) in frames.iter().enumerate() {
                // By batch, then by time, then by path.
                let (start, width) = if k < 64 * times { (0, 64) } else { (64, 6) };
                let within = k - start * times;
                let batch = batch_of(batch);
                if batch >= 70 {
                    assert_eq!(*p, k % 70);
                } else {
                    assert_eq!(*p, start + within % width);
                }
                let j = arrays.times.iter().position(|x| x == t).unwrap();
                assert_eq!(*step, settings.recorded_steps()[j]);
                let at = (p * times + j) * n;
                assert_eq!(r[..], arrays.positions[at..at + n], "path {p} time {j}");
                assert_eq!(v[..], arrays.velocities[at..at + n], "path {p} time {j}");
            }
        }
    }

    #[test]
    fn a_failed_path_has_no_frames_after_its_failure() {
        let scene = Scene::built_in("noisy-pendulum").unwrap();
        let settings = SimulateSettings::new(SchemeKind::HalfExplicitUntruncated, 64, 16, 1)
            .unwrap()
            .every(3)
            .unwrap();
        let arrays = simulate(&scene, &settings, &|| false).unwrap();
        let (out, frames) = streamed(&scene, &settings, 64);
        assert_eq!(out.failures, arrays.failures);
        let kept = arrays.positions.chunks(arrays.n).filter(|r| !r[0].is_nan());
        assert_eq!(frames.len(), kept.count());
        assert!(out.failures.iter().any(Option::is_some));
    }

    #[test]
    fn a_stop_or_a_failing_sink_ends_the_run_with_its_error() {
        let scene = Scene::built_in("pendulum").unwrap();
        let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 130, 1 << 12, 1)
            .unwrap()
            .threads(2)
            .unwrap();
        let stopped = Streaming {
            batch: 200,
            stop: &|| true,
            progress: &|_| {},
        };
        let e = simulate_streaming(&scene, &settings, &stopped, &mut |_| Ok(())).unwrap_err();
        assert!(matches!(e, StudyError::Stopped), "{e}");
        let streaming = Streaming {
            stop: &|| false,
            ..stopped
        };
        let mut calls = 0;
        let e = simulate_streaming(&scene, &settings, &streaming, &mut |_| {
            calls += 1;
            Err(StudyError::write("disk", "full"))
        })
        .unwrap_err();
        assert_eq!(
            (calls, e.to_string().as_str()),
            (1, "cannot write disk: full")
        );
        let refused = check_streaming(&scene, &settings, 0).unwrap_err();
        assert!(refused.to_string().starts_with("batch = 0"), "{refused}");
    }
}
