//! A holonomic constraint of any number m of equations written once over the number type
//! ([`Equations`]): `f64` for one path, [`Lanes`](sdae_lanes::Lanes) for W paths. Blanket
//! impls make every `Equations` type a [`Constraint`](crate::Constraint) and a [`Curvature`](crate::Curvature); for a diagonal mass
//! an ensemble engine steps the same methods over lanes (`lane_form::LaneForm`), so that its lanes
//! take the one-path numbers bit for bit.
//!
//! What the half-explicit step needs of g (seed eq. 3.1) is built here from g, Dg u, Dg^T z
//! and D^2 g(u, w):
//!
//! - the kappa system R(gamma) = g(y + M^-1 grad g(r) gamma) = 0 (upper part) with its Newton
//!   matrix J(gamma) = Dg(x) M^-1 grad g(r) at x = y + M^-1 grad g(r) gamma, assembled from
//!   the products p -> Dg(x) M^-1 grad g(r) p in the storage the constraint names
//!   ([`Equations::Shape`], [`ByProducts`]);
//! - the lambda system Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (lower part) and the update
//!   v' = v~ + M^-1 grad g(r) lambda;
//! - where m = 1 and g is quadratic ([`Equations::is_quadratic`]), R(gamma) = c0 + c1 gamma +
//!   c2 gamma^2 with c0 = g(y), c1 = Dg(y) w, c2 = D^2 g(w, w) / 2, w = M^-1 grad g(r): the
//!   root is then taken in closed form ([`Constraint::kappa_quadratic`](crate::Constraint::kappa_quadratic)).
//!
//! ```
//! use sdae_lanes::Real;
//! use sdae_manifold::{Constraint, Equations, Tridiagonal};
//!
//! /// Two unit rods in the plane hinged at the origin and at p1: |p1| = 1, |p2 - p1| = 1, as
//! /// g = ((|p1|^2 - 1) / 2, (|p2 - p1|^2 - 1) / 2).
//! #[derive(Debug, Clone, Copy)]
//! struct Rods;
//!
//! impl Equations for Rods {
//!     type Shape = Tridiagonal;
//!     fn dim(&self) -> usize { 4 }
//!     fn n_constraints(&self) -> usize { 2 }
//!     #[inline(always)]
//!     fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
//!         let (dx, dy) = (x[2] - x[0], x[3] - x[1]);
//!         out[0] = (x[0] * x[0] + x[1] * x[1] - 1.0) * 0.5;
//!         out[1] = (dx * dx + dy * dy - 1.0) * 0.5;
//!     }
//!     #[inline(always)]
//!     fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
//!         out[0] = x[0] * u[0] + x[1] * u[1];
//!         out[1] = (x[2] - x[0]) * (u[2] - u[0]) + (x[3] - x[1]) * (u[3] - u[1]);
//!     }
//!     #[inline(always)]
//!     fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
//!         let (dx, dy) = ((x[2] - x[0]) * z[1], (x[3] - x[1]) * z[1]);
//!         out.copy_from_slice(&[x[0] * z[0] - dx, x[1] * z[0] - dy, dx, dy]);
//!     }
//!     #[inline(always)]
//!     fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
//!         out[0] = u[0] * w[0] + u[1] * w[1];
//!         out[1] = (u[2] - u[0]) * (w[2] - w[0]) + (u[3] - u[1]) * (w[3] - w[1]);
//!     }
//! }
//!
//! let mut g = [1.0; 2];
//! Constraint::value(&Rods, &[0.6, 0.8, 0.6, 1.8], &mut g);
//! assert_eq!(g, [0.0, 0.0]);
//! ```

use std::any::Any;
use std::cell::RefCell;

use sdae_lanes::Real;

use crate::error::ManifoldError;
use crate::factor::DENSE_FAER_THRESHOLD;
use crate::gram::GramStructure;
use crate::mass::Mass;
use crate::point::{Evaluation, InverseMass, Point, max_abs};
use crate::roundoff::Roundoff;
use crate::shape::{ByProducts, GramShape, Product};
use crate::vector::sum_squares;

