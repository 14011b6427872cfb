//! Statistics of a convergence study: the L^p strong error over paths with a confidence
//! interval, and the observed order by least squares with its own interval, leaving out the
//! pre-asymptotic levels rather than fitting them.

use serde::Serialize;

/// Two-sided 95% normal quantile.
pub const Z95: f64 = 1.959_963_984_540_054;

/// An estimate with a confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Point estimate.
    pub estimate: f64,
    /// Lower end.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
}

/// The L^p norm over paths, (mean of d_i^p)^(1/p), of per-path errors d_i >= 0, with a 95%
/// interval from the central limit theorem for the mean of d^p mapped through t -> t^(1/p)
/// (delta method would be symmetric; mapping the interval's ends keeps it inside [0, inf)).
/// Returns NaN fields for fewer than 2 values.
pub fn lp_error(errors: &[f64], p: f64) -> Interval {
    let n = errors.len();
    if n < 2 || p.is_nan() || p < 1.0 {
        return Interval {
            estimate: f64::NAN,
            ci_low: f64::NAN,
            ci_high: f64::NAN,
        };
    }
    let powered: Vec<f64> = errors.iter().map(|d| d.powf(p)).collect();
    let mean = mean_interval(&powered);
    let root = |t: f64| t.max(0.0).powf(1.0 / p);
    Interval {
        estimate: root(mean.estimate),
        ci_low: root(mean.ci_low),
        ci_high: root(mean.ci_high),
    }
}

/// The mean of independent samples with a 95% interval from the central limit theorem
/// (mean +- 1.96 s / sqrt(n)); a single sample gives an infinite interval.
pub fn mean_interval(values: &[f64]) -> Interval {
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return Interval {
            estimate: mean,
            ci_low: f64::NEG_INFINITY,
            ci_high: f64::INFINITY,
        };
    }
    let var = values.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    let half = Z95 * (var / n as f64).sqrt();
    Interval {
        estimate: mean,
        ci_low: mean - half,
        ci_high: mean + half,
    }
}

/// A fitted order of convergence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderFit {
    /// Slope of log(error) against log(h), with a 95% interval.
    pub order: Interval,
    /// Indices (into the input) of the levels used in the fit.
    pub fitted: Vec<usize>,
    /// Indices of the levels left out as pre-asymptotic.
    pub pre_asymptotic: Vec<usize>,
}

/// Least-squares slope and its standard error for points (x, y).
fn slope_with_error(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    if points.len() < 3 {
        return (slope, f64::NAN);
    }
    let intercept = my - slope * mx;
    let rss: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    (slope, (rss / (n - 2.0) / sxx).sqrt())
}

/// Student t quantile (two-sided 95%) for the given degrees of freedom.
fn t95(dof: usize) -> f64 {
    const TABLE: [f64; 10] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
    ];
    match dof {
        0 => f64::NAN,
        1..=10 => TABLE[dof - 1],
        11..=20 => 2.086 + (2.228 - 2.086) * (20 - dof) as f64 / 10.0,
        21..=30 => 2.042 + (2.086 - 2.042) * (30 - dof) as f64 / 10.0,
        _ => Z95,
    }
}

