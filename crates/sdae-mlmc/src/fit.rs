//! The MLMC rates from a convergence test: |E[P_l - P_{l-1}]| ~ 2^(-alpha l),
//! V[P_l - P_{l-1}] ~ 2^(-beta l), work per sample ~ 2^(gamma l), fitted by least squares on
//! log2 over the levels l >= 1, with 95% intervals.
//!
//! alpha and beta are weighted fits with the Monte Carlo standard error of each point (delta
//! method: se(log2 m) = se(m) / (|m| ln 2), se(log2 V) = sqrt((kurt - 1) / N) / ln 2); when the
//! points scatter more than that error (a reduced chi^2 above 1, a rate not yet asymptotic),
//! the slope's standard error is scaled by sqrt(chi^2 / dof). They are fitted over the
//! asymptotic levels only ([`asymptotic_decay`]): coarse levels whose local slope departs from
//! the finer levels' are named and left out, as the strong study does. Levels that lost
//! samples to failed paths or whose statistics are not finite are left out of every rate and
//! named; levels whose mean is within two standard errors of 0 are unresolved and left out of
//! alpha.
//!
//! gamma is the slope of log2 of the work per sample in steps (the fine path, its antithetic
//! twin, the coarse path: C_l = 1.5 2^(k0 + l), or 2.5 2^(k0 + l) antithetic, so gamma = 1
//! exactly for l >= 1); the slope of the measured seconds per sample is fitted beside it for
//! comparison only (at coarse levels per-block overhead dominates the time, and it depends on
//! the machine).

use serde::Serialize;

use crate::sums::LevelStats;
use sdae_stats::PRE_ASYMPTOTIC_TOLERANCE;
use sdae_stats::{Interval, t975};

/// The standard normal's 97.5% quantile.
const Z_975: f64 = 1.959_963_984_540_054;

/// A level left out of the rates, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeftOut {
    /// Level l.
    pub level: u32,
    /// Why: the failed paths, or the statistics that are not finite.
    pub reason: String,
}

/// The fitted rates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rates {
    /// Weak rate alpha with its interval (`None`: fewer than two resolved levels).
    pub alpha: Option<Interval>,
    /// Variance rate beta.
    pub beta: Option<Interval>,
    /// Cost rate gamma of the work per sample in steps (exact: no Monte Carlo error).
    pub gamma: Option<Interval>,
    /// The slope of log2 of the measured seconds per sample, shown beside gamma (not used by
    /// anything: timing depends on the machine and, at coarse levels, on per-block overhead).
    pub gamma_seconds: Option<Interval>,
    /// The levels fitted (l >= this).
    pub from_level: u32,
    /// Levels left out of alpha as unresolved (|mean| < 2 se).
    pub unresolved: Vec<u32>,
    /// Coarse levels left out of alpha as pre-asymptotic.
    pub alpha_pre_asymptotic: Vec<u32>,
    /// Coarse levels left out of beta as pre-asymptotic.
    pub beta_pre_asymptotic: Vec<u32>,
    /// Levels left out of every rate: lost samples or statistics that are not finite.
    pub left_out: Vec<LeftOut>,
}

/// A decay rate fitted over the asymptotic levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decay {
    /// The rate (the negated slope of log2 against l) with its 95% interval.
    pub rate: Interval,
    /// The coarse levels left out as pre-asymptotic.
    pub pre_asymptotic: Vec<u32>,
}

/// The weights 1 / se_j^2 of points with standard errors se_j.
fn inverse_variances(se: &[f64]) -> Vec<f64> {
    se.iter().map(|s| 1.0 / (s * s).max(1e-300)).collect()
}

/// The weights c_j of the weighted least-squares slope b = sum_j c_j y_j of points (x_j, y_j)
/// with weights w_j: c_j = w_j (x_j - xm) / Sxx, xm = sum w x / sum w, Sxx = sum w (x - xm)^2.
fn slope_weights(x: &[f64], w: &[f64]) -> Vec<f64> {
    let sw: f64 = w.iter().sum();
    let xm = w.iter().zip(x).map(|(w, x)| w * x).sum::<f64>() / sw;
    let sxx: f64 = w.iter().zip(x).map(|(w, x)| w * (x - xm) * (x - xm)).sum();
    w.iter().zip(x).map(|(w, x)| w * (x - xm) / sxx).collect()
}

