//! The solver interface and the path driver of the reference solvers.

use sdae_manifold::vector::max_abs;
use sdae_manifold::{Constraint, check_state};
use sdae_scheme::{INITIAL_STATE_TOLERANCE, IncrementSource, Observer, System, TimeGrid};

use crate::error::{ReferenceError, ReferencePathError};
use crate::inherent::{CurvedSystem, InherentSde};

/// What one step of a reference solver did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceStepReport {
    /// The drift truncation factor theta in (0, 1] (1 for untruncated solvers).
    pub truncation: f64,
    /// Newton iterations of the position projection (0 for unprojected solvers).
    pub projection_iterations: usize,
}

impl Default for ReferenceStepReport {
    fn default() -> Self {
        Self {
            truncation: 1.0,
            projection_iterations: 0,
        }
    }
}

/// A one-step solver of the inherent SDE (seed eq. 2.4) that also gives the multiplier
/// increment of eq. 2.3.
pub trait ReferenceSolver {
    /// The system solved.
    type System: CurvedSystem;
    /// The inherent SDE (and through it the system).
    fn sde(&self) -> &InherentSde<Self::System>;
    /// Advances (r, v) by one step of size h with the Brownian increment dw (length l).
    fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
    ) -> Result<ReferenceStepReport, ReferenceError>;
    /// The increment of mu (eq. 2.3) over the last successful step.
    fn multiplier_increment(&self) -> &[f64];
}

/// What happened along a reference path.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceDiagnostics {
    /// Steps completed.
    pub steps: usize,
    /// Steps with truncation factor < 1.
    pub truncated_steps: usize,
    /// Smallest truncation factor.
    pub min_truncation: f64,
    /// Newton iterations of the projections, summed.
    pub projection_iterations: usize,
    /// Largest |g(r_k)| over the path (unprojected solvers drift off the manifold by O(h)).
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| over the path.
    pub max_velocity_residual: f64,
}

impl Default for ReferenceDiagnostics {
    fn default() -> Self {
        Self {
            steps: 0,
            truncated_steps: 0,
            min_truncation: 1.0,
            projection_iterations: 0,
            max_position_residual: 0.0,
            max_velocity_residual: 0.0,
        }
    }
}

fn grid(t_end: f64, steps: usize) -> Result<TimeGrid, ReferenceError> {
    if !(t_end.is_finite() && t_end > 0.0) {
        return Err(ReferenceError::InvalidSetting {
            name: "T",
            value: t_end,
            reason: "final time must be finite and > 0",
        });
    }
    if steps == 0 {
        return Err(ReferenceError::InvalidSetting {
            name: "N",
            value: 0.0,
            reason: "number of steps must be >= 1",
        });
    }
    TimeGrid::new(t_end, steps).map_err(|_| ReferenceError::InvalidSetting {
        name: "T",
        value: t_end,
        reason: "final time must be finite and > 0",
    })
}

fn check_inputs<S: ReferenceSolver, I: IncrementSource>(
    solver: &S,
    r: &[f64],
    v: &[f64],
    steps: usize,
    increments: &I,
) -> Result<(), ReferenceError> {
    let sde = solver.sde();
    check_state(sde.system().constraint(), r, v, INITIAL_STATE_TOLERANCE)?;
    crate::error::check_dim(
        "increment source dimension",
        sde.noise_dim(),
        increments.dim(),
    )?;
    if let Some(left) = increments.remaining() {
        if left < steps {
            return Err(ReferenceError::DimensionMismatch {
                what: "number of recorded increments",
                expected: steps,
                found: left,
            });
        }
    }
    Ok(())
}

/// Runs `solver` from (r_0, v_0) over N = `steps` steps of h = T / N, drawing increments from
/// `increments` and reporting to `observer` (at k = 0, k = N and the steps it wants). mu is
/// accumulated from the increments of eq. 2.3 only if the observer wants it. r and v hold the
/// final state afterwards (or the last state reached).
///
/// Fails before the first step (as step 0) if T is not finite and > 0, N = 0, the initial state
/// is off the tangent bundle by more than [`INITIAL_STATE_TOLERANCE`]
/// (`sdae_manifold::check_state`), or the increments have the wrong dimension or are too few.
///
/// [`Observer::step_done`] is not called: it takes the scheme's `StepReport`; the reference
/// solvers' per-step information is summed in the returned [`ReferenceDiagnostics`].
pub fn run_reference_path<S, I, O>(
    solver: &mut S,
    r: &mut [f64],
    v: &mut [f64],
    t_end: f64,
    steps: usize,
    increments: &mut I,
    observer: &mut O,
) -> Result<ReferenceDiagnostics, ReferencePathError>
where
    S: ReferenceSolver,
    I: IncrementSource,
    O: Observer,
{
    let at_start = |error| ReferencePathError {
        step: 0,
        time: 0.0,
        error,
    };
    let grid = grid(t_end, steps).map_err(at_start)?;
    check_inputs(solver, r, v, steps, increments).map_err(at_start)?;
    let (m, l) = (solver.sde().n_constraints(), solver.sde().noise_dim());
    let h = grid.h();
    let mut dw = vec![0.0; l];
    let mut residual = vec![0.0; m];
    let mut mu = if observer.wants_mu() {
        vec![0.0; m]
    } else {
        Vec::new()
    };
    let mut diagnostics = ReferenceDiagnostics::default();
    observer.observe(0, 0.0, r, v, &mu);
    for k in 0..steps {
        increments.next_increment(h, &mut dw);
        let report = solver
            .step(r, v, h, &dw)
            .map_err(|error| ReferencePathError {
                step: k,
                time: grid.time(k),
                error,
            })?;
        diagnostics.steps += 1;
        if report.truncation < 1.0 {
            diagnostics.truncated_steps += 1;
        }
        diagnostics.min_truncation = diagnostics.min_truncation.min(report.truncation);
        diagnostics.projection_iterations += report.projection_iterations;
        let constraint = solver.sde().system().constraint();
        constraint.value(r, &mut residual);
        diagnostics.max_position_residual =
            diagnostics.max_position_residual.max(max_abs(&residual));
        constraint.jacobian_mul(r, v, &mut residual);
        diagnostics.max_velocity_residual =
            diagnostics.max_velocity_residual.max(max_abs(&residual));
        if !mu.is_empty() {
            for (acc, d) in mu.iter_mut().zip(solver.multiplier_increment()) {
                *acc += d;
            }
        }
        let next = k + 1;
        if next == steps || observer.wants_step(next) {
            observer.observe(next, grid.time(next), r, v, &mu);
        }
    }
    Ok(diagnostics)
}
