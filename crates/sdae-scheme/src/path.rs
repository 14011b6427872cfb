//! The path driver: N fixed steps h = T/N from (r_0, v_0), mu_k = sum_{j<=k} lambda_j
//! (seed eq. 1.4), observers at chosen steps, and per-path diagnostics.

use sdae_ift::{Factorize, Method};
use sdae_manifold::{Constraint, check_state};

use crate::error::{SchemeError, StepError};
use crate::increments::IncrementSource;
use crate::stepper::{StepReport, Stepper};
use crate::system::System;

/// The grid t_k = k h, h = T / N, k = 0..=N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeGrid {
    t_end: f64,
    steps: usize,
}

impl TimeGrid {
    /// T > 0 finite, N >= 1.
    pub fn new(t_end: f64, steps: usize) -> Result<Self, SchemeError> {
        if !(t_end.is_finite() && t_end > 0.0) {
            return Err(SchemeError::InvalidSetting {
                name: "T",
                value: t_end,
                reason: "final time must be finite and > 0",
            });
        }
        if steps == 0 {
            return Err(SchemeError::InvalidSetting {
                name: "N",
                value: 0.0,
                reason: "number of steps must be >= 1",
            });
        }
        Ok(Self { t_end, steps })
    }
    /// T.
    pub fn t_end(&self) -> f64 {
        self.t_end
    }
    /// N.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// h = T / N.
    pub fn h(&self) -> f64 {
        self.t_end / self.steps as f64
    }
    /// t_k.
    pub fn time(&self, k: usize) -> f64 {
        if k == self.steps {
            self.t_end
        } else {
            k as f64 * self.h()
        }
    }
}

/// Receives the state at steps of the path.
pub trait Observer {
    /// Whether mu must be accumulated (it is not otherwise).
    fn wants_mu(&self) -> bool {
        false
    }
    /// Whether to be called at step k (k = 0 and k = N are always offered).
    fn wants_step(&self, k: usize) -> bool {
        let _ = k;
        true
    }
    /// The state at t_k; `mu` is empty unless [`Observer::wants_mu`].
    fn observe(&mut self, k: usize, t: f64, r: &[f64], v: &[f64], mu: &[f64]);
    /// After a successful step, with its report.
    fn step_done(&mut self, k: usize, report: &StepReport) {
        let _ = (k, report);
    }
}

/// Observes nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl Observer for NoObserver {
    fn wants_step(&self, _k: usize) -> bool {
        false
    }
    fn observe(&mut self, _k: usize, _t: f64, _r: &[f64], _v: &[f64], _mu: &[f64]) {}
}

/// How to read a recorded trajectory between grid points (seed Remark 4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// The value at the last grid point t_k <= t.
    PiecewiseConstant,
    /// Linear between t_k <= t <= t_{k+1}.
    PiecewiseLinear,
}

/// Records r, v (and mu if asked) at every `every`-th step and at the end.
#[derive(Debug, Clone, Default)]
pub struct Recorder {
    every: usize,
    record_mu: bool,
    dim: usize,
    mu_dim: usize,
    /// Recorded step indices.
    pub steps: Vec<usize>,
    /// Recorded times.
    pub times: Vec<f64>,
    /// Recorded positions, one row of n per time.
    pub r: Vec<f64>,
    /// Recorded velocities.
    pub v: Vec<f64>,
    /// Recorded multipliers mu, one row of m per time (empty unless asked).
    pub mu: Vec<f64>,
}

impl Recorder {
    /// Records every `every`-th step (>= 1).
    pub fn every(every: usize) -> Self {
        Self {
            every: every.max(1),
            ..Self::default()
        }
    }
    /// Also records mu.
    pub fn with_mu(mut self) -> Self {
        self.record_mu = true;
        self
    }
    /// Number of recorded times.
    pub fn len(&self) -> usize {
        self.times.len()
    }
    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }
    /// Recorded position number i.
    pub fn position(&self, i: usize) -> &[f64] {
        &self.r[i * self.dim..(i + 1) * self.dim]
    }
    /// Recorded velocity number i.
    pub fn velocity(&self, i: usize) -> &[f64] {
        &self.v[i * self.dim..(i + 1) * self.dim]
    }
    /// Recorded multiplier number i (empty unless recorded).
    pub fn multiplier(&self, i: usize) -> &[f64] {
        if self.mu_dim == 0 {
            &[]
        } else {
            &self.mu[i * self.mu_dim..(i + 1) * self.mu_dim]
        }
    }

    /// The interpolated (r, v, mu) at time t into the three buffers (seed Remark 4.2); t is
    /// clamped to the recorded range. Returns `None` if nothing was recorded.
    pub fn interpolate(
        &self,
        t: f64,
        how: Interpolation,
        r: &mut [f64],
        v: &mut [f64],
        mu: &mut [f64],
    ) -> Option<()> {
        if self.times.is_empty() {
            return None;
        }
        let k = self.times.partition_point(|&s| s <= t).saturating_sub(1);
        let k1 = (k + 1).min(self.times.len() - 1);
        let w = match how {
            Interpolation::PiecewiseConstant => 0.0,
            Interpolation::PiecewiseLinear if k1 == k => 0.0,
            Interpolation::PiecewiseLinear => {
                ((t - self.times[k]) / (self.times[k1] - self.times[k])).clamp(0.0, 1.0)
            }
        };
        let blend = |a: &[f64], b: &[f64], out: &mut [f64]| {
            for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
                *o = (1.0 - w) * x + w * y;
            }
        };
        blend(self.position(k), self.position(k1), r);
        blend(self.velocity(k), self.velocity(k1), v);
        blend(self.multiplier(k), self.multiplier(k1), mu);
        Some(())
    }
}

