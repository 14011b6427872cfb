//! Factorizations of the Gram storages, by structure: scalar, tridiagonal in O(m), dense
//! (hand-written LU for small orders, faer above [`DENSE_FAER_THRESHOLD`]). Factor once, solve
//! as often as needed. Every constraint's Gram storage is [`Factorize`]: a matrix, its
//! factorization, [`Solve`].

use crate::dense_lu::{self, PivotRow};
use crate::error::LinearError;
use crate::gram::{DenseGram, GramMatrix, ScalarGram, TridiagonalGram};
use crate::thomas::{self, Row, ThomasFactors, ThomasSweep, forward_step, tridiagonal_row};
use faer::linalg::solvers::Solve as _;

/// Above this order, dense systems are factored by faer; below it by the hand-written LU,
/// which does not allocate.
pub const DENSE_FAER_THRESHOLD: usize = 32;

/// Relative size below which a pivot of a dense LU factorization counts as zero: a pivot p
/// is rejected when |p| <= `PIVOT_TOLERANCE` x max_ij |A_ij|.
pub const PIVOT_TOLERANCE: f64 = 1e-14;

/// A matrix storage that can be factored for repeated solves.
pub trait Factorize: GramMatrix {
    /// The factorization; created once per workspace and refilled in place.
    type Factor: Solve + Clone + std::fmt::Debug;
    /// An empty factorization of the right size.
    fn new_factor(&self) -> Self::Factor;
    /// Factors `self` into `factor`.
    fn factor_into(&self, factor: &mut Self::Factor) -> Result<(), LinearError>;
    /// Factors `self` into `factor` and sets out = A^-1 b, with the floating-point operations
    /// of [`Factorize::factor_into`] followed by [`Solve::solve_in_place`] (a storage may do
    /// both in one pass). On failure `out` is unspecified.
    #[inline]
    fn factor_and_solve(
        &self, factor: &mut Self::Factor, b: &[f64], out: &mut [f64],
    ) -> Result<(), LinearError> {
        self.factor_with(factor, Some((b, out)), None)
    }
    /// Factors `self` (A) into `factor` and, with `solve` = (b, out), sets out = A^-1 b, and
    /// with `map` = (B, p, image), image = B^-1 (A p) for a matrix B given by its factors: the
    /// floating-point operations of [`Factorize::factor_into`], [`Solve::solve_in_place`] and
    /// [`GramMatrix::mul_vec`] (a storage may interleave them, so that their recurrences
    /// overlap). On failure `out` and `image` are unspecified.
    #[inline]
    fn factor_with(
        &self, factor: &mut Self::Factor, solve: Option<(&[f64], &mut [f64])>,
        map: Option<(&Self::Factor, &[f64], &mut [f64])>,
    ) -> Result<(), LinearError> {
        self.factor_into(factor)?;
        solve_and_map_apart(self, factor, solve, map);
        Ok(())
    }
}

/// The solve and the product of [`Factorize::factor_with`] after `a` is factored in `factor`,
/// one after the other.
fn solve_and_map_apart<A: Factorize>(
    a: &A, factor: &A::Factor, solve: Option<(&[f64], &mut [f64])>,
    map: Option<(&A::Factor, &[f64], &mut [f64])>,
) {
    if let Some((b, out)) = solve {
        out.copy_from_slice(b);
        factor.solve_in_place(out);
    }
    if let Some((other, p, image)) = map {
        a.mul_vec(p, image);
        other.solve_in_place(image);
    }
}

/// Solving with a factored matrix.
pub trait Solve {
    /// b <- A^-1 b.
    fn solve_in_place(&self, b: &mut [f64]);
}

fn check_finite(values: &[f64]) -> Result<(), LinearError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(LinearError::NonFinite { index }),
    }
}

/// The inverse of a 1 x 1 matrix.
#[derive(Debug, Clone, Copy, Default)]
pub struct ScalarFactor(f64);

impl Solve for ScalarFactor {
    #[inline]
    fn solve_in_place(&self, b: &mut [f64]) {
        b[0] *= self.0;
    }
}

impl Factorize for ScalarGram {
    type Factor = ScalarFactor;
    fn new_factor(&self) -> ScalarFactor {
        ScalarFactor(0.0)
    }
    #[inline]
    fn factor_into(&self, factor: &mut ScalarFactor) -> Result<(), LinearError> {
        if !self.0.is_finite() {
            return Err(LinearError::NonFinite { index: 0 });
        }
        if self.0 == 0.0 {
            return Err(LinearError::Singular {
                index: 0,
                pivot: 0.0,
            });
        }
        factor.0 = 1.0 / self.0;
        Ok(())
    }
}

