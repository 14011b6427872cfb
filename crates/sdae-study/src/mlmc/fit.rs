//! The MLMC rates from a convergence test: |E[P_l - P_{l-1}]| ~ 2^(-alpha l),
//! V[P_l - P_{l-1}] ~ 2^(-beta l), cost per sample ~ 2^(gamma l), fitted by least squares on
//! log2 over the levels l >= 1, with 95% intervals.
//!
//! alpha and beta are weighted fits with the Monte Carlo standard error of each point (delta
//! method: se(log2 m) = se(m) / (|m| ln 2), se(log2 V) = sqrt((kurt - 1) / N) / ln 2); when the
//! points scatter more than that error (a reduced chi^2 above 1, a rate not yet asymptotic),
//! the slope's standard error is scaled by sqrt(chi^2 / dof). Levels whose mean is within two
//! standard errors of 0 are unresolved and left out of alpha. gamma, from measured times, is an
//! unweighted fit with the residuals' scatter.

use serde::Serialize;

use super::sums::LevelStats;
use crate::stats::{Interval, t975};

/// The fitted rates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rates {
    /// Weak rate alpha with its interval (`None`: fewer than two resolved levels).
    pub alpha: Option<Interval>,
    /// Variance rate beta.
    pub beta: Option<Interval>,
    /// Cost rate gamma.
    pub gamma: Option<Interval>,
    /// The levels fitted (l >= this).
    pub from_level: u32,
    /// Levels left out of alpha as unresolved (|mean| < 2 se).
    pub unresolved: Vec<u32>,
}

/// A line y = a + b x fitted to points with standard errors `se` (or unweighted): the slope
/// with its 95% interval. `None` with fewer than two points or non-finite data.
pub fn fit_slope(x: &[f64], y: &[f64], se: Option<&[f64]>) -> Option<Interval> {
    let n = x.len();
    if n < 2 || x.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    let w: Vec<f64> = match se {
        Some(se) => se.iter().map(|s| 1.0 / (s * s).max(1e-300)).collect(),
        None => vec![1.0; n],
    };
    let sw: f64 = w.iter().sum();
    let xm = w.iter().zip(x).map(|(w, x)| w * x).sum::<f64>() / sw;
    let ym = w.iter().zip(y).map(|(w, y)| w * y).sum::<f64>() / sw;
    let sxx: f64 = w.iter().zip(x).map(|(w, x)| w * (x - xm) * (x - xm)).sum();
    let sxy: f64 = (0..n).map(|i| w[i] * (x[i] - xm) * (y[i] - ym)).sum();
    let slope = sxy / sxx;
    let chi2: f64 = (0..n)
        .map(|i| {
            let r = y[i] - ym - slope * (x[i] - xm);
            w[i] * r * r
        })
        .sum();
    let dof = n - 2;
    let (sd, quantile) = match (se, dof) {
        (Some(_), 0) => ((1.0 / sxx).sqrt(), 1.959_963_984_540_054),
        (Some(_), _) => ((1.0 / sxx * (chi2 / dof as f64).max(1.0)).sqrt(), t975(dof)),
        (None, 0) => {
            return Some(Interval {
                estimate: slope,
                ci_low: f64::NEG_INFINITY,
                ci_high: f64::INFINITY,
            });
        }
        (None, _) => ((chi2 / dof as f64 / sxx).sqrt(), t975(dof)),
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

/// alpha, beta and gamma from the levels l >= `from_level` (at least 1) of a convergence test.
pub fn fit_rates(levels: &[LevelStats], from_level: u32) -> Rates {
    let fitted: Vec<&LevelStats> = levels
        .iter()
        .filter(|s| s.level >= from_level.max(1) && s.samples >= 2)
        .collect();
    let ln2 = std::f64::consts::LN_2;
    let (resolved, unresolved): (Vec<&LevelStats>, Vec<&LevelStats>) =
        fitted.iter().partition(|s| s.mean_y.abs() > 2.0 * s.se_y);
    let alpha = fit_slope(
        &resolved
            .iter()
            .map(|s| f64::from(s.level))
            .collect::<Vec<_>>(),
        &resolved
            .iter()
            .map(|s| s.mean_y.abs().log2())
            .collect::<Vec<_>>(),
        Some(
            &resolved
                .iter()
                .map(|s| s.se_y / (s.mean_y.abs() * ln2))
                .collect::<Vec<_>>(),
        ),
    )
    .map(negated);
    let with_variance: Vec<&LevelStats> =
        fitted.iter().copied().filter(|s| s.var_y > 0.0).collect();
    let beta = fit_slope(
        &with_variance
            .iter()
            .map(|s| f64::from(s.level))
            .collect::<Vec<_>>(),
        &with_variance
            .iter()
            .map(|s| s.var_y.log2())
            .collect::<Vec<_>>(),
        Some(
            &with_variance
                .iter()
                .map(|s| ((s.kurtosis - 1.0).max(1.0) / s.samples as f64).sqrt() / ln2)
                .collect::<Vec<_>>(),
        ),
    )
    .map(negated);
    let timed: Vec<&LevelStats> = fitted
        .iter()
        .copied()
        .filter(|s| s.seconds_per_sample > 0.0)
        .collect();
    let gamma = fit_slope(
        &timed.iter().map(|s| f64::from(s.level)).collect::<Vec<_>>(),
        &timed
            .iter()
            .map(|s| s.seconds_per_sample.log2())
            .collect::<Vec<_>>(),
        None,
    );
    Rates {
        alpha,
        beta,
        gamma,
        from_level: from_level.max(1),
        unresolved: unresolved.iter().map(|s| s.level).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
