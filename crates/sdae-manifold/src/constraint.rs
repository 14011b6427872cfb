//! Capability traits of a holonomic constraint g: R^n -> R^m (seed eq. 1.1, Section 2.1).
//!
//! Code asks in its bounds only for what it uses: the stepper needs [`Constraint`] (g and Dg),
//! the inherent-SDE solvers also need [`Curvature`] (D^2 g), theory defaults need [`TheoryBound`].

use crate::error::ManifoldError;
use crate::factor::Factorize;
use crate::gram::{DenseGram, TridiagonalGram};
use crate::lane_form::LaneFormVisitor;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::ByProducts;
use sdae_lanes::Real;

/// The size of the motion of eq. 3.2, max(w, w^2, alpha), from a speed w and an acceleration
/// alpha: |v| and |a| for the seed's functional, or a constraint's relative speeds and forces
/// per unit of the lengths it fixes ([`Constraint::local_motion`]); for one path or for lanes.
#[inline(always)]
pub fn motion_measure<T: Real>(speed: T, acceleration: T) -> T {
    speed.max(speed * speed).max(acceleration)
}

/// g and its Jacobian Dg, applied to vectors, and the structured Gram-type matrices.
pub trait Constraint {
    /// Storage of Dg(x1) M^-1 grad g(x2), with its factorization: fixes the structure the
    /// linear solvers exploit.
    type Gram: Factorize;
    /// Dimension n of the configuration space.
    fn dim(&self) -> usize;
    /// Number m of constraints.
    fn n_constraints(&self) -> usize;
    /// out = g(x), length m.
    fn value(&self, x: &[f64], out: &mut [f64]);
    /// out = Dg(x) u, length m.
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]);
    /// out = grad g(x) z = Dg(x)^T z, length n (overwritten).
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]);
    /// A zero matrix of the right order and structure.
    fn new_gram(&self) -> Self::Gram;
    /// out = Dg(x1) M^-1 grad g(x2). `scratch` has length >= [`scratch_len`]`(n, m)` and may be
    /// used by constraints without a closed form (seed Section 2.1: G_M(x) for x1 = x2 = x).
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut Self::Gram,
    );

    /// out = y + M^-1 grad g(r) z: the position of the kappa system (seed eq. 3.1, upper part)
    /// and the velocity update of the lambda system (lower part). Overridden by constraints
    /// that can do it in one pass.
    #[inline]
    fn displace<M: Mass>(&self, r: &[f64], z: &[f64], mass: &M, y: &[f64], out: &mut [f64]) {
        displace_in_passes(self, r, z, mass, y, out);
    }

    /// value = g(x) and gram = Dg(x) M^-1 grad g(r): one Newton evaluation of the kappa system.
    /// Overridden by constraints that share work between the two.
    #[inline]
    fn value_and_cross_gram<M: Mass>(
        &self, x: &[f64], r: &[f64], mass: &M, scratch: &mut [f64], value: &mut [f64],
        gram: &mut Self::Gram,
    ) {
        self.value(x, value);
        self.cross_gram(x, r, mass, scratch, gram);
    }

    /// The coefficients [c0, c1, c2] of the kappa system of seed eq. 3.1 (upper part),
    ///
    /// R(gamma) = g(y + M^-1 grad g(r) gamma) = c0 + c1 gamma + c2 gamma^2,
    ///
    /// when m = 1 and g is a quadratic polynomial (then R is one in gamma: c0 = g(y),
    /// c1 = Dg(y) M^-1 grad g(r), c2 = D^2 g(M^-1 grad g(r), M^-1 grad g(r)) / 2), so that the
    /// root solver can take its root in closed form. `None` (the default): no closed form, the
    /// solver runs Newton. A constraint overrides this only where it is exact, so the choice is
    /// made per type at compile time.
    #[inline]
    fn kappa_quadratic<M: Mass>(&self, r: &[f64], y: &[f64], mass: &M) -> Option<[f64; 3]> {
        let _ = (r, y, mass);
        None
    }

    /// Checks that `mass` fits this constraint's Gram storage. Every SPD mass fits a scalar or
    /// dense Gram matrix (the default); a structured storage says which masses keep its
    /// structure.
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        let _ = mass;
        Ok(())
    }

    /// The size of the motion (v, force a) at x on this constraint's own length scale, for the
    /// local size functional of the truncation (beyond the seed): max(w, w^2, alpha), with w
    /// the largest relative speed of two points a constraint ties together per unit of the
    /// length it fixes and alpha the largest force on one particle per unit of that length.
    /// For a sphere of radius 1 this is the seed's max(|v|, |v|^2, |a|) (eq. 3.2); for a
    /// chain it sees one segment turning fast where |v| of all beads together does not, and
    /// a rigid translation not at all. `None` (the default): no local scale is known, and the
    /// seed's functional is used.
    fn local_motion(&self, x: &[f64], v: &[f64], a: &[f64]) -> Option<f64> {
        let _ = (x, v, a);
        None
    }
    /// Offers `visitor` this constraint's form over SIMD lanes for `mass`
    /// ([`lane_form`](crate::lane_form)): an ensemble of paths then steps in lanes. The
    /// default offers none ([`LaneFormVisitor::none`]): the paths step one at a time. A
    /// constraint that has one overrides this with a call of the visitor's method for it, so
    /// that the lane code is compiled only for the constraints that have it.
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        let _ = mass;
        visitor.none()
    }
    /// The kind of g's rounding floor, the size of |g(x)| that rounding alone produces (the
    /// floor below which Newton cannot push the residual; [`Roundoff::floor`]): none known by
    /// default.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Unknown
    }
}

