//! Mass matrices M (symmetric positive definite, seed eq. 1.1) and M^-1 applied to vectors.
//!
//! [`IdentityMass`] compiles to nothing, [`DiagonalMass`] is one multiply per entry,
//! [`DenseMass`] keeps the Cholesky factor of M (checked SPD at construction) and solves in
//! place with it.

use crate::error::{ManifoldError, check_finite, check_len, check_positive};

/// A symmetric positive definite mass matrix.
pub trait Mass {
    /// Whether M is diagonal: then [`Mass::inverse_diagonal_entry`] gives every entry of M^-1
    /// and constraints take their one-pass paths (a constant, so the other path compiles away).
    const DIAGONAL: bool;
    /// The order n, or `None` if the matrix fits any n (the identity).
    fn order(&self) -> Option<usize>;
    /// x <- M^-1 x.
    fn apply_inverse(&self, x: &mut [f64]);
    /// out = M x.
    fn apply(&self, x: &[f64], out: &mut [f64]);
    /// (M^-1)_{ii} if M is diagonal, `None` otherwise.
    fn inverse_diagonal_entry(&self, i: usize) -> Option<f64>;
    /// Bounds (lambda_min, lambda_max) on the eigenvalues of M.
    fn eigenvalue_bounds(&self) -> (f64, f64);
    /// a^T M^-1 b; `scratch` (length n) is used only by non-diagonal masses.
    fn inverse_inner(&self, a: &[f64], b: &[f64], scratch: &mut [f64]) -> f64 {
        if Self::DIAGONAL {
            a.iter()
                .zip(b)
                .enumerate()
                .map(|(i, (x, y))| x * y * self.inverse_diagonal_entry(i).unwrap_or(0.0))
                .sum()
        } else {
            scratch.copy_from_slice(b);
            self.apply_inverse(scratch);
            a.iter().zip(scratch.iter()).map(|(x, y)| x * y).sum()
        }
    }
    /// Checks that the mass fits vectors of length n.
    fn check_order(&self, n: usize) -> Result<(), ManifoldError> {
        match self.order() {
            Some(order) if order != n => Err(ManifoldError::DimensionMismatch {
                what: "mass matrix order",
                expected: n,
                found: order,
            }),
            _ => Ok(()),
        }
    }
}

/// M = I: every operation is free.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct IdentityMass;

impl Mass for IdentityMass {
    const DIAGONAL: bool = true;
    fn order(&self) -> Option<usize> {
        None
    }
    #[inline(always)]
    fn apply_inverse(&self, _x: &mut [f64]) {}
    #[inline(always)]
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        out.copy_from_slice(x);
    }
    #[inline(always)]
    fn inverse_diagonal_entry(&self, _i: usize) -> Option<f64> {
        Some(1.0)
    }
    fn eigenvalue_bounds(&self) -> (f64, f64) {
        (1.0, 1.0)
    }
    #[inline(always)]
    fn inverse_inner(&self, a: &[f64], b: &[f64], _scratch: &mut [f64]) -> f64 {
        crate::vector::dot(a, b)
    }
}

/// M = diag(m_1, ..., m_n) with every m_i > 0.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagonalMass {
    mass: Vec<f64>,
    inverse: Vec<f64>,
}

impl DiagonalMass {
    /// From the diagonal entries; each must be finite and > 0.
    pub fn new(diagonal: Vec<f64>) -> Result<Self, ManifoldError> {
        if diagonal.is_empty() {
            return Err(ManifoldError::DimensionMismatch {
                what: "mass diagonal",
                expected: 1,
                found: 0,
            });
        }
        check_finite("mass diagonal", &diagonal)?;
        if let Some(i) = diagonal.iter().position(|&m| m <= 0.0) {
            return Err(ManifoldError::NotPositiveDefinite {
                detail: format!("diagonal entry {i} is {} (must be > 0)", diagonal[i]),
            });
        }
        let inverse = diagonal.iter().map(|m| 1.0 / m).collect();
        Ok(Self {
            mass: diagonal,
            inverse,
        })
    }

