//! Multilevel randomized quasi-Monte Carlo (Giles and Waterhouse 2009, "Multilevel
//! quasi-Monte Carlo path simulation").
//!
//! A level's samples are addressed by (level l, randomization r, point i): point i of the
//! r-th randomization (an independent scrambling or shift) of one low-discrepancy sequence
//! drives the pair of paths. The R randomizations give R independent, unbiased estimates of
//! E\[P_l - P_{l-1}\] from the same n_l points each:
//!
//!   mean_{l,r} = (1 / n_l) sum_{i < n_l} Y_l(i, r),
//!   mean_l = (1 / R) sum_r mean_{l,r},
//!   V_l = (1 / (R (R - 1))) sum_r (mean_{l,r} - mean_l)^2,
//!
//! V_l the variance of mean_l (the sample variance of the R means over R). The estimate of
//! E\[P_L\] is the mean over r of the totals total_r = sum_l mean_{l,r}, i.i.d. over r, with
//! the t interval of R - 1 degrees of freedom.
//!
//! - [`QuasiSampler`]: what a model provides; the deterministic parallel driver
//!   [`RunControl::sample_points`].
//! - [`level`]: one level's R sums and their statistics, standard randomized QMC on one
//!   level ([`standard_quasi_monte_carlo`]).
//! - [`adaptive`]: the adaptive MLQMC algorithm ([`mlqmc`]).
//! - [`cost`]: the cost exponent c of work ~ eps^-c from runs at several eps.

use std::ops::Range;
use std::time::Instant;

use rayon::prelude::*;

use crate::block::BLOCK;
use crate::error::MlmcError;
use crate::sampler::RunControl;
use crate::sums::{LevelSums, Sample};

pub mod adaptive;
pub mod cost;
pub mod level;

pub use adaptive::{MlqmcEstimate, QuasiSettings, level_to_double, mlqmc, mlqmc_from};
pub use cost::{cost_exponent, cost_exponent_of};
pub use level::{QuasiEstimate, QuasiLevel, standard_quasi_monte_carlo};

/// A model multilevel QMC can sample: pairs of paths on levels l and l - 1 driven by one
/// point of a randomized low-discrepancy sequence.
///
/// The conventions are those of [`LevelSampler`](crate::LevelSampler): one worker per thread,
/// built when the thread takes its first block of points; `coupled = false` runs the fine
/// path alone (coarse values 0). Point i of randomization r of level l depends on nothing else
/// (and the sampler's settings), so results do not depend on the thread count.
pub trait QuasiSampler: Sync {
    /// A worker thread's state (its ensembles and buffers).
    type Worker;
    /// A new worker (one per thread).
    fn worker(&self) -> Result<Self::Worker, MlmcError>;
    /// The samples of points `points` of randomization `randomization` of level `level`, in
    /// order (one per point).
    fn run_points(
        &self, worker: &mut Self::Worker, level: u32, randomization: u32, points: Range<u64>,
        coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError>;
    /// Steps of one path on level l.
    fn path_steps(&self, level: u32) -> u64;
    /// Steps of one sample of level l (the fine path and the coarse path): the cost C_l of a
    /// point.
    fn pair_steps(&self, level: u32) -> u64;
    /// Points each randomized sequence offers (2^32 for Sobol' points with 32-bit direction
    /// numbers, the default): a level that would need more stops the run with an error.
    fn max_points(&self) -> u64 {
        1 << 32
    }
    /// The coordinates of a point that one path of level l takes, and how many of them are
    /// quasi-random (the rest are padded with pseudo-random numbers), where the sampler knows
    /// them (default: None).
    fn coordinates(&self, _level: u32) -> Option<(u64, u64)> {
        None
    }
}

/// The blocks of `points`: cut at the multiples of [`BLOCK`], in order.
pub fn point_blocks(points: Range<u64>) -> Vec<Range<u64>> {
    let mut blocks = Vec::new();
    let mut start = points.start;
    while start < points.end {
        let end = (start / BLOCK)
            .saturating_add(1)
            .saturating_mul(BLOCK)
            .min(points.end);
        blocks.push(start..end);
        start = end;
    }
    blocks
}

impl RunControl<'_> {
    /// The sums of points `points` of each randomization 0..`randomizations` of level
    /// `level`, one [`LevelSums`] per randomization. The points are cut into blocks
    /// ([`point_blocks`]), run on the pool (one task per randomization and block), and each
    /// randomization's blocks are folded in point order: the same bits for any thread count.
    /// The progress callback gets the points of each block; the stop flag ends the run with
    /// [`MlmcError::Interrupted`] before the next block. The block store is not used.
    pub fn sample_points<Q: QuasiSampler>(
        &self, sampler: &Q, level: u32, randomizations: u32, points: Range<u64>, coupled: bool,
    ) -> Result<Vec<LevelSums>, MlmcError> {
        let blocks = point_blocks(points);
        let tasks: Vec<(u32, Range<u64>)> = (0..randomizations)
            .flat_map(|r| blocks.iter().map(move |b| (r, b.clone())))
            .collect();
        let sums: Vec<LevelSums> = self.pool().install(|| {
            tasks
                .par_iter()
                .with_max_len(1)
                .map_init(
                    || None,
                    |worker, (r, block)| {
                        self.run_task(sampler, worker, level, *r, block.clone(), coupled)
                    },
                )
                .collect::<Result<_, _>>()
        })?;
        let mut out = vec![LevelSums::default(); randomizations as usize];
        for ((r, _), block) in tasks.iter().zip(&sums) {
            out[*r as usize].merge(block);
        }
        Ok(out)
    }

