//! What happened along a path: its [`PathDiagnostics`] (steps, truncations, Newton iterations,
//! residuals, the kappa certificates' margins) and, for a path that stopped early, the
//! [`PathFailure`] that carries them with the failing step's error.

use crate::error::StepError;
use crate::scheme::StepOutcome;

/// Largest Newton iteration count tracked separately in the histogram; larger counts share the
/// last bin.
pub const ITERATION_BINS: usize = 16;

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
