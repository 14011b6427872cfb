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
//!
//! With randomized quasi-Monte Carlo paths ([`ConvergenceSettings::randomizations`], `weak
//! --qmc`), R randomizations of n scrambled Sobol' points drive the paths, and each
//! randomization's per-path values are averaged into one sample before all of the above
//! ([`quasi`]): the statistics then rest on the R samples as on R paths.

pub mod bootstrap;
pub mod quasi;
pub mod report;

use std::collections::BTreeMap;

use rayon::prelude::*;
use sdae_model::FailureKind;
use serde::Serialize;

use crate::convergence::{
    ConvergenceRun, ConvergenceSettings, ReferenceReport, count_kinds, run_observed_on,
};
use crate::error::StudyError;
use crate::integrator::{SchemeKind, StudyScheme};
use crate::lockstep::{PathRecord, TrackOutcome};
use crate::observable::Observable;
use crate::parallel::{Control, Skipped};
use crate::scene::{Prepared, Scene, SceneRunner};
use bootstrap::Resample;
use quasi::{QmcSamples, randomization_means};
use sdae_stats::Interval;
use sdae_stats::mean_interval;

/// The weak study's settings of a scene with a `[weak]` table: the convergence settings with
/// the table's observables, its paths (default 10000), levels (default 2..7) and reference
/// (default 4 levels above the finest); with `quick`, at most 2000 paths, four levels and a
/// reference 3 levels above the finest. The reference is the most accurate scheme for
/// expectations the scene's system has ([`weak_reference`]), paired with itself at half its
/// steps ([`ConvergenceSettings::paired_reference`]) for its Richardson extrapolation and
/// bias bound ([`ReferenceBias`]). `None` without a `[weak]` table.
pub fn weak_settings(scene: &Scene, quick: bool) -> Option<ConvergenceSettings> {
    let settings = weak_table_settings(scene, quick)?;
    Some(ConvergenceSettings {
        reference_scheme: weak_reference(scene),
        ..settings
    })
}

/// [`weak_settings`] with the default reference scheme: what the `[weak]` table gives,
/// without building the scene's system (for checking the table).
pub(crate) fn weak_table_settings(scene: &Scene, quick: bool) -> Option<ConvergenceSettings> {
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
        paired_reference: true,
        ..ConvergenceSettings::for_scene(scene)
    })
}

/// The weak study's reference scheme for a scene: of weak order 2 where its system has a
/// Langevin form (BAOAB with SHAKE/RATTLE, [`SchemeKind::weak_order`]), so that the reference
/// is more accurate than every scheme it judges; otherwise the practical half-explicit scheme
/// (weak order 1; its Richardson extrapolation is of order 2 where its error expands in h).
/// A scene whose system cannot be built gets the latter (the run then says why).
pub fn weak_reference(scene: &Scene) -> SchemeKind {
    struct Pick;
    impl SceneRunner for Pick {
        type Output = SchemeKind;
        fn run<S>(self, _: &Scene, prepared: Prepared<S>) -> SchemeKind
        where
            S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
        {
            let best = SchemeKind::BaoabRattle;
            let (run, _) = crate::parallel::applicable(&[best], &[], &prepared);
            if run.is_empty() {
                SchemeKind::HalfExplicitPractical
            } else {
                best
            }
        }
    }
    scene.run(Pick).unwrap_or(SchemeKind::HalfExplicitPractical)
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
    Exact(#[serde(with = "sdae_stats::json_f64")] f64),
    /// The reference on the same paths, Richardson-extrapolated from its two finest levels
    /// ([`ReferenceBias`]), per-path differences.
    Reference,
}

/// The reference's own weak error, from its two finest levels R and R - 1 on the same paths.
///
/// With the reference scheme's weak order p, its error at R is e_R = c h_R^p + o(h_R^p), so
/// E[f_R - f_(R-1)] = (1 - 2^p) e_R + o(h_R^p) and the Richardson value
/// f_R + (f_R - f_(R-1)) / (2^p - 1) (per path; Talay and Tubaro) cancels the leading term. Its
/// remaining bias is of higher order than e_R, and is bounded here by the estimate of |e_R|
/// itself: B = (|mean(f_R - f_(R-1))| + its 95% half-width) / (2^p - 1). B is conservative
/// (the extrapolated value is better than the plain one by about a factor h_R), and a weak
/// error is resolved only where |e_N| exceeds its Monte Carlo half-width plus B.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceBias {
    /// The weak order p the reference is extrapolated with ([`SchemeKind::weak_order`]).
    pub order: u32,
    /// E[f_R - f_(R-1)] at T, with its 95% t interval.
    pub difference: Interval,
    /// The bound B at T.
    #[serde(with = "sdae_stats::json_f64")]
    pub bound: f64,
    /// The largest bound over the grid points (that of the largest error over the grid).
    #[serde(with = "sdae_stats::json_f64")]
    pub grid_bound: f64,
}