/// A holonomic constraint g: R^n -> R^m written once over the number type: `f64` for one
/// path, `Lanes<S>` for W paths. Every `Equations` type is a [`Constraint`](crate::Constraint) and a
/// [`Curvature`](crate::Curvature) through blanket impls in sdae-manifold, and (for a diagonal mass) an ensemble
/// engine steps its methods over lanes (`lane_form::LaneForm`): the one-path and the lane numbers are the same functions' and agree bit for
/// bit, provided each method takes the same operations in the same order for every `T` (as
/// code written once over `T` does).
///
/// Mark the four generic methods `#[inline(always)]`: the lanes run inside functions compiled
/// for their instruction set, and a method not inlined there takes each lane operation through
/// a call. With both this trait and [`Constraint`](crate::Constraint) in scope, name the trait of a method that
/// both have (`Equations::dim(&g)`).
pub trait Equations: Clone + Send + Sync + 'static {
    /// The structure of Dg(x1) M^-1 grad g(x2) ([`Scalar`](crate::Scalar) for m = 1,
    /// [`Tridiagonal`](crate::Tridiagonal), [`Dense`](crate::Dense)).
    type Shape: GramShape;
    /// Dimension n of the configuration space.
    fn dim(&self) -> usize;
    /// Number m of equations.
    fn n_constraints(&self) -> usize;
    /// out = g(x), m entries.
    fn value<T: Real>(&self, x: &[T], out: &mut [T]);
    /// out = Dg(x) u, m entries.
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]);
    /// out = grad g(x) z = Dg(x)^T z, n entries (overwritten).
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]);
    /// out = D^2 g(x)(u, w), m entries.
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]);
    /// g is a quadratic polynomial (D^2 g constant): with m = 1 the kappa root is taken in
    /// closed form ([`Constraint::kappa_quadratic`](crate::Constraint::kappa_quadratic)). Default false.
    fn is_quadratic(&self) -> bool {
        false
    }
    /// The kind of g's rounding floor ([`Constraint::roundoff`](crate::Constraint::roundoff)); none known by default.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Unknown
    }
    /// Checks that `mass` fits the storage [`Equations::Shape`] ([`Constraint::check_mass`](crate::Constraint::check_mass)):
    /// every mass by default.
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        let _ = mass;
        Ok(())
    }

    // What the step builds from the four methods above, each a provided method that a
    // constraint overrides where it has a cheaper form with the same numbers for every `T`
    // (the sphere's single passes, a compiled constraint's fused programs).

    /// out = Dg(x1) M^-1 grad g(x2) (seed Section 2.1: G_M(x) for x1 = x2 = x), `scratch` n + 2m
    /// entries: by default assembled from the products p -> Dg(x1) M^-1 grad g(x2) p
    /// ([`ByProducts`]).
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x1: &[T], x2: &[T], scratch: &mut [T],
        out: &mut <Self::Shape as GramShape>::Matrix<T>,
    ) {
        cross_gram(self, x1, x2, inverse_mass, scratch, out);
    }
    /// value = g(x) and gram = Dg(x) M^-1 grad g(r): one Newton evaluation of the kappa system
    /// (seed eq. 3.1, upper part), `scratch` n + 2m entries.
    #[inline(always)]
    fn value_and_cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x: &[T], r: &[T], scratch: &mut [T], value: &mut [T],
        gram: &mut <Self::Shape as GramShape>::Matrix<T>,
    ) {
        Equations::value(self, x, value);
        Equations::cross_gram(self, inverse_mass, x, r, scratch, gram);
    }
    /// out = base + M^-1 grad g(r) z (seed eq. 3.1: the position of the kappa system, and the
    /// velocity update), where `base` is `None` out is its own base (each entry read before it
    /// is written); `scratch` n entries. By default in passes: grad g(r) z, M^-1, the sum.
    #[inline(always)]
    fn displace<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], z: &[T], base: Option<&[T]>, out: &mut [T],
        scratch: &mut [T],
    ) {
        displace_in_passes(self, inverse_mass, r, z, base, out, scratch);
    }
    /// [c0, c1, c2] of the kappa system R(gamma) = g(y + M^-1 grad g(r) gamma) where it is a
    /// quadratic in gamma ([`Constraint::kappa_quadratic`](crate::Constraint::kappa_quadratic)), `scratch` n entries: by default
    /// where m = 1 and g is quadratic, c0 = g(y), c1 = Dg(y) w, c2 = D^2 g(w, w) / 2 with
    /// w = M^-1 grad g(r); `None` otherwise (Newton). The solvers ask for it only where m = 1
    /// and [`Equations::is_quadratic`] holds: an override gives coefficients for those.
    #[inline(always)]
    fn kappa_quadratic<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], y: &[T], scratch: &mut [T],
    ) -> Option<[T; 3]> {
        has_kappa_quadratic(self).then(|| kappa_coefficients(self, r, y, inverse_mass, scratch))
    }
    /// The size of the motion on the constraint's own length scale
    /// ([`Constraint::local_motion`](crate::Constraint::local_motion)); `None` (the default): the seed's functional.
    #[inline(always)]
    fn local_motion<T: Real>(&self, x: &[T], v: &[T], a: &[T]) -> Option<T> {
        let _ = (x, v, a);
        None
    }
    // The forms an ensemble engine steps with a diagonal M^-1 on points that may be formed
    // where they are read ([`Point`]): by default from the methods above, as the one-path step
    // takes them; a constraint whose rows are factored as they are formed fuses them (the
    // bead chain).

    /// One evaluation of the kappa system at (x1, r): g(x1) into `values` and J = Dg(x1) M^-1
    /// grad g(r) into `jacobian` ([`Equations::value_and_cross_gram`]), then max_i |g_i(x1)|
    /// and J factored into `factor` with the first half of J^-1 g(x1) into `step`
    /// ([`Evaluation::reduce_and_factor`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn evaluate_and_factor<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, inverse_mass: &W, x1: &P, r: &[T], values: &mut [T], jacobian: &mut GramOf<Self, T>,
        factor: &mut FactorOf<Self, T>, step: &mut [T],
    ) -> Evaluation<T> {
        let (n, m) = (Equations::dim(self), Equations::n_constraints(self));
        let mut scratch = Scratch::take(r[0], point_len(x1, n) + n + 2 * m);
        let (x1, rest) = point(x1, scratch.entries(), n);
        Equations::value_and_cross_gram(self, inverse_mass, x1, r, rest, values, jacobian);
        Evaluation::reduce_and_factor(values, jacobian, factor, step)
    }
    /// force <- M^-1 force + v (v~ of eq. 3.1 from the force eta a h + B dw), then the first
    /// half ([`MatrixFactor::forward_in_place`](crate::MatrixFactor::forward_in_place)) of
    /// lambda = J^-1 (-Dg(x) v~) into `out`, for a diagonal M^-1. By default in three passes.
    #[inline(always)]
    fn velocity_right_hand_side<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x: &[T], force: &mut [T], v: &[T], factor: &FactorOf<Self, T>,
        out: &mut [T],
    ) {
        for (k, (f, vi)) in force.iter_mut().zip(v).enumerate() {
            *f = inverse_mass.diagonal_product(k, *f) + *vi;
        }
        self.negated_jacobian_mul(x, force, out);
        crate::factor::MatrixFactor::forward_in_place(factor, out);
    }
    /// [`Equations::displace`] from a base that may be formed where it is read (written out
    /// first by default).
    #[inline(always)]
    fn displace_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, inverse_mass: &W, r: &[T], z: &[T], base: Option<&P>, out: &mut [T],
    ) {
        let n = Equations::dim(self);
        let len = base.map_or(n, |base| point_len(base, n));
        let mut scratch = Scratch::take(r[0], len);
        match base {
            Some(base) => {
                let (base, _) = point(base, scratch.entries(), n);
                Equations::displace(self, inverse_mass, r, z, Some(base), out, &mut []);
            }
            None => Equations::displace(self, inverse_mass, r, z, None, out, scratch.entries()),
        }
    }
    /// v_{k+1} = v~ + M^-1 grad g(r) lambda in place of v~ (`v`, [`Equations::displace_at`]
    /// without a base), then the paths whose v_{k+1} the one-path step finds finite
    /// (|v_{k+1}|^2 finite; a constraint may report fewer, which then step one at a time) and,
    /// if `monitor`, max_i |(Dg(x) v_{k+1})_i| (in `scratch`, m rows). By default in three
    /// passes.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn finish_velocity<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], lambda: &[T], x: &[T], monitor: bool, v: &mut [T],
        scratch: &mut [T],
    ) -> (T::Mask, T) {
        self.displace_at(inverse_mass, r, lambda, None::<&[T]>, v);
        let finite = sum_squares(v).finite();
        if !monitor {
            return (finite, v[0].splat_like(0.0));
        }
        // max_i |-(Dg(x) v)_i| = max_i |(Dg(x) v)_i|.
        self.negated_jacobian_mul(x, v, scratch);
        (finite, max_abs(scratch))
    }
    /// out = -Dg(x) u, the negation of [`Equations::jacobian_mul`] (bit for bit: negation is
    /// exact and commutes with rounding), so that lambda's right-hand side needs no pass of
    /// its own.
    #[inline(always)]
    fn negated_jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        Equations::jacobian_mul(self, x, u, out);
        for o in out.iter_mut() {
            *o = -*o;
        }
    }
    /// [`Equations::kappa_quadratic`] at a point that may be formed where it is read (`None`
    /// at once, without forming it, where m > 1 or g is not quadratic).
    #[inline(always)]
    fn kappa_quadratic_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, inverse_mass: &W, r: &[T], y: &P,
    ) -> Option<[T; 3]> {
        if !has_kappa_quadratic(self) {
            return None;
        }
        let n = Equations::dim(self);
        let mut scratch = Scratch::take(r[0], point_len(y, n) + n);
        let (y, rest) = point(y, scratch.entries(), n);
        Equations::kappa_quadratic(self, inverse_mass, r, y, rest)
    }

    /// Offers `visitor` the constraint's forms over lanes for `mass`
    /// ([`Constraint::lane_form`](crate::Constraint::lane_form)): for a diagonal mass, these
    /// methods for Newton ([`offer_newton`]). A constraint of one quadratic equation in 2 or 3
    /// coordinates with the scalar Gram storage may offer the fixed-size closed-form kernels
    /// instead ([`offer_closed_form`]: the same numbers, 3.6x faster on the pendulum), which
    /// are then compiled for its type (so they are not offered by default).
    #[inline(always)]
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        offer_newton(self, mass, visitor)
    }
}

