//! Reference solvers for the inherent SDE (seed eq. 2.4) and the multiplier formula (eq. 2.3)
//! of a constrained stochastic mechanical system (eq. 1.1).
//!
//! - [`InherentSde`]: the coefficients of eq. 2.4 (drift, diffusion applied to an increment)
//!   and the multiplier increment of eq. 2.3, evaluated allocation-free with the Gram matrix
//!   G_M(r) factored once per point; P_M is never formed.
//! - Solvers, one step at a time ([`ReferenceSolver::step`]): [`EulerMaruyama`],
//!   [`TruncatedEulerMaruyama`] (Remark 3.3, drift of Lemma 4.2), [`ProjectedEulerMaruyama`]
//!   (Euler-Maruyama followed by projection onto the tangent bundle) and [`StochasticHeun`]
//!   (trapezoidal drift, for noise B(r) that does not depend on v).
//! - [`run_reference_path`]: a path with increments from any
//!   [`IncrementSource`](sdae_scheme::IncrementSource), reported to an
//!   [`Observer`](sdae_scheme::Observer), mu accumulated only when the observer asks for it.
//!
//! ```
//! use sdae_reference::{TruncatedEulerMaruyama, run_reference_path};
//! use sdae_scheme::{GaussianIncrements, NoObserver, PendulumParams, pendulum};
//! let mut solver = TruncatedEulerMaruyama::new(pendulum(PendulumParams::default())?)?;
//! let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 0.5]);
//! let mut noise = GaussianIncrements::for_path(42, 0, 2);
//! let diagnostics =
//!     run_reference_path(&mut solver, &mut r, &mut v, 1.0, 1000, &mut noise, &mut NoObserver)?;
//! // Unprojected Euler-Maruyama drifts off the manifold by O(h), not more.
//! assert!(diagnostics.max_position_residual < 0.05);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod euler;
mod heun;
mod inherent;
mod path;
mod projected;
mod truncated;

pub use error::{ReferenceError, ReferencePathError};
pub use euler::EulerMaruyama;
pub use heun::StochasticHeun;
pub use inherent::{CurvedSystem, InherentSde};
pub use path::{ReferenceDiagnostics, ReferenceSolver, ReferenceStepReport, run_reference_path};
pub use projected::ProjectedEulerMaruyama;
pub use truncated::TruncatedEulerMaruyama;
