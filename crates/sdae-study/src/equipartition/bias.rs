//! The invariant-measure bias of each scheme: a time average at equilibrium (a configurational
//! average, or the kinetic energy) against its exact value, per step size and per second of
//! run time, with the bias order fitted from the differences between consecutive step sizes on
//! the same Brownian paths.
//!
//! With X_h the per-path time average at step h and b(h) = E[X_h] - x* ~ C h^p, the paired
//! differences D(h) = E[X_h - X_(h/2)] = C (1 - 2^-p) h^p have the slope p in log-log, and on
//! the same Brownian path they are measured with a smaller variance than the biases
//! themselves. The order is the least-squares slope of log |D(h)| over the differences whose
//! 95% interval excludes 0 (at least two, of one sign), with a 95% percentile interval from the
//! paired bootstrap over paths ([`paired_bootstrap`]).

use serde::Serialize;

use crate::convergence::ConvergenceRun;
use crate::lockstep::TrackOutcome;
use sdae_stats::Interval;
use sdae_stats::bootstrap::{BOOTSTRAP_RESAMPLES, PathTable, paired_bootstrap, quantile};
use sdae_stats::mean_interval;

/// The biases whose cheapest run time the report gives.
pub const BIAS_TARGETS: [f64; 2] = [1e-2, 1e-3];

/// Where the value the biases are measured against comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReferenceKind {
    /// A closed form ([`SystemSpec::exact_average`](crate::scene::SystemSpec::exact_average), or the equipartition value).
    ClosedForm,
    /// The estimate of g-baoab at its smallest step (no closed form is known).
    FinestGBaoab,
}

/// One step size of one scheme.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BiasLevel {
    /// Step size h.
    pub h: f64,
    /// The mean over the finished paths of the time average, with its 95% interval.
    pub value: Option<Interval>,
    /// value - reference.
    pub bias: Option<Interval>,
    /// E[X_h - X_(h/2)] over the paths that finished both, with its 95% interval (`None` at
    /// the smallest step).
    pub difference: Option<Interval>,
    /// Mean wall-clock seconds per path for the whole run of length T.
    pub seconds: f64,
    /// Paths that finished.
    pub paths: usize,
}

/// The cheapest measured step size whose bias interval lies within +-target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeToBias {
    /// The target |bias|.
    pub target: f64,
    /// The step size, if one reached the target.
    pub h: Option<f64>,
    /// Its seconds per path.
    pub seconds: Option<f64>,
    /// Whether the sample can tell: false when no step size reached the target and even the
    /// narrowest bias interval is wider than 2 x target (more paths are needed).
    pub resolved: bool,
}

/// One scheme's biases.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BiasScheme {
    /// The scheme (with C_eta for the half-explicit family).
    pub scheme: String,
    /// Per step size, largest first.
    pub levels: Vec<BiasLevel>,
    /// The fitted order p of the bias with its 95% bootstrap interval, where at least two
    /// differences are resolved.
    pub order: Option<Interval>,
    /// The step sizes whose differences the order was fitted on.
    pub fitted: Vec<f64>,
    /// For each of [`BIAS_TARGETS`], the cheapest step size that reached it.
    pub time_to: Vec<TimeToBias>,
}

/// The biases of every scheme for one time average.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BiasStudy {
    /// The time average ("kinetic_energy" or a configurational observable).
    pub quantity: String,
    /// The value biases are measured against.
    pub reference: f64,
    /// Where it comes from.
    pub reference_kind: ReferenceKind,
    /// One entry per scheme of the runs.
    pub schemes: Vec<BiasScheme>,
}

/// Which per-path time average of a track a study reads.
pub type Quantity = fn(&TrackOutcome) -> Option<f64>;