/// Fits log(error) = c + order log(h) over the levels (h_i, e_i) (any order of h). Starting from
/// all levels with a positive finite error, the coarsest level is dropped as pre-asymptotic while
/// its local slope (to the next finer level) differs from the slope of the remaining finer
/// levels by more than `tolerance` and at least three levels remain. The interval uses the
/// Student t quantile of the fit's residual spread (NaN with fewer than 3 fitted levels).
pub fn fit_order(levels: &[(f64, f64)], tolerance: f64) -> OrderFit {
    let mut usable: Vec<usize> = (0..levels.len())
        .filter(|&i| {
            let (h, e) = levels[i];
            h > 0.0 && e > 0.0 && h.is_finite() && e.is_finite()
        })
        .collect();
    // Coarse to fine.
    usable.sort_by(|&a, &b| levels[b].0.total_cmp(&levels[a].0));
    let logs = |idx: &[usize]| -> Vec<(f64, f64)> {
        idx.iter()
            .map(|&i| (levels[i].0.ln(), levels[i].1.ln()))
            .collect()
    };
    let mut pre_asymptotic = Vec::new();
    while usable.len() > 3 {
        let local = slope_with_error(&logs(&usable[..2])).0;
        let rest = slope_with_error(&logs(&usable[1..])).0;
        if (local - rest).abs() > tolerance {
            pre_asymptotic.push(usable.remove(0));
        } else {
            break;
        }
    }
    let nan = Interval {
        estimate: f64::NAN,
        ci_low: f64::NAN,
        ci_high: f64::NAN,
    };
    let order = if usable.len() >= 2 {
        let (slope, se) = slope_with_error(&logs(&usable));
        let half = t95(usable.len().saturating_sub(2)) * se;
        Interval {
            estimate: slope,
            ci_low: slope - half,
            ci_high: slope + half,
        }
    } else {
        nan
    };
    OrderFit {
        order,
        fitted: usable,
        pre_asymptotic,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_power_law_gives_its_slope() {
        let levels: Vec<(f64, f64)> = (0..7)
            .map(|k| {
                let h = 0.5f64.powi(k);
                (h, 3.0 * h.powf(0.75))
            })
            .collect();
        let fit = fit_order(&levels, 0.15);
        assert!((fit.order.estimate - 0.75).abs() < 1e-12);
        assert!(fit.pre_asymptotic.is_empty());
        assert!((fit.order.ci_high - fit.order.ci_low).abs() < 1e-9);
    }

    #[test]
    fn pre_asymptotic_levels_are_flagged_not_fitted() {
        // Order 1 for h <= 1/8; the two coarsest levels saturate.
        let levels = [
            (1.0, 0.9),
            (0.5, 0.8),
            (0.25, 0.25),
            (0.125, 0.125),
            (0.0625, 0.0625),
            (0.03125, 0.03125),
        ];
        let fit = fit_order(&levels, 0.15);
        assert_eq!(fit.pre_asymptotic, vec![0, 1]);
        assert!((fit.order.estimate - 1.0).abs() < 1e-12);
    }

    #[test]
    fn noisy_slope_interval_covers_the_truth() {
        // Deterministic "noise" of +-5% on an order-0.5 law: the interval must cover 0.5 and
        // have a width that reflects the noise.
        let levels: Vec<(f64, f64)> = (0..8)
            .map(|k| {
                let h = 0.5f64.powi(k);
                let wiggle = if k % 2 == 0 { 1.05 } else { 0.95 };
                (h, h.sqrt() * wiggle)
            })
            .collect();
        let fit = fit_order(&levels, 1.0);
        assert!(
            fit.order.ci_low < 0.5 && 0.5 < fit.order.ci_high,
            "{:?}",
            fit.order
        );
        assert!(fit.order.ci_high - fit.order.ci_low > 0.005);
    }

    #[test]
    fn lp_error_of_constant_errors_is_exact() {
        let e = lp_error(&[0.2; 10], 2.0);
        assert!((e.estimate - 0.2).abs() < 1e-15);
        assert!((e.ci_low - 0.2).abs() < 1e-15 && (e.ci_high - 0.2).abs() < 1e-15);
    }

    #[test]
    fn lp_interval_covers_the_population_value() {
        // d uniform on a grid in [0, 1]: E d^2 = 1/3 (up to the grid), so the L^2 norm is ~0.577.
        let d: Vec<f64> = (0..1000).map(|i| (i as f64 + 0.5) / 1000.0).collect();
        let e = lp_error(&d, 2.0);
        let exact = (1.0f64 / 3.0).sqrt();
        assert!(e.ci_low < exact && exact < e.ci_high, "{e:?}");
        assert!(e.ci_high - e.ci_low < 0.05);
    }
}
