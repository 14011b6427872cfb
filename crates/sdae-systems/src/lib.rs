//! Built-in constrained stochastic mechanical systems (seed Section 5): the stochastic pendulum
//! (Section 5.1), constrained Langevin molecules (Section 5.2) and inextensible fibers in
//! turbulent air (Section 5.3), each a [`System`](sdae_model::System) of seed eq. 1.1,
//!
//! ```text
//! M dv = a(r, v) dt + B(r, v) dw + grad g(r) dmu,   g(r) = 0,
//! ```
//!
//! that runs with every [`Scheme`](sdae_model::Scheme): the half-explicit stepper of
//! `sdae-scheme` and, since every constraint here provides D^2 g, the inherent-SDE solvers of
//! `sdae-reference`.
//!
//! - [`pendulum()`]: the planar or spherical pendulum with gravity, friction and additive noise
//!   ([`PendulumParams`]);
//! - [`langevin`]: [`Langevin`] (any constraint and [`Potential`]), [`chain_molecule`] and
//!   [`rigid_triatomic`] with their parameter structs;
//! - [`fiber`]: [`Fiber`] with bending, gravity, drag relative to an [`AirFlow`] and
//!   turbulent forcing ([`FiberParams`]);
//! - [`potential`]: [`BondAngles`], [`Torsions`], [`HarmonicTrap`], composable as tuples.
//!
//! Every built-in system writes its drift and noise once over [`Real`](sdae_lanes::Real)
//! ([`System::drift`](sdae_model::System::drift),
//! [`System::add_noise`](sdae_model::System::add_noise)), so that W paths at once, in SIMD
//! lanes, compute in lane i exactly what one path computes for path i: the ensemble engine of `sdae-scheme` steps many
//! paths with them.
//!
//! Parameter structs derive serde (unknown and missing fields are errors that name the field;
//! only switched-off extras such as potentials and shear are optional; a fixed-length array
//! with more or fewer entries than its length is an error, see [`exact`]),
//! and every constructor checks its parameters, failing with a [`SystemError`] that names the
//! parameter, its value and the rule it breaks.
//!
//! ```
//! use sdae_systems::{Fiber, FiberParams, SystemError};
//! let e = Fiber::new(&FiberParams { bending_stiffness: -1.0, ..FiberParams::default() });
//! assert!(matches!(e, Err(SystemError::InvalidParameter { name: "bending_stiffness", .. })));
//! ```

mod error;
pub mod exact;
pub mod fiber;
pub mod langevin;
mod masses;
pub mod pendulum;
pub mod potential;
mod vec3;

pub use error::{MAX_PARTICLES, SystemError};
pub use fiber::{AirFlow, Fiber, FiberParams};
pub use langevin::{
    ChainMolecule, ChainMoleculeParams, ChainPotential, Langevin, RigidTriatomic,
    RigidTriatomicParams, chain_molecule, rigid_triatomic,
};
pub use masses::Masses;
pub use pendulum::{Pendulum, PendulumDrift, PendulumParams, pendulum};
pub use potential::{
    AngleParams, BondAngles, HarmonicTrap, Potential, TorsionParams, Torsions, TrapParams,
};
