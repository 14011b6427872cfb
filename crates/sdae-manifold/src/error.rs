//! The error type of this crate.

use thiserror::Error;

/// What can go wrong when building a manifold, a mass matrix or checking a state.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ManifoldError {
    /// A vector or matrix has the wrong length.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// Length the manifold or mass matrix needs.
        expected: usize,
        /// Length that was passed.
        found: usize,
    },
    /// A parameter is out of its allowed range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the parameter must satisfy.
        reason: &'static str,
    },
    /// A value is NaN or infinite.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Which argument.
        what: &'static str,
        /// First non-finite entry.
        index: usize,
    },
    /// The mass matrix is not symmetric.
    #[error("mass matrix is not symmetric: |M[{row}][{col}] - M[{col}][{row}]| = {difference:e}")]
    NotSymmetric {
        /// Row of the largest asymmetry.
        row: usize,
        /// Column of the largest asymmetry.
        col: usize,
        /// Size of the asymmetry.
        difference: f64,
    },
    /// The mass matrix couples coordinates that the constraint's Gram storage keeps apart (a
    /// bead chain's tridiagonal Gram matrix needs an M^-1 that couples no two beads).
    #[error(
        "mass matrix couples beads {first} and {second}: (M^-1)[{row}][{col}] = {entry:e}; a bead chain needs a mass that does not couple beads (block-diagonal per bead)"
    )]
    CoupledMass {
        /// The first bead.
        first: usize,
        /// The second bead.
        second: usize,
        /// Row of the coupling entry of M^-1.
        row: usize,
        /// Its column.
        col: usize,
        /// Its value.
        entry: f64,
    },
    /// The mass matrix is not positive definite.
    #[error("mass matrix is not positive definite: {detail}")]
    NotPositiveDefinite {
        /// Where the Cholesky factorization broke down, or which diagonal entry is not positive.
        detail: String,
    },
    /// A position is not on the constraint manifold.
    #[error(
        "position is off the manifold: max |g(r)| = {residual:e} at constraint {index} exceeds tolerance {tolerance:e}"
    )]
    OffManifold {
        /// Largest |g_i(r)|.
        residual: f64,
        /// Constraint index i where it occurs.
        index: usize,
        /// Allowed size.
        tolerance: f64,
    },
    /// A velocity is not tangent to the manifold.
    #[error(
        "velocity is not tangent: max |Dg(r) v| = {residual:e} at constraint {index} exceeds tolerance {tolerance:e}"
    )]
    OffTangent {
        /// Largest |(Dg(r) v)_i|.
        residual: f64,
        /// Constraint index i where it occurs.
        index: usize,
        /// Allowed size.
        tolerance: f64,
    },
}

/// A linear system could not be factored.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LinearError {
    /// A pivot is zero or negligible: the matrix is singular to working precision.
    #[error("singular matrix: pivot {index} is {pivot:e}")]
    Singular {
        /// Index of the failing pivot.
        index: usize,
        /// Its value.
        pivot: f64,
    },
    /// The matrix has a NaN or infinite entry.
    #[error("non-finite matrix entry in row {index}")]
    NonFinite {
        /// Row of the first non-finite entry found.
        index: usize,
    },
}

/// Checks that a slice has the expected length.
pub fn check_len(what: &'static str, expected: usize, slice: &[f64]) -> Result<(), ManifoldError> {
    if slice.len() == expected {
        Ok(())
    } else {
        Err(ManifoldError::DimensionMismatch {
            what,
            expected,
            found: slice.len(),
        })
    }
}

/// Checks that every entry of a slice is finite.
#[inline]
pub fn check_finite(what: &'static str, slice: &[f64]) -> Result<(), ManifoldError> {
    match slice.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(ManifoldError::NonFinite { what, index }),
    }
}

/// Checks that a parameter is finite and strictly positive.
pub fn check_positive(name: &'static str, value: f64) -> Result<(), ManifoldError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ManifoldError::InvalidParameter {
            name,
            value,
            reason: "must be finite and > 0",
        })
    }
}

/// Checks that a count is at least `min`.
pub fn check_at_least(
    name: &'static str, value: usize, min: usize, reason: &'static str,
) -> Result<(), ManifoldError> {
    if value >= min {
        Ok(())
    } else {
        Err(ManifoldError::InvalidParameter {
            name,
            value: value as f64,
            reason,
        })
    }
}
