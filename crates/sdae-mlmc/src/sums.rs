//! The sums of a level's samples and the statistics Giles's `mlmc_test` prints from them.
//!
//! Sums are additive: the sums of two disjoint sets of samples are the sums of their union.
//! Folded in a fixed order (block by block in index order) they are bit-identical however the
//! samples were spread over threads or shards.

use serde::{Deserialize, Serialize};

use crate::block::BLOCK;

/// One sample of a level: the fine value P_l and the coarse value P_{l-1} (0 on level 0 and
/// for a single path), or which path of the pair failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Both paths finished.
    Value {
        /// P_l (with the antithetic option, the average over the fine path and its twin).
        fine: f64,
        /// P_{l-1}.
        coarse: f64,
    },
    /// A path of the pair failed (the sample has no value and is counted as failed).
    Failed {
        /// The fine path (or its antithetic twin) failed.
        fine: bool,
        /// The coarse path failed.
        coarse: bool,
    },
}

/// Power sums of a level's samples: Y = P_l - P_{l-1} (Y = P_0 on level 0) and P_l, the
/// failures on either path of a pair, and the measured run time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LevelSums {
    /// Samples with a value (both paths of the pair finished).
    pub samples: u64,
    /// Samples whose fine path (or its antithetic twin) failed.
    pub failed_fine: u64,
    /// Samples whose coarse path failed.
    pub failed_coarse: u64,
    /// Samples lost to a failure on either path (each counted once).
    pub failed: u64,
    /// sum Y.
    #[serde(with = "sdae_stats::json_f64")]
    pub y1: f64,
    /// sum Y^2.
    #[serde(with = "sdae_stats::json_f64")]
    pub y2: f64,
    /// sum Y^3.
    #[serde(with = "sdae_stats::json_f64")]
    pub y3: f64,
    /// sum Y^4.
    #[serde(with = "sdae_stats::json_f64")]
    pub y4: f64,
    /// sum P_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub p1: f64,
    /// sum P_l^2.
    #[serde(with = "sdae_stats::json_f64")]
    pub p2: f64,
    /// Wall-clock seconds spent on these samples (all threads together).
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds: f64,
}

impl LevelSums {
    /// Adds one sample.
    pub fn add(&mut self, sample: Sample) {
        match sample {
            Sample::Value { fine, coarse } => {
                let y = fine - coarse;
                let y2 = y * y;
                self.samples += 1;
                self.y1 += y;
                self.y2 += y2;
                self.y3 += y2 * y;
                self.y4 += y2 * y2;
                self.p1 += fine;
                self.p2 += fine * fine;
            }
            Sample::Failed { fine, coarse } => {
                self.failed += 1;
                self.failed_fine += u64::from(fine);
                self.failed_coarse += u64::from(coarse);
            }
        }
    }

    /// The sums of `samples` in order, with their run time.
    pub fn of(samples: &[Sample], seconds: f64) -> Self {
        let mut sums = Self {
            seconds,
            ..Self::default()
        };
        for &s in samples {
            sums.add(s);
        }
        sums
    }

    /// Adds the sums of other samples.
    pub fn merge(&mut self, other: &LevelSums) {
        self.samples += other.samples;
        self.failed_fine += other.failed_fine;
        self.failed_coarse += other.failed_coarse;
        self.failed += other.failed;
        self.y1 += other.y1;
        self.y2 += other.y2;
        self.y3 += other.y3;
        self.y4 += other.y4;
        self.p1 += other.p1;
        self.p2 += other.p2;
        self.seconds += other.seconds;
    }

    /// Checks the sums of one block as a run makes them, for resuming a checkpoint and for
    /// merging shards: [`BLOCK`] samples attempted, no more failures on either path than
    /// failed samples, sums of squares and the run time not negative. The error says what is
    /// wrong ("counts ...", to follow the block's name).
    pub fn check_block(&self) -> Result<(), String> {
        let counts = self.samples.checked_add(self.failed) == Some(BLOCK)
            && self.failed_fine <= self.failed
            && self.failed_coarse <= self.failed;
        if !counts {
            return Err(format!(
                "counts {} samples with a value and {} failed ({} fine, {} coarse), not a block \
                 of {BLOCK}",
                self.samples, self.failed, self.failed_fine, self.failed_coarse
            ));
        }
        let negative = [
            ("sum Y^2", self.y2),
            ("sum Y^4", self.y4),
            ("sum P^2", self.p2),
        ]
        .into_iter()
        .chain([("seconds", self.seconds)])
        .find(|(_, x)| *x < 0.0);
        match negative {
            Some((name, x)) => Err(format!("has {name} = {x:e}, below 0")),
            None => Ok(()),
        }
    }

    /// Samples attempted (with a value or failed).
    pub fn attempted(&self) -> u64 {
        self.samples + self.failed
    }

