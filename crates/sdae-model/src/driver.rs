//! The path driver, written once for every [`Scheme`]: fixed steps h = T/N from (r_0, v_0),
//! mu_k = sum_{j<=k} (mu_{j+1} - mu_j) (seed eq. 1.4), observers at chosen steps, and per-path
//! diagnostics.
//!
//! [`run_path`] runs a whole path; [`advance`] takes a stretch of steps of a path in progress
//! ([`PathState`]), which is what drivers that interleave several paths (the studies' lockstep
//! driver) are built from.

use sdae_manifold::vector::max_abs;
use sdae_manifold::{Constraint, check_state};

use crate::error::{ModelError, PathFailure, StepError, StepFailure, check_dim};
use crate::grid::TimeGrid;
use crate::increments::IncrementSource;
use crate::observer::Observer;
use crate::scheme::{Scheme, StepOutcome};
use crate::system::System;

/// Largest Newton iteration count tracked separately in the histogram; larger counts share the
/// last bin.
pub const ITERATION_BINS: usize = 16;

/// Tolerance for |g(r_0)| and |Dg(r_0) v_0| of a path's initial state.
pub const INITIAL_STATE_TOLERANCE: f64 = 1e-10;

/// Share of truncated steps above which a run is truncation-dominated: "stable but biased".
/// The truncated drift (and, in the seed's scheme, the undamped noise) then sets its
/// statistics: it neither blows up nor converges to the SDE's solution, and a Langevin run is
/// too hot (docs/stability.md). Half the steps is where the truncation, not the step size,
/// decides what most steps do.
pub const TRUNCATION_DOMINATED: f64 = 0.5;

/// What happened along a path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathDiagnostics {
    /// Steps completed.
    pub steps: usize,
    /// Steps with eta < 1.
    pub truncated_steps: usize,
    /// Smallest eta.
    pub min_eta: f64,
    /// Newton iterations summed over steps.
    pub newton_iterations: usize,
    /// `iteration_histogram[i]`: steps that took i Newton iterations (last bin: >= 15).
    pub iteration_histogram: [usize; ITERATION_BINS],
    /// Steps that needed the homotopy fallback.
    pub homotopy_steps: usize,
    /// Largest |g(r_k)|.
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k|.
    pub max_velocity_residual: f64,
    /// Largest |kappa_k| / C_kappa (0 if C_kappa is infinite or no kappa is solved for).
    pub max_kappa_ratio: f64,
    /// Largest contraction estimate of the kappa solver (0 if no kappa is solved for).
    pub max_contraction: f64,
    /// The clock lag sum_k (1 - eta_k) h: how much less time the truncated drift has
    /// integrated than the path's time (a step with eta < 1 advances the drift by eta h only).
    pub clock_lag: f64,
    /// Steps whose kappa reached C_kappa and was certified with the part that only corrects
    /// rounding set aside ([`Certificate::rounding`](sdae_ift::Certificate::rounding) > 0): how
    /// often the residual floor mattered.
    pub rounding_certified_steps: usize,
}

impl Default for PathDiagnostics {
    fn default() -> Self {
        Self {
            steps: 0,
            truncated_steps: 0,
            min_eta: 1.0,
            newton_iterations: 0,
            iteration_histogram: [0; ITERATION_BINS],
            homotopy_steps: 0,
            max_position_residual: 0.0,
            max_velocity_residual: 0.0,
            max_kappa_ratio: 0.0,
            max_contraction: 0.0,
            rounding_certified_steps: 0,
            clock_lag: 0.0,
        }
    }
}