/// LU factors of a tridiagonal matrix: Thomas' algorithm (no pivoting) when every pivot is
/// safely away from zero, otherwise LU with partial pivoting (LAPACK's gttrf), both O(m).
#[derive(Debug, Clone)]
pub struct TridiagonalFactor {
    pivoted: bool,
    /// Multipliers (Thomas: l_i / pivot_{i+1}).
    lower: Vec<f64>,
    /// Pivots (Thomas: their inverses).
    diag: Vec<f64>,
    /// First super-diagonal of U (Thomas: u_i / pivot_i).
    upper: Vec<f64>,
    /// Second super-diagonal of U (pivoted only).
    upper2: Vec<f64>,
    /// Whether rows i and i+1 were swapped (pivoted only).
    swapped: Vec<bool>,
}

impl TridiagonalFactor {
    fn with_order(m: usize) -> Self {
        let off = m.saturating_sub(1);
        Self {
            pivoted: false,
            lower: vec![0.0; off],
            diag: vec![0.0; m],
            upper: vec![0.0; off],
            upper2: vec![0.0; m.saturating_sub(2)],
            swapped: vec![false; off],
        }
    }

    /// Whether the last factorization needed row interchanges.
    pub fn is_pivoted(&self) -> bool {
        self.pivoted
    }

    /// Thomas' algorithm (`ThomasSweep`); `false` if a pivot is negligible relative to its
    /// row. With `rhs` = (b, out) the forward substitution of b runs in the same pass (into
    /// out), so that its recurrence overlaps the one of the pivots.
    ///
    /// With `mapped` = (B, p, out), out = B^-1 (A p) is formed as well, B an unpivoted Thomas
    /// factor: the rows of A p ([`GramMatrix::mul_vec`]'s operations) and B's forward
    /// substitution in the same pass, B's back substitution after it.
    #[inline(always)]
    fn factor_thomas(
        &mut self, a: &TridiagonalGram, rhs: Option<(&[f64], &mut [f64])>,
        mapped: Option<(&TridiagonalFactor, &[f64], &mut [f64])>,
    ) -> bool {
        let m = a.diag.len();
        let off = m.saturating_sub(1);
        let (diag, lower, upper) = (&a.diag[..m], &a.lower[..off], &a.upper[..off]);
        let factors = ThomasFactors {
            lower: &mut self.lower[..off],
            inverse_pivot: &mut self.diag[..m],
            upper: &mut self.upper[..off],
        };
        let mut pass = ThomasPass {
            factors,
            rhs: rhs.map(|(b, out)| (&b[..m], &mut out[..m])),
            mapped: mapped.map(|(other, p, out)| MappedForward::new(other, p, out, m)),
            sweep: ThomasSweep::new(0.0),
        };
        // The last row apart, so that each call knows whether its row has an upper entry.
        for i in 0..off {
            if !pass.row(i, diag[i], Some((upper[i], lower[i]))) {
                return false;
            }
        }
        pass.row(off, diag[off], None)
    }

    /// LU with partial pivoting (the algorithm of LAPACK dgttrf).
    fn factor_pivoted(&mut self, a: &TridiagonalGram) -> Result<(), LinearError> {
        let m = a.diag.len();
        self.lower.copy_from_slice(&a.lower);
        self.diag.copy_from_slice(&a.diag);
        self.upper.copy_from_slice(&a.upper);
        self.upper2.fill(0.0);
        self.swapped.fill(false);
        let scale = a
            .diag
            .iter()
            .chain(&a.lower)
            .chain(&a.upper)
            .fold(0.0_f64, |s, v| s.max(v.abs()));
        for i in 0..m.saturating_sub(1) {
            if self.diag[i].abs() >= self.lower[i].abs() {
                if self.diag[i] != 0.0 {
                    let fact = self.lower[i] / self.diag[i];
                    self.lower[i] = fact;
                    self.diag[i + 1] -= fact * self.upper[i];
                }
            } else {
                let fact = self.diag[i] / self.lower[i];
                self.diag[i] = self.lower[i];
                self.lower[i] = fact;
                let temp = self.upper[i];
                self.upper[i] = self.diag[i + 1];
                self.diag[i + 1] = temp - fact * self.diag[i + 1];
                if i + 2 < m {
                    self.upper2[i] = self.upper[i + 1];
                    self.upper[i + 1] *= -fact;
                }
                self.swapped[i] = true;
            }
        }
        match self
            .diag
            .iter()
            .position(|d| d.abs() <= PIVOT_TOLERANCE * scale)
        {
            Some(index) => Err(LinearError::Singular {
                index,
                pivot: self.diag[index],
            }),
            None => Ok(()),
        }
    }
}

