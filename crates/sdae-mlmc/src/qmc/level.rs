//! One level of a randomized QMC run: the sums of its R randomizations, the RQMC mean and its
//! variance, and standard randomized QMC on one level.

use serde::{Deserialize, Serialize};

use sdae_stats::{Interval, mean_interval};

use super::QuasiSampler;
use crate::error::MlmcError;
use crate::memory::samples_exceed_memory;
use crate::sampler::RunControl;
use crate::sums::LevelSums;

/// One level of a randomized QMC run: n_l points of each of R randomizations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuasiLevel {
    /// Level l.
    pub level: u32,
    /// Points n_l of each randomization (a power of two).
    pub points: u64,
    /// Steps per point C_l: [`QuasiSampler::pair_steps`] for pairs, [`QuasiSampler::path_steps`]
    /// for the fine path alone.
    pub cost: u64,
    /// The sums of each randomization's points (Y = P_l - P_{l-1}).
    pub randomizations: Vec<LevelSums>,
    /// mean_{l,r} = (sum of Y over the points of randomization r with a value) / (their number).
    #[serde(with = "sdae_stats::json_f64::vec")]
    pub means: Vec<f64>,
    /// mean_l = (1 / R) sum_r mean_{l,r}.
    #[serde(with = "sdae_stats::json_f64")]
    pub mean: f64,
    /// V_l = sum_r (mean_{l,r} - mean_l)^2 / (R (R - 1)): the variance of mean_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub variance: f64,
    /// R V_l: the variance of one randomization's mean mean_{l,r}.
    #[serde(with = "sdae_stats::json_f64")]
    pub variance_per_randomization: f64,
    /// Points that failed (either path of the pair), over all randomizations.
    pub failed: u64,
    /// Work in steps, R n_l C_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub work: f64,
}

impl QuasiLevel {
    /// Level `level` with no points yet: R = `randomizations` empty sums, cost C_l = `cost`.
    pub fn new(level: u32, randomizations: u32, cost: u64) -> Self {
        Self {
            level,
            points: 0,
            cost,
            randomizations: vec![LevelSums::default(); randomizations as usize],
            means: vec![f64::NAN; randomizations as usize],
            mean: f64::NAN,
            variance: f64::NAN,
            variance_per_randomization: f64::NAN,
            failed: 0,
            work: 0.0,
        }
    }

    /// Whether the level has the same points and, randomization by randomization, bit-identical
    /// sums of its samples (not the run time).
    pub fn same_samples(&self, other: &QuasiLevel) -> bool {
        self.points == other.points
            && self
                .randomizations
                .iter()
                .zip(&other.randomizations)
                .all(|(x, y)| x.same_samples(y))
    }

    /// Runs points n_l..`points` of every randomization (the next points of the same
    /// sequences: the first n_l are kept), adds their sums and updates the statistics.
    pub fn extend_to<Q: QuasiSampler>(
        &mut self, sampler: &Q, control: &RunControl<'_>, points: u64, coupled: bool,
    ) -> Result<(), MlmcError> {
        let r = self.randomizations.len() as u32;
        let new = control.sample_points(sampler, self.level, r, self.points..points, coupled)?;
        for (sums, block) in self.randomizations.iter_mut().zip(&new) {
            sums.merge(block);
        }
        self.points = self.points.max(points);
        self.update()
    }

    /// Recomputes the means, V_l, the failures and the work from the sums. Fails (a
    /// [`MlmcError::Levels`] naming the level) when a randomization has no point with a value
    /// (its mean does not exist: the level lost more than MLMC allows, which keeps two values
    /// per level) or a mean or V_l is not finite.
    pub fn update(&mut self) -> Result<(), MlmcError> {
        let l = self.level;
        let r = self.randomizations.len();
        self.failed = self.randomizations.iter().map(|s| s.failed).sum();
        self.work = (r as f64) * (self.points as f64) * (self.cost as f64);
        for (k, s) in self.randomizations.iter().enumerate() {
            if s.samples == 0 {
                return Err(MlmcError::Levels {
                    reason: format!(
                        "level {l}: all {} points of randomization {k} failed ({} failed of \
                         {} on the level), none left for its mean",
                        s.attempted(),
                        self.failed,
                        r as u64 * self.points
                    ),
                });
            }
        }
        self.means = self.randomizations.iter().map(LevelSums::mean_y).collect();
        if let Some((k, m)) = self.means.iter().enumerate().find(|(_, m)| !m.is_finite()) {
            return Err(MlmcError::Levels {
                reason: format!(
                    "level {l}: the mean of P_l - P_(l-1) over the {} points of randomization \
                     {k} is {m}, not finite",
                    self.points
                ),
            });
        }
        let (mean, spread) = mean_and_variance(&self.means);
        self.mean = mean;
        self.variance_per_randomization = spread;
        self.variance = spread / r as f64;
        if !(self.mean.is_finite() && self.variance.is_finite()) {
            return Err(MlmcError::Levels {
                reason: format!(
                    "level {l}: the mean {} or its variance {} over the {r} randomizations is \
                     not finite",
                    self.mean, self.variance
                ),
            });
        }
        Ok(())
    }

    /// mean_l with the 95% t interval mean_l +- t_{0.975, R-1} sqrt(V_l) (R - 1 degrees of
    /// freedom: the R means are i.i.d.). `None` before [`QuasiLevel::update`] has succeeded
    /// or with fewer than 2 randomizations.
    pub fn interval(&self) -> Option<Interval> {
        self.mean
            .is_finite()
            .then(|| mean_interval(&self.means))
            .flatten()
    }

