//! The sphere as a constraint ([`Equations`], [`TheoryBound`]), from its formulas in
//! `sphere.rs`: written once over the number type, with its single passes for a diagonal mass.

use sdae_lanes::Real;

use crate::constraint::{TheoryBound, motion_measure};
use crate::equations::{
    Equations, InverseMassOf, LaneFormVisitor, displace_in_passes, offer_closed_form,
};
use crate::gram::ScalarGram;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::Scalar;
use crate::sphere::Sphere;
use crate::vector::dot_with;

impl Equations for Sphere {
    type Shape = Scalar;
    fn dim(&self) -> usize {
        self.dim
    }
    fn n_constraints(&self) -> usize {
        1
    }
    /// g(x) = (1 - |x|^2 / rho^2) / 2, as ((-(|x|^2 / rho^2)) + 1) / 2 (1 - a is 1 + (-a)).
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        let xx = dot_with(x[0].splat_like(0.0), x, x);
        out[0] = (-(xx * self.inv_r2) + 1.0) * 0.5;
    }
    /// Dg(x) u = -x.u / rho^2.
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        out[0] = self.normal_rate(x, u);
    }
    /// grad g(x) z = -x z / rho^2.
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        let s = -z[0] * self.inv_r2;
        for (o, xi) in out.iter_mut().zip(x) {
            *o = s * *xi;
        }
    }
    /// D^2 g(x)(u, w) = -u.w / rho^2.
    #[inline(always)]
    fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        out[0] = self.curvature_rate(u, w);
    }
    fn is_quadratic(&self) -> bool {
        true
    }
    /// Rounding of g(x) = (1 - |x|^2/rho^2)/2: a few ulps of |x|^2/rho^2.
    fn roundoff(&self) -> Roundoff {
        Roundoff::SquaredRadius {
            dim: self.dim,
            inverse_radius_squared: self.inverse_radius_squared(),
        }
    }
    /// Dg(x1) M^-1 grad g(x2) = x1^T M^-1 x2 / rho^4.
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x1: &[T], x2: &[T], scratch: &mut [T], out: &mut ScalarGram<T>,
    ) {
        let inner = inverse_mass.inverse_inner(x1, x2, &mut scratch[..self.dim]);
        out.0 = inner * self.inv_r2 * self.inv_r2;
    }
    /// g(x) = (1 - |x|^2 / rho^2) / 2 and Dg(x) M^-1 grad g(r) = x^T M^-1 r / rho^4, in one pass
    /// for a diagonal mass (one Newton evaluation of the kappa system, seed eq. 3.1).
    #[inline(always)]
    fn value_and_cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, x: &[T], r: &[T], scratch: &mut [T], value: &mut [T],
        gram: &mut ScalarGram<T>,
    ) {
        if inverse_mass.diagonal_entry(0).is_none() {
            Equations::value(self, x, value);
            return Equations::cross_gram(self, inverse_mass, x, r, scratch, gram);
        }
        [value[0], gram.0] = self.value_and_gram(x, r, |k| diagonal(inverse_mass, k));
    }
    /// One pass for a diagonal mass: out_k = base_k + w_k (-z x_k / rho^2), w_k = (M^-1)_kk
    /// (seed eq. 3.1: the position of the kappa system and the velocity update).
    #[inline(always)]
    fn displace<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], z: &[T], base: Option<&[T]>, out: &mut [T],
        scratch: &mut [T],
    ) {
        if inverse_mass.diagonal_entry(0).is_none() {
            return displace_in_passes(self, inverse_mass, r, z, base, out, scratch);
        }
        let w = |k| diagonal(inverse_mass, k);
        match base {
            Some(base) => self.displace_diagonal(r, z[0], w, base, out),
            None => self.displace_diagonal_in_place(r, z[0], w, out),
        }
    }
    /// For a diagonal mass W = M^-1 (seed eq. 3.1 upper part; x = y - gamma W r / rho^2):
    ///
    /// R(gamma) = (1 - |y|^2 / rho^2) / 2 + gamma y.W r / rho^4 - gamma^2 |W r|^2 / (2 rho^6),
    ///
    /// in one pass over y and r; by the general formulas otherwise.
    #[inline(always)]
    fn kappa_quadratic<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], y: &[T], scratch: &mut [T],
    ) -> Option<[T; 3]> {
        let _ = scratch;
        inverse_mass.diagonal_entry(0)?;
        Some(self.kappa_coefficients(r, y, |k| diagonal(inverse_mass, k)))
    }
    /// w = |v| / rho, alpha = |a| / rho: the seed's functional for rho = 1.
    #[inline(always)]
    fn local_motion<T: Real>(&self, _x: &[T], v: &[T], a: &[T]) -> Option<T> {
        let zero = v[0].splat_like(0.0);
        Some(motion_measure(
            dot_with(zero, v, v).sqrt() / self.radius,
            dot_with(zero, a, a).sqrt() / self.radius,
        ))
    }
    /// The fixed-size closed-form kernels ([`LaneFormVisitor::closed_form`]) where they
    /// apply (a diagonal mass, 2 or 3 coordinates), else the general ones.
    #[inline(always)]
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        offer_closed_form(self, mass, visitor)
    }
}

/// (M^-1)_kk of a diagonal mass.
#[inline(always)]
fn diagonal<T, W: InverseMassOf<T>>(inverse_mass: &W, k: usize) -> f64 {
    inverse_mass.diagonal_entry(k).unwrap_or(0.0)
}

impl TheoryBound for Sphere {
    /// With eigenvalues of M in [m_lo, m_hi]: |M^-1 grad g| <= 1/(m_lo rho), |G_M| <= 1/(m_lo rho^2),
    /// |G_M^-1| <= m_hi rho^2, |D^2 g| = 1/rho^2, D^3 g = 0 (limit epsilon -> 0 of eq. 2.2).
    fn c_g<M: Mass>(&self, mass: &M) -> Option<f64> {
        let (lo, hi) = mass.eigenvalue_bounds();
        let r = self.radius;
        Some(
            [
                1.0,
                1.0 / (lo * r),
                1.0 / (lo * r * r),
                hi * r * r,
                1.0 / (r * r),
            ]
            .into_iter()
            .fold(1.0, f64::max),
        )
    }
}