/// Second derivative D^2 g(x)(u, w), asked only by solvers of the inherent SDE (seed eq. 2.3, 2.4).
pub trait Curvature: Constraint {
    /// out = D^2 g(x)(u, w), length m.
    fn second_derivative(&self, x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]);
}

/// The constant C_g of seed eq. 2.2, where it is known or can be bounded.
pub trait TheoryBound: Constraint {
    /// An upper bound on C_g for this constraint with this mass matrix (limit epsilon -> 0 of
    /// eq. 2.2, always >= 1), or `None` if no bound is known.
    fn c_g<M: Mass>(&self, mass: &M) -> Option<f64>;
}

/// out = y + M^-1 grad g(r) z in three passes: the product, the mass solve, the sum.
#[inline]
pub fn displace_in_passes<C: Constraint + ?Sized, M: Mass>(
    constraint: &C, r: &[f64], z: &[f64], mass: &M, y: &[f64], out: &mut [f64],
) {
    constraint.jacobian_transpose_mul(r, z, out);
    mass.apply_inverse(out);
    for (o, yi) in out.iter_mut().zip(y) {
        *o += yi;
    }
}

/// Length of the scratch buffer that [`Constraint::cross_gram`] may use.
pub const fn scratch_len(n: usize, m: usize) -> usize {
    2 * (n + m)
}

/// Assembles Dg(x1) M^-1 grad g(x2) column by column from the Jacobian products: m products,
/// O(m n) work. The fallback for constraints without a closed form.
pub fn assemble_dense_by_columns<C: Constraint + ?Sized, M: Mass>(
    constraint: &C, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut DenseGram,
) {
    assemble_by_products(constraint, x1, x2, mass, scratch, out);
}

/// Assembles a tridiagonal Dg(x1) M^-1 grad g(x2) with three probe vectors (columns j = c mod 3
/// summed): O(n) work whatever m. Valid whenever the product is known to be tridiagonal.
pub fn assemble_tridiagonal_by_probing<C: Constraint + ?Sized, M: Mass>(
    constraint: &C, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64],
    out: &mut TridiagonalGram,
) {
    assemble_by_products(constraint, x1, x2, mass, scratch, out);
}

/// Dg(x1) M^-1 grad g(x2) into `out` from the products p -> Dg(x1) M^-1 grad g(x2) p
/// ([`ByProducts`]), with n + 2m entries of `scratch`.
fn assemble_by_products<C: Constraint + ?Sized, M: Mass>(
    constraint: &C, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64],
    out: &mut impl ByProducts<f64>,
) {
    let n = constraint.dim();
    let m = constraint.n_constraints();
    let (column, rest) = scratch.split_at_mut(n);
    let (probe, rest) = rest.split_at_mut(m);
    let mut product = |p: &[f64], image: &mut [f64]| {
        constraint.jacobian_transpose_mul(x2, p, column);
        mass.apply_inverse(column);
        constraint.jacobian_mul(x1, column, image);
    };
    out.assemble_by_products(probe, &mut rest[..m], &mut product);
}
