//! The sphere of radius rho in R^d (a circle for d = 2): the pendulum of seed Section 5.1.

use crate::error::{ManifoldError, check_at_least, check_positive};
use crate::vector::dot_with;
use sdae_lanes::Real;

/// g(x) = (1 - |x|^2 / rho^2) / 2, one constraint (seed Section 5.1 with rho = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    pub(crate) dim: usize,
    pub(crate) radius: f64,
    pub(crate) inv_r2: f64,
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

    /// The dimension d of the space the sphere lies in.
    pub fn dim(&self) -> usize {
        self.dim
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

impl Sphere {
    /// [c0, c1, c2] of R(gamma) = c0 + c1 gamma + c2 gamma^2 = g(y - gamma W r / rho^2) for
    /// the diagonal W = M^-1 with entries `w(k)` ([`Constraint::kappa_quadratic`](crate::Constraint::kappa_quadratic)), in one
    /// pass over y and r, for one path (`f64`) or for lanes (the ensemble's closed-form root).
    #[inline(always)]
    pub fn kappa_coefficients<T: Real>(
        &self, r: &[T], y: &[T], w: impl Fn(usize) -> f64,
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
    /// ([`Constraint::value_and_cross_gram`](crate::Constraint::value_and_cross_gram)), in one pass, for one path or for lanes.
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

    /// Dg(x) u = -x.u / rho^2 (x.u summed as [`vector::dot`](crate::vector::dot)), for one path
    /// or for lanes.
    #[inline(always)]
    pub fn normal_rate<T: Real>(&self, x: &[T], u: &[T]) -> T {
        -dot_with(x[0].splat_like(0.0), x, u) * self.inv_r2
    }

    /// D^2 g(x)(u, w) = -u.w / rho^2 (the same sum as [`Sphere::normal_rate`]), for one path or
    /// for lanes.
    #[inline(always)]
    pub fn curvature_rate<T: Real>(&self, u: &[T], w: &[T]) -> T {
        self.normal_rate(u, w)
    }

    /// out = y + W grad g(r) z = y - z W r / rho^2 for the diagonal W = M^-1 with entries `w(k)`
    /// (seed eq. 3.1: the kappa system's point, and v~ plus the velocity's constraint force),
    /// in one pass, for one path or for lanes.
    #[inline(always)]
    pub fn displace_diagonal<T: Real>(
        &self, r: &[T], z: T, w: impl Fn(usize) -> f64, y: &[T], out: &mut [T],
    ) {
        let s = -z * self.inv_r2;
        for (k, ((o, ri), yi)) in out.iter_mut().zip(r).zip(y).enumerate() {
            *o = s * *ri * w(k) + *yi;
        }
    }

    /// out <- out + W grad g(r) z = out - z W r / rho^2 ([`Sphere::displace_diagonal`] with
    /// out its own base), in one pass.
    #[inline(always)]
    pub fn displace_diagonal_in_place<T: Real>(
        &self, r: &[T], z: T, w: impl Fn(usize) -> f64, out: &mut [T],
    ) {
        let s = -z * self.inv_r2;
        for (k, (o, ri)) in out.iter_mut().zip(r).enumerate() {
            *o = s * *ri * w(k) + *o;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraint::TheoryBound;
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