/// [`TridiagonalFactor::factor_thomas`]'s state: the factors it writes, the right-hand side it
/// solves for in the same pass, the mapped probe and the sweep.
struct ThomasPass<'a> {
    factors: ThomasFactors<'a, f64>,
    rhs: Option<(&'a [f64], &'a mut [f64])>,
    mapped: Option<MappedForward<'a>>,
    sweep: ThomasSweep<f64>,
}

impl ThomasPass<'_> {
    /// Row i of diagonal entry `d`, with (u_i, l_i) = (A[i][i+1], A[i+1][i]) unless it is the
    /// last row; `false` if its pivot is rejected.
    #[inline(always)]
    fn row(&mut self, i: usize, d: f64, next: Option<(f64, f64)>) -> bool {
        let l = self.sweep.lower();
        let b = self.rhs.as_ref().map(|(b, _)| b[i]);
        let forward = self.sweep.row(&mut self.factors, i, d, next, b);
        if !self.sweep.ok {
            return false;
        }
        if let (Some(forward), Some((_, out))) = (forward, self.rhs.as_mut()) {
            out[i] = forward;
        }
        if let Some(mapped) = self.mapped.as_mut() {
            let upper = next.map_or(0.0, |(u, _)| u);
            mapped.row(
                i,
                Row {
                    lower: l,
                    diag: d,
                    upper,
                },
            );
        }
        true
    }
}

/// out = B^-1 (A p) formed in the pass of Thomas' algorithm over A, B an unpivoted Thomas
/// factor: row by row, the row of A p and B's forward substitution (its back substitution
/// runs after the pass).
struct MappedForward<'a> {
    /// B's inverse pivots.
    b_diag: &'a [f64],
    /// B's multipliers.
    b_lower: &'a [f64],
    p: &'a [f64],
    out: &'a mut [f64],
    /// The last entry of B's forward substitution.
    forward: f64,
}

impl<'a> MappedForward<'a> {
    /// Before row 0, with B's factors, p and out cut to the order `m`.
    #[inline(always)]
    fn new(other: &'a TridiagonalFactor, p: &'a [f64], out: &'a mut [f64], m: usize) -> Self {
        let off = m.saturating_sub(1);
        Self {
            b_diag: &other.diag[..m],
            b_lower: &other.lower[..off],
            p: &p[..m],
            out: &mut out[..m],
            forward: 0.0,
        }
    }

    /// Row i of A: row i of A p as [`GramMatrix::mul_vec`] forms it, then B's forward
    /// substitution into `out[i]`.
    #[inline(always)]
    fn row(&mut self, i: usize, row: Row<f64>) {
        let value = tridiagonal_row(self.p, i, row);
        self.forward = if i == 0 {
            value * self.b_diag[0]
        } else {
            forward_step(value, self.b_diag[i], self.b_lower[i - 1], self.forward)
        };
        self.out[i] = self.forward;
    }
}

impl TridiagonalFactor {
    /// The back substitution of Thomas' algorithm (`thomas::backward`).
    #[inline(always)]
    fn backward(&self, b: &mut [f64]) {
        thomas::backward(&self.upper, b);
    }
}

impl TridiagonalFactor {
    /// [`TridiagonalFactor::backward`] of two factors and vectors of one order in one pass
    /// (two independent recurrences that overlap), each with its own operations.
    #[inline(always)]
    fn backward_pair(a: &Self, x: &mut [f64], b: &Self, y: &mut [f64]) {
        let off = a.upper.len();
        let (a_upper, b_upper) = (&a.upper[..off], &b.upper[..off]);
        let (x_head, x_last) = x.split_at_mut(off);
        let (y_head, y_last) = y[..off + 1].split_at_mut(off);
        let (mut x_next, mut y_next) = (x_last[0], y_last[0]);
        for i in (0..off).rev() {
            x_next = x_head[i] - a_upper[i] * x_next;
            x_head[i] = x_next;
            y_next = y_head[i] - b_upper[i] * y_next;
            y_head[i] = y_next;
        }
    }
}