use sdae_stats::weak_order::{self, WeakOrder};

/// One scheme (or its extrapolation) at one step size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakLevel {
    /// N (the finer level's for an extrapolated row).
    pub n_steps: usize,
    /// h = T / N.
    #[serde(with = "sdae_stats::json_f64")]
    pub h: f64,
    /// E[f(X_N)] (for an extrapolated row 2 E[f(X_N)] - E[f(X_(N/2))]) with its 95% t interval.
    pub value: Interval,
    /// The final-time weak error against the basis: its 95% t interval widened on each side by
    /// the reference's bias bound (none against an exact value).
    pub error: Interval,
    /// |error| exceeds the half-width of its (widened) interval.
    pub resolved: bool,
    /// The largest |error| over the coarsest level's grid against the reference, with its 95%
    /// bootstrap interval widened by the reference's largest bias bound over the grid.
    pub sup_error: Option<Interval>,
    /// Mean wall-clock seconds of stepping per path (both levels' for an extrapolated row).
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds_per_path: f64,
}

/// A level left out of a row: some of its paths failed, or gave values that are not finite.
/// Its E[f(X_N)] is not defined by the paths that finished (they are a selection), so it has
/// no error and no place in a fit; the scheme's other levels are reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LostLevel {
    /// N (the finer level's for an extrapolated row).
    pub n_steps: usize,
    /// Paths (of those whose reference finished) that failed at this level, by kind.
    pub failures: BTreeMap<FailureKind, usize>,
    /// Paths that finished with a value that is not finite.
    pub non_finite: usize,
}

impl LostLevel {
    /// "N = 4 (10000 failed: 10000 blow-up)" or "N = 4 (3 non-finite values)".
    pub fn describe(&self) -> String {
        let failed: usize = self.failures.values().sum();
        let mut parts = Vec::new();
        if failed > 0 {
            let kinds: Vec<String> = self
                .failures
                .iter()
                .map(|(k, n)| format!("{n} {k}"))
                .collect();
            parts.push(format!("{failed} failed: {}", kinds.join(", ")));
        }
        if self.non_finite > 0 {
            parts.push(format!("{} non-finite values", self.non_finite));
        }
        format!("N = {} ({})", self.n_steps, parts.join("; "))
    }
}

/// One scheme, or its Richardson-Romberg extrapolation, for one observable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeakScheme {
    /// The scheme's name (with " + richardson" for the extrapolation).
    pub name: String,
    /// Whether the row is the Richardson-Romberg extrapolation of the scheme.
    pub extrapolated: bool,
    /// Paths compared: those whose reference finished (every level compared has them all).
    pub paths: usize,
    /// The levels compared, coarse to fine.
    pub levels: Vec<WeakLevel>,
    /// The levels left out because paths failed there or gave values that are not finite
    /// (for an extrapolated row, those of which either level was lost).
    pub lost: Vec<LostLevel>,
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
    /// E[f(X_ref)] over the paths whose reference finished (Richardson-extrapolated from the
    /// reference's two finest levels where the run has them), with its 95% t interval.
    pub reference_value: Option<Interval>,
    /// The reference's own error and the bound on the extrapolated reference's bias (`None`
    /// without the reference's pair).
    pub reference_bias: Option<ReferenceBias>,
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
    /// With randomized quasi-Monte Carlo paths: the design and the samples (one per
    /// randomization) the statistics rest on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub qmc: Option<QmcSamples>,
    /// Schemes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// The scene as run.
    pub scene_definition: Scene,
}

