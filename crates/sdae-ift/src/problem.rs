//! The problem interface: a map R: R^m -> R^m whose root near 0 is wanted.

use sdae_manifold::Factorize;

/// A nonlinear system R(gamma) = 0 with its Jacobian in a structured storage.
///
/// For the scheme (seed eq. 3.1, upper part) R(gamma) = g(y + M^-1 grad g(r) gamma) with
/// y = r + eta v h, and the homotopy of eq. 3.10 is F(tau, gamma) = R(gamma) + (tau - 1) R(0).
pub trait BallProblem {
    /// Storage of the Jacobian D R(gamma).
    type Matrix: Factorize;
    /// The dimension m.
    fn dim(&self) -> usize;
    /// residual = R(gamma), and, when asked, jacobian = D R(gamma).
    fn evaluate(
        &mut self, gamma: &[f64], residual: &mut [f64], jacobian: Option<&mut Self::Matrix>,
    );
    /// The coefficients [c0, c1, c2] of R(gamma) = c0 + c1 gamma + c2 gamma^2 when m = 1 and R
    /// is this quadratic polynomial exactly; the solver then takes the root connected to 0 in
    /// closed form ([`BallSolver::solve`](crate::BallSolver::solve)). `None` (the default): Newton.
    fn quadratic(&mut self) -> Option<[f64; 3]> {
        None
    }
    /// The size of max |R(gamma)| that rounding alone produces near the root; the solver does
    /// not ask for a smaller residual. 0 if unknown.
    fn residual_floor(&self) -> f64 {
        0.0
    }
    /// The right-hand side b of a linear system D R(gamma*) z = b with the Jacobian at the root
    /// that the caller solves after the root (the scheme's lambda system, seed eq. 3.1 lower
    /// part), into `out`; `false` (the default) if there is none. Asked where Newton has
    /// converged, after the evaluation at that gamma, so that the solver can solve the system
    /// in the pass that factors D R(gamma) ([`BallSolver::companion`](crate::BallSolver::companion)).
    fn companion_rhs(&mut self, out: &mut [f64]) -> bool {
        let _ = out;
        false
    }
}