/// A line y = a + b x fitted to points with standard errors `se` (or unweighted): the slope
/// with its 95% interval. `None` with fewer than two points or non-finite data.
pub fn fit_slope(x: &[f64], y: &[f64], se: Option<&[f64]>) -> Option<Interval> {
    let n = x.len();
    if n < 2 || x.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    let w: Vec<f64> = match se {
        Some(se) => inverse_variances(se),
        None => vec![1.0; n],
    };
    let c = slope_weights(x, &w);
    let slope: f64 = c.iter().zip(y).map(|(c, y)| c * y).sum();
    let sw: f64 = w.iter().sum();
    let xm = w.iter().zip(x).map(|(w, x)| w * x).sum::<f64>() / sw;
    let ym = w.iter().zip(y).map(|(w, y)| w * y).sum::<f64>() / sw;
    // Var(sum c_j y_j) = sum c_j^2 / w_j = 1 / Sxx.
    let var_unit: f64 = c.iter().zip(&w).map(|(c, w)| c * c / w).sum();
    let chi2: f64 = (0..n)
        .map(|i| {
            let r = y[i] - ym - slope * (x[i] - xm);
            w[i] * r * r
        })
        .sum();
    let dof = n - 2;
    let (sd, quantile) = match (se, dof) {
        (Some(_), 0) => (var_unit.sqrt(), Z_975),
        (Some(_), _) => ((var_unit * (chi2 / dof as f64).max(1.0)).sqrt(), t975(dof)),
        (None, 0) => {
            return Some(Interval {
                estimate: slope,
                ci_low: f64::NEG_INFINITY,
                ci_high: f64::INFINITY,
            });
        }
        (None, _) => ((chi2 / dof as f64 * var_unit).sqrt(), t975(dof)),
    };
    Some(Interval {
        estimate: slope,
        ci_low: slope - quantile * sd,
        ci_high: slope + quantile * sd,
    })
}

/// The negated slope: a rate of decay.
fn negated(i: Interval) -> Interval {
    Interval {
        estimate: -i.estimate,
        ci_low: -i.ci_high,
        ci_high: -i.ci_low,
    }
}

/// A point of a rate fit: level l, y = log2 of the level's statistic, se its standard error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogPoint {
    /// Level l.
    pub level: u32,
    /// log2 of the statistic.
    pub y: f64,
    /// Its Monte Carlo standard error (levels are sampled independently).
    pub se: f64,
}

/// The decay rate of `points` (any order) over their asymptotic levels. Starting from the
/// coarsest, a level is left out as pre-asymptotic while its local slope to the next level,
/// (y_1 - y_0) / (l_1 - l_0), and the weighted least-squares slope sum_j c_j y_j of the finer
/// levels differ by more than `tolerance` and by more than 1.96 standard errors of the
/// difference, sqrt(sum_j d_j^2 se_j^2) with d_j its weight on level j (the levels are
/// independent samples), and more than three levels remain. The rate is the weighted fit
/// ([`fit_slope`]) over the levels kept, negated. `None` with fewer than two points.
pub fn asymptotic_decay(points: &[LogPoint], tolerance: f64) -> Option<Decay> {
    let mut usable: Vec<LogPoint> = points.to_vec();
    usable.sort_by_key(|p| p.level);
    let mut pre_asymptotic = Vec::new();
    while usable.len() > 3 {
        let (first, rest) = (usable[0], &usable[1..]);
        let x: Vec<f64> = rest.iter().map(|p| f64::from(p.level)).collect();
        let se: Vec<f64> = rest.iter().map(|p| p.se).collect();
        let mut d: Vec<f64> = slope_weights(&x, &inverse_variances(&se))
            .iter()
            .map(|c| -c)
            .collect();
        let dx = f64::from(rest[0].level - first.level);
        d[0] += 1.0 / dx;
        let difference = rest.iter().zip(&d).map(|(p, d)| d * p.y).sum::<f64>() - first.y / dx;
        let se = (rest
            .iter()
            .zip(&d)
            .map(|(p, d)| (d * p.se).powi(2))
            .sum::<f64>()
            + (first.se / dx).powi(2))
        .sqrt();
        if difference.abs() > tolerance && difference.abs() > Z_975 * se {
            pre_asymptotic.push(first.level);
            usable.remove(0);
        } else {
            break;
        }
    }
    let x: Vec<f64> = usable.iter().map(|p| f64::from(p.level)).collect();
    let y: Vec<f64> = usable.iter().map(|p| p.y).collect();
    let se: Vec<f64> = usable.iter().map(|p| p.se).collect();
    let rate = fit_slope(&x, &y, Some(&se)).map(negated)?;
    Some(Decay {
        rate,
        pre_asymptotic,
    })
}

