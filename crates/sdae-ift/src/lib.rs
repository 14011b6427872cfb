//! Root finding in a ball for the kappa system of the half-explicit Euler scheme
//! (seed eq. 3.1 upper part, Theorem 3.4, Appendix B).
//!
//! [`BallSolver`] runs Newton from gamma = 0 with the Jacobian in the structure the problem
//! gives (the factorizations of `sdae_manifold::Factorize`: scalar, tridiagonal O(m), dense), falls back to the homotopy
//! F(tau, gamma) = R(gamma) + (tau - 1) R(0) of eq. 3.10 when Newton fails, and returns a
//! [`Certificate`]: iterations, residual, |gamma| against the radius, and an estimate of the
//! contraction factor that backs uniqueness (Thm 3.4, Step 3). A problem whose R is a quadratic
//! in one unknown ([`BallProblem::quadratic`], e.g. the pendulum's) is solved in closed form
//! instead, with the same checks and certificate. Roots outside the ball or far
//! larger than the first Newton step justifies are rejected with a typed [`IftError`].
//!
//! ```
//! use sdae_ift::{BallProblem, BallSolver, SolverSettings};
//! use sdae_manifold::ScalarGram;
//!
//! /// R(gamma) = (1 - (1 - gamma)^2 - s^2) / 2: the pendulum's kappa equation.
//! struct Kappa(f64);
//! impl BallProblem for Kappa {
//!     type Matrix = ScalarGram;
//!     fn dim(&self) -> usize { 1 }
//!     fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut ScalarGram>) {
//!         r[0] = 0.5 * (1.0 - (1.0 - g[0]).powi(2) - self.0 * self.0);
//!         if let Some(j) = j { j.0 = 1.0 - g[0]; }
//!     }
//! }
//! let mut solver = BallSolver::new(ScalarGram(0.0), SolverSettings::default());
//! let cert = solver.solve(&mut Kappa(0.2), 0.125)?;
//! let exact = 1.0 - (1.0f64 - 0.04).sqrt();
//! assert!((solver.root()[0] - exact).abs() < 1e-15);
//! assert!(cert.contraction < 0.5);
//! # Ok::<(), sdae_ift::IftError>(())
//! ```

mod criteria;
mod error;
mod iteration;
mod problem;
mod settings;
mod solver;

pub use criteria::{ProbeMap, QuadraticRoot, power_iteration, quadratic_root};
pub use error::IftError;
pub use iteration::{
    FactorPass, NewtonIterates, NewtonStart, NewtonSystem, certify, newton_from_zero,
    newton_iterate, start_at, start_from_zero,
};
pub use problem::BallProblem;
pub use settings::SolverSettings;
pub use solver::{BallSolver, Certificate, Method};