    /// Per-particle masses in `dim` space dimensions: each mass is repeated `dim` times.
    pub fn per_particle(masses: &[f64], dim: usize) -> Result<Self, ManifoldError> {
        if dim == 0 {
            return Err(ManifoldError::InvalidParameter {
                name: "dim",
                value: 0.0,
                reason: "space dimension must be >= 1",
            });
        }
        Self::new(
            masses
                .iter()
                .flat_map(|&m| std::iter::repeat_n(m, dim))
                .collect(),
        )
    }

    /// The diagonal of M.
    pub fn diagonal(&self) -> &[f64] {
        &self.mass
    }

    /// The kinetic energy v^T M v / 2.
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        0.5 * v
            .iter()
            .zip(&self.mass)
            .map(|(vi, mi)| mi * vi * vi)
            .sum::<f64>()
    }
}

impl Mass for DiagonalMass {
    const DIAGONAL: bool = true;
    fn order(&self) -> Option<usize> {
        Some(self.mass.len())
    }
    #[inline]
    fn apply_inverse(&self, x: &mut [f64]) {
        for (xi, wi) in x.iter_mut().zip(&self.inverse) {
            *xi *= wi;
        }
    }
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        for ((o, xi), mi) in out.iter_mut().zip(x).zip(&self.mass) {
            *o = mi * xi;
        }
    }
    #[inline]
    fn inverse_diagonal_entry(&self, i: usize) -> Option<f64> {
        Some(self.inverse[i])
    }
    fn eigenvalue_bounds(&self) -> (f64, f64) {
        let lo = self.mass.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.mass.iter().copied().fold(0.0, f64::max);
        (lo, hi)
    }
}

/// A general SPD mass matrix, stored with its lower Cholesky factor L (M = L L^T).
#[derive(Debug, Clone, PartialEq)]
pub struct DenseMass {
    order: usize,
    /// Row-major M.
    matrix: Vec<f64>,
    /// Row-major lower-triangular L.
    factor: Vec<f64>,
    bounds: (f64, f64),
}

impl DenseMass {
    /// Relative tolerance on |M_ij - M_ji| / max|M|.
    pub const SYMMETRY_TOLERANCE: f64 = 1e-12;

    /// From a row-major n x n matrix; fails unless it is finite, symmetric and positive definite.
    pub fn new(n: usize, row_major: Vec<f64>) -> Result<Self, ManifoldError> {
        check_len("dense mass matrix (n*n entries)", n * n, &row_major)?;
        if n == 0 {
            return Err(ManifoldError::DimensionMismatch {
                what: "dense mass matrix order",
                expected: 1,
                found: 0,
            });
        }
        check_finite("dense mass matrix", &row_major)?;
        let scale = row_major.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
        let mut worst = (0, 0, 0.0);
        for i in 0..n {
            for j in 0..i {
                let d = (row_major[i * n + j] - row_major[j * n + i]).abs();
                if d > worst.2 {
                    worst = (i, j, d);
                }
            }
        }
        if worst.2 > Self::SYMMETRY_TOLERANCE * scale {
            return Err(ManifoldError::NotSymmetric {
                row: worst.0,
                col: worst.1,
                difference: worst.2,
            });
        }
        let a = faer::Mat::<f64>::from_fn(n, n, |i, j| row_major[i * n + j]);
        let llt = a
            .llt(faer::Side::Lower)
            .map_err(|e| ManifoldError::NotPositiveDefinite {
                detail: format!("Cholesky factorization failed ({e:?})"),
            })?;
        let l = llt.L();
        let factor = (0..n * n)
            .map(|k| {
                let (i, j) = (k / n, k % n);
                if j <= i { l[(i, j)] } else { 0.0 }
            })
            .collect();
        let (lo, hi) = eigenvalue_range(n, &row_major).map_err(|detail| {
            ManifoldError::NotPositiveDefinite {
                detail: format!("eigenvalue computation failed ({detail})"),
            }
        })?;
        check_positive("smallest eigenvalue of the mass matrix", lo).map_err(|_| {
            ManifoldError::NotPositiveDefinite {
                detail: format!("smallest eigenvalue is {lo:e}"),
            }
        })?;
        Ok(Self {
            order: n,
            matrix: row_major,
            factor,
            bounds: (lo, hi),
        })
    }
}

