//! The weak-error study: E[f(X_N)] of every scheme at every step size for the scene's
//! observables f, its error against the exact E[f(X_T)] where the scene gives it and otherwise
//! against the fine reference on the same Brownian paths, weak orders, Richardson-Romberg
//! extrapolation and run time.
//!
//! The paths are those of the convergence study ([`run_observed_on`]): every scheme, every level
//! and the reference driven by one Brownian path each, the observables evaluated at the grid
//! points of the coarsest level. Against the reference the weak error e_N = E[f(X_N) - f(X_ref)]
//! is estimated from the per-path differences, whose variance is that of the strong error (the
//! paths are coupled), not that of f: this is what makes errors of 1e-3 measurable with 1e4
//! paths.
//!
//! - final-time error: e_N = mean_i (f(X_N^i) - b_i), b_i the exact value or f(X_ref^i), with
//!   its t interval;
//! - largest error over the grid: max_k |mean_i (f(X_N^i(t_k)) - f(X_ref^i(t_k)))| over the
//!   points t_k = k T / 2^A of the coarsest level A (the grid every level shares), against the
//!   reference (exact values are given at T only);
//! - Richardson-Romberg (Talay and Tubaro): 2 E[f(X_(h/2))] - E[f(X_h)] from levels j - 1 and j
//!   on the same paths, per path 2 d_j - d_(j-1), one more row per scheme (labelled with the
//!   finer N, its run time the sum of both levels');
//! - orders: the least-squares slope of log |e_N| against log h over the levels whose error is
//!   resolved (|e_N| above the half-width of its interval), with a bootstrap interval over
//!   whole paths ([`bootstrap::path_bootstrap`]); the unresolved levels are named.

pub mod bootstrap;
pub mod report;

use rayon::prelude::*;
use serde::Serialize;

use crate::convergence::{
    ConvergenceRun, ConvergenceSettings, ReferenceReport, common_paths, run_observed_on,
};
use crate::error::StudyError;
use crate::integrator::StudyScheme;
use crate::lockstep::PathRecord;
use crate::observable::Observable;
use crate::parallel::{Control, Skipped};
use crate::scene::{Prepared, Scene};
use crate::stats::{Interval, mean_interval};

/// The weak study's settings of a scene with a `[weak]` table: the convergence settings with
/// the table's observables, its paths (default 10000), levels (default 2..7) and reference
/// (default 4 levels above the finest); with `quick`, at most 2000 paths, four levels and a
/// reference 3 levels above the finest. `None` without a `[weak]` table.
pub fn weak_settings(scene: &Scene, quick: bool) -> Option<ConvergenceSettings> {
    let weak = scene.weak.as_ref()?;
    let [coarsest, mut finest] = weak.levels.unwrap_or([2, 7]);
    let mut paths = weak.paths.unwrap_or(10_000);
    let mut reference = weak.reference.unwrap_or(finest + 4);
    if quick {
        paths = paths.min(2000);
        finest = finest.min(coarsest + 3);
        reference = finest + 3;
    }
    Some(ConvergenceSettings {
        paths,
        coarsest,
        finest,
        reference: Some(reference),
        observables: weak.observables.clone(),
        ..ConvergenceSettings::for_scene(scene)
    })
}

/// The weak study of any system (as [`run_observed_on`]): the built-in schemes of `settings` and
/// the user's `extra` schemes, the `observables` (built-in ones from
/// [`built_in_all`](crate::observable::built_in_all), a user's closures, or both) evaluated on
/// every path. Needs a reference (`settings.reference`); the paths of shard `index` of `count`,
/// steered by `control`. [`build_weak_report`] turns the run into the report.
pub fn run_weak_on<S>(
    scene: &Scene, prepared: &Prepared<S>, extra: &[StudyScheme<S>], observables: &[Observable],
    settings: &ConvergenceSettings, shard: (usize, usize), control: Control<'_>,
) -> Result<ConvergenceRun, StudyError>
where
    S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
{
    check_weak(settings, observables.len())?;
    run_observed_on(
        scene,
        prepared,
        extra,
        observables,
        settings,
        shard,
        control,
    )
}

