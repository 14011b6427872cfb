//! Tridiagonal matrices of W lanes and their factors by Thomas' algorithm: the operations of
//! `sdae_manifold`'s `TridiagonalGram` and `TridiagonalFactor` (unpivoted), lane by lane, with
//! the same floating-point operations in the same order. A lane whose pivots Thomas' algorithm
//! rejects is reported, so that its step goes through the scalar path (which pivots).

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use super::{FactorLanes, MatrixLanes, RightHandSide};

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

    /// Factors `a`, and with `rhs` = (b, out) runs the forward substitution in the same pass;
    /// the lanes where every pivot passed (`ThomasSweep::row`).
    #[inline(always)]
    fn factor(&mut self, a: &TridiagonalLanes<Sd>, mut rhs: RightHandSide<'_, Sd>) -> LaneMask<Sd> {
        let m = a.diag.len();
        let mut sweep = ThomasSweep::new(a.diag[0]);
        for i in 0..m {
            let upper = if i + 1 < m {
                Some((a.upper[i], a.lower[i]))
            } else {
                None
            };
            let b = rhs.as_ref().map(|(b, _)| b[i]);
            if let Some(forward) = sweep.row(self, i, a.diag[i], upper, b)
                && let Some((_, out)) = rhs.as_mut()
            {
                out[i] = forward;
            }
        }
        sweep.ok
    }

    #[inline(always)]
    fn back_substitute(&self, out: &mut [Lanes<Sd>]) {
        self.backward(out);
    }

    #[inline(always)]
    fn forward_in_place(&self, b: &mut [Lanes<Sd>]) {
        let mut previous = b[0];
        for (i, bi) in b.iter_mut().enumerate() {
            previous = self.forward_row(i, *bi, previous);
            *bi = previous;
        }
    }
}

/// Thomas' factorization row by row, for a caller that forms the rows as it goes (the chain's
/// Newton matrix, `super::chain`): the state carried from row to row.
pub(super) struct ThomasSweep<Sd: Simd> {
    s_prev2: Lanes<Sd>,
    s_prev: Lanes<Sd>,
    /// l_{i-1} = A[i][i-1] and l_{i-1} u_{i-1} of the previous row.
    lower: Lanes<Sd>,
    coupling: Lanes<Sd>,
    /// The forward substitution's last value.
    forward: Lanes<Sd>,
    /// The lanes where every pivot so far passed.
    pub(super) ok: LaneMask<Sd>,
}

impl<Sd: Simd> ThomasSweep<Sd> {
    /// Before row 0 (`like` gives the instruction set).
    #[inline(always)]
    pub(super) fn new(like: Lanes<Sd>) -> Self {
        let zero = like.splat_like(0.0);
        let one = zero.splat_like(1.0);
        Self {
            s_prev2: zero,
            s_prev: one,
            lower: zero,
            coupling: zero,
            forward: zero,
            ok: one.eq(one),
        }
    }

    /// Row i of the factorization into `factor`: the diagonal d_i, with (u_i, l_i) = (A[i][i+1],
    /// A[i+1][i]) unless i is the last row, and with b_i the forward substitution's value at
    /// row i. A pivot passes if |p_i| > 1e-8 x row scale and finite. The pivots are the ratios
    /// of leading principal minors, rescaled by powers of two, as in the scalar factor.
    #[inline(always)]
    pub(super) fn row(
        &mut self,
        factor: &mut ThomasLanes<Sd>,
        i: usize,
        d: Lanes<Sd>,
        upper: Option<(Lanes<Sd>, Lanes<Sd>)>,
        b: Option<Lanes<Sd>>,
    ) -> Option<Lanes<Sd>> {
        const BIG: f64 = 1.157_920_892_373_162e77; // 2^256
        const SMALL: f64 = 8.636_168_555_094_445e-78; // 2^-256
        let zero = d.splat_like(0.0);
        let one = zero.splat_like(1.0);
        let (big, small) = (zero.splat_like(BIG), zero.splat_like(SMALL));
        let l = self.lower;
        let u = match upper {
            Some((u, _)) => u,
            None => zero,
        };
        let mut s_i = d * self.s_prev - self.coupling * self.s_prev2;
        let magnitude = s_i.abs();
        let in_range = small.le(magnitude).and(magnitude.le(big));
        if !in_range.all() {
            // Out of range: rescale by 2^-256 or 2^256; 0 or not finite: the lane fails.
            let degenerate = magnitude.eq(zero).or(!magnitude.is_finite());
            self.ok = self.ok.and(!(!in_range).and(degenerate));
            let scale = Lanes::select(big.lt(magnitude), small, big);
            let scale = Lanes::select(in_range, one, scale);
            s_i = s_i * scale;
            self.s_prev = self.s_prev * scale;
        }
        let inv = self.s_prev / s_i;
        let scale = l.abs() + d.abs() + u.abs();
        let rejected = (!inv.eq(inv)).or(one.le(inv.abs() * 1e-8 * scale));
        self.ok = self.ok.and(!rejected);
        factor.inverse_pivot[i] = inv;
        let multiplier = l * inv;
        if i > 0 {
            factor.lower[i - 1] = multiplier;
        }
        // Written out: a closure (Option::map) would not inherit the instruction set.
        let forward = if let Some(b) = b {
            self.forward = if i > 0 {
                b * inv - multiplier * self.forward
            } else {
                b * inv
            };
            Some(self.forward)
        } else {
            None
        };
        if let Some((u, l_next)) = upper {
            factor.upper[i] = u * inv;
            self.lower = l_next;
            self.coupling = l_next * u;
        }
        self.s_prev2 = self.s_prev;
        self.s_prev = s_i;
        forward
    }
}

impl<Sd: Simd> ThomasLanes<Sd> {
    /// Row i of the forward substitution: b_0 / p_0 for i = 0, else b_i / p_i - (l_{i-1} /
    /// p_i) y_{i-1} with y_{i-1} the previous row's value (`previous`).
    #[inline(always)]
    pub(super) fn forward_row(&self, i: usize, b: Lanes<Sd>, previous: Lanes<Sd>) -> Lanes<Sd> {
        if i == 0 {
            b * self.inverse_pivot[0]
        } else {
            b * self.inverse_pivot[i] - self.lower[i - 1] * previous
        }
    }

    /// The back substitution: b_i <- b_i - (u_i / p_i) b_{i+1}.
    #[inline(always)]
    pub(super) fn backward(&self, b: &mut [Lanes<Sd>]) {
        let off = self.upper.len();
        let mut next = b[off];
        for i in (0..off).rev() {
            next = b[i] - self.upper[i] * next;
            b[i] = next;
        }
    }
}