impl Solve for TridiagonalFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        let m = self.diag.len();
        if !self.pivoted {
            let b = &mut b[..m];
            thomas::forward(&self.diag, &self.lower, b);
            self.backward(b);
            return;
        }
        for i in 0..m - 1 {
            if self.swapped[i] {
                let temp = b[i] - self.lower[i] * b[i + 1];
                b[i] = b[i + 1];
                b[i + 1] = temp;
            } else {
                b[i + 1] -= self.lower[i] * b[i];
            }
        }
        b[m - 1] /= self.diag[m - 1];
        if m > 1 {
            b[m - 2] = (b[m - 2] - self.upper[m - 2] * b[m - 1]) / self.diag[m - 2];
        }
        for i in (0..m.saturating_sub(2)).rev() {
            b[i] = (b[i] - self.upper[i] * b[i + 1] - self.upper2[i] * b[i + 2]) / self.diag[i];
        }
    }
}

impl Factorize for TridiagonalGram {
    type Factor = TridiagonalFactor;
    fn new_factor(&self) -> TridiagonalFactor {
        TridiagonalFactor::with_order(self.diag.len())
    }
    /// Thomas' algorithm first; a non-finite entry makes it fail (it reaches a NaN or infinite
    /// minor or pivot), so the entries are checked only before the pivoted fallback.
    fn factor_into(&self, factor: &mut TridiagonalFactor) -> Result<(), LinearError> {
        factor.pivoted = !factor.factor_thomas(self, None, None);
        if factor.pivoted {
            self.factor_pivoted_into(factor)?;
        }
        Ok(())
    }
    /// Thomas' factorization with the forward substitutions of b and of A p (with B's factors)
    /// in the same pass, then both back substitutions in one pass; where a factor is pivoted,
    /// its solve runs on its own after factoring.
    fn factor_with(
        &self, factor: &mut TridiagonalFactor, mut solve: Option<(&[f64], &mut [f64])>,
        map: Option<(&TridiagonalFactor, &[f64], &mut [f64])>,
    ) -> Result<(), LinearError> {
        let (mut fused, apart) = match map {
            Some((other, ..)) if other.pivoted => (None, map),
            _ => (map, None),
        };
        factor.pivoted = !factor.factor_thomas(
            self,
            solve.as_mut().map(|(b, out)| (*b, &mut **out)),
            fused
                .as_mut()
                .map(|(other, p, image)| (*other, *p, &mut **image)),
        );
        if factor.pivoted {
            // The pass stopped part way: every solve from the start.
            self.factor_pivoted_into(factor)?;
            solve_and_map_apart(self, factor, solve, fused);
        } else {
            match (solve, fused) {
                (Some((_, out)), Some((other, _, image))) => {
                    TridiagonalFactor::backward_pair(factor, out, other, image)
                }
                (Some((_, out)), None) => factor.backward(out),
                (None, Some((other, _, image))) => other.backward(image),
                (None, None) => {}
            }
        }
        solve_and_map_apart(self, factor, None, apart);
        Ok(())
    }
}

impl TridiagonalGram {
    /// The pivoted fallback after Thomas' algorithm failed: it fails on a non-finite entry (it
    /// reaches a NaN or infinite minor or pivot), so the entries are checked only here.
    fn factor_pivoted_into(&self, factor: &mut TridiagonalFactor) -> Result<(), LinearError> {
        check_finite(&self.diag)?;
        check_finite(&self.lower)?;
        check_finite(&self.upper)?;
        factor.factor_pivoted(self)
    }
}

/// LU factors of a dense matrix with partial pivoting.
#[derive(Debug, Clone)]
pub enum DenseFactor {
    /// Hand-written, in preallocated storage (row-major LU and row permutation).
    Small {
        /// Order m.
        order: usize,
        /// Row-major packed L (unit, below the diagonal) and U.
        lu: Vec<f64>,
        /// Row permutation.
        perm: Vec<usize>,
    },
    /// faer's partial-pivoting LU, for orders above [`DENSE_FAER_THRESHOLD`].
    Faer(Box<faer::linalg::solvers::PartialPivLu<f64>>),
    /// Not factored yet.
    Empty,
}

