//! Tridiagonal factorizations: Thomas' algorithm written once over the number type
//! ([`ThomasFactor`], `crate::thomas`), and for one path LAPACK's pivoted LU where Thomas
//! rejects a pivot ([`TridiagonalFactor`]).

use sdae_lanes::{PathMask, Real};

use super::{
    Factorize, MatrixFactor, PIVOT_TOLERANCE, RightHandSide, Solve, check_finite,
    solve_and_map_apart,
};
use crate::error::LinearError;
use crate::gram::TridiagonalGram;
use crate::thomas::{
    self, Row, ThomasFactors, ThomasSweep, forward_step, tridiagonal_row, zero_bands,
};

/// Thomas' factors of a tridiagonal matrix of order m (`crate::thomas`): the multipliers
/// l_i / p_{i+1}, the inverse pivots 1 / p_i and u_i / p_i.
#[derive(Debug, Clone)]
pub struct ThomasFactor<T = f64> {
    lower: Vec<T>,
    inverse_pivot: Vec<T>,
    upper: Vec<T>,
}

/// A product B^-1 (A p) formed in the pass of Thomas' algorithm over A
/// ([`ThomasFactor::factor_fused`]): B's factors, p and the image's storage.
pub(crate) type Mapped<'a, T> = Option<(&'a ThomasFactor<T>, &'a [T], &'a mut [T])>;

impl<T: Real> ThomasFactor<T> {
    /// The factors as `ThomasSweep::row` writes them.
    #[inline(always)]
    pub(crate) fn factors(&mut self) -> ThomasFactors<'_, T> {
        ThomasFactors {
            lower: &mut self.lower,
            inverse_pivot: &mut self.inverse_pivot,
            upper: &mut self.upper,
        }
    }

    /// Row i of the forward substitution: b_0 / p_0 for i = 0, else
    /// `thomas::forward_step` with y_{i-1} the previous row's value (`previous`).
    #[inline(always)]
    pub(crate) fn forward_row(&self, i: usize, b: T, previous: T) -> T {
        if i == 0 {
            b * self.inverse_pivot[0]
        } else {
            forward_step(b, self.inverse_pivot[i], self.lower[i - 1], previous)
        }
    }

    /// Thomas' algorithm on `a` (`ThomasSweep`): the paths where every pivot passed. With `rhs`
    /// = (b, out) the forward substitution of b runs in the same pass (into out), so that its
    /// recurrence overlaps the one of the pivots; with `mapped` = (B, p, out), out = B^-1 (A p)
    /// is formed as well, B a Thomas factor: the rows of A p ([`crate::SquareMatrix::product`]'s
    /// operations) and B's forward substitution in the same pass, B's back substitution after
    /// it. One path stops at its first rejected pivot.
    #[inline(always)]
    pub(crate) fn factor_fused(
        &mut self, a: &TridiagonalGram<T>, rhs: RightHandSide<'_, T>, mapped: Mapped<'_, T>,
    ) -> T::Mask {
        let m = a.diag.len();
        let off = m.saturating_sub(1);
        let (diag, lower, upper) = (&a.diag[..m], &a.lower[..off], &a.upper[..off]);
        let factors = ThomasFactors {
            lower: &mut self.lower[..off],
            inverse_pivot: &mut self.inverse_pivot[..m],
            upper: &mut self.upper[..off],
        };
        let mut pass = ThomasPass {
            factors,
            rhs: rhs.map(|(b, out)| (&b[..m], &mut out[..m])),
            mapped: mapped.map(|(other, p, out)| MappedForward::new(other, p, out, m)),
            sweep: ThomasSweep::new(diag[0]),
        };
        // The last row apart, so that each call knows whether its row has an upper entry.
        for i in 0..off {
            if !pass.row(i, diag[i], Some((upper[i], lower[i]))) {
                return pass.sweep.ok;
            }
        }
        pass.row(off, diag[off], None);
        pass.sweep.ok
    }

    /// The back substitution (`thomas::backward`).
    #[inline(always)]
    fn backward(&self, b: &mut [T]) {
        thomas::backward(&self.upper, b);
    }

    /// [`ThomasFactor::backward`] of two factors and vectors of one order in one pass (two
    /// independent recurrences that overlap), each with its own operations.
    #[inline(always)]
    fn backward_pair(a: &Self, x: &mut [T], b: &Self, y: &mut [T]) {
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

impl<T: Real> MatrixFactor<T> for ThomasFactor<T> {
    type Matrix = TridiagonalGram<T>;

    fn zeros_like(like: T, m: usize) -> Self {
        let [lower, inverse_pivot, upper] = zero_bands(like, m);
        Self {
            lower,
            inverse_pivot,
            upper,
        }
    }

    /// Thomas' algorithm (`ThomasFactor::factor_fused`) without a mapped product.
    #[inline(always)]
    fn factor(&mut self, a: &TridiagonalGram<T>, rhs: RightHandSide<'_, T>) -> T::Mask {
        self.factor_fused(a, rhs, None)
    }

    #[inline(always)]
    fn forward_in_place(&self, b: &mut [T]) {
        thomas::forward(&self.inverse_pivot, &self.lower, b);
    }

    #[inline(always)]
    fn back_substitute(&self, out: &mut [T]) {
        self.backward(out);
    }
}

/// [`ThomasFactor::factor_fused`]'s state: the factors it writes, the right-hand side it
/// solves for in the same pass, the mapped probe and the sweep.
struct ThomasPass<'a, T: Real> {
    factors: ThomasFactors<'a, T>,
    rhs: RightHandSide<'a, T>,
    mapped: Option<MappedForward<'a, T>>,
    sweep: ThomasSweep<T>,
}

