//! The error types of the reference solvers.

use sdae_ift::{IftError, LinearError};
use sdae_manifold::ManifoldError;
use thiserror::Error;

/// Why an evaluation or a step of a reference solver failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReferenceError {
    /// A state check failed (off the manifold, not tangent, non-finite or wrong-length input,
    /// mass matrix of the wrong order).
    #[error(transparent)]
    Manifold(#[from] ManifoldError),
    /// An argument has the wrong length, or the parts of the system do not fit together.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// The size needed.
        expected: usize,
        /// The size passed.
        found: usize,
    },
    /// The step size is NaN, infinite, zero or negative.
    #[error("invalid step size h = {h}: must be finite and > 0")]
    InvalidStepSize {
        /// The offending step size.
        h: f64,
    },
    /// A setting (final time T, number of steps N, truncation scale) is out of range.
    #[error("invalid setting {name} = {value}: {reason}")]
    InvalidSetting {
        /// Setting name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// G_M(r) = Dg(r) M^-1 grad g(r) cannot be factored: Dg(r) lacks full rank.
    #[error("Gram matrix G_M(r) is singular (Dg(r) lacks full rank): {source}")]
    SingularGram {
        /// The failure of the factorization.
        source: LinearError,
    },
    /// The projection of the position onto the manifold (projected Euler-Maruyama) failed.
    #[error("projection onto the manifold failed: {source}")]
    Projection {
        /// The failure of the root solver.
        source: IftError,
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

/// A step of a reference path failed: what, at which step and time.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("step {step} (t = {time}) failed: {error}")]
pub struct ReferencePathError {
    /// Index k of the failing step (from t_k to t_{k+1}); 0 for input checks before the path.
    pub step: usize,
    /// t_k.
    pub time: f64,
    /// What went wrong.
    #[source]
    pub error: ReferenceError,
}

/// Fails with [`ReferenceError::NonFinite`] unless every entry is finite.
pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<(), ReferenceError> {
    let size = sdae_manifold::vector::max_abs(values);
    if size.is_finite() {
        Ok(())
    } else {
        Err(ReferenceError::NonFinite { what, size })
    }
}

/// Fails with [`ReferenceError::DimensionMismatch`] unless `found == expected`.
pub(crate) fn check_dim(
    what: &'static str,
    expected: usize,
    found: usize,
) -> Result<(), ReferenceError> {
    if expected == found {
        Ok(())
    } else {
        Err(ReferenceError::DimensionMismatch {
            what,
            expected,
            found,
        })
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