/// The weak study needs observables and a reference.
fn check_weak(settings: &ConvergenceSettings, observables: usize) -> Result<(), StudyError> {
    let bad = |key: &'static str, value: String, rule: &str| {
        Err(StudyError::Setting {
            key,
            value,
            rule: rule.into(),
        })
    };
    if observables == 0 {
        return bad("weak.observables", "[]".into(), "names no observable");
    }
    if settings.reference.is_none() {
        return bad("study.reference", "none".into(), "the weak study needs one");
    }
    Ok(())
}

/// E[cos(phi_T - phi_0)] of a unit point mass on a circle of radius rho with friction gamma > 0,
/// no gravity and isotropic additive planar noise sigma dW (the `rotor` scene), started with
/// angular velocity `omega0`.
///
/// Derivation. With r = rho (cos phi, sin phi), the unit tangent t = (-sin phi, cos phi) and
/// v = rho omega t, the inherent SDE dv = (-gamma v + lambda n) dt + P(r) sigma dW (the
/// constraint force lambda n and the projection P = I - n n^T act along and across the normal
/// n) gives, on taking the tangential component (t . dv = rho d omega, since
/// d t = -omega n dt is normal and of finite variation):
/// rho d omega = -gamma rho omega dt + sigma t . dW. As t is adapted and |t| = 1,
/// W_t = int t . dW is a scalar Brownian motion (Levy), and r has finite variation, so the
/// projected noise has no Ito correction: omega is the Ornstein-Uhlenbeck process
/// d omega = -gamma omega dt + (sigma / rho) dW_t. Then phi_T - phi_0 = int_0^T omega dt is
/// Gaussian with
/// mean = omega0 (1 - e^(-gamma T)) / gamma and
/// var = (sigma / rho)^2 / gamma^2 [T - 2 (1 - e^(-gamma T)) / gamma + (1 - e^(-2 gamma T)) / (2 gamma)]
/// (the variance of int_0^T int_0^t e^(-gamma (t - s)) dW_s dt), and
/// E[cos(phi_T - phi_0)] = exp(-var / 2) cos(mean).
pub fn circle_cos_turn(omega0: f64, gamma: f64, sigma_over_rho: f64, t_end: f64) -> f64 {
    let decay = 1.0 - (-gamma * t_end).exp();
    let mean = omega0 * decay / gamma;
    let var = sigma_over_rho.powi(2) / (gamma * gamma)
        * (t_end - 2.0 * decay / gamma + (1.0 - (-2.0 * gamma * t_end).exp()) / (2.0 * gamma));
    (-0.5 * var).exp() * mean.cos()
}

/// What a weak error is measured against.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Basis {
    /// The exact E[f(X_T)] the scene gives.
    Exact(#[serde(with = "crate::real")] f64),
    /// E[f(X_ref)] of the reference on the same paths (per-path differences).
    Reference,
}

/// A fitted weak order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakOrder {
    /// Least-squares slope of log |e| against log h over the fitted levels, with its 95%
    /// bootstrap interval over whole paths.
    pub order: Interval,
    /// Indices of the levels fitted (those whose error is resolved).
    pub fitted: Vec<usize>,
    /// Indices of the levels whose error is not resolved: |e| within the half-width of its
    /// Monte Carlo interval.
    pub unresolved: Vec<usize>,
}

/// One scheme (or its extrapolation) at one step size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakLevel {
    /// N (the finer level's for an extrapolated row).
    pub n_steps: usize,
    /// h = T / N.
    #[serde(with = "crate::real")]
    pub h: f64,
    /// E[f(X_N)] (for an extrapolated row 2 E[f(X_N)] - E[f(X_(N/2))]) with its 95% t interval.
    pub value: Interval,
    /// The final-time weak error against the basis, with its 95% t interval.
    pub error: Interval,
    /// |error| exceeds the half-width of its interval.
    pub resolved: bool,
    /// The largest |error| over the coarsest level's grid against the reference, with its 95%
    /// bootstrap interval.
    pub sup_error: Option<Interval>,
    /// Mean wall-clock seconds of stepping per path (both levels' for an extrapolated row).
    #[serde(with = "crate::real")]
    pub seconds_per_path: f64,
}

