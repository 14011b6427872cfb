//! Containers for the m x m matrices of the form Dg(x1) M^-1 grad g(x2).
//!
//! With x1 = x2 = x this is the Gram matrix G_M(x) of seed Section 2.1; with x1 = r', x2 = r it
//! is the Newton matrix of the kappa system and the matrix of the lambda system (seed eq. 3.1).
//! A constraint names its container as an associated type, so the structure (scalar,
//! tridiagonal, dense) is known at compile time and solvers take the O(m) path where one exists.

use crate::dense_lu::dense_mul;
use crate::thomas::tridiagonal_mul;

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

/// An m x m matrix in one of the structured storages.
pub trait GramMatrix: Clone + std::fmt::Debug {
    /// The structure of this storage.
    const STRUCTURE: GramStructure;
    /// The order m.
    fn order(&self) -> usize;
    /// Entry (i, j); zero outside the stored pattern.
    fn entry(&self, i: usize, j: usize) -> f64;
    /// out = A x.
    fn mul_vec(&self, x: &[f64], out: &mut [f64]);
}

/// A 1 x 1 matrix.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ScalarGram(pub f64);

impl GramMatrix for ScalarGram {
    const STRUCTURE: GramStructure = GramStructure::Scalar;
    fn order(&self) -> usize {
        1
    }
    fn entry(&self, _i: usize, _j: usize) -> f64 {
        self.0
    }
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        out[0] = self.0 * x[0];
    }
}

/// A tridiagonal matrix: `lower[i] = A[i+1][i]`, `diag[i] = A[i][i]`, `upper[i] = A[i][i+1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TridiagonalGram {
    /// Sub-diagonal, length m - 1.
    pub lower: Vec<f64>,
    /// Diagonal, length m.
    pub diag: Vec<f64>,
    /// Super-diagonal, length m - 1.
    pub upper: Vec<f64>,
}

impl TridiagonalGram {
    /// A zero matrix of order m >= 1.
    pub fn zeros(m: usize) -> Self {
        let off = m.saturating_sub(1);
        Self {
            lower: vec![0.0; off],
            diag: vec![0.0; m],
            upper: vec![0.0; off],
        }
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
    /// out_i = (d_i x_i + l_{i-1} x_{i-1}) + u_i x_{i+1}: the first and last rows apart, so
    /// that the loop over the interior rows vectorizes.
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        tridiagonal_mul(&self.lower, &self.diag, &self.upper, x, out);
    }
}

/// A dense matrix stored row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseGram {
    order: usize,
    data: Vec<f64>,
}

impl DenseGram {
    /// A zero matrix of order m.
    pub fn zeros(m: usize) -> Self {
        Self {
            order: m,
            data: vec![0.0; m * m],
        }
    }
    /// Sets entry (i, j).
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        self.data[i * self.order + j] = value;
    }
    /// Row-major entries.
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }
}

impl GramMatrix for DenseGram {
    const STRUCTURE: GramStructure = GramStructure::Dense;
    fn order(&self) -> usize {
        self.order
    }
    fn entry(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.order + j]
    }
    fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        dense_mul(&self.data, x, &mut out[..self.order]);
    }
}