impl Observer for Recorder {
    fn wants_mu(&self) -> bool {
        self.record_mu
    }
    fn wants_step(&self, k: usize) -> bool {
        k % self.every == 0
    }
    fn observe(&mut self, k: usize, t: f64, r: &[f64], v: &[f64], mu: &[f64]) {
        if self.steps.last() == Some(&k) {
            return;
        }
        self.dim = r.len();
        self.mu_dim = mu.len();
        self.steps.push(k);
        self.times.push(t);
        self.r.extend_from_slice(r);
        self.v.extend_from_slice(v);
        self.mu.extend_from_slice(mu);
    }
}

/// Largest Newton iteration count tracked separately in the histogram; larger counts share the
/// last bin.
pub const ITERATION_BINS: usize = 16;

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
    /// Largest |Dg(r_k) v_k| (NaN if not monitored).
    pub max_velocity_residual: f64,
    /// Largest |kappa_k| / C_kappa (0 if C_kappa is infinite).
    pub max_kappa_ratio: f64,
    /// Largest contraction estimate of the kappa solver.
    pub max_contraction: f64,
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
        }
    }
}

impl PathDiagnostics {
    /// Adds one step's report.
    pub fn record(&mut self, report: &StepReport) {
        let c = &report.certificate;
        self.steps += 1;
        if report.eta < 1.0 {
            self.truncated_steps += 1;
        }
        self.min_eta = self.min_eta.min(report.eta);
        self.newton_iterations += c.iterations;
        self.iteration_histogram[c.iterations.min(ITERATION_BINS - 1)] += 1;
        if c.method == Method::Homotopy {
            self.homotopy_steps += 1;
        }
        self.max_position_residual = self.max_position_residual.max(report.position_residual);
        // f64::max ignores NaN, so an unmonitored run keeps 0; mark it NaN explicitly.
        self.max_velocity_residual = if report.velocity_residual.is_nan() {
            f64::NAN
        } else {
            self.max_velocity_residual.max(report.velocity_residual)
        };
        if c.radius.is_finite() {
            self.max_kappa_ratio = self.max_kappa_ratio.max(c.norm / c.radius);
        }
        self.max_contraction = self.max_contraction.max(c.contraction);
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

/// A path that stopped early: the error and what was done before it.
#[derive(Debug, Clone, PartialEq)]
pub struct PathFailure {
    /// The failing step.
    pub error: StepError,
    /// Diagnostics of the steps that succeeded.
    pub diagnostics: Box<PathDiagnostics>,
}

impl std::fmt::Display for PathFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (after {} good steps)",
            self.error, self.diagnostics.steps
        )
    }
}

impl std::error::Error for PathFailure {}

/// Tolerance for |g(r_0)| and |Dg(r_0) v_0| of a path's initial state.
pub const INITIAL_STATE_TOLERANCE: f64 = 1e-10;

/// Runs the scheme from (r_0, v_0) over `grid`, drawing increments from `increments` and
/// reporting to `observer`. r and v hold the final state afterwards (or the last good state).
///
/// Fails before the first step (as step 0) if the initial state is off the tangent bundle by
/// more than [`INITIAL_STATE_TOLERANCE`] or the increments have the wrong dimension.
pub fn run_path<S, I, O>(
    stepper: &mut Stepper<S>,
    r: &mut [f64],
    v: &mut [f64],
    grid: TimeGrid,
    increments: &mut I,
    observer: &mut O,
) -> Result<PathDiagnostics, PathFailure>
where
    S: System,
    <S::Constraint as Constraint>::Gram: Factorize,
    I: IncrementSource,
    O: Observer,
{
    let fail = |step: usize, failure, diagnostics: &PathDiagnostics| PathFailure {
        error: StepError {
            step,
            time: grid.time(step),
            failure,
        },
        diagnostics: Box::new(diagnostics.clone()),
    };
    let mut diagnostics = PathDiagnostics::default();
    let constraint = stepper.system().constraint();
    let (m, l) = (constraint.n_constraints(), stepper.system().noise_dim());
    if let Err(e) = check_state(constraint, r, v, INITIAL_STATE_TOLERANCE) {
        return Err(fail(
            0,
            crate::error::StepFailure::Input(e.into()),
            &diagnostics,
        ));
    }
    if increments.dim() != l {
        let e = SchemeError::DimensionMismatch {
            what: "increment source dimension",
            expected: l,
            found: increments.dim(),
        };
        return Err(fail(0, crate::error::StepFailure::Input(e), &diagnostics));
    }
    if let Some(left) = increments.remaining() {
        if left < grid.steps() {
            let e = SchemeError::DimensionMismatch {
                what: "number of recorded increments",
                expected: grid.steps(),
                found: left,
            };
            return Err(fail(0, crate::error::StepFailure::Input(e), &diagnostics));
        }
    }
    let h = grid.h();
    let mut dw = vec![0.0; l];
    let mut mu = if observer.wants_mu() {
        vec![0.0; m]
    } else {
        Vec::new()
    };
    observer.observe(0, 0.0, r, v, &mu);
    for k in 0..grid.steps() {
        increments.next_increment(h, &mut dw);
        let report = stepper
            .step(r, v, h, &dw)
            .map_err(|failure| fail(k, failure, &diagnostics))?;
        diagnostics.record(&report);
        observer.step_done(k, &report);
        if !mu.is_empty() {
            for (acc, l) in mu.iter_mut().zip(stepper.lambda()) {
                *acc += l;
            }
        }
        let next = k + 1;
        if next == grid.steps() || observer.wants_step(next) {
            observer.observe(next, grid.time(next), r, v, &mu);
        }
    }
    Ok(diagnostics)
}
