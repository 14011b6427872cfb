//! The plan of a block of paths (what each path runs, its failure bounds, the observables it
//! evaluates) and the records it leaves (what each scheme at each level did on each path).

use sdae_model::FailureKind;
use serde::{Deserialize, Serialize};

use crate::Observable;

/// Bounds beyond which a path counts as failed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// |r_i| or |v_i| above this is a blow-up.
    #[serde(with = "sdae_stats::json_f64")]
    pub blow_up: f64,
    /// |g(r)| or |Dg(r) v| above this is a failure (`None`: not checked, as for the
    /// convergence of unprojected schemes, which drift off the manifold by O(h)).
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub drift_tolerance: Option<f64>,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            blow_up: 1e8,
            drift_tolerance: None,
        }
    }
}

/// What one path runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PathPlan {
    /// Final time T.
    pub t_end: f64,
    /// Increments are drawn on 2^`fine` steps; the reference (if any) runs on them.
    pub fine: u32,
    /// Level exponents k (N = 2^k steps), ascending, at most `fine` (below it with a reference).
    pub levels: Vec<u32>,
    /// Accumulate mu (only when an output needs it).
    pub want_mu: bool,
    /// Failure bounds.
    pub limits: Limits,
    /// Average the kinetic energy v^T M v / 2 over the grid points with t >= this time (on
    /// the track's own clock where
    /// [`BlockEnsembles::own_clock`](crate::BlockEnsembles::own_clock) says so).
    pub kinetic_after: Option<f64>,
    /// An observable f(r, v) averaged in time like the kinetic energy (same grid points, weights
    /// and burn-in `kinetic_after`): a configurational average of the invariant measure.
    pub time_averaged: Option<Observable>,
    /// Observables to evaluate on the grid of a coarse level (`None`: none, nothing more is
    /// computed).
    pub observing: Option<Observing>,
    /// The reference also runs at half its steps, 2^(`fine` - 1), on the same Brownian path
    /// (pairwise sums of its increments), its observables recorded on the same grid: the
    /// reference's two finest levels, whose difference bounds its bias and Richardson-extrapolates
    /// it (the weak study of sdae-study). Only with a reference and observables.
    pub paired_reference: bool,
}

/// Observables f(r, v) evaluated on every track and the reference at the grid points
/// t_k = k T / 2^`grid_level`, k = 1..=2^`grid_level` (the grid every level at or above
/// `grid_level` shares; its last point is T).
#[derive(Debug, Clone, PartialEq)]
pub struct Observing {
    /// The observables.
    pub observables: Vec<Observable>,
    /// The level whose grid the values are taken on (at most the plan's coarsest level).
    pub grid_level: u32,
}

impl Observing {
    /// Values per path: one per observable and grid point.
    pub fn values_per_path(&self) -> usize {
        self.observables.len() << self.grid_level
    }

    /// Appends f(r, v) of every observable to `out`.
    pub(crate) fn evaluate(&self, r: &[f64], v: &[f64], out: &mut Vec<f64>) {
        out.extend(self.observables.iter().map(|f| f.value(r, v)));
    }
}

/// What one scheme at one level did on one path.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackOutcome {
    /// sup over the level's grid of |r - r_ref|, |v - v_ref|, |mu - mu_ref| (0 for mu when it is
    /// not accumulated); `None` if the path failed or there is no reference.
    #[serde(with = "sdae_stats::json_f64::option_triple", default)]
    pub distances: Option<[f64; 3]>,
    /// Why the path stopped early.
    pub failure: Option<FailureKind>,
    /// Wall-clock seconds spent stepping.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds: f64,
    /// Steps done.
    pub steps: usize,
    /// Steps with a truncated drift.
    pub truncated_steps: usize,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Steps that needed the homotopy.
    pub homotopy_steps: usize,
    /// Steps whose kappa was certified with its rounding part set aside.
    #[serde(default)]
    pub rounding_certified_steps: usize,
    /// The clock lag sum_k (1 - eta_k) h of the truncated drift.
    #[serde(default, with = "sdae_stats::json_f64")]
    pub clock_lag: f64,
    /// Largest |g(r_k)| on the grid.
    #[serde(with = "sdae_stats::json_f64")]
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| on the grid.
    #[serde(with = "sdae_stats::json_f64")]
    pub max_velocity_residual: f64,
    /// Time average of v^T M v / 2 after the plan's `kinetic_after` (over the scheme's own
    /// clock for a time-changed scheme).
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub kinetic_energy: Option<f64>,
    /// Time average of the plan's [`PathPlan::time_averaged`] observable, over the points and
    /// weights of `kinetic_energy`.
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub time_average: Option<f64>,
    /// The plan's observables at the grid points of its [`Observing`] (grid-point-major:
    /// `observed[k * observables + o]` is observable o at t_(k+1)), up to where the path
    /// stopped; empty when the plan observes nothing.
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        with = "sdae_stats::json_f64::vec"
    )]
    pub observed: Vec<f64>,
}

/// One path: the reference's fate and the outcome of every scheme at every level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathRecord {
    /// Path index i (its stream is derived from (seed, i)).
    pub index: usize,
    /// Why the reference failed, if it did (the path is then left out of the errors).
    pub reference_failure: Option<FailureKind>,
    /// Wall-clock seconds of the reference.
    #[serde(with = "sdae_stats::json_f64")]
    pub reference_seconds: f64,
    /// Outcomes, scheme-major: `tracks[s * levels + j]` is scheme s at level j.
    pub tracks: Vec<TrackOutcome>,
    /// The plan's observables on the reference, laid out as [`TrackOutcome::observed`].
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        with = "sdae_stats::json_f64::vec"
    )]
    pub reference_observed: Vec<f64>,
    /// The same on the reference at half its steps ([`PathPlan::paired_reference`]; empty
    /// without it).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        with = "sdae_stats::json_f64::vec"
    )]
    pub reference_coarse_observed: Vec<f64>,
}

impl PathRecord {
    /// The record of path `index` before it runs: no failure, no time, no outcome.
    pub(crate) fn empty(index: usize) -> Self {
        Self {
            index,
            reference_failure: None,
            reference_seconds: 0.0,
            tracks: Vec::new(),
            reference_observed: Vec::new(),
            reference_coarse_observed: Vec::new(),
        }
    }
}
