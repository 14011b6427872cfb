//! Error types of the stepper and the path driver.

use sdae_ift::IftError;
use sdae_manifold::ManifoldError;
use thiserror::Error;

/// A configuration or input that the scheme cannot run with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SchemeError {
    /// A constraint, mass or state check failed.
    #[error(transparent)]
    Manifold(#[from] ManifoldError),
    /// A setting is out of range.
    #[error("invalid setting {name} = {value}: {reason}")]
    InvalidSetting {
        /// Setting name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// Two parts of the system do not fit together.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was compared.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// The theory constants need C_g, which this constraint does not know.
    #[error(
        "no bound on C_g (seed eq. 2.2) is known for this constraint: set C_eta and C_kappa explicitly"
    )]
    NoTheoryBound,
}

/// Why one step failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StepFailure {
    /// The kappa system (seed eq. 3.1, upper part) has no acceptable root.
    #[error("kappa system: {0}")]
    Kappa(#[from] IftError),
    /// a(r, v) returned a NaN or infinite entry.
    #[error("drift a(r, v) is not finite at index {index}")]
    NonFiniteDrift {
        /// First non-finite entry.
        index: usize,
    },
    /// The new velocity is NaN or infinite (blow-up).
    #[error("velocity is not finite after the step (|v|^2 = {norm2})")]
    NonFiniteVelocity {
        /// Squared norm of the offending velocity.
        norm2: f64,
    },
    /// A step input has the wrong size or value.
    #[error("invalid step input: {0}")]
    Input(SchemeError),
}

/// A step of a path failed: what, at which step and time.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("step {step} (t = {time}) failed: {failure}")]
pub struct StepError {
    /// Index k of the failing step (from t_k to t_{k+1}).
    pub step: usize,
    /// t_k.
    pub time: f64,
    /// What went wrong.
    pub failure: StepFailure,
}