/// Why a level's statistics cannot enter a rate: samples lost to failed paths, too few
/// samples, or values that are not finite.
fn unusable(s: &LevelStats) -> Option<String> {
    if s.failed_fine + s.failed_coarse > 0 {
        return Some(format!(
            "{} fine and {} coarse paths failed",
            s.failed_fine, s.failed_coarse
        ));
    }
    if s.samples < 2 {
        return Some(format!("{} samples, too few for a variance", s.samples));
    }
    let finite = [s.mean_y, s.var_y, s.se_y, s.kurtosis]
        .iter()
        .all(|v| v.is_finite());
    (!finite).then(|| "its mean, variance or kurtosis is not finite".to_string())
}

/// The point of level l's mean m of P_l - P_{l-1} in a fit of alpha: log2 |m| with the
/// standard error se(m) / (|m| ln 2); `None` when the mean is unresolved, |m| <= 2 se(m), or
/// underflowed (zero or subnormal: its logarithm would measure the arithmetic).
pub fn resolved_mean(level: u32, mean: f64, se: f64) -> Option<LogPoint> {
    (mean.abs() >= f64::MIN_POSITIVE && mean.abs() > 2.0 * se).then(|| LogPoint {
        level,
        y: mean.abs().log2(),
        se: se / (mean.abs() * std::f64::consts::LN_2),
    })
}