/// One scheme, or its Richardson-Romberg extrapolation, for one observable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakScheme {
    /// The scheme's name (with " + richardson" for the extrapolation).
    pub name: String,
    /// Whether the row is the Richardson-Romberg extrapolation of the scheme.
    pub extrapolated: bool,
    /// Paths compared: those that finished every level of the scheme and whose reference
    /// finished.
    pub paths: usize,
    /// Levels, coarse to fine.
    pub levels: Vec<WeakLevel>,
    /// The order of the final-time error.
    pub order: Option<WeakOrder>,
    /// The order of the largest error over the grid.
    pub sup_order: Option<WeakOrder>,
}

/// The study of one observable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservableReport {
    /// The observable's name.
    pub name: String,
    /// What the final-time errors are measured against.
    pub basis: Basis,
    /// E[f(X_ref)] over the paths whose reference finished, with its 95% t interval.
    pub reference_value: Option<Interval>,
    /// Every scheme, each followed by its extrapolation.
    pub schemes: Vec<WeakScheme>,
}

/// The report of a weak-error study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakReport {
    /// The scene's name.
    pub scene: String,
    /// Seed of the path streams.
    pub seed: u64,
    /// Monte Carlo paths.
    pub paths: usize,
    /// Final time.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// All settings.
    pub settings: ConvergenceSettings,
    /// The times of the grid the largest error is taken over (the coarsest level's).
    pub grid: Vec<f64>,
    /// The reference.
    pub reference: ReferenceReport,
    /// One study per observable.
    pub observables: Vec<ObservableReport>,
    /// Schemes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// The scene as run.
    pub scene_definition: Scene,
}

impl WeakReport {
    /// What could not be compared, one sentence each: the reference when it failed on every
    /// path, and each scheme none of whose paths finished every level.
    pub fn uncompared(&self) -> Vec<String> {
        if self.reference.failures >= self.paths {
            return vec![format!(
                "the reference ({}) failed on all {} paths: no weak error could be measured",
                self.reference.scheme, self.paths
            )];
        }
        let Some(first) = self.observables.first() else {
            return Vec::new();
        };
        first
            .schemes
            .iter()
            .filter(|row| !row.extrapolated && row.paths == 0)
            .map(|row| format!("{}: no path finished every level", row.name))
            .collect()
    }
}

/// Per-path differences of one scheme (or extrapolation) at every level: `last[j][i]`, path i's
/// f(X_N(T)) minus the basis at level j, and `grid[j][k][i]`, its f(X_N(t_k)) - f(X_ref(t_k))
/// at the shared grid points (k = last is T).
#[derive(Debug, Clone, Default)]
pub struct LevelPaths {
    /// Step sizes, coarse to fine.
    pub h: Vec<f64>,
    /// Final-time differences against the basis.
    pub last: Vec<Vec<f64>>,
    /// Differences against the reference at the grid points.
    pub grid: Vec<Vec<Vec<f64>>>,
}

impl LevelPaths {
    /// The Richardson-Romberg combination of neighbouring levels: per path 2 d_j - d_(j-1), at
    /// the finer step sizes.
    pub fn extrapolated(&self) -> LevelPaths {
        let combine = |a: &[f64], b: &[f64]| -> Vec<f64> {
            a.iter().zip(b).map(|(c, f)| 2.0 * f - c).collect()
        };
        LevelPaths {
            h: self.h[1..].to_vec(),
            last: self
                .last
                .windows(2)
                .map(|w| combine(&w[0], &w[1]))
                .collect(),
            grid: self
                .grid
                .windows(2)
                .map(|w| w[0].iter().zip(&w[1]).map(|(c, f)| combine(c, f)).collect())
                .collect(),
        }
    }
}

