//! Reference solvers for the inherent SDE (seed eq. 2.4) and the multiplier formula (eq. 2.3)
//! of a constrained stochastic mechanical system (eq. 1.1).
//!
//! - [`InherentSde`]: the coefficients of eq. 2.4 (drift, diffusion applied to an increment)
//!   and the multiplier increment of eq. 2.3, evaluated allocation-free with the Gram matrix
//!   G_M(r) factored once per point; P_M is never formed.
//! - Solvers of eq. 2.4, each implementing the one step trait [`sdae_model::Scheme`] (so they
//!   run on the path driver [`sdae_model::run_path`] and in every study): [`EulerMaruyama`],
//!   [`TruncatedEulerMaruyama`] (Remark 3.3, drift of Lemma 4.2), [`ProjectedEulerMaruyama`]
//!   (Euler-Maruyama followed by projection onto the tangent bundle) and [`StochasticHeun`]
//!   (trapezoidal drift, diffusion at the left point: an Ito scheme).
//! - Lane forms ([`sdae_model::LaneScheme`]) of the four solvers for a sphere constraint (the
//!   pendulums) with a diagonal mass: a [`sdae_model::LaneEnsemble`] of them steps W paths at
//!   once in SIMD lanes with the same numbers as each path alone (any other system steps path
//!   by path). Each solver's step is written once over [`sdae_lanes::Real`] and runs for one
//!   path (`f64`, the coefficients from [`InherentSde`], any constraint) and for W lanes
//!   (`Lanes`, the sphere's closed forms).
//!
//! ```
//! use sdae_model::{NoObserver, TimeGrid, run_path};
//! use sdae_noise::GaussianIncrements;
//! use sdae_reference::TruncatedEulerMaruyama;
//! use sdae_systems::{PendulumParams, pendulum};
//! let mut solver = TruncatedEulerMaruyama::new(pendulum(PendulumParams::default())?)?;
//! let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 0.5]);
//! let mut noise = GaussianIncrements::for_path(42, 0, 2);
//! let grid = TimeGrid::new(1.0, 1000)?;
//! let diagnostics = run_path(&mut solver, &mut r, &mut v, grid, &mut noise, &mut NoObserver)?;
//! // Unprojected Euler-Maruyama drifts off the manifold by O(h), not more.
//! assert!(diagnostics.max_position_residual < 0.05);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

/// The accessor of the inherent SDE and the [`sdae_model::Scheme`] implementation of a solver
/// that holds an `EulerCore` in `core` and proposes a step with
/// `fn propose(&mut self, r, v, h, dw) -> StepResult` (into `core.next_r`,
/// `core.next_v`, `core.dmu`): the step commits the proposal only once it succeeded, so
/// (r, v) are unchanged on failure.
macro_rules! inherent_scheme {
    ($solver:ident) => {
        impl<S: CurvedSystem> $solver<S> {
            /// The inherent SDE (and through it the system).
            pub fn sde(&self) -> &InherentSde<S> {
                &self.core.sde
            }
        }

        impl<S: CurvedSystem> sdae_model::Scheme for $solver<S> {
            type System = S;
            fn system(&self) -> &S {
                self.core.sde.system()
            }
            /// One step (see the type's documentation); (r, v) are unchanged on failure.
            fn step(
                &mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
            ) -> sdae_model::StepResult {
                let outcome = self.propose(r, v, h, dw)?;
                self.core.commit(r, v);
                Ok(outcome)
            }
            fn multiplier_increment(&self) -> &[f64] {
                &self.core.dmu
            }
        }
    };
}

mod error;
mod euler;
mod heun;
mod inherent;
mod kernel;
mod lanes;
mod projected;
mod truncated;
mod updates;

pub use error::ReferenceError;
pub use euler::EulerMaruyama;
pub use heun::StochasticHeun;
pub use inherent::{CurvedSystem, InherentSde};
pub use projected::ProjectedEulerMaruyama;
pub use truncated::TruncatedEulerMaruyama;