/// What a constraint offers an engine over lanes ([`Equations::lane_form`]):
/// the engine implements the methods for the forms it can step, and a constraint calls the one
/// that fits it. A form the engine does not step falls back to [`LaneFormVisitor::none`].
pub trait LaneFormVisitor: Sized {
    /// What the engine makes of the offer.
    type Output;
    /// No lane form: the paths step one at a time.
    fn none(self) -> Self::Output;
    /// A constraint of one quadratic equation in 2 or 3 coordinates with the scalar Gram
    /// storage (the sphere; [`offer_closed_form`]), whose kappa
    /// system the engine solves in closed form on arrays of that size.
    fn closed_form<E: Equations>(self, constraint: &E) -> Self::Output {
        let _ = constraint;
        self.none()
    }
    /// The constraint's [`Equations`] forms over lanes for the Newton iteration with its
    /// diagonal `mass` (an engine keeps them as a `LaneForm`, built when it has none kept from
    /// an earlier step).
    fn newton<L: Equations, M: Mass>(self, constraint: &L, mass: &M) -> Self::Output {
        let _ = (constraint, mass);
        self.none()
    }
}

/// The default [`Equations::lane_form`]: the constraint's methods for Newton with a diagonal
/// mass ([`LaneFormVisitor::newton`]), none for another mass or for a dense Newton matrix
/// beyond [`DENSE_FAER_THRESHOLD`] (factored by faer, path by path, whose numbers lanes of LU
/// would not reproduce).
#[inline(always)]
pub fn offer_newton<E: Equations, M: Mass, V: LaneFormVisitor>(
    equations: &E, mass: &M, visitor: V,
) -> V::Output {
    let dense_beyond = <E::Shape as GramShape>::STRUCTURE == GramStructure::Dense
        && Equations::n_constraints(equations) > DENSE_FAER_THRESHOLD;
    if !M::DIAGONAL || dense_beyond {
        return visitor.none();
    }
    visitor.newton(equations, mass)
}

