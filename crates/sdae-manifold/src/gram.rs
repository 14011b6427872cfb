//! Containers for the m x m matrices of the form Dg(x1) M^-1 grad g(x2), written once over the
//! number type: `f64` for one path, [`Lanes`](sdae_lanes::Lanes) for W paths in SIMD lanes.
//!
//! With x1 = x2 = x this is the Gram matrix G_M(x) of seed Section 2.1; with x1 = r', x2 = r it
//! is the Newton matrix of the kappa system and the matrix of the lambda system (seed eq. 3.1).
//! A constraint names its container as an associated type, so the structure (scalar,
//! tridiagonal, dense) is known at compile time and solvers take the O(m) path where one exists;
//! [`GramShape`] names the storage and its factorization for every number type at once.

use sdae_lanes::Real;

use crate::dense_lu::dense_mul;
use crate::thomas::{tridiagonal_mul, zero_bands};

/// Which structure a constraint's Gram matrix has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GramStructure {
    /// m = 1.
    Scalar,
    /// Nonzero only on the three central diagonals.
    Tridiagonal,
    /// No structure known.
    Dense,
}

/// An m x m matrix of numbers of type T (one path's `f64`, or W paths' lanes), in one of the
/// structured storages.
pub trait SquareMatrix<T: Real>: Clone + std::fmt::Debug + Send + Sync + 'static {
    /// Zeros of order m >= 1, of the kind of `like`.
    fn zeros_like(like: T, m: usize) -> Self;
    /// out = A x.
    fn product(&self, x: &[T], out: &mut [T]);
}

/// An m x m matrix of one path (`f64`) in one of the structured storages.
pub trait GramMatrix: Clone + std::fmt::Debug {
    /// The structure of this storage.
    const STRUCTURE: GramStructure;
    /// The order m.
    fn order(&self) -> usize;
    /// Entry (i, j); zero outside the stored pattern.
    fn entry(&self, i: usize, j: usize) -> f64;
    /// out = A x ([`SquareMatrix::product`]).
    fn mul_vec(&self, x: &[f64], out: &mut [f64]);
}

/// A 1 x 1 matrix.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScalarGram<T = f64>(pub T);

impl<T: Real> SquareMatrix<T> for ScalarGram<T> {
    fn zeros_like(like: T, _m: usize) -> Self {
        Self(like.splat_like(0.0))
    }
    /// out = A x.
    #[inline(always)]
    fn product(&self, x: &[T], out: &mut [T]) {
        out[0] = self.0 * x[0];
    }
}

impl GramMatrix for ScalarGram {
    const STRUCTURE: GramStructure = GramStructure::Scalar;
    fn order(&self) -> usize {
        1
    }
    fn entry(&self, _i: usize, _j: usize) -> f64 {
        self.0
    }
    #[inline]
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        self.product(x, out);
    }
}

/// A tridiagonal matrix: `lower[i] = A[i+1][i]`, `diag[i] = A[i][i]`, `upper[i] = A[i][i+1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TridiagonalGram<T = f64> {
    /// Sub-diagonal, length m - 1.
    pub lower: Vec<T>,
    /// Diagonal, length m.
    pub diag: Vec<T>,
    /// Super-diagonal, length m - 1.
    pub upper: Vec<T>,
}

impl TridiagonalGram {
    /// A zero matrix of order m >= 1.
    pub fn zeros(m: usize) -> Self {
        Self::zeros_like(0.0, m)
    }
}

impl<T: Real> SquareMatrix<T> for TridiagonalGram<T> {
    fn zeros_like(like: T, m: usize) -> Self {
        let [lower, diag, upper] = zero_bands(like, m);
        Self { lower, diag, upper }
    }
    /// out_i = (d_i x_i + l_{i-1} x_{i-1}) + u_i x_{i+1} (`thomas::tridiagonal_mul`): the first
    /// and last rows apart, so that the loop over the interior rows vectorizes.
    #[inline(always)]
    fn product(&self, x: &[T], out: &mut [T]) {
        tridiagonal_mul(&self.lower, &self.diag, &self.upper, x, out);
    }
}

impl GramMatrix for TridiagonalGram {
    const STRUCTURE: GramStructure = GramStructure::Tridiagonal;
    fn order(&self) -> usize {
        self.diag.len()
    }
    fn entry(&self, i: usize, j: usize) -> f64 {
        if i == j {
            self.diag[i]
        } else if i == j + 1 {
            self.lower[j]
        } else if j == i + 1 {
            self.upper[i]
        } else {
            0.0
        }
    }
    #[inline]
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        self.product(x, out);
    }
}

/// A dense matrix stored row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseGram<T = f64> {
    order: usize,
    data: Vec<T>,
}

impl DenseGram {
    /// A zero matrix of order m.
    pub fn zeros(m: usize) -> Self {
        Self::zeros_like(0.0, m)
    }
}

impl<T: Copy> DenseGram<T> {
    /// Sets entry (i, j).
    #[inline(always)]
    pub fn set(&mut self, i: usize, j: usize, value: T) {
        self.data[i * self.order + j] = value;
    }
    /// Entry (i, j).
    #[inline(always)]
    pub fn get(&self, i: usize, j: usize) -> T {
        self.data[i * self.order + j]
    }
    /// Row-major entries.
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }
}

impl<T: Real> SquareMatrix<T> for DenseGram<T> {
    fn zeros_like(like: T, m: usize) -> Self {
        Self {
            order: m,
            data: vec![like.splat_like(0.0); m * m],
        }
    }
    /// out_i = sum_j A_ij x_j (`dense_lu::dense_mul`).
    #[inline(always)]
    fn product(&self, x: &[T], out: &mut [T]) {
        dense_mul(&self.data, x, &mut out[..self.order]);
    }
}

impl GramMatrix for DenseGram {
    const STRUCTURE: GramStructure = GramStructure::Dense;
    fn order(&self) -> usize {
        self.order
    }
    fn entry(&self, i: usize, j: usize) -> f64 {
        self.get(i, j)
    }
    #[inline]
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        self.product(x, out);
    }
}