    /// Measured seconds of all threads together.
    pub fn seconds(&self) -> f64 {
        self.randomizations.iter().map(|s| s.seconds).sum()
    }
}

/// The mean and the unbiased sample variance sum (x - mean)^2 / (n - 1) of `x` (n >= 2).
fn mean_and_variance(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
    (mean, var)
}

/// Checks the number of randomizations R (at least 2: the variance comes from the spread of
/// their means) and a number of points n (a power of two: the first 2^m points of a Sobol'
/// sequence form a net), and that the R n points' sums fit in the memory available.
/// `key` names the setting of the points in the error.
pub fn check_design(randomizations: u32, points: u64, key: &'static str) -> Result<(), MlmcError> {
    if randomizations < 2 {
        return Err(MlmcError::Setting {
            key: "mlqmc.randomizations",
            value: randomizations.to_string(),
            rule: "at least 2 randomizations are needed: the variance of the estimate is the \
                   spread of their means"
                .into(),
        });
    }
    let what = format!("{randomizations} randomizations of {points} points");
    if let Some(rule) = samples_exceed_memory(&[randomizations as f64 * points as f64], &what) {
        return Err(MlmcError::Setting {
            key: "mlqmc.randomizations",
            value: randomizations.to_string(),
            rule,
        });
    }
    if !points.is_power_of_two() {
        return Err(MlmcError::Setting {
            key,
            value: points.to_string(),
            rule: "the points of each randomization must number a power of two (1, 2, 4, ...): \
                   the first 2^m points of a Sobol' sequence form a net"
                .into(),
        });
    }
    Ok(())
}

/// Standard randomized QMC on one level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuasiEstimate {
    /// E\[P_l\] estimated by the mean of the R randomizations' means, with the 95% t
    /// interval mean +- t_{0.975, R-1} sqrt(V_l).
    #[serde(with = "super::interval_serde")]
    pub estimate: Interval,
    /// The level's points, sums and statistics (Y = P_l: coarse values 0); its work is
    /// R n [`QuasiSampler::path_steps`].
    pub level: QuasiLevel,
}

/// Standard randomized QMC on level `level`: the fine path alone (`coupled = false`) at points
/// 0..`points` (a power of two) of each of `randomizations` (at least 2) randomizations.
pub fn standard_quasi_monte_carlo<Q: QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, level: u32, randomizations: u32, points: u64,
) -> Result<QuasiEstimate, MlmcError> {
    check_design(randomizations, points, "mlqmc.points")?;
    if points > sampler.max_points() {
        return Err(MlmcError::Setting {
            key: "mlqmc.points",
            value: points.to_string(),
            rule: format!(
                "the sequence offers {} points per randomization",
                sampler.max_points()
            ),
        });
    }
    let mut q = QuasiLevel::new(level, randomizations, sampler.path_steps(level));
    q.extend_to(sampler, control, points, false)?;
    Ok(QuasiEstimate {
        estimate: q.interval().ok_or_else(|| MlmcError::Levels {
            reason: format!("{randomizations} randomizations give no interval"),
        })?,
        level: q,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sums::Sample;

    #[test]
    fn the_variance_is_the_spread_of_the_randomizations_means_over_r() {
        let mut q = QuasiLevel::new(1, 3, 6);
        q.points = 2;
        // Means 1, 2, 6 (randomization 2 lost one point).
        let value = |y: f64| Sample::Value {
            fine: y,
            coarse: 0.0,
        };
        let failed = Sample::Failed {
            fine: true,
            coarse: false,
        };
        q.randomizations = vec![
            LevelSums::of(&[value(0.0), value(2.0)], 0.0),
            LevelSums::of(&[value(1.0), value(3.0)], 0.0),
            LevelSums::of(&[failed, value(6.0)], 0.0),
        ];
        q.update().unwrap();
        assert_eq!(q.means, vec![1.0, 2.0, 6.0]);
        assert_eq!(q.mean, 3.0);
        // Sample variance (4 + 1 + 9) / 2 = 7, over R = 3.
        assert!((q.variance_per_randomization - 7.0).abs() < 1e-12);
        assert!((q.variance - 7.0 / 3.0).abs() < 1e-12);
        assert_eq!((q.failed, q.work), (1, 3.0 * 2.0 * 6.0));
        let i = q.interval().unwrap();
        let half = sdae_stats::t975(2) * (7.0f64 / 3.0).sqrt();
        assert!((i.ci_high - 3.0 - half).abs() < 1e-12 && (3.0 - i.ci_low - half).abs() < 1e-12);
        // A randomization without a value: a typed error naming it.
        q.randomizations[2] = LevelSums::of(&[failed, failed], 0.0);
        let err = q.update().unwrap_err();
        assert!(err.to_string().contains("randomization 2"), "{err}");
    }

    #[test]
    fn designs_need_two_randomizations_and_a_power_of_two_of_points() {
        assert!(check_design(2, 1, "n").is_ok());
        assert!(check_design(32, 1 << 20, "n").is_ok());
        for (r, n) in [(1, 4), (0, 4), (4, 0), (4, 3), (4, 12)] {
            assert!(matches!(
                check_design(r, n, "n"),
                Err(MlmcError::Setting { .. })
            ));
        }
    }
}