/// The fixed-size closed-form kernels ([`LaneFormVisitor::closed_form`]) where they apply (a
/// diagonal mass, one quadratic equation in 2 or 3 coordinates, the scalar Gram storage), else
/// [`offer_newton`]: for an override of [`Equations::lane_form`], as the sphere's.
#[inline(always)]
pub fn offer_closed_form<E: Equations, M: Mass, V: LaneFormVisitor>(
    equations: &E, mass: &M, visitor: V,
) -> V::Output {
    let fixed_size = M::DIAGONAL
        && matches!(Equations::dim(equations), 2 | 3)
        && has_kappa_quadratic(equations)
        && <E::Shape as GramShape>::STRUCTURE == GramStructure::Scalar;
    if fixed_size {
        return visitor.closed_form(equations);
    }
    offer_newton(equations, mass, visitor)
}

/// The Newton matrix of constraint C over numbers of type T.
pub type GramOf<C, T> = <<C as Equations>::Shape as GramShape>::Matrix<T>;

/// The factorization of the Newton matrix of constraint C over numbers of type T.
pub type FactorOf<C, T> = <<C as Equations>::Shape as GramShape>::Factor<T>;

/// A mass's inverse as the [`Equations`] formulas apply it, over numbers of type T: `f64` for
/// one path (any mass), lanes for W paths (a diagonal mass, [`InverseMass`]).
pub trait InverseMassOf<T> {
    /// x <- M^-1 x.
    fn apply_inverse(&self, x: &mut [T]);
    /// (M^-1)_kk where M is diagonal, `None` otherwise.
    fn diagonal_entry(&self, k: usize) -> Option<f64>;
    /// a^T M^-1 b (`Mass::inverse_inner`), `scratch` n entries.
    fn inverse_inner(&self, a: &[T], b: &[T], scratch: &mut [T]) -> T;
    /// x (M^-1)_kk where M is diagonal (NaN otherwise): the product of one entry, left out
    /// where M^-1 = I (x * 1 = x exactly).
    #[inline(always)]
    fn diagonal_product(&self, k: usize, x: T) -> T
    where
        T: Real,
    {
        x * self.diagonal_entry(k).unwrap_or(f64::NAN)
    }
    /// Whether M^-1 = I is known (false by default): a form may then take a sum of equal
    /// terms once.
    #[inline(always)]
    fn is_unit(&self) -> bool {
        false
    }
}

