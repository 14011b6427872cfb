//! The error type of the root solver.

use sdae_manifold::LinearError;
use thiserror::Error;

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
    /// A root was found but it lies outside the ball |gamma| < radius, even with the part that
    /// only corrects rounding set aside: a spurious root.
    #[error(
        "spurious root: |gamma| = {norm:e} is not inside the ball of radius {radius:e} \
         (of which at most {rounding:e} corrects rounding)"
    )]
    OutsideBall {
        /// Euclidean norm of the root found.
        norm: f64,
        /// Radius of the ball (C_kappa).
        radius: f64,
        /// The part of |gamma| that may only correct residuals below the solver's tolerance
        /// ([`Certificate::rounding`](crate::Certificate::rounding)).
        rounding: f64,
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
    /// A root in the ball whose contraction estimate |J(0)^-1 J(gamma*) - I| reaches the
    /// limit: the theorem's uniqueness argument (Thm 3.4, Step 3: < 1/2) does not back it.
    #[error(
        "uncertified root: contraction estimate {contraction:.3} reaches the limit {limit} \
         (Thm 3.4 needs < 1/2)"
    )]
    NotContracting {
        /// The estimate (a power iteration, a lower bound of the norm).
        contraction: f64,
        /// [`SolverSettings::max_contraction`](crate::SolverSettings::max_contraction).
        limit: f64,
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
