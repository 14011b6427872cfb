//! Giles's adaptive MLMC algorithm (Acta Numerica 2015, Algorithm 1 with theta = 1/2), the
//! runs with a fixed plan, and standard Monte Carlo on one level.
//!
//! With V_l the variance of P_l - P_{l-1} and C_l the cost of one sample of level l, the
//! optimal numbers of samples for a mean square error eps^2 (half variance, half bias^2) are
//! N_l = ceil(2 eps^-2 sqrt(V_l / C_l) sum_k sqrt(V_k C_k)); a level is added while the bias
//! estimate ([`bias_estimate`], a conservative form of Giles's) exceeds eps / sqrt(2). The cost
//! C_l is the work of a sample in steps (the fine path, its antithetic twin, the coarse path),
//! known exactly, so the algorithm's choices do not depend on the machine's timing or the
//! thread count.

use serde::{Deserialize, Serialize};

use crate::block::BLOCK;
use crate::error::{MlmcError, check_eps};
use crate::fit::{LogPoint, asymptotic_decay, fit_slope, resolved_mean};
use crate::memory::samples_exceed_memory;
use crate::sampler::{LevelSampler, RunControl};
use crate::sums::{LevelStats, LevelSums};
use sdae_stats::PRE_ASYMPTOTIC_TOLERANCE;
use sdae_stats::{Interval, t975};

/// Settings of the adaptive algorithm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveSettings {
    /// Root mean square accuracy eps.
    pub eps: f64,
    /// Samples on each level when it is first run (Giles's N_0).
    pub initial_samples: u64,
    /// Levels 0..=this to start with (Giles's L_min, at least 2 so that alpha can be fitted).
    pub min_levels: u32,
    /// The finest level the algorithm may add (L_max).
    pub max_level: u32,
}

impl AdaptiveSettings {
    /// Settings that start on levels 0..=2, the fewest from which alpha can be fitted.
    pub fn from_three_levels(eps: f64, initial_samples: u64, max_level: u32) -> Self {
        Self {
            eps,
            initial_samples,
            min_levels: 2,
            max_level,
        }
    }
}

/// The result of an MLMC run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MlmcEstimate {
    /// The accuracy asked for.
    pub eps: f64,
    /// sum_l mean(P_l - P_{l-1}) with its 95% interval from the sampling variance
    /// sum_l V_l / N_l: an interval for E\[P_L\] (the bias is not in it: see `with_bias`).
    pub estimate: Interval,
    /// The interval for E\[P\] the reports print: `estimate` widened by `bias` on each side.
    pub with_bias: Interval,
    /// The bias estimate at the finest level when the run stopped ([`bias_estimate`]).
    pub bias: f64,
    /// The weak rate alpha the bias estimate used.
    pub bias_alpha: f64,
    /// False if the bias estimate still exceeded eps / sqrt(2) at L_max (Giles: "failed to
    /// achieve weak convergence").
    pub converged: bool,
    /// Per level, the samples' sums.
    pub levels: Vec<LevelSums>,
    /// Work in steps, sum_l N_l C_l.
    pub work: f64,
    /// Measured seconds of all threads together.
    pub seconds: f64,
}

/// The estimate sum_l mean_l(Y) with its interval from sum_l V_l / N_l (t quantile of the
/// smallest sample).
pub fn estimate_of(levels: &[LevelSums]) -> Interval {
    let mean: f64 = levels.iter().map(LevelSums::mean_y).sum();
    let var: f64 = levels.iter().map(|s| s.var_y() / s.samples as f64).sum();
    let fewest = levels.iter().map(|s| s.samples).min().unwrap_or(0) as usize;
    let half = t975(fewest.saturating_sub(1)) * var.sqrt();
    Interval {
        estimate: mean,
        ci_low: mean - half,
        ci_high: mean + half,
    }
}

/// The mean and the standard error sqrt(V_l / N_l) of P_l - P_{l-1} on each level.
pub fn level_means(levels: &[LevelSums]) -> Vec<(f64, f64)> {
    levels
        .iter()
        .map(|s| (s.mean_y(), (s.var_y() / s.samples as f64).sqrt()))
        .collect()
}