/// The mean of `values` over the paths `indices`.
fn mean_over(values: &[f64], indices: &[usize]) -> f64 {
    indices.iter().map(|&i| values[i]).sum::<f64>() / indices.len() as f64
}

/// The least-squares slope of log |e_j| against log h_j over `levels` (NaN with fewer than 2).
fn log_slope(h: &[f64], e: &[f64], levels: &[usize]) -> f64 {
    if levels.len() < 2 {
        return f64::NAN;
    }
    let x: Vec<f64> = levels.iter().map(|&j| h[j].ln()).collect();
    let y: Vec<f64> = levels.iter().map(|&j| e[j].abs().ln()).collect();
    let mx = x.iter().sum::<f64>() / x.len() as f64;
    let my = y.iter().sum::<f64>() / y.len() as f64;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Whether an error's interval excludes 0 by its half-width: |estimate| > (high - low) / 2.
fn resolved(e: &Interval) -> bool {
    e.estimate.abs() > 0.5 * (e.ci_high - e.ci_low)
}

/// The largest |mean| over the grid points of one level, and whether it is resolved (its
/// |mean| above the half-width of its t interval at that point).
fn sup_over_grid(grid: &[Vec<f64>]) -> Option<(usize, bool)> {
    let intervals: Vec<Interval> = grid
        .iter()
        .map(|g| mean_interval(g))
        .collect::<Option<_>>()?;
    let (k, at) = intervals
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.estimate.abs().total_cmp(&b.1.estimate.abs()))?;
    Some((k, resolved(at)))
}

/// The final-time errors, their resolution, the grid's largest errors and the two orders of
/// one set of per-path differences.
struct Analysis {
    errors: Vec<Interval>,
    sup_errors: Vec<Option<Interval>>,
    order: Option<WeakOrder>,
    sup_order: Option<WeakOrder>,
}

/// The weak order of the final-time errors of per-path differences `diffs[j][i]` (path i at the
/// level of step size `h[j]`, against an exact value or the reference on the same paths):
/// fitted over the resolved levels, with a 95% bootstrap interval over whole paths. `None`
/// without 2 paths or 2 resolved levels.
pub fn weak_order(h: &[f64], diffs: &[Vec<f64>]) -> Option<WeakOrder> {
    analyse(&LevelPaths {
        h: h.to_vec(),
        last: diffs.to_vec(),
        grid: Vec::new(),
    })
    .and_then(|a| a.order)
}

/// Errors and orders of `data`: t intervals of the final-time errors, bootstrap intervals of
/// the grid's largest errors and of both orders (one bootstrap over paths for all of them).
/// `None` with fewer than 2 paths.
fn analyse(data: &LevelPaths) -> Option<Analysis> {
    let errors: Vec<Interval> = data
        .last
        .iter()
        .map(|d| mean_interval(d))
        .collect::<Option<_>>()?;
    let paths = data.last.first().map_or(0, Vec::len);
    let levels = data.h.len();
    let split = |ok: &dyn Fn(usize) -> bool| -> (Vec<usize>, Vec<usize>) {
        (0..levels).partition(|&j| ok(j))
    };
    let (fitted, unresolved) = split(&|j| resolved(&errors[j]));
    let sup: Vec<Option<(usize, bool)>> = data.grid.iter().map(|g| sup_over_grid(g)).collect();
    let (sup_fitted, sup_unresolved) =
        split(&|j| sup.get(j).copied().flatten().is_some_and(|s| s.1));
    let has_grid = data.grid.len() == levels && levels > 0;
    // [sup error per level (if a grid), order, sup order].
    let statistic = |indices: &[usize]| -> Vec<f64> {
        let last: Vec<f64> = data.last.iter().map(|d| mean_over(d, indices)).collect();
        let mut out = Vec::with_capacity(levels + 2);
        let mut sups = Vec::new();
        if has_grid {
            sups = data
                .grid
                .iter()
                .map(|g| {
                    g.iter()
                        .map(|d| mean_over(d, indices).abs())
                        .fold(0.0, f64::max)
                })
                .collect();
            out.extend(&sups);
        }
        out.push(log_slope(&data.h, &last, &fitted));
        out.push(if has_grid {
            log_slope(&data.h, &sups, &sup_fitted)
        } else {
            f64::NAN
        });
        out
    };
    let mut intervals = bootstrap::path_bootstrap(paths, statistic);
    let sup_order_interval = intervals.pop().flatten();
    let order_interval = intervals.pop().flatten();
    let order = |interval: Option<Interval>, fitted: Vec<usize>, unresolved: Vec<usize>| {
        interval
            .filter(|_| fitted.len() >= 2)
            .map(|order| WeakOrder {
                order,
                fitted,
                unresolved,
            })
    };
    let sup_errors = if has_grid {
        intervals
    } else {
        vec![None; levels]
    };
    Some(Analysis {
        errors,
        sup_errors,
        order: order(order_interval, fitted, unresolved),
        sup_order: order(sup_order_interval, sup_fitted, sup_unresolved),
    })
}