impl Solve for DenseFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        match self {
            DenseFactor::Small { order, lu, perm } => {
                let b = &mut b[..*order];
                // The row interchanges in elimination order, then L and U.
                dense_lu::permute(perm.iter().map(|&p| PivotRow::Index(p)), b);
                dense_lu::forward(lu, b);
                dense_lu::backward(lu, b);
            }
            DenseFactor::Faer(lu) => {
                let m = b.len();
                lu.solve_in_place(faer::MatMut::from_column_major_slice_mut(b, m, 1));
            }
            DenseFactor::Empty => {
                b.fill(f64::NAN);
            }
        }
    }
}

impl Factorize for DenseGram {
    type Factor = DenseFactor;
    fn new_factor(&self) -> DenseFactor {
        let m = self.order();
        if m <= DENSE_FAER_THRESHOLD {
            DenseFactor::Small {
                order: m,
                lu: vec![0.0; m * m],
                perm: vec![0; m],
            }
        } else {
            DenseFactor::Empty
        }
    }
    fn factor_into(&self, factor: &mut DenseFactor) -> Result<(), LinearError> {
        let m = self.order();
        let a = self.as_slice();
        if let Some(k) = a.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::NonFinite { index: k / m });
        }
        let scale = a.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
        if m > DENSE_FAER_THRESHOLD {
            let mat = faer::Mat::<f64>::from_fn(m, m, |i, j| a[i * m + j]);
            let lu = mat.partial_piv_lu();
            let u = lu.U();
            if let Some(index) = (0..m).find(|&i| u[(i, i)].abs() <= PIVOT_TOLERANCE * scale) {
                return Err(LinearError::Singular {
                    index,
                    pivot: u[(index, index)],
                });
            }
            *factor = DenseFactor::Faer(Box::new(lu));
            return Ok(());
        }
        let DenseFactor::Small { lu, perm, .. } = factor else {
            *factor = self.new_factor();
            return self.factor_into(factor);
        };
        lu.copy_from_slice(a);
        let tolerance = scale * PIVOT_TOLERANCE;
        for (k, row) in perm.iter_mut().enumerate() {
            let (pivot_row, pivot) = dense_lu::choose_pivot(lu, m, k);
            if let PivotRow::Index(p) = pivot_row {
                *row = p;
            }
            if dense_lu::pivot_rejected(pivot, tolerance) {
                return Err(LinearError::Singular { index: k, pivot });
            }
            dense_lu::eliminate(lu, m, k);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual<A: GramMatrix>(a: &A, x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; b.len()];
        a.mul_vec(x, &mut ax);
        ax.iter()
            .zip(b)
            .fold(0.0, |s, (p, q)| f64::max(s, (p - q).abs()))
    }

    fn solve<A: Factorize>(a: &A, b: &[f64]) -> Vec<f64> {
        let mut f = a.new_factor();
        a.factor_into(&mut f).unwrap();
        let mut x = b.to_vec();
        f.solve_in_place(&mut x);
        x
    }

    #[test]
    fn tridiagonal_thomas_and_pivoted_paths_solve() {
        let m = 9;
        let mut a = TridiagonalGram::zeros(m);
        for i in 0..m {
            a.diag[i] = 2.0 + 0.1 * i as f64;
        }
        for i in 0..m - 1 {
            a.lower[i] = -1.0;
            a.upper[i] = -0.9;
        }
        let b: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-14);
        // A zero diagonal forces the pivoted path.
        a.diag.iter_mut().for_each(|d| *d = 0.0);
        a.lower.iter_mut().for_each(|l| *l = 1.0);
        a.upper.iter_mut().for_each(|u| *u = -1.0);
        a.diag[m - 1] = 1.0;
        let mut f = a.new_factor();
        a.factor_into(&mut f).unwrap();
        assert!(f.is_pivoted());
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-13, "{}", residual(&a, &x, &b));
    }

    /// A tridiagonal matrix of order m whose Thomas pivots are safe (`zero_diagonal` false) or
    /// that needs row interchanges (true).
    fn tridiagonal(m: usize, shift: f64, zero_diagonal: bool) -> TridiagonalGram {
        let mut a = TridiagonalGram::zeros(m);
        for i in 0..m {
            a.diag[i] = if zero_diagonal && i + 1 < m {
                0.0
            } else {
                2.0 + shift * (i as f64 + 0.5).sin()
            };
        }
        for i in 0..m.saturating_sub(1) {
            a.lower[i] = -1.0 + 0.1 * (i as f64).cos();
            a.upper[i] = -0.9 + shift * 0.05 * i as f64 / m as f64;
        }
        a
    }

    #[test]
    fn factor_with_is_factor_solve_and_product_bit_for_bit() {
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for m in [1, 2, 3, 9, 40] {
            for (a_pivots, b_pivots) in [(false, false), (true, false), (false, true), (true, true)]
            {
                let a = tridiagonal(m, 0.3, a_pivots && m > 1);
                let b = tridiagonal(m, -0.2, b_pivots && m > 1);
                let mut b_factor = b.new_factor();
                b.factor_into(&mut b_factor).unwrap();
                assert_eq!(b_factor.is_pivoted(), b_pivots && m > 1);
                let p: Vec<f64> = (0..m).map(|i| (0.7 * i as f64).cos()).collect();
                let rhs: Vec<f64> = (0..m).map(|i| 1.0 - 0.3 * i as f64).collect();
                // The separate passes.
                let mut a_factor = a.new_factor();
                a.factor_into(&mut a_factor).unwrap();
                assert_eq!(a_factor.is_pivoted(), a_pivots && m > 1);
                let mut image_apart = vec![0.0; m];
                a.mul_vec(&p, &mut image_apart);
                b_factor.solve_in_place(&mut image_apart);
                let mut solution_apart = rhs.clone();
                a_factor.solve_in_place(&mut solution_apart);
                // One pass, asked for the solve, the product or both, into a factor that held
                // another matrix.
                for (with_solve, with_map) in [(true, false), (false, true), (true, true)] {
                    let mut fused = b.new_factor();
                    b.factor_into(&mut fused).unwrap();
                    let mut image = vec![f64::NAN; m];
                    let mut solution = vec![f64::NAN; m];
                    a.factor_with(
                        &mut fused,
                        with_solve.then_some((&rhs[..], &mut solution[..])),
                        with_map.then_some((&b_factor, &p[..], &mut image[..])),
                    )
                    .unwrap();
                    let case =
                        format!("m={m} pivots {a_pivots} {b_pivots}: {with_solve} {with_map}");
                    if with_map {
                        assert_eq!(bits(&image), bits(&image_apart), "{case}");
                    }
                    if with_solve {
                        assert_eq!(bits(&solution), bits(&solution_apart), "{case}");
                    }
                    // The factor is the one factor_into gives: it solves alike.
                    assert_eq!(fused.is_pivoted(), a_factor.is_pivoted(), "{case}");
                    let mut x = p.clone();
                    fused.solve_in_place(&mut x);
                    let mut y = p.clone();
                    a_factor.solve_in_place(&mut y);
                    assert_eq!(bits(&x), bits(&y), "{case}");
                }
            }
        }
    }

    #[test]
    fn singular_tridiagonal_is_reported() {
        // [[1,1,0],[1,1,1],[0,1,1]] has det -1 and a zero Thomas pivot: pivoting solves it.
        let mut a = TridiagonalGram::zeros(3);
        a.diag.copy_from_slice(&[1.0, 1.0, 1.0]);
        a.lower.copy_from_slice(&[1.0, 1.0]);
        a.upper.copy_from_slice(&[1.0, 1.0]);
        let b = [1.0, 2.0, 3.0];
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-15);
        // Rows 0 and 1 equal: singular.
        a.lower.copy_from_slice(&[1.0, 0.0]);
        a.upper.copy_from_slice(&[1.0, 0.0]);
        let mut f = a.new_factor();
        assert!(matches!(
            a.factor_into(&mut f),
            Err(LinearError::Singular { .. })
        ));
    }

    #[test]
    fn dense_small_and_faer_paths_solve() {
        for m in [3, 40] {
            let mut a = DenseGram::zeros(m);
            for i in 0..m {
                for j in 0..m {
                    a.set(
                        i,
                        j,
                        ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 0.5 } else { 0.0 },
                    );
                }
            }
            let b: Vec<f64> = (0..m).map(|i| 1.0 + i as f64).collect();
            let x = solve(&a, &b);
            let scale = x.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            assert!(
                residual(&a, &x, &b) < 1e-11 * scale,
                "m={m}: {}",
                residual(&a, &x, &b)
            );
        }
        let a = DenseGram::zeros(2);
        let mut f = a.new_factor();
        assert!(matches!(
            a.factor_into(&mut f),
            Err(LinearError::Singular { index: 0, .. })
        ));
    }
}
