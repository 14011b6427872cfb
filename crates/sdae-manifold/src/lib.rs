//! Constraint manifolds M = {x : g(x) = 0} for constrained stochastic mechanical systems
//! (seed eq. 1.1, Section 2.1).
//!
//! - [`Constraint`]: g, Dg applied to vectors, and the matrices Dg(x1) M^-1 grad g(x2) in the
//!   storage ([`ScalarGram`], [`TridiagonalGram`], [`DenseGram`]) that fits the constraint;
//!   [`Curvature`] adds D^2 g, [`TheoryBound`] the constant C_g of eq. 2.2.
//! - [`Equations`]: a constraint of any number of equations written once over
//!   [`Real`](sdae_lanes::Real) (g, Dg u, Dg^T z, D^2 g(u, w)), which is then a [`Constraint`],
//!   a [`Curvature`] and, for a diagonal mass, steps in SIMD lanes with the one-path numbers.
//! - [`Mass`]: [`IdentityMass`] (free), [`DiagonalMass`], [`DenseMass`] (checked SPD).
//! - Built-in manifolds: [`Sphere`] (the pendulum of Section 5.1) and [`BeadChain`] (the
//!   inextensible fiber of Section 5.3); [`ClosureConstraint`] for anything else.
//! - [`check_state`]: is (r, v) on the tangent bundle?
//! - [`lane_form`]: a constraint's formulas over SIMD lanes, offered to an ensemble engine
//!   through [`Constraint::lane_form`] (built in for [`BeadChain`] and [`RigidBonds`], and for
//!   every [`Equations`] type; open to any constraint).
//!
//! ```
//! use sdae_manifold::{BeadChain, Constraint, IdentityMass, TheoryBound, check_state};
//! let chain = BeadChain::new(4, 0.5)?;
//! let r = chain.straight([0.0, 0.0, 1.0])?;
//! let v = vec![0.0; chain.dim()];
//! check_state(&chain, &r, &v, 1e-12)?;
//! let c_g = chain.c_g(&IdentityMass).unwrap();
//! assert!(c_g >= 1.0);
//! # Ok::<(), sdae_manifold::ManifoldError>(())
//! ```

mod bonds;
mod chain;
mod closure;
mod constraint;
mod dense_lu;
mod equations;
mod error;
mod factor;
mod gram;
mod hypersurface;
pub mod lane_form;
mod mass;
mod newton_only;
mod one_path;
mod point;
mod roundoff;
mod shape;
mod sphere;
mod sphere_constraint;
mod state;
mod thomas;
pub mod vector;

pub use bonds::{Bond, RigidBonds};
pub use chain::BeadChain;
pub use closure::{ClosureConstraint, NoCurvature};
pub use constraint::{
    Constraint, Curvature, TheoryBound, assemble_dense_by_columns, assemble_tridiagonal_by_probing,
    motion_measure, scratch_len,
};
pub use equations::{
    Equations, FactorOf, GramOf, InverseMassOf, cross_gram as cross_gram_by_products,
    kappa_coefficients, offer_closed_form, offer_newton,
};
pub use error::{
    LinearError, ManifoldError, check_at_least, check_finite, check_len, check_positive,
};
pub use factor::{
    DENSE_FAER_THRESHOLD, DenseFactor, Factorize, LuFactor, MatrixFactor, PIVOT_TOLERANCE,
    RightHandSide, ScalarFactor, Solve, ThomasFactor, TridiagonalFactor,
};
pub use gram::{DenseGram, GramMatrix, GramStructure, ScalarGram, SquareMatrix, TridiagonalGram};
pub use hypersurface::{Hypersurface, Surface};
pub use lane_form::{LaneFormVisitor, Point};
pub use mass::{DenseMass, DiagonalMass, IdentityMass, Mass};
pub use newton_only::NewtonOnly;
pub use roundoff::Roundoff;
pub use shape::{ByProducts, Dense, GramShape, Product, Scalar, Tridiagonal};
pub use sphere::Sphere;
pub use state::{DEFAULT_STATE_TOLERANCE, StateResiduals, check_state, state_residuals};