/// The remaining bias |E[P - P_L]| of levels 0..=L with means and standard errors `means`
/// (level l at index l), with the weak rate alpha it used:
///
///   bias = max_{k <= min(2, L - 1)} (|m_{L-k}| + se_{L-k}) 2^(-k alpha) / (2^alpha - 1),
///
/// alpha = max(1/2, the lower end of the 95% interval of alpha fitted over the asymptotic
/// resolved levels 1..=L, [`asymptotic_decay`]); 1/2 where fewer than two levels are resolved.
///
/// Giles's code takes max_k |m_{L-k}| 2^(-k alpha) / (2^alpha - 1) with alpha from the
/// unweighted regression over all levels. Both of its inputs err low exactly where it matters:
/// coarse levels whose means drop faster than the asymptotic rate raise the fitted alpha, and
/// 1 / (2^alpha - 1) falls steeply with it (0.68 at alpha 1.3 against 1 at alpha 1); and the
/// finest mean is a sample with standard error se_L, of the order of its value when the run
/// stops, so a low draw stops the run a level early. On the unit circle with friction at
/// eps = 1e-3 that estimate averaged 5.1e-4 against an actual bias of 6.2e-4 (root mean square
/// error 0.95 eps over 100 seeds); on the circle of radius 1.5 of the study crate's MLMC
/// tests at eps = 1e-2 it stops at L = 3.8 on average with a mean error of -1.14 eps (root
/// mean square error 1.44 eps). Here each mean is raised by its standard error and alpha is taken at the low end of
/// what the asymptotic levels allow, so the estimate bounds the bias under the model
/// E[P_l - P_{l-1}] ~ 2^(-alpha l) for most draws: root mean square errors of 0.81 eps and 0.68
/// eps on those two circles, 0.67 eps on the pendulum at eps = 3e-3. The price is levels (7.0
/// instead of 3.8 on that circle, for 28% more work), which cost little: with beta > gamma the
/// work of a level falls as 2^(-(beta - gamma) l / 2), so the coarse levels dominate it.
pub fn bias_estimate(means: &[(f64, f64)]) -> (f64, f64) {
    let points: Vec<LogPoint> = means
        .iter()
        .enumerate()
        .skip(1)
        .filter_map(|(l, &(m, se))| resolved_mean(l as u32, m, se))
        .collect();
    let alpha =
        asymptotic_decay(&points, PRE_ASYMPTOTIC_TOLERANCE).map_or(0.5, |d| d.rate.ci_low.max(0.5));
    let last = means.len() - 1;
    let bias = (0..=2.min(last.saturating_sub(1)))
        .map(|k| {
            let (m, se) = means[last - k];
            (m.abs() + se) / 2f64.powf(k as f64 * alpha)
        })
        .fold(0.0, f64::max)
        / (2f64.powf(alpha) - 1.0);
    (bias, alpha)
}

/// The samples each level still needs: the optimal counts for the estimated variances and
/// costs at the tolerance `eps`, less those `taken`; refused ([`check_counts`]) when the
/// counts do not fit in the memory available.
fn samples_to_add(
    variances: &[f64], costs: &[f64], eps: f64, taken: &[u64],
) -> Result<Vec<u64>, MlmcError> {
    check_counts(&optimal_counts(variances, costs, eps), eps)?;
    Ok(optimal_samples(variances, costs, eps)
        .iter()
        .zip(taken)
        .map(|(w, n)| w.saturating_sub(*n))
        .collect())
}

/// N_l = 2 eps^-2 sqrt(V_l / C_l) sum_k sqrt(V_k C_k) as reals (not rounded, perhaps huge or
/// infinite): what [`optimal_samples`] rounds up.
pub fn optimal_counts(variances: &[f64], costs: &[f64], eps: f64) -> Vec<f64> {
    let total: f64 = variances
        .iter()
        .zip(costs)
        .map(|(v, c)| (v * c).sqrt())
        .sum();
    variances
        .iter()
        .zip(costs)
        .map(|(v, c)| 2.0 / (eps * eps) * (v / c).sqrt() * total)
        .collect()
}

/// N_l = ceil(2 eps^-2 sqrt(V_l / C_l) sum_k sqrt(V_k C_k)) ([`optimal_counts`] rounded up,
/// saturating at `u64::MAX`; [`check_counts`] refuses counts a run cannot hold).
pub fn optimal_samples(variances: &[f64], costs: &[f64], eps: f64) -> Vec<u64> {
    optimal_counts(variances, costs, eps)
        .into_iter()
        .map(|n| n.ceil() as u64)
        .collect()
}