impl WeakReport {
    /// What could not be compared, one sentence each: the reference when it failed on every
    /// path, and each scheme none of whose levels could be compared.
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
            .filter(|row| !row.extrapolated && row.levels.is_empty())
            .map(|row| {
                let lost: Vec<String> = row.lost.iter().map(LostLevel::describe).collect();
                format!(
                    "{}: no level could be compared ({})",
                    row.name,
                    lost.join(", ")
                )
            })
            .collect()
    }
}

/// Per-path differences of one scheme (or extrapolation) at the levels compared: `last[j][i]`,
/// path i's f(X_N(T)) minus the basis at level j, and `grid[j][k][i]`, its
/// f(X_N(t_k)) - f(X_ref(t_k)) at the shared grid points (k = last is T); with the reference's
/// bias bounds they are judged against.
#[derive(Debug, Clone, Default)]
pub struct LevelPaths {
    /// Step sizes, coarse to fine.
    pub h: Vec<f64>,
    /// Each level's index among the study's levels: neighbouring levels have consecutive ones.
    pub index: Vec<usize>,
    /// Final-time differences against the basis.
    pub last: Vec<Vec<f64>>,
    /// Differences against the reference at the grid points.
    pub grid: Vec<Vec<Vec<f64>>>,
    /// The bias bound of the basis at T (0 for an exact value).
    pub bound: f64,
    /// The reference's bias bound at each grid point (empty: 0).
    pub grid_bound: Vec<f64>,
}

impl LevelPaths {
    /// Differences against an exact basis (no bias bound) at levels of step sizes `h`.
    pub fn exact(h: &[f64], last: &[Vec<f64>]) -> Self {
        Self {
            h: h.to_vec(),
            index: (0..h.len()).collect(),
            last: last.to_vec(),
            ..Self::default()
        }
    }

    /// The Richardson-Romberg combination of neighbouring levels: per path 2 d_j - d_(j-1), at
    /// the finer step sizes (only where both levels are compared). The reference's bias enters
    /// 2 d_j - d_(j-1) once, as it enters d_j: the bounds stay.
    pub fn extrapolated(&self) -> LevelPaths {
        let pairs: Vec<usize> = (1..self.h.len())
            .filter(|&j| self.index[j] == self.index[j - 1] + 1)
            .collect();
        LevelPaths {
            h: pairs.iter().map(|&j| self.h[j]).collect(),
            index: pairs.iter().map(|&j| self.index[j]).collect(),
            last: pairs
                .iter()
                .map(|&j| richardson(&self.last[j - 1], &self.last[j]))
                .collect(),
            grid: pairs
                .iter()
                .filter(|_| !self.grid.is_empty())
                .map(|&j| {
                    let (c, f) = (&self.grid[j - 1], &self.grid[j]);
                    c.iter().zip(f).map(|(c, f)| richardson(c, f)).collect()
                })
                .collect(),
            bound: self.bound,
            grid_bound: self.grid_bound.clone(),
        }
    }

    /// The largest bias bound over the grid.
    fn largest_grid_bound(&self) -> f64 {
        self.grid_bound.iter().copied().fold(0.0, f64::max)
    }
}

/// Whether an error's interval excludes 0 by its half-width, |estimate| > (high - low) / 2,
/// and the error is a normal float: one that underflowed (zero or subnormal, as the errors of a
/// run whose steps are below the rounding of the state are) measures the arithmetic, not the
/// scheme, and is unresolved.
fn resolved(e: &Interval) -> bool {
    e.estimate.abs() >= f64::MIN_POSITIVE && e.estimate.abs() > 0.5 * (e.ci_high - e.ci_low)
}

/// `interval` widened by `by` on each side.
fn widened(interval: Interval, by: f64) -> Interval {
    Interval {
        estimate: interval.estimate,
        ci_low: interval.ci_low - by,
        ci_high: interval.ci_high + by,
    }
}

