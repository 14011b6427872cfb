//! The rounding floor of a constraint's value: the size of |g(x)| that rounding alone produces
//! for coordinates of size max_k |x_k|, below which Newton's method cannot push the residual of
//! the kappa system (seed eq. 3.1, upper part). Stated once here, for one path and for lanes:
//! a constraint says which kind of floor it has ([`Constraint::roundoff`](crate::Constraint::roundoff)),
//! and every root solver takes [`Roundoff::floor`] of it.

use sdae_lanes::Real;

/// The kind of a constraint's rounding floor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Roundoff {
    /// Not known: no floor (0).
    #[default]
    Unknown,
    /// g a squared length relative to a fixed length L (a chain's segments, rigid bonds:
    /// g = 1/2 - |x_j - x_i|^2 / (2 L^2)): the differences carry a few ulps of max |x|, so
    /// the floor is 4 eps max|x| / L.
    Length(f64),
    /// g = (1 - |x|^2 / rho^2) / 2 on d coordinates (the sphere): a few ulps of |x|^2 / rho^2,
    /// the floor 4 eps d max|x|^2 / rho^2.
    SquaredRadius {
        /// The number d of coordinates.
        dim: usize,
        /// 1 / rho^2.
        inverse_radius_squared: f64,
    },
}

impl Roundoff {
    /// The floor for coordinates of size `max_abs_x`, of the kind of `max_abs_x` (NaN where it
    /// is NaN, except for an unknown floor).
    #[inline(always)]
    pub fn floor<T: Real>(self, max_abs_x: T) -> T {
        match self {
            Roundoff::Unknown => max_abs_x.splat_like(0.0),
            Roundoff::Length(length) => {
                max_abs_x.splat_like(4.0 * f64::EPSILON) * max_abs_x / length
            }
            Roundoff::SquaredRadius {
                dim,
                inverse_radius_squared,
            } => {
                max_abs_x.splat_like(4.0 * f64::EPSILON * dim as f64)
                    * max_abs_x
                    * max_abs_x
                    * inverse_radius_squared
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floors as the constraints stated them before they were stated here, bit for bit.
    #[test]
    fn floors_are_the_stated_formulas() {
        for max in [0.0, 1e-3, 0.7, 1.0, 3.5, 1e8] {
            assert_eq!(Roundoff::Unknown.floor(max), 0.0);
            let length = 0.37;
            assert_eq!(
                Roundoff::Length(length).floor(max).to_bits(),
                (4.0 * f64::EPSILON * max / length).to_bits()
            );
            let (dim, inv_r2) = (3, 1.0 / (1.3 * 1.3));
            let squared = Roundoff::SquaredRadius {
                dim,
                inverse_radius_squared: inv_r2,
            };
            assert_eq!(
                squared.floor(max).to_bits(),
                (4.0 * f64::EPSILON * (dim as f64) * max * max * inv_r2).to_bits()
            );
        }
        assert!(Roundoff::Length(1.0).floor(f64::NAN).is_nan());
    }
}
