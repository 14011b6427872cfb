//! Tridiagonal matrices of W lanes and their factors by Thomas' algorithm, through the code
//! `TridiagonalGram` and `TridiagonalFactor` (unpivoted) run on one matrix (`thomas.rs`). A lane
//! whose pivots Thomas' algorithm rejects is reported, so that its step goes through the scalar
//! path (which pivots).

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use super::{FactorLanes, MatrixLanes, RightHandSide};
pub(super) use crate::thomas::ThomasSweep;
use crate::thomas::{self, ThomasFactors};

/// A tridiagonal matrix of order m in each lane: `lower[i] = A[i+1][i]`, `diag[i] = A[i][i]`,
/// `upper[i] = A[i][i+1]`.
#[derive(Debug, Clone)]
pub struct TridiagonalLanes<Sd: Simd> {
    pub(super) lower: Vec<Lanes<Sd>>,
    pub(super) diag: Vec<Lanes<Sd>>,
    pub(super) upper: Vec<Lanes<Sd>>,
}

/// Thomas' factors of a [`TridiagonalLanes`]: the multipliers l_i / p_{i+1}, the inverse pivots
/// 1 / p_i and u_i / p_i.
#[derive(Debug, Clone)]
pub struct ThomasLanes<Sd: Simd> {
    lower: Vec<Lanes<Sd>>,
    inverse_pivot: Vec<Lanes<Sd>>,
    upper: Vec<Lanes<Sd>>,
}

/// The three zero bands of order m (m - 1 below the diagonal, m on it, m - 1 above).
fn zero_bands<Sd: Simd>(simd: Sd, m: usize) -> [Vec<Lanes<Sd>>; 3] {
    let zero = Lanes::splat(simd, 0.0);
    [vec![zero; m - 1], vec![zero; m], vec![zero; m - 1]]
}

impl<Sd: Simd> MatrixLanes<Sd> for TridiagonalLanes<Sd> {
    fn zeros(simd: Sd, m: usize) -> Self {
        let [lower, diag, upper] = zero_bands(simd, m);
        Self { lower, diag, upper }
    }

    /// out = A x (`thomas::tridiagonal_mul`).
    #[inline(always)]
    fn mul_vec(&self, x: &[Lanes<Sd>], out: &mut [Lanes<Sd>]) {
        thomas::tridiagonal_mul(&self.lower, &self.diag, &self.upper, x, out);
    }
}

impl<Sd: Simd> FactorLanes<Sd> for ThomasLanes<Sd> {
    type Matrix = TridiagonalLanes<Sd>;

    fn zeros(simd: Sd, m: usize) -> Self {
        let [lower, inverse_pivot, upper] = zero_bands(simd, m);
        Self {
            lower,
            inverse_pivot,
            upper,
        }
    }

    /// Factors `a`, and with `rhs` = (b, out) runs the forward substitution in the same pass;
    /// the lanes where every pivot passed (`ThomasSweep::row`).
    #[inline(always)]
    fn factor(&mut self, a: &TridiagonalLanes<Sd>, mut rhs: RightHandSide<'_, Sd>) -> LaneMask<Sd> {
        let m = a.diag.len();
        let mut sweep = ThomasSweep::new(a.diag[0]);
        let mut factors = self.factors();
        for i in 0..m {
            let upper = if i + 1 < m {
                Some((a.upper[i], a.lower[i]))
            } else {
                None
            };
            let b = rhs.as_ref().map(|(b, _)| b[i]);
            if let Some(forward) = sweep.row(&mut factors, i, a.diag[i], upper, b)
                && let Some((_, out)) = rhs.as_mut()
            {
                out[i] = forward;
            }
        }
        sweep.ok
    }

    #[inline(always)]
    fn back_substitute(&self, out: &mut [Lanes<Sd>]) {
        thomas::backward(&self.upper, out);
    }

    #[inline(always)]
    fn forward_in_place(&self, b: &mut [Lanes<Sd>]) {
        thomas::forward(&self.inverse_pivot, &self.lower, b);
    }
}

impl<Sd: Simd> ThomasLanes<Sd> {
    /// The factors as `ThomasSweep::row` writes them.
    #[inline(always)]
    pub(super) fn factors(&mut self) -> ThomasFactors<'_, Lanes<Sd>> {
        ThomasFactors {
            lower: &mut self.lower,
            inverse_pivot: &mut self.inverse_pivot,
            upper: &mut self.upper,
        }
    }

    /// Row i of the forward substitution: b_0 / p_0 for i = 0, else
    /// `thomas::forward_step` with y_{i-1} the previous row's value (`previous`).
    #[inline(always)]
    pub(super) fn forward_row(&self, i: usize, b: Lanes<Sd>, previous: Lanes<Sd>) -> Lanes<Sd> {
        if i == 0 {
            b * self.inverse_pivot[0]
        } else {
            thomas::forward_step(b, self.inverse_pivot[i], self.lower[i - 1], previous)
        }
    }
}