/// out = base + M^-1 grad g(r) z in passes ([`Equations::displace`]): grad g(r) z (into `out`,
/// or into `scratch` where `out` is its own base), M^-1 applied, the sum.
#[inline(always)]
pub(crate) fn displace_in_passes<E: Equations, T: Real, W: InverseMassOf<T>>(
    equations: &E, inverse_mass: &W, r: &[T], z: &[T], base: Option<&[T]>, out: &mut [T],
    scratch: &mut [T],
) {
    let Some(base) = base else {
        let step = &mut scratch[..Equations::dim(equations)];
        Equations::jacobian_transpose_mul(equations, r, z, step);
        inverse_mass.apply_inverse(step);
        for (o, s) in out.iter_mut().zip(step.iter()) {
            *o = *s + *o;
        }
        return;
    };
    Equations::jacobian_transpose_mul(equations, r, z, out);
    inverse_mass.apply_inverse(out);
    for (o, b) in out.iter_mut().zip(base) {
        *o = *o + *b;
    }
}

/// Whether the kappa system of `equations` is a quadratic in gamma: m = 1 and g quadratic.
#[inline(always)]
pub(crate) fn has_kappa_quadratic<E: Equations>(equations: &E) -> bool {
    equations.is_quadratic() && Equations::n_constraints(equations) == 1
}

/// A diagonal M^-1, entry by entry (the engines' lanes).
impl<T: Real> InverseMassOf<T> for InverseMass {
    #[inline(always)]
    fn apply_inverse(&self, x: &mut [T]) {
        for (k, xk) in x.iter_mut().enumerate() {
            *xk = self.apply(k, *xk);
        }
    }
    #[inline(always)]
    fn diagonal_entry(&self, k: usize) -> Option<f64> {
        Some(self.entry(k))
    }
    #[inline(always)]
    fn diagonal_product(&self, k: usize, x: T) -> T {
        self.apply(k, x)
    }
    #[inline(always)]
    fn is_unit(&self) -> bool {
        InverseMass::is_unit(self)
    }
    /// sum_k a_k b_k (M^-1)_kk, in order (`Mass::inverse_inner` of a diagonal mass).
    #[inline(always)]
    fn inverse_inner(&self, a: &[T], b: &[T], _: &mut [T]) -> T {
        let mut sum = a[0].splat_like(-0.0);
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            sum = sum + *x * *y * self.entry(k);
        }
        sum
    }
}

