//! The estimates a study reports (means, L^p errors, orders of convergence), each with its
//! 95% interval.

use crate::{Interval, t975};
use serde::Serialize;

use crate::bootstrap::{BOOTSTRAP_RESAMPLES, PathTable, paired_bootstrap, quantile};

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

/// The largest of the errors (NaN if one is NaN): the scale that keeps d^p from underflowing.
fn largest(errors: &[f64]) -> f64 {
    errors
        .iter()
        .fold(0.0_f64, |m, &d| if d.is_nan() { d } else { m.max(d) })
}

/// The L^p norm over paths, (mean of d_i^p)^(1/p), of per-path errors d_i >= 0, with a 95%
/// studentized bootstrap interval on the log scale. Computed as d_max (mean of
/// (d_i / d_max)^p)^(1/p) with d_max the largest error, so that neither large p (d^p underflows
/// from p ~ 200 for errors of 1e-2) nor tiny errors give 0. With m the mean of (d / d_max)^p and
/// se = s / (sqrt(n) m) the delta-method standard error of log m, the quantiles of
/// (log m* - log m) / se* over [`BOOTSTRAP_RESAMPLES`] resamples of the paths
/// ([`paired_bootstrap`]) give the interval of log m, mapped back by exp, the p-th root and the
/// scale. It adapts to the skew of d^p (measured coverage in docs/studies.md); the resampling
/// stream is fixed, so the interval depends only on the data. `None` for fewer than 2 errors or
/// p < 1; a zero-width interval when every error is equal (or 0, or one is infinite or NaN).
pub fn lp_error(errors: &[f64], p: f64) -> Option<Interval> {
    let (level, powered) = match LpLevel::of(errors, p)? {
        Ok(level) => level,
        Err(exact_error) => return Some(exact(exact_error)),
    };
    let (n, mean) = (level.n, level.mean);
    // Columns x - mean and (x - mean)^2: the resample's mean and variance from their sums
    // (the shift keeps the sum of squares well conditioned).
    let table = PathTable::from_rows(n, 2, |i, row| {
        let x = powered[i] - mean;
        row.copy_from_slice(&[x, x * x]);
    });
    let statistics = paired_bootstrap(&table, BOOTSTRAP_RESAMPLES, |s| level.statistic(s[0], s[1]));
    Some(level.interval(statistics))
}

/// The estimate of [`lp_error`] alone, without its interval (no bootstrap): the same number,
/// bit for bit, at the cost of one pass over the errors. `None` where [`lp_error`] is `None`.
pub fn lp_estimate(errors: &[f64], p: f64) -> Option<f64> {
    Some(match LpLevel::of(errors, p)? {
        Ok((level, _)) => level.root(level.mean),
        Err(exact_error) => exact_error,
    })
}

/// A zero-width interval at `e`.
fn exact(e: f64) -> Interval {
    Interval {
        estimate: e,
        ci_low: e,
        ci_high: e,
    }
}

/// One level's L^p error from x_i = (d_i / scale)^p: the mean m and unbiased variance of x
/// over n paths.
struct LpLevel {
    scale: f64,
    mean: f64,
    var: f64,
    n: usize,
    p: f64,
}

impl LpLevel {
    /// The level of `errors` with its x_i = (d_i / scale)^p; `Err(e)` when the error is `e`
    /// exactly (the largest error is 0, infinite or NaN); `None` for fewer than 2 errors or
    /// p < 1.
    fn of(errors: &[f64], p: f64) -> Option<Result<(Self, Vec<f64>), f64>> {
        let n = errors.len();
        if n < 2 || p.is_nan() || p < 1.0 {
            return None;
        }
        let scale = largest(errors);
        if !(scale.is_finite() && scale > 0.0) {
            return Some(Err(scale));
        }
        let powered: Vec<f64> = errors.iter().map(|d| (d / scale).powf(p)).collect();
        let (mean, var) = mean_and_variance(&powered);
        let level = LpLevel {
            scale,
            mean,
            var,
            n,
            p,
        };
        Some(Ok((level, powered)))
    }

    /// scale t^(1/p): the L^p error of a mean t of x (0 for t <= 0).
    fn root(&self, t: f64) -> f64 {
        self.scale * t.max(0.0).powf(1.0 / self.p)
    }

