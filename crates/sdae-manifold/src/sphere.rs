//! The sphere of radius rho in R^d (a circle for d = 2): the pendulum of seed Section 5.1.

use crate::constraint::{Constraint, Curvature, TheoryBound, motion_measure};
use crate::error::{ManifoldError, check_at_least, check_positive};
use crate::gram::ScalarGram;
use crate::lane_form::LaneFormVisitor;
use crate::mass::Mass;
use crate::vector::dot;
use sdae_lanes::Real;

/// g(x) = (1 - |x|^2 / rho^2) / 2, one constraint (seed Section 5.1 with rho = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    dim: usize,
    radius: f64,
    inv_r2: f64,
}

impl Sphere {
    /// The sphere of radius `radius` centred at the origin of R^`dim`, dim >= 2.
    pub fn new(dim: usize, radius: f64) -> Result<Self, ManifoldError> {
        check_at_least("dim", dim, 2, "a sphere needs dimension >= 2")?;
        check_positive("radius", radius)?;
        Ok(Self {
            dim,
            radius,
            inv_r2: 1.0 / (radius * radius),
        })
    }

    /// The unit circle in R^2, the seed's planar pendulum.
    pub fn unit_circle() -> Self {
        Self {
            dim: 2,
            radius: 1.0,
            inv_r2: 1.0,
        }
    }

    /// The radius rho.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// 1 / rho^2, as g and its derivatives use it.
    pub fn inverse_radius_squared(&self) -> f64 {
        self.inv_r2
    }
}

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
    #[inline]
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        out[0] = -dot(x, u) * self.inv_r2;
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
        &self,
        x1: &[f64],
        x2: &[f64],
        mass: &M,
        scratch: &mut [f64],
        out: &mut ScalarGram,
    ) {
        out.0 = mass.inverse_inner(x1, x2, &mut scratch[..self.dim]) * self.inv_r2 * self.inv_r2;
    }
    /// g(x) = (1 - |x|^2 / rho^2) / 2 and Dg(x) M^-1 grad g(r) = x^T M^-1 r / rho^4, in one pass
    /// for diagonal masses (one Newton evaluation of the kappa system, seed eq. 3.1).
    #[inline(always)]
    fn value_and_cross_gram<M: Mass>(
        &self,
        x: &[f64],
        r: &[f64],
        mass: &M,
        scratch: &mut [f64],
        value: &mut [f64],
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
        let s = -z[0] * self.inv_r2;
        for (k, ((o, ri), yi)) in out.iter_mut().zip(r).zip(y).enumerate() {
            *o = s * ri * mass.inverse_diagonal_entry(k).unwrap_or(0.0) + yi;
        }
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
    fn value_roundoff(&self, max_abs_x: f64) -> f64 {
        self.roundoff(max_abs_x)
    }
    /// The closed form of the kappa system ([`LaneFormVisitor::sphere`]).
    #[inline(always)]
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        let _ = mass;
        visitor.sphere(self)
    }
}

impl Sphere {
    /// [c0, c1, c2] of R(gamma) = c0 + c1 gamma + c2 gamma^2 = g(y - gamma W r / rho^2) for
    /// the diagonal W = M^-1 with entries `w(k)` ([`Constraint::kappa_quadratic`]), in one
    /// pass over y and r, for one path (`f64`) or for lanes (the ensemble's closed-form root).
    #[inline(always)]
    pub fn kappa_coefficients<T: Real>(
        &self,
        r: &[T],
        y: &[T],
        w: impl Fn(usize) -> f64,
    ) -> [T; 3] {
        let zero = r[0].splat_like(0.0);
        let (mut yy, mut yu, mut uu) = (zero, zero, zero);
        for (k, (ri, yi)) in r.iter().zip(y).enumerate() {
            let u = *ri * w(k);
            yy = yy + *yi * *yi;
            yu = yu + *yi * u;
            uu = uu + u * u;
        }
        let c = self.inv_r2;
        // (1 - yy c) / 2 as ((-(yy c)) + 1) / 2: 1 - x is 1 + (-x), bit for bit.
        [(-(yy * c) + 1.0) * 0.5, yu * c * c, uu * -0.5 * c * c * c]
    }

    /// [g(x), x^T W r / rho^4] for the diagonal W = M^-1 with entries `w(k)`
    /// ([`Constraint::value_and_cross_gram`]), in one pass, for one path or for lanes.
    #[inline(always)]
    pub fn value_and_gram<T: Real>(&self, x: &[T], r: &[T], w: impl Fn(usize) -> f64) -> [T; 2] {
        let zero = x[0].splat_like(0.0);
        let (mut xx, mut xr) = (zero, zero);
        for (k, (xi, ri)) in x.iter().zip(r).enumerate() {
            xx = xx + *xi * *xi;
            xr = xr + *xi * *ri * w(k);
        }
        let c = self.inv_r2;
        [(-(xx * c) + 1.0) * 0.5, xr * c * c]
    }

    /// Rounding of g(x) = (1 - |x|^2/rho^2)/2: a few ulps of |x|^2/rho^2.
    pub fn roundoff(&self, max_abs_x: f64) -> f64 {
        4.0 * f64::EPSILON * (self.dim as f64) * max_abs_x * max_abs_x * self.inv_r2
    }
}

impl Curvature for Sphere {
    /// D^2 g(x)(u, w) = -u.w / rho^2.
    fn second_derivative(&self, _x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        out[0] = -dot(u, w) * self.inv_r2;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mass::{DiagonalMass, IdentityMass};

    #[test]
    fn unit_circle_has_c_g_one() {
        assert_eq!(Sphere::unit_circle().c_g(&IdentityMass), Some(1.0));
        let heavy = DiagonalMass::new(vec![2.0, 2.0]).unwrap();
        assert_eq!(Sphere::new(2, 1.0).unwrap().c_g(&heavy), Some(2.0));
    }

    #[test]
    fn bad_parameters_are_rejected() {
        assert!(Sphere::new(1, 1.0).is_err());
        assert!(Sphere::new(3, 0.0).is_err());
        assert!(Sphere::new(3, f64::NAN).is_err());
    }
}
