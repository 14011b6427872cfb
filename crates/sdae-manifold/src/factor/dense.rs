//! Dense LU factorizations with partial pivoting: written once over the number type
//! ([`LuFactor`], `crate::dense_lu`), and for one path with faer above
//! [`DENSE_FAER_THRESHOLD`] and typed errors ([`DenseFactor`]).

use faer::linalg::solvers::Solve as _;
use sdae_lanes::{PathMask, Real};

use super::{DENSE_FAER_THRESHOLD, Factorize, MatrixFactor, PIVOT_TOLERANCE, RightHandSide, Solve};
use crate::dense_lu::{self, PivotRow};
use crate::error::LinearError;
use crate::gram::{DenseGram, GramMatrix};

/// The LU factors of a dense matrix with partial pivoting: L (unit, below the diagonal) and U
/// packed row-major, and the pivot row of each elimination step (an index for one path, a
/// number per path in lanes).
#[derive(Debug, Clone)]
pub struct LuFactor<T = f64> {
    order: usize,
    lu: Vec<T>,
    perm: Vec<PivotRow<T>>,
}

impl<T: Real> MatrixFactor<T> for LuFactor<T> {
    type Matrix = DenseGram<T>;

    fn zeros_like(like: T, m: usize) -> Self {
        let zero = like.splat_like(0.0);
        Self {
            order: m,
            lu: vec![zero; m * m],
            perm: vec![PivotRow::PerPath(zero); m],
        }
    }

    /// The elimination with partial pivoting (`dense_lu`), and with `rhs` = (b, out) the first
    /// half of the solve; the paths whose entries are finite and whose pivots all pass
    /// (|p| > `PIVOT_TOLERANCE` x max |A_ij|).
    #[inline(always)]
    fn factor(&mut self, a: &DenseGram<T>, rhs: RightHandSide<'_, T>) -> T::Mask {
        let entries = a.as_slice();
        let zero = entries[0].splat_like(0.0);
        let mut ok = zero.mask_like(true);
        let mut scale = zero;
        for entry in entries {
            ok = ok.and(entry.finite());
            scale = scale.max(entry.abs());
        }
        self.lu.copy_from_slice(entries);
        ok = ok.and(self.eliminate(scale * PIVOT_TOLERANCE));
        if let Some((b, out)) = rhs {
            out.copy_from_slice(b);
            self.forward_in_place(out);
        }
        ok
    }

    /// The row interchanges in elimination order and the forward substitution
    /// (`dense_lu::permute`, `dense_lu::forward`).
    #[inline(always)]
    fn forward_in_place(&self, b: &mut [T]) {
        let b = &mut b[..self.order];
        dense_lu::permute(self.perm.iter().copied(), b);
        dense_lu::forward(&self.lu, b);
    }

    /// The back substitution (`dense_lu::backward`).
    #[inline(always)]
    fn back_substitute(&self, b: &mut [T]) {
        dense_lu::backward(&self.lu, &mut b[..self.order]);
    }
}

impl<T: Real> LuFactor<T> {
    /// The elimination with partial pivoting of `lu` (holding A) in place (`dense_lu`): the
    /// paths whose pivots all pass (|p| > `tolerance`); one path stops at its first rejected
    /// pivot.
    #[inline(always)]
    fn eliminate(&mut self, tolerance: T) -> T::Mask {
        let m = self.order;
        let mut ok = tolerance.mask_like(true);
        for k in 0..m {
            let (pivot_row, pivot) = dense_lu::choose_pivot(&mut self.lu, m, k);
            self.perm[k] = pivot_row;
            ok = ok.and(!dense_lu::pivot_rejected(pivot, tolerance));
            if T::ONE_PATH && !ok.all() {
                return ok;
            }
            dense_lu::eliminate(&mut self.lu, m, k);
        }
        ok
    }
}

impl LuFactor {
    /// The step and the pivot of the first pivot the elimination rejected, for a matrix whose
    /// largest |entry| is `scale` (each step leaves the rows above it as they are, so U's
    /// diagonal holds every step's pivot up to the one it stopped at).
    fn first_rejected_pivot(&self, scale: f64) -> Option<(usize, f64)> {
        let m = self.order;
        (0..m)
            .map(|k| (k, self.lu[k * m + k]))
            .find(|&(_, pivot)| dense_lu::pivot_rejected(pivot, scale * PIVOT_TOLERANCE))
    }
}

/// LU factors of a dense matrix of one path with partial pivoting.
#[derive(Debug, Clone)]
pub enum DenseFactor {
    /// Hand-written ([`LuFactor`]), in preallocated storage.
    Small(LuFactor),
    /// faer's partial-pivoting LU, for orders above [`DENSE_FAER_THRESHOLD`].
    Faer(Box<faer::linalg::solvers::PartialPivLu<f64>>),
    /// Not factored yet.
    Empty,
}

