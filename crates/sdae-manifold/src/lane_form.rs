//! What an ensemble engine steps with: a constraint's [`Equations`] forms over SIMD lanes.
//!
//! A constraint offers them through [`Constraint::lane_form`](crate::Constraint::lane_form): it hands a [`LaneFormVisitor`]
//! either itself for the fixed-size closed-form kernels (one quadratic equation in 2 or 3
//! coordinates, as the [`Sphere`](crate::Sphere)) or itself with its mass as a [`LaneForm`]:
//! its [`Equations`] formulas at `T = Lanes<S>` for the Newton iteration of the kappa system
//! (seed eq. 3.1, upper part) and the velocity update (lower part). A constraint that is not
//! [`Equations`] offers none, and an engine then steps the paths one at a time. The built-in
//! constraints of several equations are the bead chain's ([`BeadChain`](crate::BeadChain),
//! with Thomas' algorithm for its tridiagonal Newton matrix, fused with the rows' evaluation)
//! and rigid bonds' ([`RigidBonds`](crate::RigidBonds), with an LU factorization with partial
//! pivoting per lane); a user's constraint is written the same way
//! (`crates/sdae-scheme/examples/custom_constraint.rs`: a torus and a double pendulum). The
//! Newton matrix and its factorization are the one-path storage and code run over lanes,
//! named by the structure ([`GramShape`](crate::GramShape)).
//!
//! Each formula takes the floating-point operations of the one-path form it names, in the
//! same order: then a lane's numbers are the scalar step's, bit for bit, whatever the width.

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

pub use crate::equations::LaneFormVisitor;
use crate::equations::{Equations, FactorOf, GramOf};
use crate::mass::Mass;
pub use crate::point::{Evaluation, InverseMass, Point, base_coords, max_abs, max_abs_and_finite};
use crate::roundoff::Roundoff;

/// A constraint with the diagonal M^-1 it steps with, built by an engine from what
/// [`LaneFormVisitor::newton`] hands it and kept: its methods are the constraint's
/// [`Equations`] methods at `T = Lanes<S>` with this mass.
pub struct LaneForm<C> {
    constraint: C,
    inverse_mass: InverseMass,
}

impl<C: Equations> LaneForm<C> {
    /// `constraint` with a diagonal `mass`; `None` for another mass.
    pub fn new<M: Mass>(constraint: &C, mass: &M) -> Option<Self> {
        M::DIAGONAL.then(|| Self {
            constraint: constraint.clone(),
            inverse_mass: InverseMass::of(mass, Equations::dim(constraint)),
        })
    }
    /// The constraint.
    pub fn constraint(&self) -> &C {
        &self.constraint
    }
    /// M^-1.
    pub fn inverse_mass(&self) -> &InverseMass {
        &self.inverse_mass
    }
    /// The kind of the residual floor (`Constraint::roundoff`).
    pub fn roundoff(&self) -> Roundoff {
        Equations::roundoff(&self.constraint)
    }
    /// (n, m).
    pub fn dims(&self) -> (usize, usize) {
        (
            Equations::dim(&self.constraint),
            Equations::n_constraints(&self.constraint),
        )
    }
    /// [`Equations::evaluate_and_factor`].
    #[inline(always)]
    pub fn evaluate_and_factor<Sd: Simd, P: Point<Lanes<Sd>> + ?Sized>(
        &self, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>], jacobian: &mut Jacobian<Sd, C>,
        factor: &mut Factor<Sd, C>, step: &mut [Lanes<Sd>],
    ) -> Evaluation<Lanes<Sd>> {
        let w = &self.inverse_mass;
        self.constraint
            .evaluate_and_factor(w, x1, r, values, jacobian, factor, step)
    }
    /// [`Equations::velocity_right_hand_side`].
    #[inline(always)]
    pub fn velocity_right_hand_side<Sd: Simd>(
        &self, x: &[Lanes<Sd>], force: &mut [Lanes<Sd>], v: &[Lanes<Sd>], factor: &Factor<Sd, C>,
        out: &mut [Lanes<Sd>],
    ) {
        let w = &self.inverse_mass;
        self.constraint
            .velocity_right_hand_side(w, x, force, v, factor, out);
    }
    /// [`Equations::displace_at`].
    #[inline(always)]
    pub fn displace<Sd: Simd, P: Point<Lanes<Sd>> + ?Sized>(
        &self, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>, out: &mut [Lanes<Sd>],
    ) {
        self.constraint
            .displace_at(&self.inverse_mass, r, z, base, out);
    }
    /// [`Equations::finish_velocity`].
    #[inline(always)]
    pub fn finish_velocity<Sd: Simd>(
        &self, r: &[Lanes<Sd>], lambda: &[Lanes<Sd>], x: &[Lanes<Sd>], monitor: bool,
        v: &mut [Lanes<Sd>], scratch: &mut [Lanes<Sd>],
    ) -> (LaneMask<Sd>, Lanes<Sd>) {
        let w = &self.inverse_mass;
        self.constraint
            .finish_velocity(w, r, lambda, x, monitor, v, scratch)
    }
    /// [`Equations::negated_jacobian_mul`].
    #[inline(always)]
    pub fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        self.constraint.negated_jacobian_mul(x, u, out);
    }
    /// [`Equations::kappa_quadratic_at`].
    #[inline(always)]
    pub fn kappa_quadratic<Sd: Simd, P: Point<Lanes<Sd>> + ?Sized>(
        &self, r: &[Lanes<Sd>], y: &P,
    ) -> Option<[Lanes<Sd>; 3]> {
        self.constraint.kappa_quadratic_at(&self.inverse_mass, r, y)
    }
    /// [`Equations::local_motion`].
    #[inline(always)]
    pub fn local_motion<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        Equations::local_motion(&self.constraint, &[], v, a)
    }
}

/// The Newton matrix of constraint C over lanes of Sd.
pub type Jacobian<Sd, C> = GramOf<C, Lanes<Sd>>;

/// The factorization of the Newton matrix of constraint C over lanes of Sd.
pub type Factor<Sd, C> = FactorOf<C, Lanes<Sd>>;

/// Whether any lane of `mask` holds.
#[inline(always)]
pub fn active_any<Sd: Simd>(mask: LaneMask<Sd>) -> bool {
    mask.any()
}
