//! Dense m x m matrices of W lanes and their LU factors with partial pivoting, through the code
//! `DenseGram::mul_vec` and the hand-written `DenseFactor` (orders up to `DENSE_FAER_THRESHOLD`)
//! run on one matrix (`dense_lu.rs`). A lane whose matrix has a non-finite entry or a pivot the
//! scalar factorization rejects (|p| <= `PIVOT_TOLERANCE` x max |A_ij|) is reported, so that
//! its step goes through the scalar path.

use crate::factor::PIVOT_TOLERANCE;
use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use super::{FactorLanes, MatrixLanes, RightHandSide};
use crate::dense_lu::{self, PivotRow};

/// A dense matrix of order m in each lane, row-major.
#[derive(Debug, Clone)]
pub struct DenseLanes<Sd: Simd> {
    order: usize,
    entries: Vec<Lanes<Sd>>,
}

impl<Sd: Simd> DenseLanes<Sd> {
    /// Entry (i, j).
    #[inline(always)]
    pub fn entry(&self, i: usize, j: usize) -> Lanes<Sd> {
        self.entries[i * self.order + j]
    }

    /// Sets entry (i, j).
    #[inline(always)]
    pub fn set(&mut self, i: usize, j: usize, value: Lanes<Sd>) {
        self.entries[i * self.order + j] = value;
    }
}

impl<Sd: Simd> MatrixLanes<Sd> for DenseLanes<Sd> {
    fn zeros(simd: Sd, m: usize) -> Self {
        Self {
            order: m,
            entries: vec![Lanes::splat(simd, 0.0); m * m],
        }
    }

    /// out = A x (`dense_lu::dense_mul`).
    #[inline(always)]
    fn mul_vec(&self, x: &[Lanes<Sd>], out: &mut [Lanes<Sd>]) {
        dense_lu::dense_mul(&self.entries, x, &mut out[..self.order]);
    }
}

/// The LU factors of a [`DenseLanes`] with partial pivoting: L (unit, below the diagonal) and
/// U packed row-major, and the pivot row of each elimination step (as a lane value).
#[derive(Debug, Clone)]
pub struct LuLanes<Sd: Simd> {
    order: usize,
    lu: Vec<Lanes<Sd>>,
    perm: Vec<Lanes<Sd>>,
}

impl<Sd: Simd> FactorLanes<Sd> for LuLanes<Sd> {
    type Matrix = DenseLanes<Sd>;

    fn zeros(simd: Sd, m: usize) -> Self {
        let zero = Lanes::splat(simd, 0.0);
        Self {
            order: m,
            lu: vec![zero; m * m],
            perm: vec![zero; m],
        }
    }

    /// `DenseGram::factor_into` (and the solve of `factor_and_solve`) lane by lane.
    #[inline(always)]
    fn factor(&mut self, a: &DenseLanes<Sd>, rhs: RightHandSide<'_, Sd>) -> LaneMask<Sd> {
        let m = self.order;
        let zero = a.entries[0].splat_like(0.0);
        let mut ok = zero.eq(zero);
        let mut scale = zero;
        for entry in &a.entries {
            ok = ok.and(entry.is_finite());
            scale = scale.max(entry.abs());
        }
        let tolerance = scale * PIVOT_TOLERANCE;
        self.lu.copy_from_slice(&a.entries);
        for k in 0..m {
            let (pivot_row, pivot) = dense_lu::choose_pivot(&mut self.lu, m, k);
            if let PivotRow::PerPath(row) = pivot_row {
                self.perm[k] = row;
            }
            ok = ok.and(!dense_lu::pivot_rejected(pivot, tolerance));
            dense_lu::eliminate(&mut self.lu, m, k);
        }
        if let Some((b, out)) = rhs {
            out.copy_from_slice(b);
            self.forward_in_place(out);
        }
        ok
    }

    /// The back substitution of `DenseFactor::solve_in_place` (`dense_lu::backward`).
    #[inline(always)]
    fn back_substitute(&self, b: &mut [Lanes<Sd>]) {
        dense_lu::backward(&self.lu, &mut b[..self.order]);
    }