/// The largest |mean| over the grid points of one level, and whether it is resolved (its
/// |mean| above the half-width of its t interval at that point plus the point's bias bound).
fn sup_over_grid(grid: &[Vec<f64>], bounds: &[f64]) -> Option<(usize, bool)> {
    let intervals: Vec<Interval> = grid
        .iter()
        .enumerate()
        .map(|(k, g)| mean_interval(g).map(|i| widened(i, bounds.get(k).copied().unwrap_or(0.0))))
        .collect::<Option<_>>()?;
    let (k, at) = intervals
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.estimate.abs().total_cmp(&b.1.estimate.abs()))?;
    Some((k, resolved(at)))
}

/// The final-time errors, the grid's largest errors and the two orders of one set of per-path
/// differences.
struct Analysis {
    errors: Vec<Interval>,
    sup_errors: Vec<Option<Interval>>,
    order: Option<WeakOrder>,
    sup_order: Option<WeakOrder>,
}

/// The weak order of the final-time errors of per-path differences `diffs[j][i]` (path i at the
/// level of step size `h[j]`, against an exact value): fitted over the resolved, asymptotic
/// levels (the weak orders of `sdae_stats::weak_order`), with a 95% bootstrap interval over whole paths. `None` without 2 paths
/// or 2 resolved levels.
pub fn weak_order(h: &[f64], diffs: &[Vec<f64>]) -> Option<WeakOrder> {
    analyse(&LevelPaths::exact(h, diffs)).and_then(|a| a.order)
}