/// The biases of `quantity` in every scheme of `runs` (labelled by `label(run, scheme)`)
/// against `reference`, or, without one, against g-baoab's value at its smallest step
/// (`None` if neither exists).
pub fn bias_study(
    runs: &[ConvergenceRun], name: &str, quantity: Quantity, reference: Option<f64>,
    label: impl Fn(&ConvergenceRun, &str) -> String,
) -> Option<BiasStudy> {
    let mut schemes: Vec<BiasScheme> = runs
        .iter()
        .flat_map(|run| {
            let label = &label;
            run.schemes
                .iter()
                .enumerate()
                .map(move |(s, name)| scheme_levels(run, s, label(run, name), quantity))
        })
        .collect();
    let (reference, reference_kind) = match reference {
        Some(x) => (x, ReferenceKind::ClosedForm),
        None => {
            let finest = schemes
                .iter()
                .find(|s| s.scheme == "g-baoab")
                .and_then(|s| s.levels.last())
                .and_then(|l| l.value)?;
            (finest.estimate, ReferenceKind::FinestGBaoab)
        }
    };
    for scheme in &mut schemes {
        for level in &mut scheme.levels {
            level.bias = level.value.map(|v| Interval {
                estimate: v.estimate - reference,
                ci_low: v.ci_low - reference,
                ci_high: v.ci_high - reference,
            });
        }
        scheme.time_to = BIAS_TARGETS
            .iter()
            .map(|&target| cheapest(&scheme.levels, target))
            .collect();
    }
    Some(BiasStudy {
        quantity: name.to_string(),
        reference,
        reference_kind,
        schemes,
    })
}

/// Scheme `s` of `run`: its levels' values and differences and the fitted order (biases and
/// times are filled in once the reference is known).
fn scheme_levels(run: &ConvergenceRun, s: usize, scheme: String, quantity: Quantity) -> BiasScheme {
    let levels = run.settings.levels();
    let count = levels.len();
    let value = |record: &crate::lockstep::PathRecord, j: usize| {
        record
            .tracks
            .get(s * count + j)
            .filter(|t| t.failure.is_none())
            .and_then(quantity)
    };
    let h = |j: usize| run.settings.t_end / (1u64 << levels[j]) as f64;
    let mut out = Vec::with_capacity(count);
    for j in 0..count {
        let values: Vec<f64> = run.records.iter().filter_map(|r| value(r, j)).collect();
        let seconds: Vec<f64> = run
            .records
            .iter()
            .filter_map(|r| r.tracks.get(s * count + j).map(|t| t.seconds))
            .collect();
        let differences: Vec<f64> = run
            .records
            .iter()
            .filter_map(|r| Some(value(r, j)? - value(r, j + 1)?))
            .collect();
        out.push(BiasLevel {
            h: h(j),
            value: mean_interval(&values),
            bias: None,
            difference: (j + 1 < count)
                .then(|| mean_interval(&differences))
                .flatten(),
            seconds: seconds.iter().sum::<f64>() / seconds.len().max(1) as f64,
            paths: values.len(),
        });
    }
    // Paths that finished every level, for the paired bootstrap of the order.
    let table_rows: Vec<Vec<f64>> = run
        .records
        .iter()
        .filter_map(|r| (0..count).map(|j| value(r, j)).collect())
        .collect();
    let (order, fitted) = fit_order(&out, &table_rows);
    BiasScheme {
        scheme,
        levels: out,
        order,
        fitted,
        time_to: Vec::new(),
    }
}

/// The slope of log |D| against log h over the resolved differences (95% interval excluding
/// 0, all of one sign, at least two), with its paired-bootstrap interval over `rows` (each
/// path's values at every level).
fn fit_order(levels: &[BiasLevel], rows: &[Vec<f64>]) -> (Option<Interval>, Vec<f64>) {
    let resolved: Vec<usize> = (0..levels.len())
        .filter(|&j| {
            levels[j]
                .difference
                .is_some_and(|d| d.ci_low > 0.0 || d.ci_high < 0.0)
        })
        .collect();
    let signs = resolved
        .iter()
        .filter(|&&j| levels[j].difference.is_some_and(|d| d.estimate > 0.0))
        .count();
    if resolved.len() < 2 || (signs != 0 && signs != resolved.len()) {
        return (None, Vec::new());
    }
    let log_h: Vec<f64> = resolved.iter().map(|&j| levels[j].h.ln()).collect();
    let slope_of = |means: &[f64]| -> Option<f64> {
        let log_d: Vec<f64> = resolved
            .iter()
            .map(|&j| (means[j] - means[j + 1]).abs().ln())
            .collect();
        slope(&log_h, &log_d).filter(|p| p.is_finite())
    };
    let width = levels.len();
    let table = PathTable::from_rows(rows.len(), width, |i, row| row.copy_from_slice(&rows[i]));
    let n = rows.len() as f64;
    let means = |sums: &[f64]| sums.iter().map(|s| s / n).collect::<Vec<_>>();
    let full: Vec<f64> = (0..width)
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>())
        .collect();
    let Some(estimate) = slope_of(&means(&full)) else {
        return (None, Vec::new());
    };
    let mut slopes = paired_bootstrap(&table, BOOTSTRAP_RESAMPLES, |sums| slope_of(&means(sums)));
    if slopes.len() < BOOTSTRAP_RESAMPLES / 2 {
        return (None, Vec::new());
    }
    slopes.sort_by(f64::total_cmp);
    let order = Interval {
        estimate,
        ci_low: quantile(&slopes, 0.025),
        ci_high: quantile(&slopes, 0.975),
    };
    (Some(order), resolved.iter().map(|&j| levels[j].h).collect())
}

