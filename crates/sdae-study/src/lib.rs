//! Studies of schemes for constrained stochastic mechanical systems (seed eq. 1.1).
//!
//! - [`scene`]: what to simulate, as data (TOML files; built-in scenes ship as files);
//!   [`scene_load`] reads and checks them, every study table as the studies run it.
//! - [`integrator`]: the schemes compared, behind one interface: the half-explicit
//!   drift-truncated Euler scheme (seed eq. 3.1-3.2) with the theory's and a practical C_eta and
//!   untruncated, and Euler-Maruyama, truncated, projected and stochastic Heun on the inherent
//!   SDE (eq. 2.4).
//! - [`lockstep`]: one Monte Carlo path, every scheme at every step size and the fine reference
//!   driven by one Brownian path, with memory independent of the number of fine steps (the
//!   [`sdae_lockstep`] crate).
//! - [`convergence`]: strong errors (L^p over paths of the sup over the grid) with confidence
//!   intervals, observed orders, run time and failures per scheme and step size; sharding.
//! - [`stability`]: failures by kind, constraint residuals and truncation on stiff and extreme
//!   scenes over a range of step sizes.
//! - [`equipartition`]: the kinetic temperature of Langevin scenes against h and C_eta.
//! - [`mlmc`]: multilevel Monte Carlo (Giles, the [`sdae_mlmc`] crate) for E[f(X_T)] of a
//!   scene's observable, with antithetic fine paths for multiplicative noise.
//! - [`weak`]: weak errors E[f(X_N)] - E[f(X_T)] of observables, weak orders and
//!   Richardson-Romberg extrapolation, against exact values or the reference on the same paths.
//! - [`observable`]: scalar functions of the state (built-in per system, or a user's closure)
//!   whose expectations the weak study and MLMC measure.
//! - [`options`]: what a caller changes of a scene's study settings (the command line's flags,
//!   the Python package's keywords), turned into settings by one piece of code.
//! - [`simulate`]: many paths of a scene with one scheme, recorded every k-th step, as arrays.
//! - [`trajectory`]: the paths as files for ParaView, VMD and OVITO (extended XYZ, VTK, CSV),
//!   written as they are simulated.
//! - [`trace`]: a picture of one path of a scene (a pendulum's path, a fiber's shapes).
//! - [`plots`], [`output`]: SVG plots and the report files (the statistics, intervals, orders
//!   and the paired bootstrap over paths, are [`sdae_stats`]).
//!
//! Path i draws from its own stream derived from (seed, i), so the numbers do not depend on the
//! thread count or the sharding.

mod catalog;
pub mod convergence;
pub mod equipartition;
mod error;
pub mod files;
pub mod gibbs;
pub mod integrator;
pub use sdae_lockstep as lockstep;
pub mod mlmc;
pub mod observable;
pub mod options;
pub mod output;
pub mod parallel;
pub mod plots;
pub mod scene;
pub mod scene_load;
pub mod simulate;
pub mod stability;
pub mod trace;
pub mod trajectory;
pub mod weak;

pub use error::StudyError;
