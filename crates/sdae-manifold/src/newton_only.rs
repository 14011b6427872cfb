//! A constraint stepped by the general engine whatever fixed-size path it has
//! ([`NewtonOnly`]): for comparing such a path with the general one, in numbers (bit for bit)
//! and in time.

use sdae_lanes::Real;

use crate::constraint::TheoryBound;
use crate::equations::{Equations, InverseMassOf};
use crate::error::ManifoldError;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::GramShape;

/// `E` with every formula its own but the lane form the general one
/// ([`Equations::lane_form`]'s default: Newton over lanes, with the closed form where the
/// kappa system is quadratic): the sphere, which otherwise offers its fixed-size path
/// ([`LaneFormVisitor::closed_form`](crate::LaneFormVisitor::closed_form)), steps through the engine of
/// every other constraint.
///
/// ```
/// use sdae_manifold::{Constraint, NewtonOnly, Sphere};
///
/// let circle = NewtonOnly(Sphere::unit_circle());
/// let mut g = [1.0];
/// Constraint::value(&circle, &[0.6, 0.8], &mut g);
/// assert!(g[0].abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOnly<E>(pub E);

impl<E: Equations> Equations for NewtonOnly<E> {
    type Shape = E::Shape;
    fn dim(&self) -> usize {
        Equations::dim(&self.0)
    }
    fn n_constraints(&self) -> usize {
        Equations::n_constraints(&self.0)
    }
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        Equations::value(&self.0, x, out);
    }
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        Equations::jacobian_mul(&self.0, x, u, out);
    }
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        Equations::jacobian_transpose_mul(&self.0, x, z, out);
    }
    #[inline(always)]
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        Equations::second_derivative(&self.0, x, u, w, out);
    }
    fn is_quadratic(&self) -> bool {
        self.0.is_quadratic()
    }
    fn roundoff(&self) -> Roundoff {
        Equations::roundoff(&self.0)
    }
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        Equations::check_mass(&self.0, mass)
    }
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x1: &[T], x2: &[T], scratch: &mut [T],
        out: &mut <Self::Shape as GramShape>::Matrix<T>,
    ) {
        Equations::cross_gram(&self.0, inverse_mass, x1, x2, scratch, out);
    }
    #[inline(always)]
    fn value_and_cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x: &[T], r: &[T], scratch: &mut [T], value: &mut [T],
        gram: &mut <Self::Shape as GramShape>::Matrix<T>,
    ) {
        Equations::value_and_cross_gram(&self.0, inverse_mass, x, r, scratch, value, gram);
    }
    #[inline(always)]
    fn displace<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], z: &[T], base: Option<&[T]>, out: &mut [T],
        scratch: &mut [T],
    ) {
        Equations::displace(&self.0, inverse_mass, r, z, base, out, scratch);
    }
    #[inline(always)]
    fn kappa_quadratic<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], y: &[T], scratch: &mut [T],
    ) -> Option<[T; 3]> {
        Equations::kappa_quadratic(&self.0, inverse_mass, r, y, scratch)
    }
    #[inline(always)]
    fn local_motion<T: Real>(&self, x: &[T], v: &[T], a: &[T]) -> Option<T> {
        Equations::local_motion(&self.0, x, v, a)
    }
}

/// `E`'s bound: the constraint is the same.
impl<E: Equations + TheoryBound> TheoryBound for NewtonOnly<E> {
    fn c_g<M: Mass>(&self, mass: &M) -> Option<f64> {
        self.0.c_g(mass)
    }
}
