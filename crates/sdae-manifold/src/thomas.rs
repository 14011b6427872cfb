//! Tridiagonal matrices and Thomas' algorithm (their LU factorization without pivoting),
//! written once over [`Real`]: [`TridiagonalGram`](crate::TridiagonalGram) and
//! [`ThomasFactor`](crate::ThomasFactor) run them on one matrix (`f64`, where
//! [`TridiagonalFactor`](crate::TridiagonalFactor) adds LAPACK's pivoted LU for a pivot Thomas
//! rejects) and on W matrices in SIMD lanes (a lane whose pivot is rejected steps through the
//! scalar path). Lane i computes exactly what the `f64`
//! form computes for matrix i.
//!
//! The factors are the multipliers l_i / p_{i+1}, the inverse pivots 1 / p_i and u_i / p_i
//! (l_i = A[i+1][i], u_i = A[i][i+1]). The pivots p_i = d_i - l_{i-1} u_{i-1} / p_{i-1} are
//! computed as ratios s_i / s_{i-1} of the leading principal minors,
//! s_i = d_i s_{i-1} - l_{i-1} u_{i-1} s_{i-2}: the recurrence then has a multiply and a
//! subtract on its critical path instead of a division, and the divisions overlap. The minors
//! are rescaled by exact powers of two to stay in range.

use sdae_lanes::{PathMask, Real};

/// out = A x for the tridiagonal A of sub-diagonal `lower`, diagonal `diag` and super-diagonal
/// `upper` (order m = `diag.len()`): out_i = (d_i x_i + l_{i-1} x_{i-1}) + u_i x_{i+1}, the first
/// and last rows apart so that the loop over the interior rows vectorizes.
#[inline(always)]
pub(crate) fn tridiagonal_mul<T: Real>(
    lower: &[T], diag: &[T], upper: &[T], x: &[T], out: &mut [T],
) {
    let m = diag.len();
    let (x, out) = (&x[..m], &mut out[..m]);
    if m < 2 {
        if m == 1 {
            out[0] = diag[0] * x[0];
        }
        return;
    }
    let (lower, upper) = (&lower[..m - 1], &upper[..m - 1]);
    out[0] = diag[0] * x[0] + upper[0] * x[1];
    for i in 1..m - 1 {
        out[i] = diag[i] * x[i] + lower[i - 1] * x[i - 1] + upper[i] * x[i + 1];
    }
    out[m - 1] = diag[m - 1] * x[m - 1] + lower[m - 2] * x[m - 2];
}

/// Three bands of zeros of the kind of `like` for order m >= 1: m - 1 below the diagonal, m
/// on it, m - 1 above (a tridiagonal matrix, or Thomas' factors).
pub(crate) fn zero_bands<T: Real>(like: T, m: usize) -> [Vec<T>; 3] {
    let zero = like.splat_like(0.0);
    let off = m.saturating_sub(1);
    [vec![zero; off], vec![zero; m], vec![zero; off]]
}

/// Row i of A x for a tridiagonal A of order `x.len()`, from the row's entries: what
/// [`tridiagonal_mul`] computes for that row.
#[inline(always)]
pub(crate) fn tridiagonal_row<T: Real>(x: &[T], i: usize, row: Row<T>) -> T {
    let mut sum = row.diag * x[i];
    if i > 0 {
        sum = sum + row.lower * x[i - 1];
    }
    if i + 1 < x.len() {
        sum = sum + row.upper * x[i + 1];
    }
    sum
}

/// Row i of a tridiagonal matrix: A[i][i-1], A[i][i] and A[i][i+1] (0 outside the matrix).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Row<T> {
    pub(crate) lower: T,
    pub(crate) diag: T,
    pub(crate) upper: T,
}

/// The factors Thomas' algorithm writes, as slices of the caller's storage.
pub(crate) struct ThomasFactors<'a, T> {
    /// The multipliers l_i / p_{i+1} (m - 1).
    pub(crate) lower: &'a mut [T],
    /// The inverse pivots 1 / p_i (m).
    pub(crate) inverse_pivot: &'a mut [T],
    /// u_i / p_i (m - 1).
    pub(crate) upper: &'a mut [T],
}

/// Thomas' factorization row by row, for a caller that forms the rows as it goes (the chain's
/// Newton matrix in lanes) or reads them from a matrix: the state carried from row to row.
pub(crate) struct ThomasSweep<T: Real> {
    /// s_{i-2} and s_{i-1}.
    s_prev2: T,
    s_prev: T,
    /// l_{i-1} = A[i][i-1] and l_{i-1} u_{i-1} of the previous row.
    lower: T,
    coupling: T,
    /// The forward substitution's last value.
    forward: T,
    /// The paths where every pivot so far passed.
    pub(crate) ok: T::Mask,
}