    /// The studentized statistic (log m* - log m) / se* of a resample from the sums S1, S2 of
    /// x_i - m and (x_i - m)^2 over its paths: m* = m + S1 / n,
    /// v* = (S2 - S1^2 / n) / (n - 1), se* = sqrt(v* / n) / m*. `None` for a resample without
    /// spread.
    fn statistic(&self, s1: f64, s2: f64) -> Option<f64> {
        let count = self.n as f64;
        let m = self.mean + s1 / count;
        let v = ((s2 - s1 * s1 / count) / (count - 1.0)).max(0.0);
        let se_star = (v / count).sqrt() / m;
        let t = (s1 / (count * self.mean)).ln_1p() / se_star;
        t.is_finite().then_some(t)
    }

    /// The interval from the resamples' statistics: with se = s / (sqrt(n) m), the 2.5% and
    /// 97.5% quantiles lo, hi of the statistics give scale (m e^{-hi se})^(1/p) and
    /// scale (m e^{-lo se})^(1/p) (the t quantiles stand in when fewer than half of the
    /// resamples have a spread; zero width when the sample has none).
    fn interval(&self, mut statistics: Vec<f64>) -> Interval {
        let root = |t: f64| self.root(t);
        let se = (self.var / self.n as f64).sqrt() / self.mean;
        if !(se.is_finite() && se > 0.0) {
            return exact(root(self.mean));
        }
        statistics.sort_by(f64::total_cmp);
        let (lo, hi) = if statistics.len() < BOOTSTRAP_RESAMPLES / 2 {
            let t = t975(self.n - 1);
            (-t, t)
        } else {
            (quantile(&statistics, 0.025), quantile(&statistics, 0.975))
        };
        Interval {
            estimate: root(self.mean),
            ci_low: root(self.mean * (-hi * se).exp()),
            ci_high: root(self.mean * (-lo * se).exp()),
        }
    }
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

/// log E_j = log (mean_i d_ij^p) / p at every level, computed as
/// log s_j + log (mean_i (d_ij / s_j)^p) / p with s_j the level's largest error (no underflow
/// of d^p), with the covariance of these logs from the Monte Carlo error (delta method:
/// Cov(log m_j, log m_k) = Cov(x_j, x_k) / (n m_j m_k p^2), x_ij = (d_ij / s_j)^p, m_j its
/// mean).
struct LogErrors {
    x: Vec<f64>,
    y: Vec<f64>,
    cov: Vec<Vec<f64>>,
    /// x_ij, one row per level.
    powered: Vec<Vec<f64>>,
    /// m_j.
    means: Vec<f64>,
    /// Each level's L^p error from its x_ij.
    lp: Vec<LpLevel>,
    p: f64,
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
        let scales: Vec<f64> = data.errors.iter().map(|e| largest(e)).collect();
        if scales.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return None;
        }
        let powered: Vec<Vec<f64>> = data
            .errors
            .iter()
            .zip(&scales)
            .map(|(e, s)| e.iter().map(|d| (d / s).powf(data.p)).collect())
            .collect();
        let means: Vec<f64> = powered
            .iter()
            .map(|v| v.iter().sum::<f64>() / n as f64)
            .collect();
        let sample_cov = |j: usize, k: usize| {
            powered[j]
                .iter()
                .zip(&powered[k])
                .map(|(a, b)| (a - means[j]) * (b - means[k]))
                .sum::<f64>()
                / (n - 1) as f64
        };
        let cov = (0..levels)
            .map(|j| {
                (0..levels)
                    .map(|k| sample_cov(j, k) / (n as f64 * means[j] * means[k] * data.p * data.p))
                    .collect()
            })
            .collect();
        let lp = (0..levels)
            .map(|j| LpLevel {
                scale: scales[j],
                mean: means[j],
                var: sample_cov(j, j),
                n,
                p: data.p,
            })
            .collect();
        Some(Self {
            x: data.h.iter().map(|h| h.ln()).collect(),
            y: scales
                .iter()
                .zip(&means)
                .map(|(s, m)| s.ln() + m.ln() / data.p)
                .collect(),
            cov,
            powered,
            means,
            lp,
            p: data.p,
            n,
        })
    }

    /// The value and standard error of the linear functional sum_j w_j y_j.
    fn functional(&self, w: &[(usize, f64)]) -> (f64, f64) {
        let value = w.iter().map(|&(j, wj)| wj * self.y[j]).sum();
        (
            value,
            quadratic_form(w, |j, k| self.cov[j][k]).max(0.0).sqrt(),
        )
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

    /// The delta-method t interval of a functional.
    fn interval(&self, w: &[(usize, f64)]) -> Interval {
        let (value, se) = self.functional(w);
        let half = t975(self.n - 1) * se;
        Interval {
            estimate: value,
            ci_low: value - half,
            ci_high: value + half,
        }
    }

    /// Symmetric percentile-t intervals of the functionals sum_j w_j y_j from the paired
    /// bootstrap of the paths (every level of a path drawn together): with f and se the
    /// functional's value and delta-method standard error, the 95% quantile q of
    /// |f* - f| / se* over the resamples gives f +- q se. The resampled statistic is
    /// studentized by its own se*, so a resample that draws a heavy path twice widens its se*
    /// with its shift, and q carries the excess spread of the slope that the delta method's
    /// normal quantile misses at heavy tails. The symmetric form's coverage error is of a
    /// higher order in 1/n than the equal-tailed [f - q_97.5 se, f - q_2.5 se] (Hall 1988),
    /// and on slopes of heavy-tailed errors it covers by several points more (measured in
    /// tests/integration/coverage.rs: 94.8% against 91.4% at 200 paths with a log-normal path factor,
    /// 94.4% against 86.8% with a heavier one). A functional without Monte Carlo
    /// error (se = 0) keeps a zero-width interval; `None` when fewer than half of the
    /// resamples are usable (a degenerate sample). The same resamples give each level's L^p
    /// error interval (second; exactly [`lp_error`]'s, whose stream of n paths this is).
    fn bootstrap(
        &self, functionals: &[Vec<(usize, f64)>],
    ) -> (Option<Vec<Interval>>, Vec<Interval>) {
        let (levels, n) = (self.y.len(), self.n as f64);
        let pairs: Vec<(usize, usize)> = (0..levels)
            .flat_map(|j| (j..levels).map(move |k| (j, k)))
            .collect();
        let diagonal: Vec<usize> = (0..levels)
            .map(|j| pairs.iter().position(|&p| p == (j, j)).unwrap_or(0))
            .collect();
        // Columns x_ij - m_j and the products (x_ij - m_j)(x_ik - m_k), j <= k.
        let table = PathTable::from_rows(self.n, levels + pairs.len(), |i, row| {
            let (centred, products) = row.split_at_mut(levels);
            for (j, c) in centred.iter_mut().enumerate() {
                *c = self.powered[j][i] - self.means[j];
            }
            for (cell, &(j, k)) in products.iter_mut().zip(&pairs) {
                *cell = centred[j] * centred[k];
            }
        });
        let estimates: Vec<(f64, f64)> = functionals.iter().map(|w| self.functional(w)).collect();
        let mut cov = vec![0.0; levels * levels];
        let mut shift = vec![0.0; levels];
        let mut m = vec![0.0; levels];
        let statistics = paired_bootstrap(&table, BOOTSTRAP_RESAMPLES, |sums| {
            let (s1, s2) = sums.split_at(levels);
            let level_t: Vec<Option<f64>> = (0..levels)
                .map(|j| self.lp[j].statistic(s1[j], s2[diagonal[j]]))
                .collect();
            for j in 0..levels {
                m[j] = self.means[j] + s1[j] / n;
                // log m*_j - log m_j.
                shift[j] = (s1[j] / (n * self.means[j])).ln_1p() / self.p;
            }
            for (&(j, k), &c) in pairs.iter().zip(s2) {
                let v = (c - s1[j] * s1[k] / n) / (n - 1.0) / (n * m[j] * m[k] * self.p * self.p);
                cov[j * levels + k] = v;
                cov[k * levels + j] = v;
            }
            let functional_t = functionals
                .iter()
                .zip(&estimates)
                .map(|(w, &(_, se))| {
                    if se == 0.0 {
                        return Some(0.0);
                    }
                    let change: f64 = w.iter().map(|&(j, wj)| wj * shift[j]).sum();
                    let t = change / quadratic_form(w, |j, k| cov[j * levels + k]).sqrt();
                    t.is_finite().then_some(t)
                })
                .collect::<Option<Vec<f64>>>();
            Some((level_t, functional_t))
        });
        let level_intervals = (0..levels)
            .map(|j| {
                let t = statistics.iter().filter_map(|s| s.0[j]).collect();
                self.lp[j].interval(t)
            })
            .collect();
        let usable: Vec<&Vec<f64>> = statistics.iter().filter_map(|s| s.1.as_ref()).collect();
        if usable.len() < BOOTSTRAP_RESAMPLES / 2 {
            return (None, level_intervals);
        }
        let intervals = estimates
            .iter()
            .enumerate()
            .map(|(f, &(value, se))| {
                let mut t: Vec<f64> = usable.iter().map(|s| s[f].abs()).collect();
                t.sort_by(f64::total_cmp);
                let half = quantile(&t, 0.95) * se;
                Interval {
                    estimate: value,
                    ci_low: value - half,
                    ci_high: value + half,
                }
            })
            .collect();
        (Some(intervals), level_intervals)
    }

    /// The effective number of paths behind the functional sum_j w_j y_j
    /// ([`lognormal_effective_paths`] of the shares psi_i = sum_j w_j (x_ij - m_j) / (p m_j),
    /// path i's part of the functional's Monte Carlo error: its influence, the delta method's
    /// linearization). A heavy path factor that the levels share cancels in a slope and leaves
    /// the shares small.
    fn effective_paths(&self, w: &[(usize, f64)]) -> f64 {
        lognormal_effective_paths(
            (0..self.n)
                .map(|i| {
                    let share: f64 = w
                        .iter()
                        .map(|&(j, wj)| wj * (self.powered[j][i] / self.means[j] - 1.0))
                        .sum();
                    share / self.p
                })
                .collect(),
        )
    }

    /// Whether the functionals `a` and `b` differ by more than the Monte Carlo error allows
    /// (95%, delta method) and by more than `tolerance`.
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

/// sum_jk w_j w_k c(j, k) for weights w on levels.
fn quadratic_form(w: &[(usize, f64)], c: impl Fn(usize, usize) -> f64) -> f64 {
    w.iter()
        .flat_map(|&(j, wj)| w.iter().map(move |&(k, wk)| (j, k, wj * wk)))
        .map(|(j, k, wjk)| wjk * c(j, k))
        .sum()
}

/// The effective number of paths behind a mean of n shares psi_i (each path's part of an
/// estimate's Monte Carlo error): sigma = ln(q_0.9 / q_0.5) / z_0.9, the log-normal spread that
/// the upper body of |psi| shows (z_0.9 = 1.2816), gives n e^(-sigma^2), the effective sample
/// size E[w]^2 / E[w^2] of log-normal weights of that spread. The spread is read from the body,
/// which every sample of a heavy law shows, not from the largest values, which a sample of a
/// heavy law lacks (an estimate from those looks light exactly when the sample missed the heavy
/// paths). n when every share is 0 (no Monte Carlo error), 0 when more than half are.
fn lognormal_effective_paths(mut shares: Vec<f64>) -> f64 {
    let n = shares.len() as f64;
    shares.iter_mut().for_each(|x| *x = x.abs());
    shares.sort_by(f64::total_cmp);
    if shares.is_empty() {
        return 0.0;
    }
    let (body, upper) = (quantile(&shares, 0.5), quantile(&shares, 0.9));
    if upper == 0.0 {
        return n;
    }
    if body == 0.0 || upper.is_nan() {
        return 0.0;
    }
    let sigma = (upper / body).ln() / Z_90;
    n * (-sigma * sigma).exp()
}

/// The effective number of paths behind the L^p error of per-path errors `errors`
/// (`lognormal_effective_paths` of the shares (d_i / d_max)^p / m, m their mean): about n for
/// errors of one size, far fewer when a few heavy paths make up the mean of d^p. The error's
/// interval is indicative below [`INDICATIVE_BELOW`].
pub fn effective_paths(errors: &[f64], p: f64) -> f64 {
    let scale = largest(errors);
    if !(scale.is_finite() && scale > 0.0) {
        return errors.len() as f64;
    }
    let powered: Vec<f64> = errors.iter().map(|d| (d / scale).powf(p)).collect();
    let mean = powered.iter().sum::<f64>() / powered.len() as f64;
    lognormal_effective_paths(powered.iter().map(|x| x / mean).collect())
}

/// Below this many effective paths an order's interval is indicative: its coverage falls
/// short of 95% by more than a few points on heavy-tailed errors (docs/studies.md,
/// tests/integration/coverage.rs).
pub const INDICATIVE_BELOW: usize = 20;

/// The standard normal's 90% quantile.
const Z_90: f64 = 1.281_551_565_544_600_5;

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
    /// symmetric percentile-t interval from the paired bootstrap of the paths (the Monte Carlo error of
    /// the errors, not the regression residuals).
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
    /// The effective number of paths behind the order: n e^(-sigma^2), with sigma the
    /// log-normal spread of the paths' shares of the order's Monte Carlo error (read from the
    /// body of their law). Heavy-tailed errors whose heavy paths do not cancel between levels
    /// leave few effective paths of many.
    pub effective_paths: f64,
    /// The intervals are indicative only: fewer than [`INDICATIVE_BELOW`] effective paths, or
    /// a bootstrap with too few usable resamples (the delta-method t intervals stand in).
    pub indicative: bool,
}