impl PathDiagnostics {
    /// Adds one step of size `h` (its residuals where the scheme measured them).
    #[inline]
    pub fn record(&mut self, outcome: &StepOutcome, h: f64) {
        self.steps += 1;
        self.clock_lag += (1.0 - outcome.eta) * h;
        if outcome.truncated() {
            self.truncated_steps += 1;
        }
        self.min_eta = self.min_eta.min(outcome.eta);
        self.newton_iterations += outcome.newton_iterations;
        self.iteration_histogram[outcome.newton_iterations.min(ITERATION_BINS - 1)] += 1;
        if outcome.used_homotopy() {
            self.homotopy_steps += 1;
        }
        if let Some(g) = outcome.position_residual {
            self.max_position_residual = self.max_position_residual.max(g);
        }
        if let Some(dgv) = outcome.velocity_residual {
            self.max_velocity_residual = self.max_velocity_residual.max(dgv);
        }
        if let Some(c) = &outcome.certificate {
            if c.radius.is_finite() {
                self.max_kappa_ratio = self.max_kappa_ratio.max(c.norm / c.radius);
            }
            self.max_contraction = self.max_contraction.max(c.contraction);
            if c.rounding > 0.0 {
                self.rounding_certified_steps += 1;
            }
        }
    }

    /// Whether more than [`TRUNCATION_DOMINATED`] of the steps were truncated: the path is
    /// stable but biased.
    pub fn truncation_dominated(&self) -> bool {
        self.truncated_fraction() > TRUNCATION_DOMINATED
    }

    /// Share of steps with eta < 1.
    pub fn truncated_fraction(&self) -> f64 {
        if self.steps == 0 {
            0.0
        } else {
            self.truncated_steps as f64 / self.steps as f64
        }
    }
}

/// A path in progress: the index k of the next step, mu_k (empty unless tracked) and the
/// diagnostics so far. The state (r_k, v_k) is held by the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct PathState {
    /// Steps taken.
    pub k: usize,
    /// mu_k, accumulated from the schemes' multiplier increments; empty if not tracked.
    pub mu: Vec<f64>,
    /// What the steps so far did.
    pub diagnostics: PathDiagnostics,
    /// Whether [`advance`] measures |g(r_k)| and |Dg(r_k) v_k| where a scheme did not
    /// (an O(n) product per step).
    pub measure_residuals: bool,
    /// Buffer of length m for the residuals.
    residual: Vec<f64>,
}

impl PathState {
    /// A path at k = 0 of a system with `m` constraints, tracking mu if `track_mu`.
    pub fn new(m: usize, track_mu: bool, measure_residuals: bool) -> Self {
        Self {
            k: 0,
            mu: if track_mu { vec![0.0; m] } else { Vec::new() },
            diagnostics: PathDiagnostics::default(),
            measure_residuals,
            residual: if measure_residuals {
                vec![0.0; m]
            } else {
                Vec::new()
            },
        }
    }

    /// One step of size h of `scheme` from (r, v) = (r_k, v_k) with the increment dw: the
    /// residuals the scheme did not measure (if [`PathState::measure_residuals`]), the
    /// diagnostics, mu_{k+1} = mu_k + (mu_{k+1} - mu_k) (seed eq. 1.4) and k + 1. On failure
    /// nothing changes (a non-finite failure with a non-finite dw is reported as the
    /// increment's, [`StepFailure::blaming_increment`]).
    #[inline]
    pub fn step<S: Scheme + ?Sized>(
        &mut self,
        scheme: &mut S,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
    ) -> Result<StepOutcome, StepFailure> {
        let mut outcome = scheme
            .step(r, v, h, dw)
            .map_err(|failure| failure.blaming_increment(dw))?;
        if self.measure_residuals {
            self.complete(scheme.system().constraint(), r, v, &mut outcome);
        }
        self.diagnostics.record(&outcome, h);
        if !self.mu.is_empty() {
            for (acc, d) in self.mu.iter_mut().zip(scheme.multiplier_increment()) {
                *acc += d;
            }
        }
        self.k += 1;
        Ok(outcome)
    }

    /// Measures the residuals the scheme did not report into the outcome.
    fn complete<C: Constraint>(&mut self, c: &C, r: &[f64], v: &[f64], outcome: &mut StepOutcome) {
        if outcome.position_residual.is_none() {
            c.value(r, &mut self.residual);
            outcome.position_residual = Some(max_abs(&self.residual));
        }
        if outcome.velocity_residual.is_none() {
            c.jacobian_mul(r, v, &mut self.residual);
            outcome.velocity_residual = Some(max_abs(&self.residual));
        }
    }
}

