//! Statistics of a study, with intervals that hold their 95% where the sample allows it:
//!
//! - [`t975`]: the Student t quantile for every degree of freedom;
//! - [`mean_interval`]: the mean of independent samples with its t interval;
//! - [`lp_error`]: the L^p norm over paths of per-path errors, with a studentized bootstrap
//!   interval on the log scale (per-path errors are skewed: the CLT interval of the mean of
//!   d^p under-covers badly at small samples);
//! - [`fit_order`]: the observed order of convergence from the per-path errors of all levels
//!   of one set of paths, its interval from the Monte Carlo error (delta method on the per-path
//!   covariance across levels), and the local slopes with theirs, so that curvature is flagged
//!   as pre-asymptotic rather than hidden in an interval.

use rand::RngExt;
use sdae_model::path_rng;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// An estimate with a 95% confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Point estimate.
    #[serde(with = "crate::real")]
    pub estimate: f64,
    /// Lower end.
    #[serde(with = "crate::real")]
    pub ci_low: f64,
    /// Upper end.
    #[serde(with = "crate::real")]
    pub ci_high: f64,
}

impl Interval {
    /// Whether `x` lies in [ci_low, ci_high].
    pub fn contains(&self, x: f64) -> bool {
        self.ci_low <= x && x <= self.ci_high
    }
}

/// The two-sided 95% quantile t_{0.975, dof} of Student's t distribution (NaN for dof = 0).
pub fn t975(dof: usize) -> f64 {
    if dof == 0 {
        return f64::NAN;
    }
    StudentsT::new(0.0, 1.0, dof as f64).map_or(f64::NAN, |t| t.inverse_cdf(0.975))
}

/// Mean and unbiased variance.
fn mean_and_variance(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, var)
}

/// The mean of independent samples with the 95% t interval mean +- t_{0.975, n-1} s / sqrt(n),
/// exact for normal samples at every n >= 2. `None` for fewer than 2 samples: no interval can
/// be formed from one.
pub fn mean_interval(values: &[f64]) -> Option<Interval> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let (mean, var) = mean_and_variance(values);
    let half = t975(n - 1) * (var / n as f64).sqrt();
    Some(Interval {
        estimate: mean,
        ci_low: mean - half,
        ci_high: mean + half,
    })
}

/// Bootstrap resamples of [`lp_error`].
pub const BOOTSTRAP_RESAMPLES: usize = 400;

/// Seed of the bootstrap's resampling stream (fixed: the interval is a function of the data).
const BOOTSTRAP_SEED: u64 = 0x5eed_b007;

/// A uniform index in 0..n from 64 random bits (multiply-shift).
fn index(bits: u64, n: usize) -> usize {
    ((u128::from(bits) * n as u128) >> 64) as usize
}

/// The L^p norm over paths, (mean of d_i^p)^(1/p), of per-path errors d_i >= 0, with a 95%
/// studentized bootstrap interval on the log scale: with m the mean of d^p and
/// se = s / (sqrt(n) m) the delta-method standard error of log m, the quantiles of
/// (log m* - log m) / se* over [`BOOTSTRAP_RESAMPLES`] resamples of the paths give the
/// interval of log m, mapped back by exp and the p-th root. It adapts to the skew of d^p
/// (measured coverage in docs/studies.md); resampling draws from a fixed stream, so the interval
/// depends only on the data. `None` for fewer than 2 errors or p < 1; a zero interval when every
/// error is 0.
pub fn lp_error(errors: &[f64], p: f64) -> Option<Interval> {
    let n = errors.len();
    if n < 2 || p.is_nan() || p < 1.0 {
        return None;
    }
    let powered: Vec<f64> = errors.iter().map(|d| d.powf(p)).collect();
    let (mean, var) = mean_and_variance(&powered);
    let root = |t: f64| t.max(0.0).powf(1.0 / p);
    let se = (var / n as f64).sqrt() / mean;
    if !(se.is_finite() && se > 0.0) {
        let e = root(mean);
        return Some(Interval {
            estimate: e,
            ci_low: e,
            ci_high: e,
        });
    }
    let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
    let mut statistics = Vec::with_capacity(BOOTSTRAP_RESAMPLES);
    for _ in 0..BOOTSTRAP_RESAMPLES {
        let (m, v) = resample_moments(&powered, mean, &mut rng);
        let se_star = (v / n as f64).sqrt() / m;
        if se_star.is_finite() && se_star > 0.0 {
            statistics.push((m.ln() - mean.ln()) / se_star);
        }
    }
    statistics.sort_by(f64::total_cmp);
    // Resamples of identical values have no spread; with too few others, fall back to t.
    let (lo, hi) = if statistics.len() < BOOTSTRAP_RESAMPLES / 2 {
        let t = t975(n - 1);
        (-t, t)
    } else {
        (quantile(&statistics, 0.025), quantile(&statistics, 0.975))
    };
    Some(Interval {
        estimate: root(mean),
        ci_low: root(mean * (-hi * se).exp()),
        ci_high: root(mean * (-lo * se).exp()),
    })
}

