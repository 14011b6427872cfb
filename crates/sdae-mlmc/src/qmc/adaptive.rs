//! The adaptive multilevel QMC algorithm of Giles and Waterhouse (2009).
//!
//! Levels 0..=L_min start with n_0 points of each of R randomizations. While the sampling
//! variance sum_l V_l exceeds eps^2 / 2, n_l is doubled on the level [`level_to_double`]
//! picks (points n_l..2 n_l of the same sequences are run and added). Then the bias is
//! estimated as MLMC does ([`bias_estimate`] of the level means with standard errors
//! sqrt(V_l)); above eps / sqrt(2) a level is added with n_0 points, and the loop goes on. At
//! L_max the run stops with `converged = false`. Every choice depends on the sums alone (and
//! the exact costs C_l), so a run is the same bits for any thread count.

use serde::{Deserialize, Serialize};

use sdae_stats::{Interval, mean_interval};

use super::QuasiSampler;
use super::level::{QuasiLevel, check_design};
use crate::algorithm::bias_estimate;
use crate::error::{MlmcError, check_eps};
use crate::memory::samples_exceed_memory;
use crate::sampler::RunControl;

/// Settings of the adaptive MLQMC algorithm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuasiSettings {
    /// Root mean square accuracy eps.
    pub eps: f64,
    /// Randomizations R per level (at least 2; Giles and Waterhouse take 32).
    pub randomizations: u32,
    /// Points n_0 of each randomization when a level is first run (a power of two).
    pub initial_points: u64,
    /// Levels 0..=this to start with (at least 2, as MLMC's L_min).
    pub min_levels: u32,
    /// The finest level the algorithm may add (L_max).
    pub max_level: u32,
}

impl QuasiSettings {
    /// Accuracy `eps` with R = 32 randomizations, n_0 = 1 point, levels 0..=2 to start and
    /// L_max = 12.
    pub fn new(eps: f64) -> Self {
        Self {
            eps,
            randomizations: 32,
            initial_points: 1,
            min_levels: 2,
            max_level: 12,
        }
    }
}

/// The result of an MLQMC run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlqmcEstimate {
    /// The accuracy asked for.
    #[serde(with = "sdae_stats::json_f64")]
    pub eps: f64,
    /// Randomizations R.
    pub randomizations: u32,
    /// The mean over r of the totals `totals` with the 95% t interval of R - 1 degrees of
    /// freedom, mean +- t_{0.975, R-1} s / sqrt(R), s the totals' sample standard deviation
    /// (an interval for E\[P_L\]; the bias is not in it: see `with_bias`).
    #[serde(with = "super::interval_serde")]
    pub estimate: Interval,
    /// The interval for E\[P\] the reports print: `estimate` widened by `bias` on each side.
    #[serde(with = "super::interval_serde")]
    pub with_bias: Interval,
    /// total_r = sum_l mean_{l,r}: R independent estimates of E\[P_L\].
    #[serde(with = "sdae_stats::json_f64::vec")]
    pub totals: Vec<f64>,
    /// sum_l V_l at the end (at most eps^2 / 2 unless the run failed).
    #[serde(with = "sdae_stats::json_f64")]
    pub variance: f64,
    /// The bias estimate at the finest level when the run stopped ([`bias_estimate`]).
    #[serde(with = "sdae_stats::json_f64")]
    pub bias: f64,
    /// The weak rate alpha the bias estimate used.
    #[serde(with = "sdae_stats::json_f64")]
    pub bias_alpha: f64,
    /// False if the bias estimate still exceeded eps / sqrt(2) at L_max.
    pub converged: bool,
    /// Levels 0..=L.
    pub levels: Vec<QuasiLevel>,
    /// Work in steps, sum_l R n_l C_l.
    #[serde(with = "sdae_stats::json_f64")]
    pub work: f64,
    /// Measured seconds of all threads together.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds: f64,
}

