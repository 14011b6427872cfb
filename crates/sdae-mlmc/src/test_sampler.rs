//! A sampler of both kinds for the drivers' unit tests.

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