/// The least-squares slope of y against x (`None` for fewer than two distinct x).
fn slope(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The cheapest level whose bias interval lies within +-target.
fn cheapest(levels: &[BiasLevel], target: f64) -> TimeToBias {
    let best = levels
        .iter()
        .filter(|l| {
            l.bias
                .is_some_and(|b| b.ci_low >= -target && b.ci_high <= target)
        })
        .min_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let narrowest = levels
        .iter()
        .filter_map(|l| l.bias.map(|b| b.ci_high - b.ci_low))
        .fold(f64::INFINITY, f64::min);
    TimeToBias {
        target,
        h: best.map(|l| l.h),
        seconds: best.map(|l| l.seconds),
        resolved: best.is_some() || narrowest <= 2.0 * target,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(h: f64, value: f64, difference: Option<f64>) -> BiasLevel {
        let interval = |x: f64| Interval {
            estimate: x,
            ci_low: x - 1e-6,
            ci_high: x + 1e-6,
        };
        BiasLevel {
            h,
            value: Some(interval(value)),
            bias: None,
            difference: difference.map(interval),
            seconds: 1.0 / h,
            paths: 3,
        }
    }

    /// Values x_h = 1 + 0.3 h^2 (+ a path's own offset, common to its levels) give the order 2
    /// with a tight interval.
    #[test]
    fn the_order_of_a_quadratic_bias_is_two() {
        let hs = [0.4, 0.2, 0.1, 0.05];
        let value = |h: f64| 1.0 + 0.3 * h * h;
        let rows: Vec<Vec<f64>> = (0..50)
            .map(|p| {
                let offset = 1e-3 * ((p * 37 % 11) as f64 - 5.0);
                hs.iter().map(|&h| value(h) + offset).collect()
            })
            .collect();
        let levels: Vec<BiasLevel> = hs
            .iter()
            .enumerate()
            .map(|(j, &h)| level(h, value(h), hs.get(j + 1).map(|&f| value(h) - value(f))))
            .collect();
        let (order, fitted) = fit_order(&levels, &rows);
        let order = order.unwrap();
        assert!((order.estimate - 2.0).abs() < 1e-9, "{order:?}");
        assert!(order.ci_low > 1.99 && order.ci_high < 2.01, "{order:?}");
        assert_eq!(fitted, vec![0.4, 0.2, 0.1]);
    }

    #[test]
    fn the_cheapest_level_within_the_target_is_chosen() {
        let mut levels = vec![
            level(0.4, 0.0, None),
            level(0.2, 0.0, None),
            level(0.1, 0.0, None),
        ];
        for (l, b) in levels.iter_mut().zip([0.05, 0.005, 0.0004]) {
            l.bias = Some(Interval {
                estimate: b,
                ci_low: b - 1e-4,
                ci_high: b + 1e-4,
            });
        }
        let t = cheapest(&levels, 1e-2);
        assert_eq!((t.h, t.seconds), (Some(0.2), Some(5.0)));
        assert_eq!(cheapest(&levels, 1e-3).h, Some(0.1));
        let beyond = cheapest(&levels, 1e-5);
        assert_eq!((beyond.h, beyond.resolved), (None, false));
        // Narrow intervals away from 0: resolved, not reached.
        for l in &mut levels {
            l.bias = Some(Interval {
                estimate: 0.5,
                ci_low: 0.5 - 1e-6,
                ci_high: 0.5 + 1e-6,
            });
        }
        assert!(cheapest(&levels, 1e-3).resolved);
    }
}
