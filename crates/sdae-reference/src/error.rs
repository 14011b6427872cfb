//! The error type of the reference solvers' construction and of the one-shot evaluations of
//! the inherent SDE. Failures of a step are [`sdae_model::StepFailure`]s, shared by every
//! scheme.

use sdae_manifold::{LinearError, ManifoldError};
use sdae_model::{ModelError, StepFailure};
use thiserror::Error;

/// Why a construction or an evaluation of the inherent SDE failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReferenceError {
    /// A setting out of range, an argument of the wrong length, a state check (off the
    /// manifold, not tangent, non-finite), a mass matrix of the wrong order.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// G_M(r) = Dg(r) M^-1 grad g(r) cannot be factored: Dg(r) lacks full rank.
    #[error("Gram matrix G_M(r) is singular (Dg(r) lacks full rank): {source}")]
    SingularGram {
        /// The failure of the factorization.
        source: LinearError,
    },
    /// A value became NaN or infinite: the blow-up that plain Euler-Maruyama shows for large
    /// steps on this drift (it grows like |v|^2, seed Section 5.1).
    #[error("non-finite {what} (blow-up): max |entry| = {size:e}")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
        /// max |entry| (NaN or infinite).
        size: f64,
    },
}

impl From<ManifoldError> for ReferenceError {
    fn from(e: ManifoldError) -> Self {
        ReferenceError::Model(e.into())
    }
}

impl From<LinearError> for ReferenceError {
    fn from(source: LinearError) -> Self {
        match source {
            LinearError::NonFinite { .. } => ReferenceError::NonFinite {
                what: "Gram matrix G_M(r)",
                size: f64::NAN,
            },
            LinearError::Singular { .. } => ReferenceError::SingularGram { source },
        }
    }
}

impl From<ReferenceError> for StepFailure {
    fn from(error: ReferenceError) -> Self {
        match error {
            ReferenceError::Model(e) => StepFailure::Input(e),
            ReferenceError::SingularGram { source } => StepFailure::Singular {
                what: "Gram matrix G_M(r)",
                source,
            },
            ReferenceError::NonFinite { what, size } => StepFailure::NonFinite { what, size },
        }
    }
}

/// Fails with [`ReferenceError::NonFinite`] unless every entry is finite.
#[inline]
pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<(), ReferenceError> {
    if values.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ReferenceError::NonFinite {
            what,
            size: sdae_manifold::vector::max_abs(values),
        })
    }
}
