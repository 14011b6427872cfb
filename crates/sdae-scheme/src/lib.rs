//! The half-explicit drift-truncated Euler scheme of seed eq. 3.1-3.2 for constrained
//! stochastic mechanical systems (eq. 1.1):
//!
//! ```text
//! r' = r + eta v h + M^-1 grad g(r) kappa,                       g(r') = 0
//! v' = v + M^-1 [eta a(r,v) h + B(r,v) dw + grad g(r) lambda],  Dg(r') v' = 0
//! eta = min(1, C_eta / (max(|v|, |v|^2, |a(r,v)|) h)),          mu_k = sum_{j<=k} lambda_j
//! ```
//!
//! - [`System`] (built from parts with [`MechanicalSystem`], or the [`pendulum`]),
//! - [`StepperConfig`] (C_eta, C_kappa, solver settings; theory defaults from C_g),
//! - [`Stepper::step`] (one step, with a [`StepReport`]),
//! - [`run_path`] (a path on a [`TimeGrid`] with increments from an [`IncrementSource`],
//!   recorded by an [`Observer`] such as [`Recorder`], summarized in [`PathDiagnostics`]).
//!
//! ```
//! use sdae_scheme::{
//!     GaussianIncrements, PendulumParams, Recorder, Stepper, StepperConfig, TimeGrid, pendulum,
//!     run_path,
//! };
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
mod error;
mod increments;
mod initial;
mod path;
mod pendulum;
mod stepper;
mod system;

pub use config::StepperConfig;
pub use error::{SchemeError, StepError, StepFailure};
pub use increments::{
    Coarsened, GaussianIncrements, IncrementSource, RecordedIncrements, path_rng,
};
pub use initial::project_state;
pub use path::{
    INITIAL_STATE_TOLERANCE, ITERATION_BINS, Interpolation, NoObserver, Observer, PathDiagnostics,
    PathFailure, Recorder, TimeGrid, run_path,
};
pub use pendulum::{Pendulum, PendulumDrift, PendulumParams, pendulum};
pub use stepper::{StepReport, Stepper};
pub use system::{
    AdditiveNoise, ClosureNoise, Drift, MechanicalSystem, NoNoise, Noise, System, ZeroDrift,
};
