//! Splitting schemes for constrained Langevin dynamics, the molecular-dynamics standard:
//! constrained BAOAB and geodesic g-BAOAB (Leimkuhler and Matthews 2013, 2016) with SHAKE
//! position and RATTLE velocity projections, for systems
//!
//! ```text
//! M dv = [F(r) - gamma v] dt + sigma dw + grad g(r) dmu,   g(r) = 0,   M diagonal
//! ```
//!
//! (seed Section 5.2; [`sdae_model::System::langevin`] says whether a system has this form).
//! Their configurational averages are second-order accurate in h where the half-explicit
//! scheme's are first order; their SHAKE projection can fail where no point of the manifold lies
//! near the drifted position, which the half-explicit scheme's truncation avoids (seed
//! Thm 3.4). A failed projection is a typed [`sdae_model::StepFailure`], counted in every
//! report like the half-explicit scheme's failures.
//!
//! - [`SplittingConfig`]: K_r geodesic substeps (1: BAOAB, 3: g-BAOAB), the SHAKE tolerance
//!   (1e-12 on max |g| by default) and iteration limit;
//! - [`Splitting`]: the scheme, an implementation of the one step trait
//!   [`sdae_model::Scheme`], and of [`sdae_model::LaneScheme`], so that a
//!   [`sdae_model::LaneEnsemble`] steps W paths at once in SIMD lanes: the sphere's closed form
//!   for the pendulums, Newton's SHAKE over lanes ([`sdae_model::engine::NewtonRoot`], the
//!   half-explicit ensemble's root) for a constraint that offers formulas over lanes (bead
//!   chains, rigid bonds, a user's constraint), each lane with its path's scalar numbers;
//! - [`OuFactors`]: the O step's exact Ornstein-Uhlenbeck update.
//!
//! ```
//! use sdae_model::{NoObserver, TimeGrid, run_path};
//! use sdae_noise::GaussianIncrements;
//! use sdae_splitting::{Splitting, SplittingConfig};
//! use sdae_systems::{ChainMoleculeParams, chain_molecule};
//! let molecule = chain_molecule(&ChainMoleculeParams::default())?;
//! let (mut r, mut v) = molecule.initial_state();
//! let mut noise = GaussianIncrements::for_path(1, 0, molecule.noise_dimension());
//! let mut g_baoab = Splitting::new(molecule, SplittingConfig::g_baoab())?;
//! let grid = TimeGrid::new(1.0, 200)?;
//! let diagnostics = run_path(&mut g_baoab, &mut r, &mut v, grid, &mut noise, &mut NoObserver)?;
//! assert!(diagnostics.max_position_residual < 1e-11);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod config;
mod error;
mod kernel;
mod newton;
mod ou;
mod scheme;
mod sphere;
mod splitting;

pub use config::{DEFAULT_TOLERANCE, G_BAOAB_SUBSTEPS, SplittingConfig};
pub use error::SplittingError;
pub use ou::OuFactors;
pub use splitting::Splitting;