/// Takes `steps` steps of `grid.h()` from (r, v) = (r_k, v_k), k = `path.k`, with increments
/// from `increments`: updates mu and the diagnostics, calls [`Observer::step_done`] after each
/// step and [`Observer::observe`] at the steps it wants and at k = N. On failure the step index
/// and time are those of the failing step, (r, v) and `path` hold the last good state.
pub fn advance<S, I, O>(
    scheme: &mut S,
    r: &mut [f64],
    v: &mut [f64],
    path: &mut PathState,
    (grid, steps): (TimeGrid, usize),
    increments: &mut I,
    observer: &mut O,
) -> Result<(), StepError>
where
    S: Scheme + ?Sized,
    I: IncrementSource + ?Sized,
    O: Observer + ?Sized,
{
    let h = grid.h();
    let mut dw = vec![0.0; increments.dim()];
    for _ in 0..steps {
        let k = path.k;
        increments.next_increment(h, &mut dw);
        let outcome = path
            .step(scheme, r, v, h, &dw)
            .map_err(|failure| StepError {
                step: k,
                time: grid.time(k),
                failure,
            })?;
        observer.step_done(k, &outcome);
        if path.k == grid.steps() || observer.wants_step(path.k) {
            observer.observe(path.k, grid.time(path.k), r, v, &path.mu);
        }
    }
    Ok(())
}

/// Checks a path's start: (r_0, v_0) on the tangent bundle within
/// [`INITIAL_STATE_TOLERANCE`], increments of dimension l, and at least N of them.
fn check_start<S, I>(
    scheme: &S,
    r: &[f64],
    v: &[f64],
    grid: TimeGrid,
    increments: &I,
) -> Result<(), ModelError>
where
    S: Scheme + ?Sized,
    I: IncrementSource + ?Sized,
{
    let system = scheme.system();
    check_state(system.constraint(), r, v, INITIAL_STATE_TOLERANCE)?;
    check_dim(
        "increment source dimension",
        system.noise_dim(),
        increments.dim(),
    )?;
    if let Some(left) = increments.remaining() {
        check_dim(
            "number of recorded increments",
            grid.steps(),
            left.min(grid.steps()),
        )?;
    }
    Ok(())
}

/// Runs `scheme` from (r_0, v_0) over `grid`, drawing increments from `increments` and
/// reporting to `observer` (at k = 0, k = N and the steps it wants; mu is accumulated only if
/// the observer wants it). r and v hold the final state afterwards (or the last good state).
///
/// Fails before the first step (as step 0) if the initial state is off the tangent bundle by
/// more than [`INITIAL_STATE_TOLERANCE`] or the increments have the wrong dimension or are too
/// few. The diagnostics' residuals are measured after every step where the scheme did not
/// measure them itself.
pub fn run_path<S, I, O>(
    scheme: &mut S,
    r: &mut [f64],
    v: &mut [f64],
    grid: TimeGrid,
    increments: &mut I,
    observer: &mut O,
) -> Result<PathDiagnostics, PathFailure>
where
    S: Scheme + ?Sized,
    I: IncrementSource + ?Sized,
    O: Observer + ?Sized,
{
    let m = scheme.system().constraint().n_constraints();
    let mut path = PathState::new(m, observer.wants_mu(), true);
    let failed = |error: StepError, path: &PathState| PathFailure {
        error,
        diagnostics: Box::new(path.diagnostics.clone()),
    };
    if let Err(e) = check_start(scheme, r, v, grid, increments) {
        let error = StepError {
            step: 0,
            time: 0.0,
            failure: StepFailure::Input(e),
        };
        return Err(failed(error, &path));
    }
    observer.observe(0, 0.0, r, v, &path.mu);
    advance(
        scheme,
        r,
        v,
        &mut path,
        (grid, grid.steps()),
        increments,
        observer,
    )
    .map_err(|error| failed(error, &path))?;
    Ok(path.diagnostics)
}