/// The mean and unbiased variance of one bootstrap resample of `values` (n indices drawn from
/// `rng`), in one pass without storing the resample: the sums of x - shift and (x - shift)^2
/// run in four independent partial sums, so that the additions do not wait on each other
/// (`shift`, the sample's mean, keeps the sum of squares well conditioned:
/// var = (S2 - S1^2 / n) / (n - 1) with S1 of the order of sqrt(n) s).
fn resample_moments<R: RngExt>(values: &[f64], shift: f64, rng: &mut R) -> (f64, f64) {
    const PARTIALS: usize = 4;
    let n = values.len();
    let mut draw = || values[index(rng.random::<u64>(), n)] - shift;
    let (mut s1, mut s2) = ([0.0; PARTIALS], [0.0; PARTIALS]);
    for _ in 0..n / PARTIALS {
        for (a, b) in s1.iter_mut().zip(s2.iter_mut()) {
            let x = draw();
            *a += x;
            *b += x * x;
        }
    }
    for (a, b) in s1.iter_mut().zip(s2.iter_mut()).take(n % PARTIALS) {
        let x = draw();
        *a += x;
        *b += x * x;
    }
    let (s1, s2): (f64, f64) = (s1.iter().sum(), s2.iter().sum());
    let count = n as f64;
    let variance = ((s2 - s1 * s1 / count) / (count - 1.0)).max(0.0);
    (shift + s1 / count, variance)
}

/// The q-quantile of sorted values (linear between order statistics).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let x = q * (sorted.len() - 1) as f64;
    let (i, w) = (x.floor() as usize, x - x.floor());
    let j = (i + 1).min(sorted.len() - 1);
    (1.0 - w) * sorted[i] + w * sorted[j]
}

/// The per-path errors of one set of paths at several levels: `errors[j][i]` is path i at the
/// level of step size `h[j]` (the same paths at every level, so errors at different h are
/// correlated through the path).
#[derive(Debug, Clone, Copy)]
pub struct PathErrors<'a> {
    /// Step sizes, one per level.
    pub h: &'a [f64],
    /// Per-path errors, one row per level, each of the same length.
    pub errors: &'a [Vec<f64>],
    /// The errors are L^p norms over paths.
    pub p: f64,
}

/// log E_j = log (mean_i d_ij^p) / p at every level, with the covariance of these logs from the
/// Monte Carlo error (delta method: Cov(log m_j, log m_k) = Cov(d_j^p, d_k^p) / (n m_j m_k)).
struct LogErrors {
    x: Vec<f64>,
    y: Vec<f64>,
    cov: Vec<Vec<f64>>,
    n: usize,
}