/// Where an observable's values sit in a path's `observed` values.
#[derive(Clone, Copy)]
struct Layout {
    /// Observables.
    count: usize,
    /// Grid points.
    points: usize,
}

impl Layout {
    /// Observable o at grid point k.
    fn at(self, k: usize, o: usize) -> usize {
        k * self.count + o
    }
}

/// A row's levels and orders.
type RowParts = (Vec<WeakLevel>, Option<WeakOrder>, Option<WeakOrder>);

/// The levels and orders of one row from its per-path differences, values and run times.
fn rows_of(
    data: &LevelPaths, values: &[Vec<f64>], seconds: &[f64], h: &[f64],
    settings: &ConvergenceSettings,
) -> RowParts {
    let Some(analysis) = analyse(data) else {
        return (Vec::new(), None, None);
    };
    let levels = analysis
        .errors
        .iter()
        .zip(&analysis.sup_errors)
        .enumerate()
        .filter_map(|(j, (error, sup))| {
            Some(WeakLevel {
                n_steps: (settings.t_end / h[j]).round() as usize,
                h: h[j],
                value: mean_interval(&values[j])?,
                error: *error,
                resolved: resolved(error),
                sup_error: *sup,
                seconds_per_path: seconds[j],
            })
        })
        .collect();
    (levels, analysis.order, analysis.sup_order)
}

/// What the weak report's tables are computed from.
struct WeakInputs<'a> {
    /// The run's settings.
    settings: &'a ConvergenceSettings,
    /// The paths whose reference finished, by index.
    good: &'a [&'a PathRecord],
    /// The schemes that ran, in the order of the records' tracks.
    schemes: &'a [String],
    /// Per observable, what its errors are measured against.
    bases: Vec<Basis>,
    /// Where the observables sit in a path's values.
    layout: Layout,
}