/// A diagonal M^-1 of N entries, for any number type: x (M^-1)_kk entry by entry.
impl<T: Real, const N: usize> InverseMassOf<T> for [f64; N] {
    #[inline(always)]
    fn apply_inverse(&self, x: &mut [T]) {
        for (xk, w) in x.iter_mut().zip(self) {
            *xk = *xk * *w;
        }
    }
    #[inline(always)]
    fn diagonal_entry(&self, k: usize) -> Option<f64> {
        Some(self[k])
    }
    /// sum_k a_k b_k (M^-1)_kk, in order.
    #[inline(always)]
    fn inverse_inner(&self, a: &[T], b: &[T], _: &mut [T]) -> T {
        let mut sum = a[0].splat_like(-0.0);
        for ((x, y), w) in a.iter().zip(b).zip(self) {
            sum = sum + *x * *y * *w;
        }
        sum
    }
}

/// The map p -> Dg(x1) M^-1 grad g(x2) p, with its n-entry column.
struct CrossProduct<'a, E, T, W> {
    equations: &'a E,
    x1: &'a [T],
    x2: &'a [T],
    inverse_mass: &'a W,
    column: &'a mut [T],
}

impl<E: Equations, T: Real, W: InverseMassOf<T>> Product<T> for CrossProduct<'_, E, T, W> {
    /// grad g(x2) p, then M^-1 in place, then Dg(x1) of that.
    #[inline(always)]
    fn product(&mut self, p: &[T], image: &mut [T]) {
        Equations::jacobian_transpose_mul(self.equations, self.x2, p, self.column);
        self.inverse_mass.apply_inverse(self.column);
        Equations::jacobian_mul(self.equations, self.x1, self.column, image);
    }
}

/// out = Dg(x1) M^-1 grad g(x2) (seed Section 2.1; the Newton matrix of the kappa system and
/// the matrix of the lambda system of eq. 3.1) from the products p -> Dg(x1) M^-1 grad g(x2)
/// p ([`ByProducts`]). `scratch` has n + 2m entries at least. The default
/// [`Equations::cross_gram`], for a constraint whose override falls back to it.
#[inline(always)]
pub fn cross_gram<E: Equations, T: Real, W: InverseMassOf<T>>(
    equations: &E, x1: &[T], x2: &[T], inverse_mass: &W, scratch: &mut [T],
    out: &mut impl ByProducts<T>,
) {
    let (n, m) = (
        Equations::dim(equations),
        Equations::n_constraints(equations),
    );
    let (column, rest) = scratch.split_at_mut(n);
    let (probe, rest) = rest.split_at_mut(m);
    let mut product = CrossProduct {
        equations,
        x1,
        x2,
        inverse_mass,
        column,
    };
    out.assemble_by_products(probe, &mut rest[..m], &mut product);
}

/// [c0, c1, c2] of the kappa system of one equation where g is quadratic (seed eq. 3.1, upper
/// part): R(gamma) = g(y + gamma w) = c0 + c1 gamma + c2 gamma^2 with w = M^-1 grad g(r) (into
/// `w`, n entries), c0 = g(y), c1 = Dg(y) w, c2 = D^2 g(y)(w, w) / 2 (computed as the product
/// with 0.5). The default [`Equations::kappa_quadratic`] where it applies, for a constraint
/// whose override falls back to it.
#[inline(always)]
pub fn kappa_coefficients<E: Equations, T: Real, W: InverseMassOf<T>>(
    equations: &E, r: &[T], y: &[T], inverse_mass: &W, w: &mut [T],
) -> [T; 3] {
    let one = [r[0].splat_like(1.0)];
    let w = &mut w[..Equations::dim(equations)];
    Equations::jacobian_transpose_mul(equations, r, &one, w);
    inverse_mass.apply_inverse(w);
    let mut c = [[r[0]]; 3];
    Equations::value(equations, y, &mut c[0]);
    Equations::jacobian_mul(equations, y, w, &mut c[1]);
    Equations::second_derivative(equations, y, w, w, &mut c[2]);
    [c[0][0], c[1][0], c[2][0] * 0.5]
}

