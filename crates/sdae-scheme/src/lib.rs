//! The half-explicit drift-truncated Euler scheme of seed eq. 3.1-3.2 for constrained
//! stochastic mechanical systems (eq. 1.1):
//!
//! ```text
//! r' = r + eta v h + M^-1 grad g(r) kappa,                       g(r') = 0
//! v' = v + M^-1 [eta a(r,v) h + B(r,v) dw + grad g(r) lambda],  Dg(r') v' = 0
//! eta = min(1, C_eta / (max(|v|, |v|^2, |a(r,v)|) h)),          mu_k = sum_{j<=k} lambda_j
//! ```
//!
//! The stepper implements the one step trait [`sdae_model::Scheme`], so it runs on the path
//! driver [`sdae_model::run_path`] and in every study, next to the inherent-SDE solvers and a
//! user's own schemes.
//!
//! - [`StepperConfig`] (C_eta, C_kappa, solver settings; theory defaults from C_g),
//! - [`Stepper`] (the system, the constants and the buffers of one path),
//! - [`Ensemble`] (many paths of one system stepped together in SIMD lanes),
//! - [`runaway_bound`] (the C_eta below which truncated steps keep a rotor's energy bounded).
//!
//! ```
//! use sdae_model::{Recorder, TimeGrid, run_path};
//! use sdae_noise::GaussianIncrements;
//! use sdae_scheme::{Stepper, StepperConfig};
//! use sdae_systems::{PendulumParams, pendulum};
//! let system = pendulum(PendulumParams::default())?;
//! let config = StepperConfig::for_system(&system)?.with_c_eta(1.0)?;
//! let mut stepper = Stepper::new(system, config)?;
//! let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 0.5]);
//! let mut noise = GaussianIncrements::for_path(42, 0, 2);
//! let mut recorder = Recorder::every(100).with_mu();
//! let grid = TimeGrid::new(1.0, 1000)?;
//! let diagnostics = run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut recorder)?;
//! assert!(diagnostics.max_position_residual < 1e-12);
//! assert_eq!(recorder.len(), 11);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod config;
mod ensemble;
mod error;
mod formulas;
mod one_path;
mod runaway;
mod step;
mod stepper;

pub use config::StepperConfig;
pub use ensemble::Ensemble;
pub use error::SchemeError;
pub use runaway::runaway_bound;
pub use stepper::Stepper;