    /// One block of points of one randomization: its sums, in point order.
    fn run_task<Q: QuasiSampler>(
        &self, sampler: &Q, worker: &mut Option<Result<Q::Worker, MlmcError>>, level: u32,
        randomization: u32, points: Range<u64>, coupled: bool,
    ) -> Result<LevelSums, MlmcError> {
        let worker = self.thread_worker(worker, || sampler.worker())?;
        let start = Instant::now();
        let count = points.end - points.start;
        let samples = sampler.run_points(worker, level, randomization, points.clone(), coupled)?;
        if samples.len() as u64 != count {
            return Err(MlmcError::Levels {
                reason: format!(
                    "level {level}, randomization {randomization}: the sampler returned {} \
                     samples for the {count} points {points:?}",
                    samples.len()
                ),
            });
        }
        let sums = LevelSums::of(&samples, start.elapsed().as_secs_f64());
        if let Some(progress) = self.progress {
            progress(count);
        }
        Ok(sums)
    }
}

/// Serde for [`Interval`](sdae_stats::Interval) fields (which serialize but do not
/// deserialize by themselves): the same three fields, non-finite values as strings.
pub(crate) mod interval_serde {
    use sdae_stats::Interval;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// The interval as it serializes itself.
    pub fn serialize<S: Serializer>(interval: &Interval, s: S) -> Result<S::Ok, S::Error> {
        interval.serialize(s)
    }

    /// An interval from its three fields.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Interval, D::Error> {
        #[derive(Deserialize)]
        struct Fields {
            #[serde(with = "sdae_stats::json_f64")]
            estimate: f64,
            #[serde(with = "sdae_stats::json_f64")]
            ci_low: f64,
            #[serde(with = "sdae_stats::json_f64")]
            ci_high: f64,
        }
        let f = Fields::deserialize(d)?;
        Ok(Interval {
            estimate: f.estimate,
            ci_low: f.ci_low,
            ci_high: f.ci_high,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_are_cut_at_multiples_of_the_block_size() {
        assert_eq!(point_blocks(0..1), vec![0..1]);
        assert_eq!(point_blocks(2..4), vec![2..4]);
        assert_eq!(
            point_blocks(BLOCK - 1..2 * BLOCK + 3),
            vec![BLOCK - 1..BLOCK, BLOCK..2 * BLOCK, 2 * BLOCK..2 * BLOCK + 3]
        );
        assert!(point_blocks(5..5).is_empty());
    }
}
