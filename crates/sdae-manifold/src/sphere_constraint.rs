//! The sphere as a constraint ([`Constraint`], [`Curvature`], [`TheoryBound`]), from its
//! formulas in `sphere.rs`.

use crate::constraint::{Constraint, Curvature, TheoryBound, motion_measure};
use crate::gram::ScalarGram;
use crate::lane_form::LaneFormVisitor;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::sphere::Sphere;
use crate::vector::dot;

impl Constraint for Sphere {
    type Gram = ScalarGram;
    fn dim(&self) -> usize {
        self.dim
    }
    fn n_constraints(&self) -> usize {
        1
    }
    #[inline]
    fn value(&self, x: &[f64], out: &mut [f64]) {
        out[0] = 0.5 * (1.0 - dot(x, x) * self.inv_r2);
    }
    /// Dg(x) u = -x.u / rho^2.
    #[inline(always)]
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        out[0] = self.normal_rate(x, u);
    }
    /// grad g(x) z = -x z / rho^2.
    #[inline]
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        let s = -z[0] * self.inv_r2;
        for (o, xi) in out.iter_mut().zip(x) {
            *o = s * xi;
        }
    }
    /// w = |v| / rho, alpha = |a| / rho: the seed's functional for rho = 1.
    fn local_motion(&self, _x: &[f64], v: &[f64], a: &[f64]) -> Option<f64> {
        Some(motion_measure(
            dot(v, v).sqrt() / self.radius,
            dot(a, a).sqrt() / self.radius,
        ))
    }
    fn new_gram(&self) -> ScalarGram {
        ScalarGram(0.0)
    }
    /// Dg(x1) M^-1 grad g(x2) = x1^T M^-1 x2 / rho^4.
    #[inline]
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut ScalarGram,
    ) {
        out.0 = mass.inverse_inner(x1, x2, &mut scratch[..self.dim]) * self.inv_r2 * self.inv_r2;
    }
    /// g(x) = (1 - |x|^2 / rho^2) / 2 and Dg(x) M^-1 grad g(r) = x^T M^-1 r / rho^4, in one pass
    /// for diagonal masses (one Newton evaluation of the kappa system, seed eq. 3.1).
    #[inline(always)]
    fn value_and_cross_gram<M: Mass>(
        &self, x: &[f64], r: &[f64], mass: &M, scratch: &mut [f64], value: &mut [f64],
        gram: &mut ScalarGram,
    ) {
        if !M::DIAGONAL {
            self.value(x, value);
            return self.cross_gram(x, r, mass, scratch, gram);
        }
        [value[0], gram.0] =
            self.value_and_gram(x, r, |k| mass.inverse_diagonal_entry(k).unwrap_or(0.0));
    }
    /// One pass for diagonal masses: out_k = y_k + w_k (-z x_k / rho^2), w_k = (M^-1)_kk
    /// (seed eq. 3.1: the position of the kappa system and the velocity update).
    #[inline]
    fn displace<M: Mass>(&self, r: &[f64], z: &[f64], mass: &M, y: &[f64], out: &mut [f64]) {
        if !M::DIAGONAL {
            return crate::constraint::displace_in_passes(self, r, z, mass, y, out);
        }
        self.displace_diagonal(
            r,
            z[0],
            |k| mass.inverse_diagonal_entry(k).unwrap_or(0.0),
            y,
            out,
        );
    }
    /// For diagonal masses W = M^-1 (seed eq. 3.1 upper part; x = y - gamma W r / rho^2):
    ///
    /// R(gamma) = (1 - |x|^2 / rho^2) / 2
    ///          = (1 - |y|^2 / rho^2) / 2 + gamma y.W r / rho^4 - gamma^2 |W r|^2 / (2 rho^6),
    ///
    /// in one pass over y and r; `None` for non-diagonal masses.
    #[inline]
    fn kappa_quadratic<M: Mass>(&self, r: &[f64], y: &[f64], mass: &M) -> Option<[f64; 3]> {
        if !M::DIAGONAL {
            return None;
        }
        Some(self.kappa_coefficients(r, y, |k| mass.inverse_diagonal_entry(k).unwrap_or(0.0)))
    }
    /// Rounding of g(x) = (1 - |x|^2/rho^2)/2: a few ulps of |x|^2/rho^2.
    fn roundoff(&self) -> Roundoff {
        Roundoff::SquaredRadius {
            dim: self.dim(),
            inverse_radius_squared: self.inverse_radius_squared(),
        }
    }
    /// The closed form of the kappa system ([`LaneFormVisitor::sphere`]).
    #[inline(always)]
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        let _ = mass;
        visitor.sphere(self)
    }
}

impl Curvature for Sphere {
    /// D^2 g(x)(u, w) = -u.w / rho^2.
    #[inline(always)]
    fn second_derivative(&self, _x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        out[0] = self.curvature_rate(u, w);
    }
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