impl<T: Real> ThomasPass<'_, T> {
    /// Row i of diagonal entry `d`, with (u_i, l_i) = (A[i][i+1], A[i+1][i]) unless it is the
    /// last row; `false` if one path's pivot is rejected (paths in lanes go on: the others
    /// need their factors).
    #[inline(always)]
    fn row(&mut self, i: usize, d: T, next: Option<(T, T)>) -> bool {
        let l = self.sweep.lower();
        let b = self.rhs.as_ref().map(|(b, _)| b[i]);
        let forward = self.sweep.row(&mut self.factors, i, d, next, b);
        if T::ONE_PATH && !self.sweep.ok.all() {
            return false;
        }
        if let (Some(forward), Some((_, out))) = (forward, self.rhs.as_mut()) {
            out[i] = forward;
        }
        if let Some(mapped) = self.mapped.as_mut() {
            let upper = match next {
                Some((u, _)) => u,
                None => d.splat_like(0.0),
            };
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

/// out = B^-1 (A p) formed in the pass of Thomas' algorithm over A, B a Thomas factor: row by
/// row, the row of A p and B's forward substitution (its back substitution runs after the
/// pass).
struct MappedForward<'a, T> {
    /// B's inverse pivots.
    b_inverse_pivot: &'a [T],
    /// B's multipliers.
    b_lower: &'a [T],
    p: &'a [T],
    out: &'a mut [T],
    /// The last entry of B's forward substitution.
    forward: T,
}

impl<'a, T: Real> MappedForward<'a, T> {
    /// Before row 0, with B's factors, p and out cut to the order `m`.
    #[inline(always)]
    fn new(other: &'a ThomasFactor<T>, p: &'a [T], out: &'a mut [T], m: usize) -> Self {
        let off = m.saturating_sub(1);
        Self {
            b_inverse_pivot: &other.inverse_pivot[..m],
            b_lower: &other.lower[..off],
            p: &p[..m],
            forward: p[0].splat_like(0.0),
            out: &mut out[..m],
        }
    }

    /// Row i of A: row i of A p as [`crate::SquareMatrix::product`] forms it, then B's forward
    /// substitution into `out[i]`.
    #[inline(always)]
    fn row(&mut self, i: usize, row: Row<T>) {
        let value = tridiagonal_row(self.p, i, row);
        self.forward = if i == 0 {
            value * self.b_inverse_pivot[0]
        } else {
            forward_step(
                value,
                self.b_inverse_pivot[i],
                self.b_lower[i - 1],
                self.forward,
            )
        };
        self.out[i] = self.forward;
    }
}

/// LU factors of a tridiagonal matrix of one path: Thomas' algorithm (no pivoting) when every
/// pivot is safely away from zero, otherwise LU with partial pivoting (LAPACK's gttrf), both
/// O(m).
#[derive(Debug, Clone)]
pub struct TridiagonalFactor {
    pivoted: bool,
    thomas: ThomasFactor<f64>,
    interchanged: PivotedFactor,
}

/// The factors of LAPACK's gttrf.
#[derive(Debug, Clone)]
struct PivotedFactor {
    /// Multipliers.
    lower: Vec<f64>,
    /// Pivots.
    diag: Vec<f64>,
    /// First super-diagonal of U.
    upper: Vec<f64>,
    /// Second super-diagonal of U.
    upper2: Vec<f64>,
    /// Whether rows i and i+1 were swapped.
    swapped: Vec<bool>,
}

impl TridiagonalFactor {
    fn with_order(m: usize) -> Self {
        let off = m.saturating_sub(1);
        Self {
            pivoted: false,
            thomas: ThomasFactor::zeros_like(0.0, m),
            interchanged: PivotedFactor {
                lower: vec![0.0; off],
                diag: vec![0.0; m],
                upper: vec![0.0; off],
                upper2: vec![0.0; m.saturating_sub(2)],
                swapped: vec![false; off],
            },
        }
    }

    /// Whether the last factorization needed row interchanges.
    pub fn is_pivoted(&self) -> bool {
        self.pivoted
    }
}

impl PivotedFactor {
    /// LU with partial pivoting (the algorithm of LAPACK dgttrf).
    fn factor(&mut self, a: &TridiagonalGram) -> Result<(), LinearError> {
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

    /// b <- A^-1 b with gttrf's factors (LAPACK dgttrs).
    fn solve_in_place(&self, b: &mut [f64]) {
        let m = self.diag.len();
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

impl Solve for TridiagonalFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        if self.pivoted {
            self.interchanged.solve_in_place(b);
        } else {
            let b = &mut b[..self.thomas.inverse_pivot.len()];
            self.thomas.forward_in_place(b);
            self.thomas.backward(b);
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
        factor.pivoted = !factor.thomas.factor_fused(self, None, None);
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
        factor.pivoted = !factor.thomas.factor_fused(
            self,
            solve.as_mut().map(|(b, out)| (*b, &mut **out)),
            fused
                .as_mut()
                .map(|(other, p, image)| (&other.thomas, *p, &mut **image)),
        );
        if factor.pivoted {
            // The pass stopped part way: every solve from the start.
            self.factor_pivoted_into(factor)?;
            solve_and_map_apart(self, factor, solve, fused);
        } else {
            match (solve, fused) {
                (Some((_, out)), Some((other, _, image))) => {
                    ThomasFactor::backward_pair(&factor.thomas, out, &other.thomas, image)
                }
                (Some((_, out)), None) => factor.thomas.backward(out),
                (None, Some((other, _, image))) => other.thomas.backward(image),
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
        factor.interchanged.factor(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::factor::dense::lanes_case::{LaneMatrix, LanesCase, check_orders};
    use crate::factor::lanes_check::lanes_of;
    use crate::{GramMatrix, SquareMatrix};
    use pulp::Simd;
    use sdae_lanes::Lanes;

    /// Matrices of order `m`, one per lane: diagonally dominant ones of different entries, and
    /// in lane 1 one with a zero leading pivot (Thomas rejects it, one path pivots).
    fn matrix(m: usize, lane: usize) -> TridiagonalGram {
        let mut a = TridiagonalGram::zeros(m);
        for i in 0..m {
            a.diag[i] = 2.5 + (0.7 * (i + 3 * lane) as f64).sin();
        }
        for i in 0..m.saturating_sub(1) {
            a.lower[i] = -1.0 + 0.1 * ((i + lane) as f64).cos();
            a.upper[i] = -0.9 + 0.05 * lane as f64;
        }
        if lane == 1 && m > 1 {
            a.diag[0] = 0.0;
        }
        a
    }

    /// The lanes of Thomas' algorithm; it rejects the lanes whose pivots one path's
    /// factorization rejects too (where one path pivots).
    impl LanesCase for TridiagonalGram {
        type LaneFactor<S: Simd> = ThomasFactor<Lanes<S>>;

        fn lanes_matrix<S: Simd>(simd: S, one_path: &[Self]) -> LaneMatrix<Self, S> {
            let m = one_path[0].order();
            let mut a = TridiagonalGram::zeros_like(Lanes::splat(simd, 0.0), m);
            for i in 0..m {
                a.diag[i] = lanes_of(simd, |lane| one_path[lane].diag[i]);
            }
            for i in 0..m - 1 {
                a.lower[i] = lanes_of(simd, |lane| one_path[lane].lower[i]);
                a.upper[i] = lanes_of(simd, |lane| one_path[lane].upper[i]);
            }
            a
        }

        fn accepted(factor: &TridiagonalFactor, result: Result<(), LinearError>) -> bool {
            result.is_ok() && !factor.is_pivoted()
        }
    }

    #[test]
    fn lanes_factor_and_solve_as_one_path_bit_for_bit() {
        check_orders([2, 3, 7, 16], matrix);
    }
}
