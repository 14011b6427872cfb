//! What MLMC asks of a model (the samples of a level, block by block), the deterministic
//! parallel driver that runs the blocks on a thread pool, and the statistics of each level.
//!
//! Sample i of level l draws from its own stream (seed, l, i). Samples are taken in blocks of
//! [`BLOCK`] consecutive indices starting at multiples of [`BLOCK`]; each block's samples are
//! summed in index order and the blocks' sums are folded in block order, so the sums of a
//! level are the same bits whatever the thread count, and a sharded run (block b on shard
//! b mod n) merges into exactly the unsharded sums.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::block::{BLOCK, BlockKey};
use crate::error::MlmcError;
use crate::sums::{LevelStats, LevelSums, Sample};

/// A model MLMC can sample: pairs of paths on levels l and l - 1 driven by one Brownian path.
pub trait LevelSampler: Sync {
    /// A worker thread's state (its ensembles and buffers).
    type Worker;
    /// A new worker (one per thread).
    fn worker(&self) -> Result<Self::Worker, MlmcError>;
    /// The samples `indices` of level `level`, in order; `coupled = false` runs the fine path
    /// alone (standard Monte Carlo on level `level`: coarse values 0). Sample i draws from its
    /// own stream (seed, level, i) only.
    fn run_block(
        &self, worker: &mut Self::Worker, level: u32, indices: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError>;
    /// Steps of one path on level l (its work: the cost model of the optimal N_l, which makes
    /// the algorithm's choices independent of the machine's timing).
    fn path_steps(&self, level: u32) -> u64;
    /// Steps of one sample of level l: the fine path (twice with the antithetic option) and
    /// the coarse path.
    fn pair_steps(&self, level: u32) -> u64;
}

/// Where a run keeps the sums of its blocks (a checkpoint): blocks it has are not run again,
/// and each block run is handed to it.
pub trait BlockStore: Sync {
    /// The saved sums of block `key`, if any.
    fn saved(&self, key: BlockKey) -> Option<LevelSums>;
    /// Called with the sums of each block run, as it finishes.
    fn finished(&self, key: BlockKey, sums: &LevelSums);
}

/// The thread pool, the progress callback, the stop flag and the block store of a run.
pub struct RunControl<'a> {
    pool: rayon::ThreadPool,
    threads: usize,
    /// Called with the number of samples finished (or taken from the store) in each block.
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// Once set, no further block starts and the run ends with [`MlmcError::Interrupted`].
    pub stop: Option<&'a AtomicBool>,
    /// Blocks saved by an interrupted run are taken from it instead of run, and each block
    /// run is handed to it: a run resumed from a checkpoint folds exactly the sums of an
    /// uninterrupted one.
    pub store: Option<&'a dyn BlockStore>,
}