/// Refuses an accuracy `eps` whose optimal sample counts `counts` (per level, as reals) do not
/// fit in the memory available ([`samples_exceed_memory`]): a named error (the eps and the
/// counts) instead of an allocation that aborts.
pub fn check_counts(counts: &[f64], eps: f64) -> Result<(), MlmcError> {
    let what = format!(
        "the optimal N_l of levels 0..={} (from the measured variances)",
        counts.len().saturating_sub(1)
    );
    // A count that is not a number (from a variance that is not) is left to the levels' own
    // checks.
    let counts: Vec<f64> = counts.iter().copied().filter(|n| !n.is_nan()).collect();
    match samples_exceed_memory(&counts, &what) {
        None => Ok(()),
        Some(rule) => Err(MlmcError::Setting {
            key: "mlmc.eps",
            value: format!("{eps:e}"),
            rule: format!("{rule}: ask for a larger accuracy"),
        }),
    }
}

/// The slope of log2 of `values` over levels 1.. (Giles's regression), negated.
fn decay_rate(values: &[f64]) -> Option<f64> {
    let x: Vec<f64> = (1..values.len()).map(|l| l as f64).collect();
    let y: Vec<f64> = values[1..].iter().map(|v| v.log2()).collect();
    fit_slope(&x, &y, None).map(|i| -i.estimate)
}

/// Fails if a level has no sample with a value (every pair failed).
fn check_levels(levels: &[LevelSums]) -> Result<(), MlmcError> {
    for (l, s) in levels.iter().enumerate() {
        if s.samples < 2 {
            return Err(MlmcError::Levels {
                reason: format!(
                    "level {l}: {} of {} samples failed, too few left for a variance",
                    s.failed,
                    s.attempted()
                ),
            });
        }
    }
    Ok(())
}

/// Giles's adaptive algorithm: levels 0..=L_min with N_0 samples each, then optimal N_l from
/// the measured variances, and a new level while the bias estimate exceeds eps / sqrt(2).
/// Samples are added in whole blocks ([`BLOCK`]).
pub fn adaptive<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, settings: &AdaptiveSettings,
) -> Result<MlmcEstimate, MlmcError> {
    let eps = check_eps(settings.eps)?;
    if settings.min_levels < 2 || settings.min_levels > settings.max_level {
        return Err(MlmcError::Levels {
            reason: format!(
                "the first levels 0..={} must number at least 3 and stay within L_max = {}",
                settings.min_levels, settings.max_level
            ),
        });
    }
    let mut top = settings.min_levels as usize;
    let mut sums = vec![LevelSums::default(); top + 1];
    let mut taken = vec![0u64; top + 1];
    let mut more = vec![settings.initial_samples.max(2); top + 1];
    let mut beta = 0.0f64;
    let mut costs: Vec<f64> = (0..=top)
        .map(|l| sampler.pair_steps(l as u32) as f64)
        .collect();
    let (bias, converged) = loop {
        for l in 0..=top {
            if more[l] > 0 {
                taken[l] +=
                    control.extend(sampler, l as u32, &mut sums[l], taken[l], more[l], true)?;
            }
        }
        check_levels(&sums)?;
        let mut variances: Vec<f64> = sums.iter().map(LevelSums::var_y).collect();
        // Giles's guard against variances that happen to be tiny.
        for l in 2..=top {
            variances[l] = variances[l].max(0.5 * variances[l - 1] / 2f64.powf(beta));
        }
        beta = decay_rate(&variances).map_or(0.5, |b| b.max(0.5));
        more = samples_to_add(&variances, &costs, eps, &taken)?;
        let settled = more
            .iter()
            .zip(&taken)
            .all(|(&m, &n)| m as f64 <= 0.01 * n as f64);
        if settled {
            let bias = bias_estimate(&level_means(&sums));
            if bias.0 <= eps / 2f64.sqrt() {
                break (bias, true);
            }
            if top as u32 == settings.max_level {
                break (bias, false);
            }
            top += 1;
            variances.push(variances[top - 1] / 2f64.powf(beta));
            costs.push(sampler.pair_steps(top as u32) as f64);
            sums.push(LevelSums::default());
            taken.push(0);
            more = samples_to_add(&variances, &costs, eps, &taken)?;
        }
    };
    Ok(finish(sampler, eps, sums, bias, converged))
}

