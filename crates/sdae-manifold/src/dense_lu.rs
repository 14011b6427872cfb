//! Dense matrices (row-major, order m) and their LU factorization with partial pivoting,
//! written once over [`Real`]: [`DenseGram`](crate::DenseGram) and
//! [`LuFactor`](crate::LuFactor) run them on one matrix (`f64`, as
//! [`DenseFactor`](crate::DenseFactor) does up to
//! [`DENSE_FAER_THRESHOLD`](crate::DENSE_FAER_THRESHOLD)) and on W matrices in SIMD lanes. Each path picks its own pivot rows (the last largest |entry| of the
//! column, as `Iterator::max_by` does), so that in lanes the row interchanges are selects;
//! lane i computes exactly what the `f64` form computes for matrix i. Sums run in order from
//! -0, as the standard library's `sum` does.

use sdae_lanes::{PathMask, Real};

/// out_i = sum_j A_ij x_j for the row-major `entries` of order m = `out.len()`.
#[inline(always)]
pub(crate) fn dense_mul<T: Real>(entries: &[T], x: &[T], out: &mut [T]) {
    let m = out.len();
    for (row, o) in entries.chunks_exact(m).zip(out.iter_mut()) {
        let mut sum = x[0].splat_like(-0.0);
        for (a, xj) in row.iter().zip(x) {
            sum = sum + *a * *xj;
        }
        *o = sum;
    }
}

/// The pivot row of an elimination step: an index for one path, a number per path in lanes.
#[derive(Debug, Clone, Copy)]
pub(crate) enum PivotRow<T> {
    /// The row of the one path (`f64`).
    Index(usize),
    /// Each lane's row, as a number.
    PerPath(T),
}

/// Step k of the elimination on the row-major `lu` of order m: picks the pivot row p >= k of
/// column k (the last with the largest |entry|) and swaps rows k and p (for one path a swap,
/// in lanes a select per row and lane); returns p and the pivot.
#[inline(always)]
pub(crate) fn choose_pivot<T: Real>(lu: &mut [T], m: usize, k: usize) -> (PivotRow<T>, T) {
    let mut largest = lu[k * m + k].abs();
    if T::ONE_PATH {
        let mut p = k;
        for i in k + 1..m {
            let candidate = lu[i * m + k].abs();
            if largest.at_most(candidate).all() {
                (largest, p) = (candidate, i);
            }
        }
        if p != k {
            for j in 0..m {
                lu.swap(k * m + j, p * m + j);
            }
        }
        return (PivotRow::Index(p), lu[k * m + k]);
    }
    let mut pivot_row = largest.splat_like(k as f64);
    for i in k + 1..m {
        let candidate = lu[i * m + k].abs();
        let later = largest.at_most(candidate);
        largest = T::select(later, candidate, largest);
        pivot_row = T::select(later, candidate.splat_like(i as f64), pivot_row);
    }
    for i in k + 1..m {
        let swap = pivot_row.equal(pivot_row.splat_like(i as f64));
        if swap.any() {
            for j in 0..m {
                let (upper, lower) = (lu[k * m + j], lu[i * m + j]);
                lu[k * m + j] = T::select(swap, lower, upper);
                lu[i * m + j] = T::select(swap, upper, lower);
            }
        }
    }
    (PivotRow::PerPath(pivot_row), lu[k * m + k])
}

/// Whether a pivot is rejected: |p| <= `tolerance` (PIVOT_TOLERANCE x max |A_ij|) or p = 0.
#[inline(always)]
pub(crate) fn pivot_rejected<T: Real>(pivot: T, tolerance: T) -> T::Mask {
    pivot
        .abs()
        .at_most(tolerance)
        .or(pivot.equal(pivot.splat_like(0.0)))
}

/// Step k of the elimination after the pivot: the multipliers of column k below the diagonal
/// and the update of the rows below.
#[inline(always)]
pub(crate) fn eliminate<T: Real>(lu: &mut [T], m: usize, k: usize) {
    let pivot = lu[k * m + k];
    for i in k + 1..m {
        let f = lu[i * m + k] / pivot;
        lu[i * m + k] = f;
        for j in k + 1..m {
            let upper = lu[k * m + j];
            let entry = &mut lu[i * m + j];
            *entry = *entry - f * upper;
        }
    }
}

/// The row interchanges of the factorization applied to b in elimination order, the pivot row
/// of step k being the k-th of `pivot_rows`.
#[inline(always)]
pub(crate) fn permute<T: Real>(pivot_rows: impl IntoIterator<Item = PivotRow<T>>, b: &mut [T]) {
    let m = b.len();
    for (k, row) in pivot_rows.into_iter().enumerate().take(m) {
        let row = match row {
            PivotRow::Index(p) => {
                b.swap(k, p);
                continue;
            }
            PivotRow::PerPath(row) => row,
        };
        for i in k + 1..m {
            let swap = row.equal(row.splat_like(i as f64));
            if swap.any() {
                let (upper, lower) = (b[k], b[i]);
                b[k] = T::select(swap, lower, upper);
                b[i] = T::select(swap, upper, lower);
            }
        }
    }
}

/// The forward substitution with the unit lower factor L of `lu` (order `b.len()`), in place.
#[inline(always)]
pub(crate) fn forward<T: Real>(lu: &[T], b: &mut [T]) {
    let m = b.len();
    for i in 0..m {
        let mut s = b[0].splat_like(-0.0);
        for j in 0..i {
            s = s + lu[i * m + j] * b[j];
        }
        b[i] = b[i] - s;
    }
}

/// The back substitution with the upper factor U of `lu` (order `b.len()`), in place.
#[inline(always)]
pub(crate) fn backward<T: Real>(lu: &[T], b: &mut [T]) {
    let m = b.len();
    for i in (0..m).rev() {
        let mut s = b[0].splat_like(-0.0);
        for j in i + 1..m {
            s = s + lu[i * m + j] * b[j];
        }
        b[i] = (b[i] - s) / lu[i * m + i];
    }
}
