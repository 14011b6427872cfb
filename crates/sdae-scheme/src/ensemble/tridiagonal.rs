//! Tridiagonal matrices of W lanes and their factors by Thomas' algorithm: the operations of
//! `sdae_manifold`'s `TridiagonalGram` and `TridiagonalFactor` (unpivoted), lane by lane, with
//! the same floating-point operations in the same order. A lane whose pivots Thomas' algorithm
//! rejects is reported, so that its step goes through the scalar path (which pivots).

use pulp::Simd;
use sdae_model::lanes::{LaneMask, Lanes};

use super::newton::{FactorLanes, MatrixLanes, RightHandSide};

/// A tridiagonal matrix of order m in each lane: `lower[i] = A[i+1][i]`, `diag[i] = A[i][i]`,
/// `upper[i] = A[i][i+1]`.
#[derive(Debug, Clone)]
pub(super) struct TridiagonalLanes<Sd: Simd> {
    pub(super) lower: Vec<Lanes<Sd>>,
    pub(super) diag: Vec<Lanes<Sd>>,
    pub(super) upper: Vec<Lanes<Sd>>,
}

/// Thomas' factors of a [`TridiagonalLanes`]: the multipliers l_i / p_{i+1}, the inverse pivots
/// 1 / p_i and u_i / p_i.
#[derive(Debug, Clone)]
pub(super) struct ThomasLanes<Sd: Simd> {
    lower: Vec<Lanes<Sd>>,
    inverse_pivot: Vec<Lanes<Sd>>,
    upper: Vec<Lanes<Sd>>,
}

impl<Sd: Simd> MatrixLanes<Sd> for TridiagonalLanes<Sd> {
    fn zeros(simd: Sd, m: usize) -> Self {
        let zero = Lanes::splat(simd, 0.0);
        Self {
            lower: vec![zero; m - 1],
            diag: vec![zero; m],
            upper: vec![zero; m - 1],
        }
    }

    /// out = A x: out_i = (d_i x_i + l_{i-1} x_{i-1}) + u_i x_{i+1}.
    #[inline(always)]
    fn mul_vec(&self, x: &[Lanes<Sd>], out: &mut [Lanes<Sd>]) {
        let m = self.diag.len();
        if m == 1 {
            out[0] = self.diag[0] * x[0];
            return;
        }
        out[0] = self.diag[0] * x[0] + self.upper[0] * x[1];
        for i in 1..m - 1 {
            out[i] = self.diag[i] * x[i] + self.lower[i - 1] * x[i - 1] + self.upper[i] * x[i + 1];
        }
        out[m - 1] = self.diag[m - 1] * x[m - 1] + self.lower[m - 2] * x[m - 2];
    }
}

impl<Sd: Simd> FactorLanes<Sd> for ThomasLanes<Sd> {
    type Matrix = TridiagonalLanes<Sd>;

    fn zeros(simd: Sd, m: usize) -> Self {
        let zero = Lanes::splat(simd, 0.0);
        Self {
            lower: vec![zero; m - 1],
            inverse_pivot: vec![zero; m],
            upper: vec![zero; m - 1],
        }
    }

    /// Factors `a`, and with `rhs` = (b, out) solves A out = b in the same pass; the lanes
    /// where every pivot passed (|p_i| > 1e-8 x row scale, finite). The pivots are the ratios
    /// of leading principal minors, rescaled by powers of two, as in the scalar factor.
    #[inline(always)]
    fn factor(&mut self, a: &TridiagonalLanes<Sd>, mut rhs: RightHandSide<'_, Sd>) -> LaneMask<Sd> {
        const BIG: f64 = 1.157_920_892_373_162e77; // 2^256
        const SMALL: f64 = 8.636_168_555_094_445e-78; // 2^-256
        let m = a.diag.len();
        let off = m - 1;
        let zero = a.diag[0].splat_like(0.0);
        let one = zero.splat_like(1.0);
        let (big, small) = (zero.splat_like(BIG), zero.splat_like(SMALL));
        let (mut s_prev2, mut s_prev) = (zero, one);
        let (mut l, mut coupling, mut forward) = (zero, zero, zero);
        let mut ok = one.eq(one);
        for i in 0..m {
            let d = a.diag[i];
            let u = if i < off { a.upper[i] } else { zero };
            let mut s_i = d * s_prev - coupling * s_prev2;
            let magnitude = s_i.abs();
            let in_range = small.le(magnitude).and(magnitude.le(big));
            if !in_range.all() {
                // Out of range: rescale by 2^-256 or 2^256; 0 or not finite: the lane fails.
                let degenerate = magnitude.eq(zero).or(!magnitude.is_finite());
                ok = ok.and(!(!in_range).and(degenerate));
                let scale = Lanes::select(big.lt(magnitude), small, big);
                let scale = Lanes::select(in_range, one, scale);
                s_i = s_i * scale;
                s_prev = s_prev * scale;
            }
            let inv = s_prev / s_i;
            let scale = l.abs() + d.abs() + u.abs();
            let rejected = (!inv.eq(inv)).or(one.le(inv.abs() * 1e-8 * scale));
            ok = ok.and(!rejected);
            self.inverse_pivot[i] = inv;
            if i > 0 {
                let multiplier = l * inv;
                self.lower[i - 1] = multiplier;
                if let Some((b, out)) = rhs.as_mut() {
                    forward = b[i] * inv - multiplier * forward;
                    out[i] = forward;
                }
            } else if let Some((b, out)) = rhs.as_mut() {
                forward = b[0] * inv;
                out[0] = forward;
            }
            if i < off {
                self.upper[i] = u * inv;
                l = a.lower[i];
                coupling = l * u;
            }
            s_prev2 = s_prev;
            s_prev = s_i;
        }
        if let Some((_, out)) = rhs {
            self.backward(out);
        }
        ok
    }

    /// b <- A^-1 b.
    #[inline(always)]
    fn solve_in_place(&self, b: &mut [Lanes<Sd>]) {
        let mut previous = b[0] * self.inverse_pivot[0];
        b[0] = previous;
        for (i, bi) in b.iter_mut().enumerate().skip(1) {
            previous = *bi * self.inverse_pivot[i] - self.lower[i - 1] * previous;
            *bi = previous;
        }
        self.backward(b);
    }
}

impl<Sd: Simd> ThomasLanes<Sd> {
    /// The back substitution: b_i <- b_i - (u_i / p_i) b_{i+1}.
    #[inline(always)]
    fn backward(&self, b: &mut [Lanes<Sd>]) {
        let off = self.upper.len();
        let mut next = b[off];
        for i in (0..off).rev() {
            next = b[i] - self.upper[i] * next;
            b[i] = next;
        }
    }
}