/// Errors and orders of `data`: t intervals of the final-time errors and bootstrap intervals of
/// the grid's largest errors, each widened by the reference's bias bound, and both orders over
/// the asymptotic levels (one bootstrap over paths for all of them). `None` with fewer than 2
/// paths.
fn analyse(data: &LevelPaths) -> Option<Analysis> {
    let errors: Vec<Interval> = data
        .last
        .iter()
        .map(|d| mean_interval(d).map(|i| widened(i, data.bound)))
        .collect::<Option<_>>()?;
    let paths = data.last.first().map_or(0, Vec::len);
    let levels = data.h.len();
    let sup: Vec<Option<(usize, bool)>> = data
        .grid
        .iter()
        .map(|g| sup_over_grid(g, &data.grid_bound))
        .collect();
    let has_grid = data.grid.len() == levels && levels > 0;
    let last_fit = weak_order::OrderCandidates::new(&data.h, |j| resolved(&errors[j]));
    let sup_fit = weak_order::OrderCandidates::new(&data.h, |j| {
        has_grid && sup.get(j).copied().flatten().is_some_and(|s| s.1)
    });
    let sups_of = |sample: &Resample<'_>| -> Vec<f64> {
        data.grid
            .iter()
            .map(|g| g.iter().map(|d| sample.mean(d).abs()).fold(0.0, f64::max))
            .collect()
    };
    let means_of =
        |sample: &Resample<'_>| -> Vec<f64> { data.last.iter().map(|d| sample.mean(d)).collect() };
    // [sup error per level (if a grid), the final-time order's candidates, the sup order's].
    let statistic = |sample: &Resample<'_>| -> Vec<f64> {
        let mut out = Vec::new();
        let sups = if has_grid {
            sups_of(sample)
        } else {
            Vec::new()
        };
        out.extend(&sups);
        last_fit.push(&means_of(sample), &mut out);
        sup_fit.push(&sups, &mut out);
        out
    };
    let intervals = bootstrap::path_bootstrap(paths, statistic);
    let (sup_errors, rest) = intervals.split_at(if has_grid { levels } else { 0 });
    let (last_intervals, sup_intervals) = rest.split_at(last_fit.len());
    let all = Resample::all();
    let means = means_of(&all);
    let sups = if has_grid { sups_of(&all) } else { Vec::new() };
    let grid_bound = data.largest_grid_bound();
    Some(Analysis {
        errors,
        sup_errors: if has_grid {
            sup_errors
                .iter()
                .map(|i| i.map(|i| widened(i, grid_bound)))
                .collect()
        } else {
            vec![None; levels]
        },
        order: last_fit.choose(&means, last_intervals),
        sup_order: sup_fit.choose(&sups, sup_intervals),
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

/// Where one scheme's values of one observable sit in a path's records.
#[derive(Clone, Copy)]
struct SchemeTrack {
    /// The scheme's index among the schemes that ran.
    s: usize,
    /// The observable's index.
    o: usize,
    /// The study's levels.
    count: usize,
    /// Where the observables sit in a track's values.
    layout: Layout,
}

impl SchemeTrack {
    /// The scheme's outcome on path `p` at level `j`.
    fn outcome(self, p: &PathRecord, j: usize) -> &TrackOutcome {
        &p.tracks[self.s * self.count + j]
    }

    /// The observable's value on path `p` at level `j` and grid point `k`.
    fn value(self, p: &PathRecord, j: usize, k: usize) -> f64 {
        self.outcome(p, j).observed[self.layout.at(k, self.o)]
    }
}

/// The Richardson-Romberg combination of a coarse and a fine level's per-path values: per path
/// 2 fine - coarse.
fn richardson(coarse: &[f64], fine: &[f64]) -> Vec<f64> {
    coarse.iter().zip(fine).map(|(c, f)| 2.0 * f - c).collect()
}

/// The levels an extrapolation loses, one per level j of `levels` (the study's step exponents)
/// whose pair j - 1, j is not both in `kept`: an extrapolated level is lost with either of its
/// two levels, and counts the failures and non-finite values of both (from `lost`).
fn lost_pairs(levels: &[u32], kept: &[usize], lost: &[LostLevel]) -> Vec<LostLevel> {
    (1..levels.len())
        .filter(|j| !(kept.contains(j) && kept.contains(&(j - 1))))
        .map(|j| {
            let n = 1usize << levels[j];
            let of = |n: usize| lost.iter().find(|l| l.n_steps == n);
            let mut pair = LostLevel {
                n_steps: n,
                failures: BTreeMap::new(),
                non_finite: 0,
            };
            for l in [of(n / 2), of(n)].into_iter().flatten() {
                for (kind, paths) in &l.failures {
                    *pair.failures.entry(*kind).or_insert(0) += paths;
                }
                pair.non_finite += l.non_finite;
            }
            pair
        })
        .collect()
}

/// A row's levels and orders.
struct RowParts {
    levels: Vec<WeakLevel>,
    order: Option<WeakOrder>,
    sup_order: Option<WeakOrder>,
}

/// The levels and orders of one row from its per-path differences, values and run times (one
/// per level of `data`).
fn rows_of(
    data: &LevelPaths, values: &[Vec<f64>], seconds: &[f64], settings: &ConvergenceSettings,
) -> RowParts {
    let Some(analysis) = analyse(data) else {
        return RowParts {
            levels: Vec::new(),
            order: None,
            sup_order: None,
        };
    };
    let levels = analysis
        .errors
        .iter()
        .zip(&analysis.sup_errors)
        .enumerate()
        .filter_map(|(j, (error, sup))| {
            Some(WeakLevel {
                n_steps: (settings.t_end / data.h[j]).round() as usize,
                h: data.h[j],
                value: mean_interval(&values[j])?,
                error: *error,
                resolved: resolved(error),
                sup_error: *sup,
                seconds_per_path: seconds[j],
            })
        })
        .collect();
    RowParts {
        levels,
        order: analysis.order,
        sup_order: analysis.sup_order,
    }
}

/// An observable's basis per path: the exact value, or the reference extrapolated from its
/// pair (or the plain reference without one), at every grid point, with the bounds.
struct PathBasis {
    /// `at[k][i]`: path i's reference value at grid point k (extrapolated where paired).
    at: Vec<Vec<f64>>,
    /// The exact value at T, if the scene gives one.
    exact: Option<f64>,
    /// The reference's bias and its bound, from its pair.
    bias: Option<ReferenceBias>,
    /// The bias bound at each grid point (0 without a pair).
    grid_bound: Vec<f64>,
}

impl PathBasis {
    /// Path i's basis at T.
    fn last(&self, i: usize) -> f64 {
        self.exact.unwrap_or_else(|| self.at[self.at.len() - 1][i])
    }

    /// The bias bound at T.
    fn bound(&self) -> f64 {
        match self.exact {
            Some(_) => 0.0,
            None => self.grid_bound.last().copied().unwrap_or(0.0),
        }
    }
}

/// What the weak report's tables are computed from.
struct WeakInputs<'a> {
    /// The run's settings.
    settings: &'a ConvergenceSettings,
    /// The samples the statistics run on, by index: the paths whose reference finished, or
    /// with randomized QMC paths one mean per randomization ([`quasi`]).
    good: &'a [&'a PathRecord],
    /// The paths behind the samples (the samples themselves without QMC): the failures of a
    /// level are counted in paths.
    paths: &'a [&'a PathRecord],
    /// The schemes that ran, in the order of the records' tracks.
    schemes: &'a [String],
    /// Per observable, the exact value the scene gives.
    exact: Vec<Option<f64>>,
    /// Where the observables sit in a path's values.
    layout: Layout,
}