/// The estimate of a run from its levels' sums, its bias estimate and rate (see
/// [`bias_estimate`]) and whether that met eps / sqrt(2).
fn finish<L: LevelSampler>(
    sampler: &L, eps: f64, levels: Vec<LevelSums>, (bias, bias_alpha): (f64, f64), converged: bool,
) -> MlmcEstimate {
    let work = work_of(sampler, &levels);
    let estimate = estimate_of(&levels);
    MlmcEstimate {
        eps,
        estimate,
        with_bias: estimate.widened(bias),
        bias,
        bias_alpha,
        converged,
        seconds: levels.iter().map(|s| s.seconds).sum(),
        work,
        levels,
    }
}

/// The work of `levels` in steps: each level's attempted samples times the steps of one of its
/// samples, sum_l N_l C_l.
pub fn work_of<L: LevelSampler>(sampler: &L, levels: &[LevelSums]) -> f64 {
    levels
        .iter()
        .enumerate()
        .map(|(l, s)| s.attempted() as f64 * sampler.pair_steps(l as u32) as f64)
        .sum()
}

/// A run with fixed numbers of samples per level (each rounded up to whole blocks): the plan
/// an adaptive pilot found, for a sharded main run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The accuracy the plan is for.
    pub eps: f64,
    /// N_l for l = 0..=L.
    pub samples: Vec<u64>,
}

impl Plan {
    /// The plan of a finished run: its levels and numbers of samples.
    pub fn of(run: &MlmcEstimate) -> Self {
        Self {
            eps: run.eps,
            samples: run.levels.iter().map(LevelSums::attempted).collect(),
        }
    }
}

/// The sums of each level of `samples` (levels 0..samples.len()), block by block in order:
/// the same bits as an adaptive run that took these numbers of samples.
pub fn run_plan<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, samples: &[u64],
) -> Result<Vec<LevelSums>, MlmcError> {
    samples
        .iter()
        .enumerate()
        .map(|(l, &n)| {
            let mut sums = LevelSums::default();
            control.extend(sampler, l as u32, &mut sums, 0, n, true)?;
            Ok(sums)
        })
        .collect()
}

/// The estimate of a plan's sums (merged from shards or run at once).
pub fn estimate_of_plan<L: LevelSampler>(
    sampler: &L, plan: &Plan, levels: Vec<LevelSums>,
) -> Result<MlmcEstimate, MlmcError> {
    check_levels(&levels)?;
    let bias = bias_estimate(&level_means(&levels));
    let converged = bias.0 <= plan.eps / 2f64.sqrt();
    Ok(finish(sampler, plan.eps, levels, bias, converged))
}

/// The plan for accuracy `eps` from a convergence test (a pilot run's): the fewest levels
/// 0..=L (L >= 2) whose bias estimate ([`bias_estimate`]) is within eps / sqrt(2), and the
/// optimal N_l from the test's variances and the work per sample. Fails if the test's levels
/// do not reach that bias.
pub fn plan_from_test<L: LevelSampler>(
    sampler: &L, test: &[LevelStats], eps: f64,
) -> Result<Plan, MlmcError> {
    let eps = check_eps(eps)?;
    let means: Vec<(f64, f64)> = test.iter().map(|s| (s.mean_y, s.se_y)).collect();
    let top = (2..means.len())
        .find(|&l| bias_estimate(&means[..=l]).0 <= eps / 2f64.sqrt())
        .ok_or_else(|| MlmcError::Levels {
            reason: format!(
                "the convergence test's levels 0..={} do not bring the bias estimate below \
                 eps / sqrt(2) = {:.3e}: test more levels",
                means.len().saturating_sub(1),
                eps / 2f64.sqrt()
            ),
        })?;
    let variances: Vec<f64> = test[..=top].iter().map(|s| s.var_y).collect();
    let costs: Vec<f64> = (0..=top)
        .map(|l| sampler.pair_steps(l as u32) as f64)
        .collect();
    Ok(Plan {
        eps,
        samples: optimal_samples(&variances, &costs, eps),
    })
}

/// Standard Monte Carlo on level `level`: `samples` single fine paths (rounded up to whole
/// blocks), from the same streams as the fine paths of the level's pairs.
pub fn standard_monte_carlo<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, level: u32, samples: u64,
) -> Result<LevelSums, MlmcError> {
    let mut sums = LevelSums::default();
    control.extend(sampler, level, &mut sums, 0, samples, false)?;
    Ok(sums)
}

/// Samples rounded up to whole blocks.
pub fn whole_blocks(samples: u64) -> u64 {
    samples.div_ceil(BLOCK) * BLOCK
}
