//! The error type of a splitting scheme's construction. Failures of a step are
//! [`sdae_model::StepFailure`]s, shared by every scheme.

use sdae_model::ModelError;
use thiserror::Error;

/// A setting or a system that a splitting scheme cannot run with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SplittingError {
    /// A setting out of range, or parts that do not fit.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The system is not of Langevin type ([`sdae_model::System::langevin`]): its drift has
    /// no constant friction or its noise is not additive (e.g. velocity-dependent drag).
    #[error(
        "the system has no Langevin form (a(r, v) = F(r) - gamma v with constant gamma, B = sigma I): {0}"
    )]
    NotLangevin(&'static str),
}

impl SplittingError {
    /// [`ModelError::InvalidSetting`]: setting `name` = `value` violates `reason`.
    pub(crate) fn invalid(name: &'static str, value: f64, reason: &'static str) -> Self {
        SplittingError::Model(ModelError::InvalidSetting {
            name,
            value,
            reason,
        })
    }
}