/// Fits log(error) = c + order log(h) over the levels of one set of paths (any order of h).
/// Starting from all levels, the coarsest level is left out as pre-asymptotic while its local
/// slope disagrees with the slope of the remaining finer levels (beyond the delta-method Monte
/// Carlo error and by more than `tolerance`) and at least three levels remain. The intervals
/// of the order and of the local slopes are symmetric percentile-t intervals of the paired bootstrap of
/// the paths ([`paired_bootstrap`]). `None` without >= 2 paths, >= 2 levels and positive finite
/// errors at every level.
pub fn fit_order(data: PathErrors<'_>, tolerance: f64) -> Option<OrderFit> {
    fit_order_and_errors(data, tolerance).map(|(fit, _)| fit)
}

/// [`fit_order`], with the L^p error interval of every level (in the order of `data`) from the
/// same resamples: each is the one [`lp_error`] gives for that level, at the cost of one
/// bootstrap for all.
pub fn fit_order_and_errors(
    data: PathErrors<'_>, tolerance: f64,
) -> Option<(OrderFit, Vec<Interval>)> {
    let logs = LogErrors::new(data)?;
    let mut usable: Vec<usize> = (0..data.h.len()).collect();
    if usable.len() < 2 {
        return None;
    }
    // Coarse to fine.
    usable.sort_by(|&a, &b| data.h[b].total_cmp(&data.h[a]));
    let neighbours: Vec<(usize, usize)> = usable.windows(2).map(|w| (w[0], w[1])).collect();
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
    let functionals: Vec<Vec<(usize, f64)>> = std::iter::once(fitted)
        .chain(neighbours.iter().map(|&(a, b)| logs.local_weights(a, b)))
        .collect();
    let (bootstrapped, errors) = logs.bootstrap(&functionals);
    let effective_paths = logs.effective_paths(&functionals[0]);
    let indicative = bootstrapped.is_none() || effective_paths < INDICATIVE_BELOW as f64;
    let mut intervals = bootstrapped
        .unwrap_or_else(|| functionals.iter().map(|w| logs.interval(w)).collect())
        .into_iter();
    let order = intervals.next()?;
    let fit = OrderFit {
        order,
        fitted: usable,
        pre_asymptotic,
        local_slopes: neighbours
            .iter()
            .zip(intervals)
            .map(|(&(coarse, fine), slope)| LocalSlope {
                coarse,
                fine,
                slope,
            })
            .collect(),
        curvature,
        effective_paths,
        indicative,
    };
    Some((fit, errors))
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(fit.indicative, "10 paths are below {INDICATIVE_BELOW}");
    }

    /// Errors C h^q W_i V_ij with a path factor W_i shared by the levels and level noise V_ij
    /// (deterministic, spread like log-normals).
    fn noisy_power_law(paths: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
        let (h, mut errors) = power_law(0.5, paths);
        for (j, level) in errors.iter_mut().enumerate() {
            for (i, d) in level.iter_mut().enumerate() {
                *d *= (0.3 * (1.7 * (i * 7 + j * 13) as f64).sin()).exp();
            }
        }
        (h, errors)
    }

    #[test]
    fn the_fits_level_intervals_are_lp_errors_and_its_intervals_hold_the_estimates() {
        // The path factors 1..=n spread the paths' shares: 300 paths give about 54 effective
        // ones, 100 fewer than 20.
        for paths in [300, 1000] {
            let (h, errors) = noisy_power_law(paths);
            let data = PathErrors {
                h: &h,
                errors: &errors,
                p: 2.0,
            };
            let (fit, levels) = fit_order_and_errors(data, 0.05).unwrap();
            assert!(!fit.indicative, "{paths} paths: {}", fit.effective_paths);
            for (e, d) in levels.iter().zip(&errors) {
                let alone = lp_error(d, 2.0).unwrap();
                for (a, b) in [
                    (e.estimate, alone.estimate),
                    (e.ci_low, alone.ci_low),
                    (e.ci_high, alone.ci_high),
                ] {
                    assert!((a - b).abs() <= 1e-12 * b, "{e:?} against {alone:?}");
                }
            }
            let slopes = fit.local_slopes.iter().map(|l| l.slope);
            for i in std::iter::once(fit.order).chain(slopes) {
                assert!(i.ci_low < i.estimate && i.estimate < i.ci_high, "{i:?}");
            }
        }
    }

    #[test]
    fn lp_estimate_is_lp_errors_estimate_bit_for_bit() {
        let spread: Vec<f64> = (1..=37)
            .map(|i| (0.3 * i as f64).sin().abs() * 1e-3)
            .collect();
        let cases: [(&[f64], f64); 6] = [
            (&spread, 2.0),
            (&spread, 1.0),
            (&spread, 400.0),
            (&[0.2; 10], 2.0),
            (&[0.0, 0.0, 0.0], 2.0),
            (&[1.0, f64::INFINITY], 2.0),
        ];
        for (errors, p) in cases {
            let full = lp_error(errors, p).unwrap().estimate;
            let alone = lp_estimate(errors, p).unwrap();
            assert_eq!(full.to_bits(), alone.to_bits(), "{errors:?} at p = {p}");
        }
        assert_eq!(lp_estimate(&[0.1], 2.0), None);
        assert_eq!(lp_estimate(&spread, 0.5), None);
        assert!(lp_estimate(&[1.0, f64::NAN], 2.0).unwrap().is_nan());
    }

    #[test]
    fn lp_error_of_constant_errors_is_exact() {
        let e = lp_error(&[0.2; 10], 2.0).unwrap();
        assert!((e.estimate - 0.2).abs() < 1e-15);
        assert!((e.ci_low - 0.2).abs() < 1e-15 && (e.ci_high - 0.2).abs() < 1e-15);
        assert!(lp_error(&[0.2], 2.0).is_none());
        assert!(mean_interval(&[1.0]).is_none());
        let zero = lp_error(&[0.0; 4], 2.0).unwrap();
        assert_eq!((zero.estimate, zero.ci_low, zero.ci_high), (0.0, 0.0, 0.0));
    }

    #[test]
    fn large_p_and_tiny_errors_do_not_underflow() {
        // d^400 underflows to 0 for every d below 0.17: the unscaled mean of d^p was 0.
        let p = 400.0;
        let tiny: Vec<f64> = (1..=20).map(|i| 1e-3 * (1.0 + 0.01 * i as f64)).collect();
        let e = lp_error(&tiny, p).unwrap();
        // (mean d^p)^(1/p) = d_max (mean (d / d_max)^p)^(1/p).
        let scaled: f64 = tiny.iter().map(|d| (d / 1.2e-3).powf(p)).sum::<f64>() / 20.0;
        let expected = 1.2e-3 * scaled.powf(1.0 / p);
        assert!(
            (e.estimate - expected).abs() <= 1e-13 * expected,
            "{e:?} against {expected}"
        );
        assert!(e.ci_low > 0.0 && e.ci_low <= e.estimate && e.estimate <= e.ci_high);
        // p = 400 takes the sample's norm close to its largest error.
        assert!(e.ci_high.is_finite() && e.estimate > 1.18e-3, "{e:?}");
        // Errors of 1e-200 at p = 2 (d^2 underflows) and an exact power law at p = 400.
        let e = lp_error(&[1e-200, 2e-200, 3e-200], 2.0).unwrap();
        let expected = 1e-200 * (14.0f64 / 3.0).sqrt();
        assert!((e.estimate - expected).abs() <= 1e-14 * expected, "{e:?}");
        let (h, mut errors) = power_law(0.75, 10);
        errors.iter_mut().flatten().for_each(|d| *d *= 1e-3);
        let data = PathErrors {
            h: &h,
            errors: &errors,
            p,
        };
        let fit = fit_order(data, 0.05).unwrap();
        assert!((fit.order.estimate - 0.75).abs() < 1e-12, "{fit:?}");
    }
}