impl Mass for DenseMass {
    const DIAGONAL: bool = false;
    fn order(&self) -> Option<usize> {
        Some(self.order)
    }
    /// Forward substitution with L, then backward substitution with L^T, both in place.
    fn apply_inverse(&self, x: &mut [f64]) {
        let n = self.order;
        let l = &self.factor;
        for i in 0..n {
            let s: f64 = (0..i).map(|j| l[i * n + j] * x[j]).sum();
            x[i] = (x[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| l[j * n + i] * x[j]).sum();
            x[i] = (x[i] - s) / l[i * n + i];
        }
    }
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        for (row, o) in self.matrix.chunks_exact(self.order).zip(out.iter_mut()) {
            *o = row.iter().zip(x).map(|(a, b)| a * b).sum();
        }
    }
    fn inverse_diagonal_entry(&self, _i: usize) -> Option<f64> {
        None
    }
    fn eigenvalue_bounds(&self) -> (f64, f64) {
        self.bounds
    }
}

/// The smallest and the largest eigenvalue (the latter at least 0) of the symmetric n x n
/// matrix `row_major` (its lower triangle is read), or why they could not be computed.
///
/// Not generic, so that the eigenvalue solver is compiled once, here, and not in every crate
/// whose generic code asks for a bound.
pub(crate) fn eigenvalue_range(n: usize, row_major: &[f64]) -> Result<(f64, f64), String> {
    let a = faer::Mat::<f64>::from_fn(n, n, |i, j| row_major[i * n + j]);
    let eig = a
        .self_adjoint_eigenvalues(faer::Side::Lower)
        .map_err(|e| format!("{e:?}"))?;
    let lo = eig.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = eig.iter().copied().fold(0.0, f64::max);
    Ok((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_inverse_matches_solution() {
        let m = DenseMass::new(3, vec![4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0]).unwrap();
        let x = [1.0, -2.0, 0.5];
        let mut mx = [0.0; 3];
        m.apply(&x, &mut mx);
        m.apply_inverse(&mut mx);
        for (a, b) in mx.iter().zip(&x) {
            assert!((a - b).abs() < 1e-14, "{a} vs {b}");
        }
        let (lo, hi) = m.eigenvalue_bounds();
        assert!(lo > 1.0 && hi < 5.0, "{lo} {hi}");
    }

    #[test]
    fn non_spd_and_asymmetric_are_rejected() {
        let e = DenseMass::new(2, vec![1.0, 2.0, 2.0, 1.0]).unwrap_err();
        assert!(
            matches!(e, ManifoldError::NotPositiveDefinite { .. }),
            "{e}"
        );
        let e = DenseMass::new(2, vec![1.0, 0.5, 0.0, 1.0]).unwrap_err();
        assert!(
            matches!(e, ManifoldError::NotSymmetric { row: 1, col: 0, .. }),
            "{e}"
        );
        let e = DiagonalMass::new(vec![1.0, -1.0]).unwrap_err();
        assert!(
            matches!(e, ManifoldError::NotPositiveDefinite { .. }),
            "{e}"
        );
        let e = DenseMass::new(2, vec![1.0; 3]).unwrap_err();
        assert!(matches!(
            e,
            ManifoldError::DimensionMismatch {
                expected: 4,
                found: 3,
                ..
            }
        ));
    }

    #[test]
    fn inverse_inner_agrees_across_masses() {
        let d = DiagonalMass::new(vec![2.0, 4.0]).unwrap();
        let full = DenseMass::new(2, vec![2.0, 0.0, 0.0, 4.0]).unwrap();
        let mut s = [0.0; 2];
        let a = [1.0, 2.0];
        let b = [3.0, -1.0];
        let exact = 3.0 / 2.0 - 2.0 / 4.0;
        assert!((d.inverse_inner(&a, &b, &mut s) - exact).abs() < 1e-15);
        assert!((full.inverse_inner(&a, &b, &mut s) - exact).abs() < 1e-15);
        assert_eq!(IdentityMass.inverse_inner(&a, &b, &mut s), 1.0);
    }
}