impl Solve for DenseFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        match self {
            DenseFactor::Small(lu) => MatrixFactor::solve_in_place(lu, b),
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
            DenseFactor::Small(LuFactor::zeros_like(0.0, m))
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
        let DenseFactor::Small(lu) = factor else {
            *factor = self.new_factor();
            return self.factor_into(factor);
        };
        // The entries are finite (checked above): the elimination fails exactly where a
        // pivot is rejected, and stops there.
        lu.lu.copy_from_slice(a);
        if lu.eliminate(scale * PIVOT_TOLERANCE) {
            return Ok(());
        }
        match lu.first_rejected_pivot(scale) {
            Some((index, pivot)) => Err(LinearError::Singular { index, pivot }),
            None => Ok(()),
        }
    }
}

/// The check that a factorization over lanes is one path's in each lane, written once for the
/// test matrices of every structure.
#[cfg(test)]
pub(super) mod lanes_case {
    use pulp::{Simd, WithSimd};
    use sdae_lanes::Lanes;

    use crate::error::LinearError;
    use crate::factor::lanes_check::{assert_lanes_are_one_path, at_every_width};
    use crate::factor::{Factorize, MatrixFactor};

    /// A one-path storage, with its factorization over lanes.
    pub(in crate::factor) trait LanesCase: Factorize + Sized {
        /// The factorization over W lanes.
        type LaneFactor<S: Simd>: MatrixFactor<Lanes<S>>;
        /// The storage over lanes whose lane i holds `one_path[i]`.
        fn lanes_matrix<S: Simd>(simd: S, one_path: &[Self]) -> LaneMatrix<Self, S>;
        /// Whether the lane of one path's factorization (its factor and result) is accepted.
        fn accepted(factor: &Self::Factor, result: Result<(), LinearError>) -> bool;
    }

    /// The matrix over lanes that G's factorization over lanes factors.
    pub(in crate::factor) type LaneMatrix<G, S> =
        <<G as LanesCase>::LaneFactor<S> as MatrixFactor<Lanes<S>>>::Matrix;

    /// Each lane's factor, solve and product against one path's storage G and its
    /// factorization, bit for bit, on the test matrices `matrix(m, lane)`.
    struct Check<G> {
        m: usize,
        matrix: fn(usize, usize) -> G,
    }

    impl<G: LanesCase> WithSimd for Check<G> {
        type Output = ();
        fn with_simd<S: Simd>(self, simd: S) {
            let one_path: Vec<G> = (0..Lanes::<S>::WIDTH)
                .map(|lane| (self.matrix)(self.m, lane))
                .collect();
            let a = G::lanes_matrix(simd, &one_path);
            assert_lanes_are_one_path::<S, G::LaneFactor<S>, _>(simd, &a, &one_path, G::accepted);
        }
    }

    /// The check at every lane width for each order in `orders`, on the test matrices
    /// `matrix(m, lane)` of order m, one per lane.
    pub(in crate::factor) fn check_orders<G: LanesCase>(
        orders: impl IntoIterator<Item = usize>, matrix: fn(usize, usize) -> G,
    ) {
        for m in orders {
            at_every_width(|| Check { m, matrix });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::lanes_case::{LaneMatrix, LanesCase, check_orders};
    use super::*;
    use crate::SquareMatrix;
    use crate::factor::lanes_check::lanes_of;
    use pulp::Simd;
    use sdae_lanes::Lanes;

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

    /// The lanes of the LU factorization; one path's factorization rejects the lanes it
    /// reports.
    impl LanesCase for DenseGram {
        type LaneFactor<S: Simd> = LuFactor<Lanes<S>>;

        fn lanes_matrix<S: Simd>(simd: S, one_path: &[Self]) -> LaneMatrix<Self, S> {
            let m = one_path[0].order();
            let mut a = DenseGram::zeros_like(Lanes::splat(simd, 0.0), m);
            for i in 0..m {
                for j in 0..m {
                    a.set(i, j, lanes_of(simd, |lane| one_path[lane].entry(i, j)));
                }
            }
            a
        }

        fn accepted(_: &DenseFactor, result: Result<(), LinearError>) -> bool {
            result.is_ok()
        }
    }

    #[test]
    fn lanes_factor_and_solve_as_the_scalar_lu_bit_for_bit() {
        check_orders(1..=6, matrix);
    }

    #[test]
    fn the_test_matrices_need_row_interchanges() {
        // The eliminations above pivot: some lane's first pivot row is not row 0.
        let a = matrix(4, 0);
        let first_column: Vec<f64> = (0..4).map(|i| a.entry(i, 0).abs()).collect();
        assert!(first_column[1..].iter().any(|&c| c >= first_column[0]));
    }
}
