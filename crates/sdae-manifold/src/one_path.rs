//! The one-path forms of a constraint written once over [`Real`](sdae_lanes::Real): every
//! [`Equations`] type is a [`Constraint`] (its methods at `T = f64`, the mass applied by
//! itself) and a [`Curvature`], and offers an ensemble engine its forms over lanes
//! ([`Equations::lane_form`]).

use crate::constraint::{Constraint, Curvature};
use crate::equations::{Equations, InverseMassOf, LaneFormVisitor, Scratch, has_kappa_quadratic};
use crate::error::ManifoldError;
use crate::gram::SquareMatrix;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::GramShape;

/// The one-path forms: the [`Equations`] methods at T = f64 with the mass applied by itself.
impl<E: Equations> Constraint for E {
    type Gram = <E::Shape as GramShape>::Gram;
    fn dim(&self) -> usize {
        Equations::dim(self)
    }
    fn n_constraints(&self) -> usize {
        Equations::n_constraints(self)
    }
    #[inline]
    fn value(&self, x: &[f64], out: &mut [f64]) {
        Equations::value(self, x, out);
    }
    #[inline]
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        Equations::jacobian_mul(self, x, u, out);
    }
    #[inline]
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        Equations::jacobian_transpose_mul(self, x, z, out);
    }
    fn new_gram(&self) -> Self::Gram {
        SquareMatrix::zeros_like(0.0, Equations::n_constraints(self))
    }
    /// [`Equations::cross_gram`].
    #[inline]
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut Self::Gram,
    ) {
        let out = E::Shape::one_path(out);
        Equations::cross_gram(self, &OnePath(mass), x1, x2, scratch, out);
    }
    /// [`Equations::value_and_cross_gram`].
    #[inline]
    fn value_and_cross_gram<M: Mass>(
        &self, x: &[f64], r: &[f64], mass: &M, scratch: &mut [f64], value: &mut [f64],
        gram: &mut Self::Gram,
    ) {
        let gram = E::Shape::one_path(gram);
        Equations::value_and_cross_gram(self, &OnePath(mass), x, r, scratch, value, gram);
    }
    /// [`Equations::displace`].
    #[inline]
    fn displace<M: Mass>(&self, r: &[f64], z: &[f64], mass: &M, y: &[f64], out: &mut [f64]) {
        Equations::displace(self, &OnePath(mass), r, z, Some(y), out, &mut []);
    }
    /// [`Equations::kappa_quadratic`] (`None` at once where m > 1 or g is not quadratic).
    #[inline]
    fn kappa_quadratic<M: Mass>(&self, r: &[f64], y: &[f64], mass: &M) -> Option<[f64; 3]> {
        if !has_kappa_quadratic(self) {
            return None;
        }
        let mut scratch = Scratch::take(0.0, Equations::dim(self));
        Equations::kappa_quadratic(self, &OnePath(mass), r, y, scratch.entries())
    }
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        Equations::check_mass(self, mass)
    }
    fn local_motion(&self, x: &[f64], v: &[f64], a: &[f64]) -> Option<f64> {
        Equations::local_motion(self, x, v, a)
    }
    /// [`Equations::lane_form`], inlined into the engine that asks (the sphere's step of one
    /// path runs inside its visitor).
    #[inline(always)]
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        Equations::lane_form(self, mass, visitor)
    }
    fn roundoff(&self) -> Roundoff {
        Equations::roundoff(self)
    }
}

impl<E: Equations> Curvature for E {
    #[inline]
    fn second_derivative(&self, x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        Equations::second_derivative(self, x, u, w, out);
    }
}

/// One path's mass.
struct OnePath<'a, M>(&'a M);

impl<M: Mass> InverseMassOf<f64> for OnePath<'_, M> {
    #[inline(always)]
    fn apply_inverse(&self, x: &mut [f64]) {
        self.0.apply_inverse(x);
    }
    #[inline(always)]
    fn diagonal_entry(&self, k: usize) -> Option<f64> {
        if M::DIAGONAL {
            self.0.inverse_diagonal_entry(k)
        } else {
            None
        }
    }
    #[inline(always)]
    fn inverse_inner(&self, a: &[f64], b: &[f64], scratch: &mut [f64]) -> f64 {
        self.0.inverse_inner(a, b, scratch)
    }
}