impl<'a> RunControl<'a> {
    /// A pool of `threads` worker threads.
    pub fn new(threads: usize) -> Result<Self, MlmcError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .map_err(|e| MlmcError::Threads {
                threads,
                message: e.to_string(),
            })?;
        Ok(Self {
            pool,
            threads: threads.max(1),
            progress: None,
            stop: None,
            store: None,
        })
    }

    /// Worker threads.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Whether the stop flag is set.
    pub(crate) fn stopped(&self) -> bool {
        self.stop.is_some_and(|s| s.load(Ordering::Relaxed))
    }

    /// The worker of a pool thread, built by `build` for the thread's first task (a failed
    /// build fails each of its tasks); [`MlmcError::Interrupted`] instead once the stop flag
    /// is set. The flag is checked before a worker is built: after a stop, each task left ends
    /// at once.
    pub(crate) fn thread_worker<'w, W>(
        &self, worker: &'w mut Option<Result<W, MlmcError>>,
        build: impl FnOnce() -> Result<W, MlmcError>,
    ) -> Result<&'w mut W, MlmcError> {
        if self.stopped() {
            return Err(MlmcError::Interrupted);
        }
        worker
            .get_or_insert_with(build)
            .as_mut()
            .map_err(|e| e.clone())
    }

    /// The thread pool, for the drivers of other samplers (the quasi-Monte Carlo one).
    pub(crate) fn pool(&self) -> &rayon::ThreadPool {
        &self.pool
    }

    /// The sums of each block `blocks` of level `level` (block b holds the samples
    /// b BLOCK .. (b + 1) BLOCK), in the order given: from the store when it has them, else
    /// run (and handed to the store).
    pub fn sample_blocks<L: LevelSampler>(
        &self, sampler: &L, level: u32, blocks: &[u64], coupled: bool,
    ) -> Result<Vec<LevelSums>, MlmcError> {
        self.pool.install(|| {
            blocks
                .par_iter()
                .with_max_len(1)
                .map_init(
                    || None,
                    |worker, &b| {
                        let key = BlockKey {
                            level,
                            block: b,
                            coupled,
                        };
                        if let Some(saved) = self.store.and_then(|s| s.saved(key)) {
                            if let Some(progress) = self.progress {
                                progress(BLOCK);
                            }
                            return Ok(saved);
                        }
                        // After a stop, each of the blocks left (millions in a direct
                        // standard run) ends at once.
                        let worker = self.thread_worker(worker, || sampler.worker())?;
                        let start = Instant::now();
                        let samples = sampler.run_block(
                            worker,
                            level,
                            b * BLOCK..(b + 1) * BLOCK,
                            coupled,
                        )?;
                        let sums = LevelSums::of(&samples, start.elapsed().as_secs_f64());
                        if let Some(store) = self.store {
                            store.finished(key, &sums);
                        }
                        if let Some(progress) = self.progress {
                            progress(BLOCK);
                        }
                        Ok(sums)
                    },
                )
                .collect()
        })
    }

    /// The sums of the first `samples` samples of level `level` (rounded up to whole blocks),
    /// starting after the `done` samples already summed (a multiple of [`BLOCK`]), folded in
    /// block order into `sums`. Returns the samples added.
    pub fn extend<L: LevelSampler>(
        &self, sampler: &L, level: u32, sums: &mut LevelSums, done: u64, samples: u64,
        coupled: bool,
    ) -> Result<u64, MlmcError> {
        let (first, count) = (done / BLOCK, samples.div_ceil(BLOCK));
        let blocks: Vec<u64> = (first..first + count).collect();
        for block in self.sample_blocks(sampler, level, &blocks, coupled)? {
            sums.merge(&block);
        }
        Ok(count * BLOCK)
    }
}

/// The fine paths alone of the first `samples` samples of level `level` (whole blocks), run on
/// the calling thread and kept out of any block store: whether a level runs at all, probed
/// before a run whose blocks a checkpoint keeps.
pub fn probe_level<L: LevelSampler>(
    sampler: &L, level: u32, samples: u64,
) -> Result<LevelSums, MlmcError> {
    let mut worker = sampler.worker()?;
    let start = Instant::now();
    let mut found = Vec::new();
    for b in 0..samples.div_ceil(BLOCK) {
        found.extend(sampler.run_block(&mut worker, level, b * BLOCK..(b + 1) * BLOCK, false)?);
    }
    Ok(LevelSums::of(&found, start.elapsed().as_secs_f64()))
}

/// The blocks of the first `samples` samples (rounded up) that shard `shard` = (index, count)
/// runs: block b on shard b mod count.
pub fn shard_blocks(samples: u64, shard: (u64, u64)) -> Vec<u64> {
    let (index, count) = shard;
    (0..samples.div_ceil(BLOCK))
        .filter(|b| b % count.max(1) == index)
        .collect()
}

/// The statistics of each level from its sums, with the steps of `sampler`'s paths.
pub fn level_stats<L: LevelSampler>(sums: &[LevelSums], sampler: &L) -> Vec<LevelStats> {
    let mut out: Vec<LevelStats> = Vec::with_capacity(sums.len());
    for (l, s) in sums.iter().enumerate() {
        let n = s.samples as f64;
        let consistency = match out.last() {
            Some(prev) => {
                let scale =
                    3.0 * (s.var_y().sqrt() + s.var_p().sqrt() + prev.var_p.sqrt()) / n.sqrt();
                (s.mean_y() - s.mean_p() + prev.mean_p).abs() / scale
            }
            None => 0.0,
        };
        out.push(LevelStats {
            level: l as u32,
            steps: sampler.path_steps(l as u32),
            work_per_sample: sampler.pair_steps(l as u32),
            samples: s.samples,
            failed_fine: s.failed_fine,
            failed_coarse: s.failed_coarse,
            mean_y: s.mean_y(),
            var_y: s.var_y(),
            se_y: (s.var_y() / n).sqrt(),
            mean_p: s.mean_p(),
            var_p: s.var_p(),
            kurtosis: s.kurtosis(),
            consistency,
            seconds_per_sample: s.seconds / s.attempted().max(1) as f64,
        });
    }
    out
}