impl LogErrors {
    /// `None` unless there are >= 2 paths and every level's L^p error is positive and finite.
    fn new(data: PathErrors<'_>) -> Option<Self> {
        let levels = data.h.len();
        let n = data.errors.first().map_or(0, Vec::len);
        if n < 2 || data.errors.len() != levels || data.errors.iter().any(|e| e.len() != n) {
            return None;
        }
        let powered: Vec<Vec<f64>> = data
            .errors
            .iter()
            .map(|e| e.iter().map(|d| d.powf(data.p)).collect())
            .collect();
        let means: Vec<f64> = powered
            .iter()
            .map(|v| v.iter().sum::<f64>() / n as f64)
            .collect();
        if means.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
            return None;
        }
        let cov = (0..levels)
            .map(|j| {
                (0..levels)
                    .map(|k| {
                        let c = powered[j]
                            .iter()
                            .zip(&powered[k])
                            .map(|(a, b)| (a - means[j]) * (b - means[k]))
                            .sum::<f64>()
                            / (n - 1) as f64;
                        c / (n as f64 * means[j] * means[k] * data.p * data.p)
                    })
                    .collect()
            })
            .collect();
        Some(Self {
            x: data.h.iter().map(|h| h.ln()).collect(),
            y: means.iter().map(|m| m.ln() / data.p).collect(),
            cov,
            n,
        })
    }

    /// The value and standard error of the linear functional sum_j w_j y_j.
    fn functional(&self, w: &[(usize, f64)]) -> (f64, f64) {
        let value = w.iter().map(|&(j, wj)| wj * self.y[j]).sum();
        let var: f64 = w
            .iter()
            .flat_map(|&(j, wj)| w.iter().map(move |&(k, wk)| wj * wk * self.cov[j][k]))
            .sum();
        (value, var.max(0.0).sqrt())
    }

    /// Least-squares slope of y against x over `levels` as weights on y.
    fn slope_weights(&self, levels: &[usize]) -> Vec<(usize, f64)> {
        let mx = levels.iter().map(|&j| self.x[j]).sum::<f64>() / levels.len() as f64;
        let sxx: f64 = levels.iter().map(|&j| (self.x[j] - mx).powi(2)).sum();
        levels
            .iter()
            .map(|&j| (j, (self.x[j] - mx) / sxx))
            .collect()
    }

    /// The local slope between levels a and b as weights on y.
    fn local_weights(&self, a: usize, b: usize) -> Vec<(usize, f64)> {
        let dx = self.x[a] - self.x[b];
        vec![(a, 1.0 / dx), (b, -1.0 / dx)]
    }

    /// The t interval of a functional.
    fn interval(&self, w: &[(usize, f64)]) -> Interval {
        let (value, se) = self.functional(w);
        let half = t975(self.n - 1) * se;
        Interval {
            estimate: value,
            ci_low: value - half,
            ci_high: value + half,
        }
    }

    /// Whether the functionals `a` and `b` differ by more than the Monte Carlo error allows
    /// (95%) and by more than `tolerance`.
    fn disagree(&self, a: &[(usize, f64)], b: &[(usize, f64)], tolerance: f64) -> bool {
        let difference: Vec<(usize, f64)> = a
            .iter()
            .copied()
            .chain(b.iter().map(|&(j, w)| (j, -w)))
            .collect();
        let (d, se) = self.functional(&difference);
        d.abs() > tolerance && d.abs() > t975(self.n - 1) * se
    }
}

/// The slope between two neighbouring levels, with its Monte Carlo interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LocalSlope {
    /// Index of the coarser level.
    pub coarse: usize,
    /// Index of the finer level.
    pub fine: usize,
    /// log(E_coarse / E_fine) / log(h_coarse / h_fine) with its 95% interval.
    pub slope: Interval,
}

/// A fitted order of convergence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderFit {
    /// Least-squares slope of log(error) against log(h) over the fitted levels, with its 95%
    /// interval from the Monte Carlo error of the errors (not from the regression residuals).
    pub order: Interval,
    /// Indices (into the input) of the levels used in the fit.
    pub fitted: Vec<usize>,
    /// Indices of coarse levels left out as pre-asymptotic: their local slope to the next
    /// finer level disagrees with the slope of the finer levels beyond the Monte Carlo error
    /// (and by more than the tolerance).
    pub pre_asymptotic: Vec<usize>,
    /// Local slopes between neighbouring levels, coarse to fine, with their intervals.
    pub local_slopes: Vec<LocalSlope>,
    /// Fitted levels whose local slope still disagrees with the fitted order beyond the Monte
    /// Carlo error: the error curve bends there, and the order's interval does not cover that
    /// model error.
    pub curvature: Vec<usize>,
}

