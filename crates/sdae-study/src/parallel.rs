//! Monte Carlo over paths on a thread pool: which schemes apply to a scene, and the records of
//! the selected paths, each from its own random stream (the numbers do not depend on the thread
//! count or the sharding).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rayon::prelude::*;
use sdae_lanes::lane_stride;
use sdae_reference::CurvedSystem;
use serde::{Deserialize, Serialize};

use crate::error::StudyError;
use crate::integrator::{SchemeKind, StudyScheme};
use crate::lockstep::{
    BLOCK_PATHS, BlockEnsembles, PathNoise, PathPlan, PathRecord, QuasiPaths, run_block_with,
};
use crate::scene::Prepared;

/// A scheme left out, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// The scheme.
    pub name: String,
    /// Why it does not apply.
    pub reason: String,
}

/// The built-in schemes of `kinds` and the user's `extra` schemes that apply to the scene (each
/// built once to find out), and the rest with the reason.
pub fn applicable<S>(
    kinds: &[SchemeKind], extra: &[StudyScheme<S>], prepared: &Prepared<S>,
) -> (Vec<StudyScheme<S>>, Vec<Skipped>)
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let built_in = kinds
        .iter()
        .map(|&kind| StudyScheme::built_in(kind, &prepared.system, &prepared.constants));
    let mut run = Vec::new();
    let mut skipped = Vec::new();
    for scheme in built_in.chain(extra.iter().cloned()) {
        match scheme.build() {
            Ok(_) => run.push(scheme),
            Err(e) => skipped.push(Skipped {
                name: scheme.name().into(),
                reason: match e {
                    StudyError::SchemeNotApplicable { reason, .. } => reason,
                    other => other.to_string(),
                },
            }),
        }
    }
    (run, skipped)
}

/// Ensembles of `paths` paths from (r0, v0) for a block: each scheme at each of the plan's
/// levels, the reference, and its pair at half the steps where the plan asks for it.
fn block_ensembles<S>(
    schemes: &[StudyScheme<S>], reference: Option<&StudyScheme<S>>, plan: &PathPlan, paths: usize,
    r0: &[f64], v0: &[f64],
) -> Result<BlockEnsembles<S>, StudyError> {
    let mut tracks = Vec::with_capacity(schemes.len() * plan.levels.len());
    let mut own_clock = Vec::with_capacity(tracks.capacity());
    for scheme in schemes {
        for _ in &plan.levels {
            tracks.push(scheme.build_ensemble(paths, r0, v0)?);
            own_clock.push(scheme.time_changed());
        }
    }
    let build = |s: &StudyScheme<S>| s.build_ensemble(paths, r0, v0);
    let coarse_reference = reference
        .filter(|_| plan.paired_reference)
        .map(build)
        .transpose()?;
    Ok(BlockEnsembles {
        tracks,
        own_clock,
        reference: reference.map(build).transpose()?,
        coarse_reference,
    })
}

/// Paths per block: [`BLOCK_PATHS`], or fewer (a multiple of the lane block) so that every
/// thread gets at least [`BLOCKS_PER_THREAD`] blocks, which balances the threads' load and
/// lets a stop take effect early.
fn block_len(paths: usize, threads: usize) -> usize {
    let even = lane_stride(paths.div_ceil(BLOCKS_PER_THREAD * threads.max(1)));
    BLOCK_PATHS.min(even).max(1)
}

/// The fewest blocks per thread [`block_len`] aims at.
const BLOCKS_PER_THREAD: usize = 4;

/// Which paths to run, and on how many threads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSelection {
    /// Seed of the path streams.
    pub seed: u64,
    /// All paths of the study.
    pub paths: usize,
    /// Run the paths i with i % shard.1 == shard.0.
    pub shard: (usize, usize),
    /// Worker threads.
    pub threads: usize,
    /// Randomized quasi-Monte Carlo paths: R randomizations of `paths` / R scrambled Sobol'
    /// points, path p being point p % n of randomization p / n ([`QuasiPaths`]); `None`: each
    /// path its own pseudo-random streams.
    pub randomizations: Option<usize>,
}

/// Floats a block's quasi-random increments may hold (256 MiB): they are computed up front
/// over all the fine steps.
const QUASI_BLOCK_BUDGET: usize = 1 << 25;

/// What receives the records of a block of paths that finished.
pub type FinishedBlock<'a> = dyn Fn(&[PathRecord]) + Sync + 'a;