    /// Whether the sums of the samples (not the run time) are bit-identical.
    pub fn same_samples(&self, other: &LevelSums) -> bool {
        let bits = |s: &LevelSums| [s.y1, s.y2, s.y3, s.y4, s.p1, s.p2].map(f64::to_bits);
        (
            self.samples,
            self.failed_fine,
            self.failed_coarse,
            self.failed,
        ) == (
            other.samples,
            other.failed_fine,
            other.failed_coarse,
            other.failed,
        ) && bits(self) == bits(other)
    }

    /// Mean of Y.
    pub fn mean_y(&self) -> f64 {
        self.y1 / self.samples as f64
    }

    /// Unbiased variance of Y: (sum Y^2 - (sum Y)^2 / N) / (N - 1), never below 0.
    pub fn var_y(&self) -> f64 {
        let n = self.samples as f64;
        ((self.y2 - self.y1 * self.y1 / n) / (n - 1.0)).max(0.0)
    }

    /// Mean of P_l.
    pub fn mean_p(&self) -> f64 {
        self.p1 / self.samples as f64
    }

    /// Unbiased variance of P_l.
    pub fn var_p(&self) -> f64 {
        let n = self.samples as f64;
        ((self.p2 - self.p1 * self.p1 / n) / (n - 1.0)).max(0.0)
    }

    /// Kurtosis of Y as `mlmc_test` computes it: the fourth central moment over the squared
    /// (biased) variance, from the power sums.
    pub fn kurtosis(&self) -> f64 {
        let n = self.samples as f64;
        let m = self.y1 / n;
        let (s2, s3, s4) = (self.y2 / n, self.y3 / n, self.y4 / n);
        let var = s2 - m * m;
        (s4 - 4.0 * s3 * m + 6.0 * s2 * m * m - 3.0 * m * m * m * m) / (var * var)
    }
}

/// What `mlmc_test` prints for one level.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LevelStats {
    /// Level l.
    pub level: u32,
    /// Steps of the fine path, 2^(k0 + l).
    pub steps: u64,
    /// Work per sample in steps: the fine path (twice with the antithetic option) and the
    /// coarse path (`LevelSampler::pair_steps`).
    pub work_per_sample: u64,
    /// Samples with a value.
    pub samples: u64,
    /// Samples whose fine path failed.
    pub failed_fine: u64,
    /// Samples whose coarse path failed.
    pub failed_coarse: u64,
    /// mean of P_l - P_{l-1}.
    #[serde(with = "sdae_stats::json_f64")]
    pub mean_y: f64,
    /// Variance of P_l - P_{l-1}.
    #[serde(with = "sdae_stats::json_f64")]
    pub var_y: f64,
    /// Standard error of the mean of P_l - P_{l-1}, sqrt(V / N).
    #[serde(with = "sdae_stats::json_f64")]
    pub se_y: f64,
    /// mean of P_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub mean_p: f64,
    /// Variance of P_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub var_p: f64,
    /// Kurtosis of P_l - P_{l-1} (above 100: the variance estimate is unreliable).
    #[serde(with = "sdae_stats::json_f64")]
    pub kurtosis: f64,
    /// Consistency check |m_Y(l) - m_P(l) + m_P(l-1)| / (3 (s_Y(l) + s_P(l) + s_P(l-1)) /
    /// sqrt(N)) (above 1: the coarse path of a pair does not have level l-1's law); 0 on
    /// level 0.
    #[serde(with = "sdae_stats::json_f64")]
    pub consistency: f64,
    /// Measured seconds per sample (both paths of the pair).
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds_per_sample: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_give_mean_variance_and_kurtosis_of_the_samples() {
        let ys = [1.0, 2.0, 4.0, 7.0];
        let samples: Vec<Sample> = ys
            .iter()
            .map(|&y| Sample::Value {
                fine: y + 1.0,
                coarse: 1.0,
            })
            .collect();
        let s = LevelSums::of(&samples, 0.0);
        assert_eq!(s.mean_y(), 3.5);
        // Unbiased variance: sum (y - 3.5)^2 / 3 = (6.25 + 2.25 + 0.25 + 12.25) / 3 = 7.
        assert!((s.var_y() - 7.0).abs() < 1e-12);
        assert_eq!(s.mean_p(), 4.5);
        // Fourth central moment over the squared biased variance (5.25).
        let m4 = [2.5f64, 1.5, 0.5, 3.5]
            .iter()
            .map(|d| d.powi(4))
            .sum::<f64>()
            / 4.0;
        assert!((s.kurtosis() - m4 / (5.25 * 5.25)).abs() < 1e-12);
    }

    #[test]
    fn failures_are_counted_per_path_and_merging_adds() {
        let mut a = LevelSums::of(
            &[
                Sample::Failed {
                    fine: true,
                    coarse: false,
                },
                Sample::Value {
                    fine: 1.0,
                    coarse: 0.5,
                },
            ],
            1.0,
        );
        let b = LevelSums::of(
            &[Sample::Failed {
                fine: true,
                coarse: true,
            }],
            2.0,
        );
        a.merge(&b);
        assert_eq!(
            (a.samples, a.failed, a.failed_fine, a.failed_coarse),
            (1, 2, 2, 1)
        );
        assert_eq!(a.attempted(), 3);
        assert_eq!(a.seconds, 3.0);
    }
}
