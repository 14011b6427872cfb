//! The error type of the stepper's construction and constants. Failures of a step are
//! [`sdae_model::StepFailure`]s, shared by every scheme.

use sdae_manifold::ManifoldError;
use sdae_model::ModelError;
use thiserror::Error;

/// A configuration or input that the scheme cannot run with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SchemeError {
    /// A setting out of range, parts that do not fit, a constraint, mass or state check.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The theory constants need C_g, which this constraint does not know.
    #[error(
        "no bound on C_g (seed eq. 2.2) is known for this constraint: set C_eta and C_kappa explicitly"
    )]
    NoTheoryBound,
}

impl From<ManifoldError> for SchemeError {
    fn from(e: ManifoldError) -> Self {
        SchemeError::Model(e.into())
    }
}

impl SchemeError {
    /// [`ModelError::InvalidSetting`]: setting `name` = `value` violates `reason`.
    pub(crate) fn invalid(name: &'static str, value: f64, reason: &'static str) -> Self {
        SchemeError::Model(ModelError::InvalidSetting {
            name,
            value,
            reason,
        })
    }
}