impl WeakInputs<'_> {
    /// The rows of every observable and scheme (observable-major), on the settings' threads.
    fn rows(&self) -> Vec<Vec<WeakScheme>> {
        let jobs: Vec<(usize, usize)> = (0..self.layout.count)
            .flat_map(|o| (0..self.schemes.len()).map(move |s| (o, s)))
            .collect();
        let rows = |&(o, s): &(usize, usize)| self.scheme_rows(s, o);
        let on_threads = rayon::ThreadPoolBuilder::new()
            .num_threads(self.settings.threads.max(1))
            .build();
        match on_threads {
            Ok(pool) => pool.install(|| jobs.par_iter().map(rows).collect()),
            Err(_) => jobs.iter().map(rows).collect(),
        }
    }

    /// Scheme `s`'s report rows (the scheme and its extrapolation) for observable `o`.
    fn scheme_rows(&self, s: usize, o: usize) -> Vec<WeakScheme> {
        let (name, basis, layout) = (&self.schemes[s], self.bases[o], self.layout);
        let (good, settings) = (self.good, self.settings);
        let levels = settings.levels();
        let count = levels.len();
        let paths = common_paths(good, s, count);
        let h: Vec<f64> = levels
            .iter()
            .map(|&k| settings.t_end / (1u64 << k) as f64)
            .collect();
        let last_point = layout.points - 1;
        let value_at =
            |p: &PathRecord, j: usize, k: usize| p.tracks[s * count + j].observed[layout.at(k, o)];
        let reference_at = |p: &PathRecord, k: usize| p.reference_observed[layout.at(k, o)];
        let base = |p: &PathRecord| match basis {
            Basis::Exact(x) => x,
            Basis::Reference => reference_at(p, last_point),
        };
        let data = LevelPaths {
            h: h.clone(),
            last: (0..count)
                .map(|j| {
                    paths
                        .iter()
                        .map(|p| value_at(p, j, last_point) - base(p))
                        .collect()
                })
                .collect(),
            grid: (0..count)
                .map(|j| {
                    (0..layout.points)
                        .map(|k| {
                            paths
                                .iter()
                                .map(|p| value_at(p, j, k) - reference_at(p, k))
                                .collect()
                        })
                        .collect()
                })
                .collect(),
        };
        let values: Vec<Vec<f64>> = (0..count)
            .map(|j| paths.iter().map(|p| value_at(p, j, last_point)).collect())
            .collect();
        let seconds: Vec<f64> = (0..count)
            .map(|j| {
                paths
                    .iter()
                    .map(|p| p.tracks[s * count + j].seconds)
                    .sum::<f64>()
                    / paths.len().max(1) as f64
            })
            .collect();
        let plain = rows_of(&data, &values, &seconds, &h, settings);
        let combined: Vec<Vec<f64>> = values
            .windows(2)
            .map(|w| w[0].iter().zip(&w[1]).map(|(c, f)| 2.0 * f - c).collect())
            .collect();
        let both: Vec<f64> = seconds.windows(2).map(|w| w[0] + w[1]).collect();
        let extrapolated = rows_of(&data.extrapolated(), &combined, &both, &h[1..], settings);
        let row = |(levels, order, sup_order): RowParts, extrapolated: bool| WeakScheme {
            name: if extrapolated {
                format!("{name} + richardson")
            } else {
                name.to_string()
            },
            extrapolated,
            paths: paths.len(),
            levels,
            order,
            sup_order,
        };
        vec![row(plain, false), row(extrapolated, true)]
    }

    /// One report per observable: the reference's value at T and the rows of every scheme.
    fn observables(&self) -> Vec<ObservableReport> {
        let layout = self.layout;
        let mut computed = self.rows().into_iter();
        self.settings
            .observables
            .iter()
            .enumerate()
            .map(|(o, name)| {
                let reference: Vec<f64> = self
                    .good
                    .iter()
                    .map(|p| p.reference_observed[layout.at(layout.points - 1, o)])
                    .collect();
                ObservableReport {
                    name: name.clone(),
                    basis: self.bases[o],
                    reference_value: mean_interval(&reference),
                    schemes: computed
                        .by_ref()
                        .take(self.schemes.len())
                        .flatten()
                        .collect(),
                }
            })
            .collect()
    }
}

/// Per observable of `settings`: its exact value if the scene's weak table gives one, else the
/// reference.
fn bases(scene: &Scene, settings: &ConvergenceSettings) -> Vec<Basis> {
    let exact = scene
        .weak
        .as_ref()
        .map(|w| w.exact.clone())
        .unwrap_or_default();
    settings
        .observables
        .iter()
        .map(|name| {
            exact
                .get(name)
                .map_or(Basis::Reference, |&x| Basis::Exact(x))
        })
        .collect()
}