/// alpha, beta and gamma from the levels l >= `from_level` (at least 1) of a convergence test.
pub fn fit_rates(levels: &[LevelStats], from_level: u32) -> Rates {
    let ln2 = std::f64::consts::LN_2;
    let from_level = from_level.max(1);
    let candidates = levels.iter().filter(|s| s.level >= from_level);
    let (mut fitted, mut left_out) = (Vec::new(), Vec::new());
    for s in candidates {
        match unusable(s) {
            Some(reason) => left_out.push(LeftOut {
                level: s.level,
                reason,
            }),
            None => fitted.push(s),
        }
    }
    let mut resolved = Vec::new();
    let mut unresolved = Vec::new();
    for s in &fitted {
        match resolved_mean(s.level, s.mean_y, s.se_y) {
            Some(point) => resolved.push(point),
            None => unresolved.push(s.level),
        }
    }
    let alpha = asymptotic_decay(&resolved, PRE_ASYMPTOTIC_TOLERANCE);
    let variances: Vec<LogPoint> = fitted
        .iter()
        // A variance that underflowed (zero or subnormal) gives no point.
        .filter(|s| s.var_y >= f64::MIN_POSITIVE)
        .map(|s| LogPoint {
            level: s.level,
            y: s.var_y.log2(),
            se: ((s.kurtosis - 1.0).max(1.0) / s.samples as f64).sqrt() / ln2,
        })
        .collect();
    let beta = asymptotic_decay(&variances, PRE_ASYMPTOTIC_TOLERANCE);
    let unweighted_slope = |value: &dyn Fn(&LevelStats) -> f64| {
        let points: Vec<(f64, f64)> = fitted
            .iter()
            .map(|s| (f64::from(s.level), value(s)))
            .filter(|(_, v)| *v >= f64::MIN_POSITIVE)
            .map(|(l, v)| (l, v.log2()))
            .collect();
        let (x, y): (Vec<f64>, Vec<f64>) = points.into_iter().unzip();
        fit_slope(&x, &y, None)
    };
    Rates {
        gamma: unweighted_slope(&|s| s.work_per_sample as f64),
        gamma_seconds: unweighted_slope(&|s| s.seconds_per_sample),
        alpha_pre_asymptotic: alpha
            .as_ref()
            .map_or(Vec::new(), |d| d.pre_asymptotic.clone()),
        beta_pre_asymptotic: beta
            .as_ref()
            .map_or(Vec::new(), |d| d.pre_asymptotic.clone()),
        alpha: alpha.map(|d| d.rate),
        beta: beta.map(|d| d.rate),
        from_level,
        unresolved,
        left_out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_that_underflow_are_unresolved() {
        assert!(resolved_mean(1, 1e-3, 1e-5).is_some());
        assert!(resolved_mean(1, -3.5e-317, 0.0).is_none());
        assert!(resolved_mean(1, 0.0, 0.0).is_none());
    }

    #[test]
    fn an_exact_line_has_its_slope_and_a_tight_interval() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let y: Vec<f64> = x.iter().map(|x| 3.0 - 2.0 * x).collect();
        let fit = fit_slope(&x, &y, Some(&[0.1; 4])).unwrap();
        assert!((fit.estimate + 2.0).abs() < 1e-12);
        // No scatter: the interval is the Monte Carlo error alone, t975(2) 0.1 / sqrt(5).
        let half = t975(2) * 0.1 / 5f64.sqrt();
        assert!((fit.ci_high - fit.estimate - half).abs() < 1e-12);
        let plain = fit_slope(&x, &y, None).unwrap();
        assert!((plain.ci_high - plain.ci_low).abs() < 1e-12);
    }

    #[test]
    fn scatter_beyond_the_error_widens_the_interval() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let y = [1.0, -1.0, 1.0, -1.0];
        let fit = fit_slope(&x, &y, Some(&[0.01; 4])).unwrap();
        assert!(fit.ci_high - fit.ci_low > 1.0);
    }

    /// A level of a convergence test with mean m, variance V, kurtosis 3 and N samples.
    fn level(l: u32, mean: f64, var: f64, samples: u64) -> LevelStats {
        LevelStats {
            level: l,
            steps: 4 << l,
            work_per_sample: if l == 0 { 4 } else { 6 << l },
            samples,
            failed_fine: 0,
            failed_coarse: 0,
            mean_y: mean,
            var_y: var,
            se_y: (var / samples as f64).sqrt(),
            mean_p: 0.5,
            var_p: 0.1,
            kurtosis: 3.0,
            consistency: 0.0,
            seconds_per_sample: 1e-6 * 1.7f64.powi(l as i32),
        }
    }

    /// Levels 0..=6 whose variances drop by log2 ratios 3.2 and 2.7, then exactly 2 (the
    /// pendulum's coarse levels), and whose means halve from level 1 on.
    fn pendulum_like() -> Vec<LevelStats> {
        let drops = [3.2, 2.7, 2.0, 2.0, 2.0];
        let mut log_var = -5.0f64;
        let mut levels = vec![
            level(0, 0.5, 0.1, 1 << 20),
            level(1, 0.02, 0.031_25, 1 << 20),
        ];
        for (k, drop) in drops.iter().enumerate() {
            log_var -= drop;
            let l = k as u32 + 2;
            levels.push(level(
                l,
                0.02 / f64::from(1 << (l - 1)),
                log_var.exp2(),
                1 << 20,
            ));
        }
        levels
    }

    #[test]
    fn coarse_levels_that_drop_faster_are_left_out_of_beta_and_named() {
        let rates = fit_rates(&pendulum_like(), 1);
        let beta = rates.beta.unwrap();
        // The finer levels' slope exactly; over levels 1..=6 it would be about 2.3.
        assert!((beta.estimate - 2.0).abs() < 1e-9, "{beta:?}");
        assert_eq!(rates.beta_pre_asymptotic, vec![1, 2]);
        assert!((rates.alpha.unwrap().estimate - 1.0).abs() < 1e-9);
        assert!(rates.alpha_pre_asymptotic.is_empty());
    }

    #[test]
    fn a_drop_within_the_tolerance_or_the_monte_carlo_error_is_kept() {
        let mut levels = pendulum_like();
        // Few samples: the coarse levels' faster drop is within the Monte Carlo error.
        for l in &mut levels {
            l.samples = 16;
        }
        let rates = fit_rates(&levels, 1);
        assert!(rates.beta_pre_asymptotic.is_empty());
        assert!(rates.beta.unwrap().estimate > 2.2);
    }

    #[test]
    fn gamma_is_the_slope_of_the_work_and_the_seconds_are_beside_it() {
        let rates = fit_rates(&pendulum_like(), 1);
        let gamma = rates.gamma.unwrap();
        assert!(
            [gamma.estimate, gamma.ci_low, gamma.ci_high]
                .iter()
                .all(|g| (g - 1.0).abs() < 1e-12),
            "{gamma:?}"
        );
        let seconds = rates.gamma_seconds.unwrap();
        assert!(
            (seconds.estimate - 1.7f64.log2()).abs() < 1e-9,
            "{seconds:?}"
        );
    }

    #[test]
    fn levels_that_lost_samples_or_are_not_finite_are_left_out_and_named() {
        let mut levels = pendulum_like();
        levels[1].failed_fine = 3;
        levels[2].var_y = f64::NAN;
        let rates = fit_rates(&levels, 1);
        let named: Vec<u32> = rates.left_out.iter().map(|o| o.level).collect();
        assert_eq!(named, vec![1, 2]);
        assert!(rates.left_out[0].reason.contains("3 fine"));
        assert!(rates.left_out[1].reason.contains("not finite"));
        // Levels 3..=6 alone: exactly 2, nothing pre-asymptotic left.
        assert!((rates.beta.unwrap().estimate - 2.0).abs() < 1e-9);
    }
}
