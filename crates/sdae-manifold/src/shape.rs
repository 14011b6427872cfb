//! The structure of a Gram matrix as a type ([`GramShape`]): its storage ([`crate::gram`]) and
//! its factorization ([`crate::factor`]) for every number type at once, above both.

use sdae_lanes::Real;

use crate::factor::{LuFactor, MatrixFactor, ScalarFactor, ThomasFactor};
use crate::gram::{DenseGram, GramStructure, ScalarGram, SquareMatrix, TridiagonalGram};

/// The structure of a Gram matrix as a type: its storage and the factorization run in lanes,
/// for every number type. A constraint's lane form names its shape
/// ([`ConstraintLanes::Shape`](crate::ConstraintLanes::Shape)).
pub trait GramShape: Send + Sync + 'static {
    /// The structure.
    const STRUCTURE: GramStructure;
    /// The storage of a matrix of this shape.
    type Matrix<T: Real>: SquareMatrix<T>;
    /// Its factorization without fallbacks (the one that runs in lanes; a path it rejects
    /// goes through the one-path factorization with its fallbacks and typed errors).
    type Factor<T: Real>: MatrixFactor<T, Matrix = Self::Matrix<T>>;
}

/// m = 1: [`ScalarGram`] and [`ScalarFactor`].
#[derive(Debug, Clone, Copy)]
pub struct Scalar;

/// Tridiagonal: [`TridiagonalGram`] and Thomas' factors ([`ThomasFactor`]).
#[derive(Debug, Clone, Copy)]
pub struct Tridiagonal;

/// Dense: [`DenseGram`] and LU factors with partial pivoting ([`LuFactor`]).
#[derive(Debug, Clone, Copy)]
pub struct Dense;

impl GramShape for Scalar {
    const STRUCTURE: GramStructure = GramStructure::Scalar;
    type Matrix<T: Real> = ScalarGram<T>;
    type Factor<T: Real> = ScalarFactor<T>;
}

impl GramShape for Tridiagonal {
    const STRUCTURE: GramStructure = GramStructure::Tridiagonal;
    type Matrix<T: Real> = TridiagonalGram<T>;
    type Factor<T: Real> = ThomasFactor<T>;
}

impl GramShape for Dense {
    const STRUCTURE: GramStructure = GramStructure::Dense;
    type Matrix<T: Real> = DenseGram<T>;
    type Factor<T: Real> = LuFactor<T>;
}