    /// The first half of `DenseFactor::solve_in_place`: the row interchanges in elimination
    /// order and the forward substitution (`dense_lu::permute`, `dense_lu::forward`).
    #[inline(always)]
    fn forward_in_place(&self, b: &mut [Lanes<Sd>]) {
        let b = &mut b[..self.order];
        dense_lu::permute(self.perm.iter().map(|&row| PivotRow::PerPath(row)), b);
        dense_lu::forward(&self.lu, b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DenseGram, Factorize, GramMatrix, Solve};
    use pulp::WithSimd;
    use sdae_lanes::LaneWidth;

    /// Matrices of order `m`, one per lane, whose pivot rows differ from lane to lane (a
    /// permuted diagonally weak matrix, ties included) and one singular matrix (lane 2).
    fn matrix(m: usize, lane: usize) -> DenseGram {
        let mut a = DenseGram::zeros(m);
        for i in 0..m {
            for j in 0..m {
                let value = ((i * 7 + j * 3 + lane * 5) % 11) as f64 - 5.0
                    + if (i + lane) % m == j { 0.25 } else { 0.0 };
                a.set(i, j, if lane == 2 { 1.0 } else { value });
            }
        }
        a
    }

    /// Each lane's factor, solve and product against the scalar `DenseGram` and `DenseFactor`,
    /// bit for bit, and the lanes the scalar factorization rejects.
    struct Check {
        m: usize,
    }

    impl WithSimd for Check {
        type Output = ();
        fn with_simd<S: Simd>(self, simd: S) {
            let m = self.m;
            let width = Lanes::<S>::WIDTH;
            let lanes_of = |values: &dyn Fn(usize) -> f64| {
                let per_lane: Vec<f64> = (0..width).map(values).collect();
                Lanes::load(simd, &per_lane)
            };
            let scalar: Vec<DenseGram> = (0..width).map(|lane| matrix(m, lane)).collect();
            let mut a = DenseLanes::zeros(simd, m);
            for i in 0..m {
                for j in 0..m {
                    a.set(i, j, lanes_of(&|lane| scalar[lane].entry(i, j)));
                }
            }
            let b_of = |lane: usize, i: usize| (i as f64 + 0.5 * lane as f64).sin();
            let b: Vec<Lanes<S>> = (0..m).map(|i| lanes_of(&|lane| b_of(lane, i))).collect();
            let mut x = vec![Lanes::splat(simd, 0.0); m];
            let mut factor = LuLanes::zeros(simd, m);
            let ok = factor.factor(&a, Some((&b, &mut x)));
            factor.back_substitute(&mut x);
            let mut product = vec![Lanes::splat(simd, 0.0); m];
            a.mul_vec(&b, &mut product);
            for (lane, gram) in scalar.iter().enumerate() {
                let mut expected_product = vec![0.0; m];
                let b_lane: Vec<f64> = (0..m).map(|i| b_of(lane, i)).collect();
                gram.mul_vec(&b_lane, &mut expected_product);
                for i in 0..m {
                    assert_eq!(
                        product[i].lane(lane).to_bits(),
                        expected_product[i].to_bits()
                    );
                }
                let mut scalar_factor = gram.new_factor();
                let factored = gram.factor_into(&mut scalar_factor);
                assert_eq!(ok.lane(lane), factored.is_ok(), "m = {m}, lane {lane}");
                if factored.is_ok() {
                    let mut expected = b_lane.clone();
                    scalar_factor.solve_in_place(&mut expected);
                    for i in 0..m {
                        assert_eq!(
                            x[i].lane(lane).to_bits(),
                            expected[i].to_bits(),
                            "m = {m}, lane {lane}, entry {i}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn lanes_factor_and_solve_as_the_scalar_lu_bit_for_bit() {
        for m in 1..=6 {
            for width in [
                LaneWidth::One,
                LaneWidth::Four,
                LaneWidth::Eight,
                LaneWidth::Best,
            ] {
                width.dispatch(Check { m });
            }
        }
    }

    #[test]
    fn the_test_matrices_need_row_interchanges() {
        // The eliminations above pivot: some lane's first pivot row is not row 0.
        let a = matrix(4, 0);
        let first_column: Vec<f64> = (0..4).map(|i| a.entry(i, 0).abs()).collect();
        assert!(first_column[1..].iter().any(|&c| c >= first_column[0]));
    }
}