impl<T: Real> ThomasSweep<T> {
    /// Before row 0 (`like` gives the kind of number): s_{-2} = 0, s_{-1} = 1.
    #[inline(always)]
    pub(crate) fn new(like: T) -> Self {
        let zero = like.splat_like(0.0);
        Self {
            s_prev2: zero,
            s_prev: zero.splat_like(1.0),
            lower: zero,
            coupling: zero,
            forward: zero,
            ok: zero.mask_like(true),
        }
    }

    /// A[i][i-1] of the row to come (0 before row 1).
    #[inline(always)]
    pub(crate) fn lower(&self) -> T {
        self.lower
    }

    /// Row i of the factorization into `factors`: the diagonal d_i, with (u_i, l_i) =
    /// (A[i][i+1], A[i+1][i]) unless i is the last row, and with b_i the forward substitution's
    /// value at row i, which it returns. A pivot passes if |p_i| > 1e-8 x row scale and finite;
    /// a minor of 0 or not finite fails the path (`ok`).
    #[inline(always)]
    pub(crate) fn row(
        &mut self, factors: &mut ThomasFactors<'_, T>, i: usize, d: T, upper: Option<(T, T)>,
        b: Option<T>,
    ) -> Option<T> {
        let zero = d.splat_like(0.0);
        let l = self.lower;
        let u = match upper {
            Some((u, _)) => u,
            None => zero,
        };
        let inv = self.inverse_pivot(d);
        let scale = l.abs() + d.abs() + u.abs();
        let rejected = (!inv.equal(inv)).or(zero.splat_like(1.0).at_most(inv.abs() * 1e-8 * scale));
        self.ok = self.ok.and(!rejected);
        factors.inverse_pivot[i] = inv;
        let multiplier = l * inv;
        if i > 0 {
            factors.lower[i - 1] = multiplier;
        }
        // Written out: a closure (Option::map) would not inherit the instruction set.
        let forward = if let Some(b) = b {
            self.forward = if i > 0 {
                forward_step(b, inv, multiplier, self.forward)
            } else {
                b * inv
            };
            Some(self.forward)
        } else {
            None
        };
        if let Some((u, l_next)) = upper {
            factors.upper[i] = u * inv;
            self.lower = l_next;
            self.coupling = l_next * u;
        }
        forward
    }

    /// Moves to the row of diagonal entry `d` and returns the inverse pivot 1 / p_i =
    /// s_{i-1} / s_i. Outside [2^-256, 2^256], s_i and s_{i-1} are rescaled by 2^256 or 2^-256
    /// (exactly); a minor of 0 or not finite fails the path.
    #[inline(always)]
    fn inverse_pivot(&mut self, d: T) -> T {
        const BIG: f64 = 1.157_920_892_373_162e77; // 2^256
        const SMALL: f64 = 8.636_168_555_094_445e-78; // 2^-256
        let (big, small) = (d.splat_like(BIG), d.splat_like(SMALL));
        let mut s_i = d * self.s_prev - self.coupling * self.s_prev2;
        let magnitude = s_i.abs();
        let in_range = small.at_most(magnitude).and(magnitude.at_most(big));
        if !in_range.all() {
            let degenerate = magnitude.equal(d.splat_like(0.0)).or(!magnitude.finite());
            self.ok = self.ok.and(!(!in_range).and(degenerate));
            let scale = T::select(big.less(magnitude), small, big);
            let scale = T::select(in_range, d.splat_like(1.0), scale);
            s_i = s_i * scale;
            self.s_prev = self.s_prev * scale;
        }
        let inv = self.s_prev / s_i;
        self.s_prev2 = self.s_prev;
        self.s_prev = s_i;
        inv
    }
}

/// One row of the forward substitution after row 0: b_i / p_i - (l_{i-1} / p_i) y_{i-1}, from
/// the inverse pivot, the multiplier and the previous row's value.
#[inline(always)]
pub(crate) fn forward_step<T: Real>(b: T, inverse_pivot: T, multiplier: T, previous: T) -> T {
    b * inverse_pivot - multiplier * previous
}

/// The forward substitution of Thomas' factors in place: y_0 = b_0 / p_0, then
/// [`forward_step`].
#[inline(always)]
pub(crate) fn forward<T: Real>(inverse_pivot: &[T], lower: &[T], b: &mut [T]) {
    let mut previous = b[0] * inverse_pivot[0];
    b[0] = previous;
    for ((bi, inv), l) in b[1..].iter_mut().zip(&inverse_pivot[1..]).zip(lower) {
        previous = forward_step(*bi, *inv, *l, previous);
        *bi = previous;
    }
}

/// The back substitution of Thomas' factors in place: b_i <- b_i - (u_i / p_i) b_{i+1}, the
/// running value kept in a register.
#[inline(always)]
pub(crate) fn backward<T: Real>(upper: &[T], b: &mut [T]) {
    let off = upper.len();
    let (head, last) = b[..off + 1].split_at_mut(off);
    let mut next = last[0];
    for (bi, u) in head.iter_mut().zip(upper).rev() {
        next = *bi - *u * next;
        *bi = next;
    }
}