/// The weak report from the records of all paths (in any order). Fails without observables or
/// a reference in the run's settings.
pub fn build_weak_report(run: ConvergenceRun) -> Result<WeakReport, StudyError> {
    let ConvergenceRun {
        scene,
        settings,
        schemes,
        skipped,
        mut records,
        ..
    } = run;
    check_weak(&settings, settings.observables.len())?;
    records.sort_by_key(|r| r.index);
    let good: Vec<&PathRecord> = records
        .iter()
        .filter(|r| r.reference_failure.is_none())
        .collect();
    let layout = Layout {
        count: settings.observables.len(),
        points: 1 << settings.coarsest,
    };
    let observables = WeakInputs {
        settings: &settings,
        good: &good,
        schemes: &schemes,
        bases: bases(&scene, &settings),
        layout,
    }
    .observables();
    let reference = ReferenceReport::of(&settings, &records, good.len()).ok_or_else(|| {
        StudyError::Setting {
            key: "study.reference",
            value: "none".into(),
            rule: "the weak study needs one".into(),
        }
    })?;
    Ok(WeakReport {
        scene: scene.name.clone(),
        seed: settings.seed,
        paths: settings.paths,
        t_end: settings.t_end,
        grid: (1..=layout.points)
            .map(|k| settings.t_end * k as f64 / layout.points as f64)
            .collect(),
        settings,
        reference,
        observables,
        skipped,
        scene_definition: scene,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_power_law_differences_give_their_order() {
        // d_ij = c h_j (1 + 0.1 z_i): the mean error is c h_j (1 + 0.1 mean z), resolved at every
        // level, and the slope is exactly 1 on every resample.
        let h: Vec<f64> = (0..5).map(|j| 0.5f64.powi(j)).collect();
        let z: Vec<f64> = (0..200)
            .map(|i| ((i * 37 % 101) as f64 / 50.0) - 1.0)
            .collect();
        let diffs: Vec<Vec<f64>> = h
            .iter()
            .map(|hj| z.iter().map(|zi| 0.3 * hj * (1.0 + 0.1 * zi)).collect())
            .collect();
        let fit = weak_order(&h, &diffs).unwrap();
        assert!((fit.order.estimate - 1.0).abs() < 1e-12, "{fit:?}");
        assert!(fit.order.ci_high - fit.order.ci_low < 1e-9, "{fit:?}");
        assert_eq!(fit.fitted, vec![0, 1, 2, 3, 4]);
        assert!(fit.unresolved.is_empty());
    }

    #[test]
    fn unresolved_levels_are_left_out_and_named() {
        // Zero-mean noise at the finest level: its error is not resolved.
        let h = [0.5, 0.25, 0.125];
        let noise: Vec<f64> = (0..100)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let diffs = vec![
            noise.iter().map(|x| 1.0 + 0.1 * x).collect(),
            noise.iter().map(|x| 0.5 + 0.1 * x).collect(),
            noise.iter().map(|x| 1e-6 + x).collect(),
        ];
        let fit = weak_order(&h, &diffs).unwrap();
        assert_eq!(fit.unresolved, vec![2]);
        assert_eq!(fit.fitted, vec![0, 1]);
        assert!((fit.order.estimate - 1.0).abs() < 1e-12);
    }

    #[test]
    fn extrapolation_cancels_a_first_order_error() {
        // d_j = h_j + h_j^2 on every path: 2 d_(j+1) - d_j = -h_j^2 / 2 = -2 h_(j+1)^2.
        let h = vec![0.5, 0.25, 0.125];
        let data = LevelPaths {
            h: h.clone(),
            last: h.iter().map(|x| vec![x + x * x; 4]).collect(),
            grid: Vec::new(),
        };
        let rr = data.extrapolated();
        assert_eq!(rr.h, vec![0.25, 0.125]);
        for (j, d) in rr.last.iter().enumerate() {
            let hf = rr.h[j];
            assert!((d[0] + 2.0 * hf * hf).abs() < 1e-15, "{d:?}");
        }
    }
}