/// The level whose n_l to double: the largest V_l / (C_l n_l) (the first of equals).
///
/// Doubling n_l costs R n_l C_l more steps. If the level's RQMC variance falls as n^-p with a
/// rate p common to the levels (p = 1 for plain Monte Carlo, up to about 2 or more for
/// scrambled Sobol' points on smooth integrands), it removes (1 - 2^-p) V_l, so the variance
/// removed per step is (1 - 2^-p) V_l / (R C_l n_l): proportional to V_l / (C_l n_l), the
/// ratio Giles and Waterhouse use. It is not V_l / C_l (the design note's shorthand), which
/// ignores that the price of a doubling grows with the points already taken.
pub fn level_to_double(levels: &[QuasiLevel]) -> usize {
    let gain = |q: &QuasiLevel| q.variance / (q.cost as f64 * q.points as f64);
    (1..levels.len()).fold(0, |best, l| {
        if gain(&levels[l]) > gain(&levels[best]) {
            l
        } else {
            best
        }
    })
}

/// sum_l V_l.
fn total_variance(levels: &[QuasiLevel]) -> f64 {
    levels.iter().map(|q| q.variance).sum()
}

/// Checks the settings; returns eps.
fn check_settings(settings: &QuasiSettings) -> Result<f64, MlmcError> {
    let eps = check_eps(settings.eps)?;
    check_design(
        settings.randomizations,
        settings.initial_points,
        "mlqmc.initial_points",
    )?;
    if settings.min_levels < 2 || settings.min_levels > settings.max_level {
        return Err(MlmcError::Levels {
            reason: format!(
                "the first levels 0..={} must number at least 3 and stay within L_max = {}",
                settings.min_levels, settings.max_level
            ),
        });
    }
    Ok(eps)
}

/// 2 n points of a level that has n: refused when that overflows, exceeds the points the
/// sampler's sequences offer, or the sums of the R n new points' blocks would not fit in the
/// memory available.
pub fn doubled(
    n: u64, randomizations: u32, limit: u64, level: u32, eps: f64,
) -> Result<u64, MlmcError> {
    let refuse = |rule: String| MlmcError::Setting {
        key: "mlqmc.eps",
        value: format!("{eps:e}"),
        rule: format!("{rule}: ask for a larger accuracy"),
    };
    let two_n = n.checked_mul(2).ok_or_else(|| {
        refuse(format!(
            "level {level} would need 2 x {n} points, beyond 2^64"
        ))
    })?;
    if two_n > limit {
        return Err(refuse(format!(
            "level {level} would need {two_n} points per randomization, more than the {limit} \
             its sequences offer"
        )));
    }
    let what = format!("the {randomizations} randomizations of {n} new points on level {level}");
    match samples_exceed_memory(&[randomizations as f64 * n as f64], &what) {
        Some(rule) => Err(refuse(rule)),
        None => Ok(two_n),
    }
}

/// Level `level` with `settings.initial_points` points of each randomization.
fn first_points<Q: QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, settings: &QuasiSettings, level: u32,
) -> Result<QuasiLevel, MlmcError> {
    let mut q = QuasiLevel::new(level, settings.randomizations, sampler.pair_steps(level));
    let n = settings.initial_points;
    if n > sampler.max_points() {
        return Err(MlmcError::Setting {
            key: "mlqmc.initial_points",
            value: n.to_string(),
            rule: format!("the sequence offers {} points", sampler.max_points()),
        });
    }
    q.extend_to(sampler, control, n, true)?;
    Ok(q)
}

/// Doubles n_l on the level [`level_to_double`] picks until sum_l V_l <= eps^2 / 2.
fn reduce_variance<Q: QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, eps: f64, levels: &mut [QuasiLevel],
) -> Result<(), MlmcError> {
    while total_variance(levels) > eps * eps / 2.0 {
        let q = &mut levels[level_to_double(levels)];
        let r = q.randomizations.len() as u32;
        let target = doubled(q.points, r, sampler.max_points(), q.level, eps)?;
        q.extend_to(sampler, control, target, true)?;
    }
    Ok(())
}

/// The adaptive MLQMC algorithm (see the module's documentation): the estimate of E\[P_L\]
/// with sampling variance sum_l V_l <= eps^2 / 2 and a bias estimate <= eps / sqrt(2).
pub fn mlqmc<Q: QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, settings: &QuasiSettings,
) -> Result<MlqmcEstimate, MlmcError> {
    check_settings(settings)?;
    let levels = (0..=settings.min_levels)
        .map(|l| first_points(sampler, control, settings, l))
        .collect::<Result<Vec<_>, _>>()?;
    mlqmc_from(sampler, control, settings, levels)
}