/// What the caller steers while a run goes on: progress, an early stop, the paths an earlier
/// run already finished, and where finished paths go as they finish.
#[derive(Clone, Copy, Default)]
pub struct Control<'a> {
    /// Called once per finished path with the number of paths this run has finished.
    pub progress: Option<&'a (dyn Fn(usize) + Sync)>,
    /// Once set (say by a Ctrl-C or SIGTERM handler), no further path starts, the blocks of
    /// paths in progress are abandoned within one chunk of fine steps, and the run returns the
    /// paths it finished; each path is whole or absent, never cut short.
    pub stop: Option<&'a AtomicBool>,
    /// Called with the records of each block of paths as it finishes (before the run ends),
    /// so that they can be saved periodically.
    pub finished: Option<&'a FinishedBlock<'a>>,
    /// Indices of paths finished by an interrupted run (their records are kept by the caller):
    /// they are not run again.
    pub done: &'a [usize],
}

impl Control<'_> {
    fn stopped(&self) -> bool {
        self.stop.is_some_and(|s| s.load(Ordering::Relaxed))
    }

    /// Hands the `records` of a finished block of `paths` paths to [`Control::finished`],
    /// counts its paths into `finished` and reports each of them to [`Control::progress`].
    fn block_finished(&self, records: &[PathRecord], paths: usize, finished: &AtomicUsize) {
        if let Some(save) = self.finished {
            save(records);
        }
        let finished = finished.fetch_add(paths, Ordering::Relaxed);
        if let Some(progress) = self.progress {
            for done in finished + 1..=finished + paths {
                progress(done);
            }
        }
    }
}

/// Runs the selected paths of `plan` with `schemes` (and `reference`, if given; all must
/// apply) but those in `control.done`, sorted by index, until `control.stop` is set.
pub fn run_paths<S>(
    plan: &PathPlan, schemes: &[StudyScheme<S>], reference: Option<&StudyScheme<S>>,
    prepared: &Prepared<S>, selection: PathSelection, control: Control<'_>,
) -> Result<Vec<PathRecord>, StudyError>
where
    S: CurvedSystem + Clone + Sync + 'static,
{
    let mine = selection.mine(control.done);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(selection.threads.max(1))
        .build()
        .map_err(|e| StudyError::Threads {
            threads: selection.threads,
            message: e.to_string(),
        })?;
    let finished = AtomicUsize::new(0);
    let (r0, v0) = (&prepared.position[..], &prepared.velocity[..]);
    let block = block_len(mine.len(), selection.threads);
    let quasi = quasi_paths(plan, prepared, selection, block)?;
    let noise = match &quasi {
        Some(quasi) => PathNoise::Quasi(quasi),
        None => PathNoise::Pseudo {
            seed: selection.seed,
        },
    };
    let reference = reference.cloned();
    let blocks = pool.install(|| {
        mine.par_chunks(block)
            .with_max_len(1)
            .map_init(
                || None,
                |ensembles, indices| {
                    // Checked before the ensembles are built: after a stop, the blocks left end
                    // at once.
                    if control.stopped() {
                        return Ok(Vec::new());
                    }
                    let ensembles = ensembles
                        .get_or_insert_with(|| {
                            block_ensembles(schemes, reference.as_ref(), plan, block, r0, v0)
                        })
                        .as_mut()
                        .map_err(|e| e.clone())?;
                    let stopped = || control.stopped();
                    let Some(records) =
                        run_block_with(plan, ensembles, (r0, v0), noise, indices, &stopped)?
                    else {
                        return Ok(Vec::new());
                    };
                    control.block_finished(&records, indices.len(), &finished);
                    Ok(records)
                },
            )
            .collect::<Result<Vec<_>, StudyError>>()
    });
    Ok(blocks?.into_iter().flatten().collect())
}

impl PathSelection {
    /// The indices of this shard's paths that are not among `done`, in order.
    fn mine(&self, done: &[usize]) -> Vec<usize> {
        let (index, count) = self.shard;
        let done: std::collections::BTreeSet<usize> = done.iter().copied().collect();
        (0..self.paths)
            .filter(|i| i % count.max(1) == index && !done.contains(i))
            .collect()
    }
}

/// The randomized QMC paths of `selection` (`None` for pseudo-random paths), for blocks of
/// `block` paths of the prepared system: refused where a block's increments over all the fine
/// steps exceed [`QUASI_BLOCK_BUDGET`].
fn quasi_paths<S: CurvedSystem>(
    plan: &PathPlan, prepared: &Prepared<S>, selection: PathSelection, block: usize,
) -> Result<Option<QuasiPaths>, StudyError> {
    let Some(r) = selection.randomizations else {
        return Ok(None);
    };
    let floats =
        (prepared.system.noise_dim() * lane_stride(block)).saturating_mul(1usize << plan.fine);
    if floats > QUASI_BLOCK_BUDGET {
        return Err(StudyError::Setting {
            key: "study.reference",
            value: plan.fine.to_string(),
            rule: format!(
                "randomized QMC paths hold a block's increments over all 2^{} fine steps at \
                 once: {floats} floats, above {QUASI_BLOCK_BUDGET}",
                plan.fine
            ),
        });
    }
    let points = selection.paths / r.max(1);
    Ok(Some(QuasiPaths::new(selection.seed, r, points)))
}