impl<'a> WeakInputs<'a> {
    /// Observable `o`'s basis on every good path: the reference at each grid point,
    /// Richardson-extrapolated with the reference scheme's weak order p where the run paired
    /// it, f_R + (f_R - f_(R-1)) / (2^p - 1), and the bias bounds ([`ReferenceBias`]).
    fn basis(&self, o: usize) -> PathBasis {
        let layout = self.layout;
        let paired = self.settings.paired_reference;
        let p = self.settings.reference_scheme.weak_order();
        let divisor = f64::from((1u32 << p) - 1);
        let mut at = Vec::with_capacity(layout.points);
        let mut grid_bound = Vec::with_capacity(layout.points);
        let mut difference = None;
        for k in 0..layout.points {
            let fine: Vec<f64> = self
                .good
                .iter()
                .map(|r| r.reference_observed[layout.at(k, o)])
                .collect();
            if !paired {
                at.push(fine);
                grid_bound.push(0.0);
                continue;
            }
            let step: Vec<f64> = self
                .good
                .iter()
                .zip(&fine)
                .map(|(r, f)| f - r.reference_coarse_observed[layout.at(k, o)])
                .collect();
            let d = mean_interval(&step);
            let bound = d.map_or(f64::INFINITY, |d| {
                (d.estimate.abs() + 0.5 * (d.ci_high - d.ci_low)) / divisor
            });
            grid_bound.push(bound);
            difference = d;
            at.push(
                fine.iter()
                    .zip(&step)
                    .map(|(f, s)| f + s / divisor)
                    .collect(),
            );
        }
        let bias = difference.map(|difference| ReferenceBias {
            order: p,
            difference,
            bound: grid_bound.last().copied().unwrap_or(0.0),
            grid_bound: grid_bound.iter().copied().fold(0.0, f64::max),
        });
        PathBasis {
            at,
            exact: self.exact[o],
            bias,
            grid_bound,
        }
    }

    /// The rows of every observable and scheme (observable-major), on the settings' threads.
    fn rows(&self, bases: &[PathBasis]) -> Vec<Vec<WeakScheme>> {
        let jobs: Vec<(usize, usize)> = (0..self.layout.count)
            .flat_map(|o| (0..self.schemes.len()).map(move |s| (o, s)))
            .collect();
        let rows = |&(o, s): &(usize, usize)| self.scheme_rows(s, o, &bases[o]);
        let on_threads = rayon::ThreadPoolBuilder::new()
            .num_threads(self.settings.threads.max(1))
            .build();
        match on_threads {
            Ok(pool) => pool.install(|| jobs.par_iter().map(rows).collect()),
            Err(_) => jobs.iter().map(rows).collect(),
        }
    }

