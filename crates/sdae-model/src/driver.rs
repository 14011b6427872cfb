//! The path driver, written once for every [`Scheme`]: fixed steps h = T/N from (r_0, v_0),
//! mu_k = sum_{j<=k} (mu_{j+1} - mu_j) (seed eq. 1.4), observers at chosen steps, and per-path
//! diagnostics.
//!
//! [`run_path`] runs a whole path; [`advance`] takes a stretch of steps of a path in progress
//! ([`PathState`]), which is what drivers that interleave several paths (the studies' lockstep
//! driver) are built from.

use sdae_manifold::vector::max_abs;
use sdae_manifold::{Constraint, check_state};
use sdae_noise::IncrementSource;

use crate::diagnostics::{PathDiagnostics, PathFailure};
use crate::error::{ModelError, StepError, StepFailure, check_dim};
use crate::grid::TimeGrid;
use crate::observer::Observer;
use crate::scheme::{Scheme, StepOutcome, StepResult};
use crate::system::System;

/// Tolerance for |g(r_0)| and |Dg(r_0) v_0| of a path's initial state.
pub const INITIAL_STATE_TOLERANCE: f64 = 1e-10;

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

    /// Back to k = 0 with mu = 0 and no diagnostics, as [`PathState::new`] leaves it, in the
    /// same buffers.
    pub fn restart(&mut self) {
        self.k = 0;
        self.mu.fill(0.0);
        self.diagnostics = PathDiagnostics::default();
    }

    /// One step of size h of `scheme` from (r, v) = (r_k, v_k) with the increment dw: the
    /// residuals the scheme did not measure (if [`PathState::measure_residuals`]), the
    /// diagnostics, mu_{k+1} = mu_k + (mu_{k+1} - mu_k) (seed eq. 1.4) and k + 1. On failure
    /// nothing changes (a non-finite failure with a non-finite dw is reported as the
    /// increment's, [`StepFailure::blaming_increment`]).
    #[inline]
    pub fn step<S: Scheme + ?Sized>(
        &mut self, scheme: &mut S, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
    ) -> StepResult {
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

/// `count` steps of the grid's h ([`advance`]).
#[derive(Debug, Clone, Copy)]
pub struct Steps {
    /// The grid whose steps are taken.
    pub grid: TimeGrid,
    /// How many.
    pub count: usize,
}

/// Takes `steps.count` steps of `steps.grid.h()` from (r, v) = (r_k, v_k), k = `path.k`, with increments
/// from `increments`: updates mu and the diagnostics, calls [`Observer::step_done`] after each
/// step and [`Observer::observe`] at the steps it wants and at k = N. On failure the step index
/// and time are those of the failing step, (r, v) and `path` hold the last good state.
pub fn advance<S, I, O>(
    scheme: &mut S, r: &mut [f64], v: &mut [f64], path: &mut PathState, steps: Steps,
    increments: &mut I, observer: &mut O,
) -> Result<(), StepError>
where
    S: Scheme + ?Sized,
    I: IncrementSource + ?Sized,
    O: Observer + ?Sized,
{
    let Steps { grid, count } = steps;
    let h = grid.h();
    let mut dw = vec![0.0; increments.dim()];
    for _ in 0..count {
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
    scheme: &S, r: &[f64], v: &[f64], grid: TimeGrid, increments: &I,
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
    scheme: &mut S, r: &mut [f64], v: &mut [f64], grid: TimeGrid, increments: &mut I,
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
    let steps = Steps {
        grid,
        count: grid.steps(),
    };
    advance(scheme, r, v, &mut path, steps, increments, observer)
        .map_err(|error| failed(error, &path))?;
    Ok(path.diagnostics)
}