/// The adaptive MLQMC algorithm carried on from `levels` (levels 0..=L already run with
/// `settings.randomizations` randomizations each, a pilot's): the doublings and levels it
/// still needs, as [`mlqmc`] adds them. Levels added get `settings.initial_points` points.
pub fn mlqmc_from<Q: QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, settings: &QuasiSettings, mut levels: Vec<QuasiLevel>,
) -> Result<MlqmcEstimate, MlmcError> {
    let eps = check_settings(settings)?;
    let r = settings.randomizations as usize;
    if levels.is_empty() || levels.iter().any(|q| q.randomizations.len() != r) {
        return Err(MlmcError::Levels {
            reason: format!(
                "MLQMC carries on from levels with {r} randomizations each, got {} levels",
                levels.len()
            ),
        });
    }
    loop {
        reduce_variance(sampler, control, eps, &mut levels)?;
        let means: Vec<(f64, f64)> = levels.iter().map(|q| (q.mean, q.variance.sqrt())).collect();
        let bias = bias_estimate(&means);
        let top = levels.len() as u32 - 1;
        if bias.0 <= eps / 2f64.sqrt() || top == settings.max_level {
            let converged = bias.0 <= eps / 2f64.sqrt();
            return finish(settings, levels, bias, converged);
        }
        levels.push(first_points(sampler, control, settings, top + 1)?);
    }
}

/// The estimate of a run from its levels: the totals over the levels per randomization and
/// their mean with its t interval.
fn finish(
    settings: &QuasiSettings, levels: Vec<QuasiLevel>, (bias, bias_alpha): (f64, f64),
    converged: bool,
) -> Result<MlqmcEstimate, MlmcError> {
    let r = settings.randomizations as usize;
    let totals: Vec<f64> = (0..r)
        .map(|k| levels.iter().map(|q| q.means[k]).sum())
        .collect();
    let estimate = mean_interval(&totals).ok_or_else(|| MlmcError::Levels {
        reason: format!("{r} randomizations give no interval"),
    })?;
    Ok(MlqmcEstimate {
        eps: settings.eps,
        randomizations: settings.randomizations,
        estimate,
        with_bias: estimate.widened(bias),
        totals,
        variance: total_variance(&levels),
        bias,
        bias_alpha,
        converged,
        work: levels.iter().map(|q| q.work).sum(),
        seconds: levels.iter().map(QuasiLevel::seconds).sum(),
        levels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(l: u32, points: u64, cost: u64, variance: f64) -> QuasiLevel {
        let mut q = QuasiLevel::new(l, 2, cost);
        q.points = points;
        q.variance = variance;
        q
    }

    #[test]
    fn the_level_doubled_removes_the_most_variance_per_step() {
        // V_l / (C_l n_l): 1 / 4, 1 / 6, 0.5 / 24.
        let levels = [
            level(0, 4, 1, 1.0),
            level(1, 2, 3, 1.0),
            level(2, 4, 6, 0.5),
        ];
        assert_eq!(level_to_double(&levels), 0);
        // Equal variances, equal points: the cheapest level.
        let levels = [
            level(0, 8, 4, 1.0),
            level(1, 8, 3, 1.0),
            level(2, 8, 6, 1.0),
        ];
        assert_eq!(level_to_double(&levels), 1);
        // Equal variance per step: more points already make a doubling dearer.
        let levels = [level(0, 64, 1, 1.0), level(1, 1, 6, 1.0)];
        assert_eq!(level_to_double(&levels), 1);
    }

    #[test]
    fn doubling_refuses_overflow_and_the_sequence_s_end() {
        assert_eq!(doubled(4, 32, 1 << 32, 1, 1e-3), Ok(8));
        for (n, limit) in [(1u64 << 63, u64::MAX), (64, 64)] {
            let err = doubled(n, 32, limit, 3, 1e-3).unwrap_err();
            assert_eq!(err.setting_key(), Some("mlqmc.eps"), "{err}");
            assert!(err.to_string().contains("level 3"), "{err}");
        }
    }
}