    /// Scheme `s`'s levels for observable `o`: those compared (every good path finished there
    /// with finite values) and those lost.
    fn split_levels(&self, s: usize, o: usize) -> (Vec<usize>, Vec<LostLevel>) {
        let levels = self.settings.levels();
        let count = levels.len();
        let wanted = self.layout.points;
        let mut kept = Vec::new();
        let mut lost = Vec::new();
        for (j, &k) in levels.iter().enumerate() {
            let tracks =
                |of: &'a [&'a PathRecord]| of.iter().map(move |p| &p.tracks[s * count + j]);
            let failures = count_kinds(tracks(self.paths).filter_map(|t| t.failure));
            let bad = |t: &&TrackOutcome| {
                t.failure.is_none()
                    && (t.observed.len() != wanted * self.layout.count
                        || (0..wanted).any(|g| !t.observed[self.layout.at(g, o)].is_finite()))
            };
            let non_finite = tracks(self.paths).filter(bad).count();
            // A mean over a randomization that is not finite although its paths' values are.
            let samples_bad = tracks(self.good).any(|t| t.failure.is_none() && bad(&t));
            if failures.is_empty() && non_finite == 0 && !samples_bad {
                kept.push(j);
            } else {
                lost.push(LostLevel {
                    n_steps: 1 << k,
                    failures,
                    non_finite,
                });
            }
        }
        (kept, lost)
    }

    /// Scheme `s`'s report rows (the scheme and its extrapolation) for observable `o`.
    fn scheme_rows(&self, s: usize, o: usize, basis: &PathBasis) -> Vec<WeakScheme> {
        let settings = self.settings;
        let (kept, lost) = self.split_levels(s, o);
        let track = SchemeTrack {
            s,
            o,
            count: settings.levels().len(),
            layout: self.layout,
        };
        let data = self.level_paths(track, &kept, basis);
        let values = self.final_values(track, &kept);
        let seconds = self.mean_seconds(track, &kept);
        let plain = rows_of(&data, &values, &seconds, settings);
        let pairs: Vec<usize> = (1..kept.len())
            .filter(|&j| kept[j] == kept[j - 1] + 1)
            .collect();
        let combined: Vec<Vec<f64>> = pairs
            .iter()
            .map(|&j| richardson(&values[j - 1], &values[j]))
            .collect();
        let both: Vec<f64> = pairs.iter().map(|&j| seconds[j - 1] + seconds[j]).collect();
        let extrapolated = rows_of(&data.extrapolated(), &combined, &both, settings);
        let lost_pairs = lost_pairs(&settings.levels(), &kept, &lost);
        vec![
            self.row(s, plain, false, lost),
            self.row(s, extrapolated, true, lost_pairs),
        ]
    }

    /// The per-path differences of `track` against `basis` at the levels `kept` (indices among
    /// the study's levels), with the basis's bias bounds.
    fn level_paths(&self, track: SchemeTrack, kept: &[usize], basis: &PathBasis) -> LevelPaths {
        let (good, settings) = (self.good, self.settings);
        let last_point = self.layout.points - 1;
        LevelPaths {
            h: kept
                .iter()
                .map(|&j| settings.t_end / (1u64 << settings.levels()[j]) as f64)
                .collect(),
            index: kept.to_vec(),
            last: kept
                .iter()
                .map(|&j| {
                    good.iter()
                        .enumerate()
                        .map(|(i, p)| track.value(p, j, last_point) - basis.last(i))
                        .collect()
                })
                .collect(),
            grid: kept
                .iter()
                .map(|&j| {
                    (0..self.layout.points)
                        .map(|k| {
                            good.iter()
                                .enumerate()
                                .map(|(i, p)| track.value(p, j, k) - basis.at[k][i])
                                .collect()
                        })
                        .collect()
                })
                .collect(),
            bound: basis.bound(),
            grid_bound: basis.grid_bound.clone(),
        }
    }

    /// The values of `track` at T on every good path, per level of `kept`.
    fn final_values(&self, track: SchemeTrack, kept: &[usize]) -> Vec<Vec<f64>> {
        let last_point = self.layout.points - 1;
        kept.iter()
            .map(|&j| {
                self.good
                    .iter()
                    .map(|p| track.value(p, j, last_point))
                    .collect()
            })
            .collect()
    }

    /// The mean run time per good path of `track`, per level of `kept`.
    fn mean_seconds(&self, track: SchemeTrack, kept: &[usize]) -> Vec<f64> {
        let good = self.good;
        kept.iter()
            .map(|&j| {
                good.iter()
                    .map(|p| track.outcome(p, j).seconds)
                    .sum::<f64>()
                    / good.len().max(1) as f64
            })
            .collect()
    }

    /// The report row of scheme `s` (its extrapolation if `extrapolated`) from its levels and
    /// orders and the levels it lost.
    fn row(
        &self, s: usize, parts: RowParts, extrapolated: bool, lost: Vec<LostLevel>,
    ) -> WeakScheme {
        let name = &self.schemes[s];
        WeakScheme {
            name: if extrapolated {
                format!("{name} + richardson")
            } else {
                name.to_string()
            },
            extrapolated,
            paths: self.good.len(),
            levels: parts.levels,
            lost,
            order: parts.order,
            sup_order: parts.sup_order,
        }
    }

    /// One report per observable: the reference's value at T and the rows of every scheme.
    fn observables(&self) -> Vec<ObservableReport> {
        let bases: Vec<PathBasis> = (0..self.layout.count).map(|o| self.basis(o)).collect();
        let mut computed = self.rows(&bases).into_iter();
        self.settings
            .observables
            .iter()
            .zip(bases)
            .map(|(name, basis)| {
                let reference = basis.at.last().cloned().unwrap_or_default();
                ObservableReport {
                    name: name.clone(),
                    basis: basis.exact.map_or(Basis::Reference, Basis::Exact),
                    reference_value: mean_interval(&reference),
                    reference_bias: basis.bias,
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

/// Per observable of `settings`: its exact value if the scene's weak table gives one.
fn exact_values(scene: &Scene, settings: &ConvergenceSettings) -> Vec<Option<f64>> {
    let exact = scene
        .weak
        .as_ref()
        .map(|w| w.exact.clone())
        .unwrap_or_default();
    settings
        .observables
        .iter()
        .map(|name| exact.get(name).copied())
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
    // With randomized QMC paths the statistics run on one mean per randomization.
    let (means, behind, qmc) = match settings.randomizations {
        Some(r) => {
            let all: Vec<&PathRecord> = records.iter().collect();
            let (means, behind, qmc) = randomization_means(&all, r, settings.paths / r.max(1));
            (means, behind, Some(qmc))
        }
        None => (Vec::new(), good.clone(), None),
    };
    let samples: Vec<&PathRecord> = match qmc {
        Some(_) => means.iter().collect(),
        None => good.clone(),
    };
    let observables = WeakInputs {
        settings: &settings,
        good: &samples,
        paths: &behind,
        schemes: &schemes,
        exact: exact_values(&scene, &settings),
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
        qmc,
        skipped,
        scene_definition: scene,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_that_underflow_are_unresolved() {
        let exact = |e: f64| Interval {
            estimate: e,
            ci_low: e,
            ci_high: e,
        };
        assert!(resolved(&exact(-1e-3)));
        assert!(!resolved(&exact(-3.5e-317)));
        assert!(!resolved(&exact(0.0)));
    }

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
        let order = fit.order.unwrap();
        assert!((order.estimate - 1.0).abs() < 1e-12, "{fit:?}");
        // The interval is the fit's resolution: +-0.05 around the exact slope.
        assert!((order.ci_high - order.ci_low - 0.1).abs() < 1e-9, "{fit:?}");
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
        // Two resolved levels have one local slope and cannot show the asymptote.
        assert!(fit.unshown && fit.order.is_none(), "{fit:?}");
        assert!((fit.local_slopes[0].slope.estimate - 1.0).abs() < 1e-12);
    }

    #[test]
    fn extrapolation_cancels_a_first_order_error() {
        // d_j = h_j + h_j^2 on every path: 2 d_(j+1) - d_j = -h_j^2 / 2 = -2 h_(j+1)^2.
        let h = vec![0.5, 0.25, 0.125];
        let last: Vec<Vec<f64>> = h.iter().map(|x| vec![x + x * x; 4]).collect();
        let data = LevelPaths::exact(&h, &last);
        let rr = data.extrapolated();
        assert_eq!(rr.h, vec![0.25, 0.125]);
        for (j, d) in rr.last.iter().enumerate() {
            let hf = rr.h[j];
            assert!((d[0] + 2.0 * hf * hf).abs() < 1e-15, "{d:?}");
        }
    }
}