/// The scratch entries [`point`] takes: none where `x` is stored, n where it is formed.
#[inline(always)]
fn point_len<T: Real, P: Point<T> + ?Sized>(x: &P, n: usize) -> usize {
    if x.stored().is_some() { 0 } else { n }
}

/// The n coordinates of `x` as a slice: `x` itself where it is stored, else formed into the
/// first n entries of `scratch`; and the rest of `scratch`.
#[inline(always)]
fn point<'a, T: Real, P: Point<T> + ?Sized>(
    x: &'a P, scratch: &'a mut [T], n: usize,
) -> (&'a [T], &'a mut [T]) {
    match x.stored() {
        Some(x) => (&x[..n], scratch),
        None => {
            let (formed, rest) = scratch.split_at_mut(n);
            x.write_to(formed);
            (formed, rest)
        }
    }
}

thread_local! {
    /// Each thread's scratch buffers, one per number type (`Vec<T>`), kept between calls.
    static SCRATCH: RefCell<Vec<Box<dyn Any>>> = const { RefCell::new(Vec::new()) };
}

/// At most this many scratch values live on the stack ([`Scratch`]); more take the thread's
/// buffer.
const SMALL_SCRATCH: usize = 16;

/// At most this many scratch values take the smaller array of the stack ([`Scratch::Few`]):
/// a small system's point, row and pair of rows (the pendulum's 2 to 6), without writing the
/// 16 of [`SMALL_SCRATCH`] on every call.
const FEW_SCRATCH: usize = 8;

/// Scratch values of type T: on the stack where they are few, else the thread's buffer for
/// T ([`Scratch::take`]), given back when dropped; so a steady state allocates nothing.
/// While the thread's buffer is taken, another of the same type (a nested use) is a buffer
/// of its own.
pub(crate) enum Scratch<T: Real> {
    /// `len` <= [`FEW_SCRATCH`] values on the stack.
    Few([T; FEW_SCRATCH], usize),
    /// `len` <= [`SMALL_SCRATCH`] values on the stack.
    Small([T; SMALL_SCRATCH], usize),
    /// The thread's buffer and `len`.
    Thread(Vec<T>, usize),
}

impl<T: Real> Scratch<T> {
    /// `len` values of the kind of `like` (their content unspecified).
    #[inline(always)]
    pub(crate) fn take(like: T, len: usize) -> Self {
        let zero = like.splat_like(0.0);
        if len <= FEW_SCRATCH {
            return Self::Few([zero; FEW_SCRATCH], len);
        }
        if len <= SMALL_SCRATCH {
            return Self::Small([zero; SMALL_SCRATCH], len);
        }
        let mut buffer: Vec<T> = SCRATCH.with_borrow_mut(|buffers| {
            buffers
                .iter_mut()
                .find_map(|b| b.downcast_mut::<Vec<T>>())
                .map(std::mem::take)
                .unwrap_or_default()
        });
        if buffer.len() < len {
            buffer.resize(len, zero);
        }
        Self::Thread(buffer, len)
    }
    /// The values.
    #[inline(always)]
    pub(crate) fn entries(&mut self) -> &mut [T] {
        match self {
            Self::Few(values, len) => &mut values[..*len],
            Self::Small(values, len) => &mut values[..*len],
            Self::Thread(buffer, len) => &mut buffer[..*len],
        }
    }
}

impl<T: Real> Drop for Scratch<T> {
    /// The thread's buffer back to the thread, where it is the larger.
    #[inline(always)]
    fn drop(&mut self) {
        let Self::Thread(buffer, _) = self else {
            return;
        };
        let buffer = std::mem::take(buffer);
        SCRATCH.with_borrow_mut(|buffers| {
            match buffers.iter_mut().find_map(|b| b.downcast_mut::<Vec<T>>()) {
                Some(slot) if slot.capacity() < buffer.capacity() => *slot = buffer,
                Some(_) => {}
                None => buffers.push(Box::new(buffer)),
            }
        });
    }
}