/// Fits log(error) = c + order log(h) over the levels of one set of paths (any order of h).
/// Starting from all levels, the coarsest level is left out as pre-asymptotic while its local
/// slope disagrees with the slope of the remaining finer levels (beyond the Monte Carlo error
/// and by more than `tolerance`) and at least three levels remain. `None` without >= 2 paths,
/// >= 2 levels and positive finite errors at every level.
pub fn fit_order(data: PathErrors<'_>, tolerance: f64) -> Option<OrderFit> {
    let logs = LogErrors::new(data)?;
    let mut usable: Vec<usize> = (0..data.h.len()).collect();
    if usable.len() < 2 {
        return None;
    }
    // Coarse to fine.
    usable.sort_by(|&a, &b| data.h[b].total_cmp(&data.h[a]));
    let local_slopes: Vec<LocalSlope> = usable
        .windows(2)
        .map(|w| LocalSlope {
            coarse: w[0],
            fine: w[1],
            slope: logs.interval(&logs.local_weights(w[0], w[1])),
        })
        .collect();
    let mut pre_asymptotic = Vec::new();
    while usable.len() > 3 {
        let local = logs.local_weights(usable[0], usable[1]);
        let rest = logs.slope_weights(&usable[1..]);
        if logs.disagree(&local, &rest, tolerance) {
            pre_asymptotic.push(usable.remove(0));
        } else {
            break;
        }
    }
    let fitted = logs.slope_weights(&usable);
    let curvature = usable
        .windows(2)
        .filter(|w| logs.disagree(&logs.local_weights(w[0], w[1]), &fitted, tolerance))
        .map(|w| w[0])
        .collect();
    Some(OrderFit {
        order: logs.interval(&fitted),
        fitted: usable,
        pre_asymptotic,
        local_slopes,
        curvature,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_pass_resample_moments_match_the_stored_resample() {
        // Skewed values (squares of a lognormal-like spread) of lengths off and on multiples
        // of the partial sums' count.
        for n in [2, 3, 10, 1003] {
            let values: Vec<f64> = (0..n)
                .map(|i| (0.37 * i as f64).sin().exp().powi(2))
                .collect();
            let (mean, _) = mean_and_variance(&values);
            let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
            let mut copy = rng.clone();
            for _ in 0..5 {
                let (m, v) = resample_moments(&values, mean, &mut rng);
                let stored: Vec<f64> = (0..n)
                    .map(|_| values[index(copy.random::<u64>(), n)])
                    .collect();
                let (m2, v2) = mean_and_variance(&stored);
                assert!(
                    (m - m2).abs() <= 1e-14 * m2,
                    "n = {n}: mean {m} against {m2}"
                );
                // Relative to the scale of the values: a resample of equal values has v = 0.
                assert!(
                    (v - v2).abs() <= 1e-12 * (v2 + m2 * m2),
                    "n = {n}: variance {v} against {v2}"
                );
            }
        }
    }

    #[test]
    fn t_quantiles_match_published_values() {
        let table = [
            (1, 12.706),
            (2, 4.303),
            (4, 2.776),
            (19, 2.093),
            (39, 2.023),
            (199, 1.972),
            (100_000, 1.960),
        ];
        for (dof, value) in table {
            assert!((t975(dof) - value).abs() < 5e-4, "dof {dof}: {}", t975(dof));
        }
        assert!(t975(0).is_nan());
    }

    /// Errors at levels h = 2^-j of an exact power law E = C h^q on shared paths.
    fn power_law(q: f64, paths: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
        let h: Vec<f64> = (0..6).map(|j| 0.5f64.powi(j)).collect();
        let errors = h
            .iter()
            .map(|hj| {
                (0..paths)
                    .map(|i| 3.0 * hj.powf(q) * (1.0 + i as f64))
                    .collect()
            })
            .collect();
        (h, errors)
    }

    #[test]
    fn exact_power_law_gives_its_slope() {
        let (h, errors) = power_law(0.75, 10);
        let data = PathErrors {
            h: &h,
            errors: &errors,
            p: 2.0,
        };
        let fit = fit_order(data, 0.05).unwrap();
        assert!((fit.order.estimate - 0.75).abs() < 1e-12);
        assert!(fit.pre_asymptotic.is_empty() && fit.curvature.is_empty());
        // The path factor cancels in the slope: no Monte Carlo error.
        assert!(
            fit.order.ci_high - fit.order.ci_low < 1e-6,
            "{:?}",
            fit.order
        );
        assert_eq!(fit.local_slopes.len(), 5);
    }

    #[test]
    fn lp_error_of_constant_errors_is_exact() {
        let e = lp_error(&[0.2; 10], 2.0).unwrap();
        assert!((e.estimate - 0.2).abs() < 1e-15);
        assert!((e.ci_low - 0.2).abs() < 1e-15 && (e.ci_high - 0.2).abs() < 1e-15);
        assert!(lp_error(&[0.2], 2.0).is_none());
        assert!(mean_interval(&[1.0]).is_none());
    }
}
