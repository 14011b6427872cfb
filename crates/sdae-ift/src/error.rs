//! Error types of the root solver and the linear solvers.

use thiserror::Error;

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

/// Why a root in the ball was not found.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum IftError {
    /// Newton (and the homotopy corrector, if enabled) did not reach the tolerance.
    #[error(
        "no convergence after {iterations} iterations: residual {last:e} > tolerance {tolerance:e} (history {history:?})",
        last = history.last().copied().unwrap_or(f64::NAN)
    )]
    NoConvergence {
        /// Newton iterations done.
        iterations: usize,
        /// Residual max-norm after each evaluation.
        history: Vec<f64>,
        /// The tolerance that was asked for.
        tolerance: f64,
    },
    /// A root was found but it lies outside the ball |gamma| < radius: a spurious root.
    #[error("spurious root: |gamma| = {norm:e} is not inside the ball of radius {radius:e}")]
    OutsideBall {
        /// Euclidean norm of the root found.
        norm: f64,
        /// Radius of the ball (C_kappa).
        radius: f64,
    },
    /// A root was found, but it is far larger than the first Newton step justifies: with a
    /// contraction factor q the right root satisfies |gamma| <= |step_1| / (1 - q).
    #[error(
        "implausible root: |gamma| = {norm:e} exceeds {factor} x |first Newton step| = {bound:e} (likely the second root)"
    )]
    Implausible {
        /// Euclidean norm of the root found.
        norm: f64,
        /// factor x |first Newton step|.
        bound: f64,
        /// The plausibility factor.
        factor: f64,
    },
    /// The homotopy path from gamma = 0 at tau = 0 ends at a fold before tau = 1: no root is
    /// connected to gamma = 0 (seed Fig. 1b).
    #[error(
        "no root: the homotopy path stops at a fold at tau = {tau:.6} < 1 (|gamma| = {norm:e})"
    )]
    NoRoot {
        /// Last tau reached on the path.
        tau: f64,
        /// |gamma| there.
        norm: f64,
    },
    /// The Jacobian is singular at an iterate.
    #[error("singular Jacobian at Newton iteration {iteration}: {source}")]
    Singular {
        /// Iteration where the factorization failed.
        iteration: usize,
        /// The failure of the linear solver.
        source: LinearError,
    },
    /// The residual or the iterate became NaN or infinite.
    #[error("non-finite {what} at Newton iteration {iteration}")]
    NonFinite {
        /// "residual" or "iterate".
        what: &'static str,
        /// Iteration where it happened.
        iteration: usize,
    },
}
