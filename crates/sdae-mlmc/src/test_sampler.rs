//! A sampler of both kinds for the drivers' unit tests, and the tests of the drivers that use
//! it (here, above the drivers, so that no driver's module imports this one).

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::error::MlmcError;
use crate::qmc::QuasiSampler;
use crate::sampler::LevelSampler;
use crate::sums::Sample;

/// Sample i (of any level and randomization) is `fine(i)` on the fine path and 0 on the
/// coarse one; a path of level l takes 2^l steps, and so does a sample. It counts the workers
/// it builds.
pub(crate) struct ValueSampler {
    fine: fn(u64) -> f64,
    workers: AtomicUsize,
}

impl ValueSampler {
    /// The sampler whose sample i is `fine(i)`.
    pub(crate) fn new(fine: fn(u64) -> f64) -> Self {
        Self {
            fine,
            workers: AtomicUsize::new(0),
        }
    }

    /// The workers built so far.
    pub(crate) fn workers(&self) -> usize {
        self.workers.load(Ordering::SeqCst)
    }

    /// The samples `indices`, in order.
    fn samples(&self, indices: Range<u64>) -> Vec<Sample> {
        indices
            .map(|i| Sample::Value {
                fine: (self.fine)(i),
                coarse: 0.0,
            })
            .collect()
    }
}

impl LevelSampler for ValueSampler {
    type Worker = ();
    fn worker(&self) -> Result<(), MlmcError> {
        self.workers.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }
    fn run_block(
        &self, _: &mut (), _: u32, indices: Range<u64>, _: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        Ok(self.samples(indices))
    }
    fn path_steps(&self, level: u32) -> u64 {
        1 << level
    }
    fn pair_steps(&self, level: u32) -> u64 {
        1 << level
    }
}

/// The same samples at the points of every randomization, at the same cost.
impl QuasiSampler for ValueSampler {
    type Worker = ();
    fn worker(&self) -> Result<(), MlmcError> {
        LevelSampler::worker(self)
    }
    fn run_points(
        &self, _: &mut (), _: u32, _: u32, points: Range<u64>, _: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        Ok(self.samples(points))
    }
    fn path_steps(&self, level: u32) -> u64 {
        LevelSampler::path_steps(self, level)
    }
    fn pair_steps(&self, level: u32) -> u64 {
        LevelSampler::pair_steps(self, level)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, Ordering};

    use super::*;
    use crate::block::BLOCK;
    use crate::sampler::RunControl;
    use crate::sums::LevelSums;

    #[test]
    fn after_a_stop_the_blocks_left_end_without_building_a_worker() {
        let sampler = ValueSampler::new(|_| 1.0);
        let stop = AtomicBool::new(false);
        let mut control = RunControl::new(2).unwrap();
        control.stop = Some(&stop);
        let mut sums = LevelSums::default();
        control
            .extend(&sampler, 3, &mut sums, 0, 64 * BLOCK, false)
            .unwrap();
        assert_eq!(sums.attempted(), 64 * BLOCK);
        let built = sampler.workers();
        assert!(built >= 1);
        // A direct standard run of a million blocks, stopped: no block runs, no worker is
        // built (each used to build one before it looked at the stop flag).
        stop.store(true, Ordering::SeqCst);
        let stopped = control.extend(&sampler, 3, &mut sums, 0, 1 << 25, false);
        assert_eq!(stopped, Err(MlmcError::Interrupted));
        assert_eq!(sampler.workers(), built);
    }

    #[test]
    fn points_are_summed_per_randomization_with_progress_and_stop() {
        use std::sync::atomic::AtomicU64;
        let index = ValueSampler::new(|i| i as f64);
        let done = AtomicU64::new(0);
        let progress = |n: u64| {
            done.fetch_add(n, Ordering::SeqCst);
        };
        let stop = AtomicBool::new(false);
        let mut control = RunControl::new(2).unwrap();
        control.progress = Some(&progress);
        control.stop = Some(&stop);
        let sums = control.sample_points(&index, 2, 3, 10..100, true).unwrap();
        assert_eq!(sums.len(), 3);
        for s in &sums {
            assert_eq!(s.samples, 90);
            assert_eq!(s.y1, (10..100).sum::<u64>() as f64);
        }
        assert_eq!(done.load(Ordering::SeqCst), 3 * 90);
        stop.store(true, Ordering::SeqCst);
        let stopped = control.sample_points(&index, 2, 3, 0..64, true);
        assert_eq!(stopped, Err(MlmcError::Interrupted));
    }
}
