//! The structure of a Gram matrix as a type ([`GramShape`]): its storage ([`crate::gram`]) and
//! its factorization ([`crate::factor`]) for every number type at once, above both.

use sdae_lanes::Real;

use crate::factor::{Factorize, LuFactor, MatrixFactor, ScalarFactor, ThomasFactor};
use crate::gram::{DenseGram, GramStructure, ScalarGram, SquareMatrix, TridiagonalGram};

/// The structure of a Gram matrix as a type: its storage and the factorization run in lanes,
/// for every number type. A constraint's lane form names its shape
/// ([`Equations::Shape`](crate::Equations::Shape)).
pub trait GramShape: Send + Sync + 'static {
    /// The structure.
    const STRUCTURE: GramStructure;
    /// The storage of a matrix of this shape, filled from its products ([`ByProducts`]).
    type Matrix<T: Real>: SquareMatrix<T> + ByProducts<T>;
    /// Its factorization without fallbacks (the one that runs in lanes; a path it rejects
    /// goes through the one-path factorization with its fallbacks and typed errors).
    type Factor<T: Real>: MatrixFactor<T, Matrix = Self::Matrix<T>>;
    /// The one-path storage, `Matrix<f64>`, with its factorization with fallbacks and typed
    /// errors ([`Factorize`]): the `Constraint::Gram` of a constraint of this shape
    /// ([`Equations`](crate::Equations)).
    type Gram: Factorize + SquareMatrix<f64> + ByProducts<f64>;
    /// The one-path storage as the matrix over `f64` it is (`Gram` is `Matrix<f64>`), for
    /// code written once over the number type.
    fn one_path(gram: &mut Self::Gram) -> &mut Self::Matrix<f64>;
}

/// A storage of an m x m matrix A filled from the map p -> A p: one product per column (or
/// per set of columns that share no row of the structure), m products for a dense matrix, 3
/// for a tridiagonal one whatever m, 1 for a scalar. With p -> Dg(x1) M^-1 grad g(x2) p it
/// assembles the Gram-type matrix of any constraint from its Jacobian products, for one path
/// and for lanes alike.
pub trait ByProducts<T: Real> {
    /// Sets A from the products image = A p of `product`, with `probe` and `image` scratch
    /// of m entries each.
    fn assemble_by_products(
        &mut self, probe: &mut [T], image: &mut [T], product: &mut impl Product<T>,
    );
}

/// The map p -> A p of an m x m matrix A ([`ByProducts`]). A closure is one; a type of its
/// own with an `#[inline(always)]` method is inlined where lanes are compiled for their
/// instruction set.
pub trait Product<T> {
    /// image = A p (m entries each).
    fn product(&mut self, p: &[T], image: &mut [T]);
}

impl<T, F: FnMut(&[T], &mut [T])> Product<T> for F {
    #[inline(always)]
    fn product(&mut self, p: &[T], image: &mut [T]) {
        self(p, image);
    }
}

impl<T: Real> ByProducts<T> for ScalarGram<T> {
    /// A = A 1.
    #[inline(always)]
    fn assemble_by_products(
        &mut self, probe: &mut [T], image: &mut [T], product: &mut impl Product<T>,
    ) {
        probe[0] = probe[0].splat_like(1.0);
        product.product(&probe[..1], &mut image[..1]);
        self.0 = image[0];
    }
}

impl<T: Real> ByProducts<T> for DenseGram<T> {
    /// Column j = A e_j, j = 0, ..., m - 1.
    #[inline(always)]
    fn assemble_by_products(
        &mut self, probe: &mut [T], image: &mut [T], product: &mut impl Product<T>,
    ) {
        let m = probe.len();
        let (zero, one) = (probe[0].splat_like(0.0), probe[0].splat_like(1.0));
        probe.fill(zero);
        for j in 0..m {
            probe[j] = one;
            product.product(probe, image);
            for (i, value) in image.iter().enumerate() {
                self.set(i, j, *value);
            }
            probe[j] = zero;
        }
    }
}

impl<T: Real> ByProducts<T> for TridiagonalGram<T> {
    /// Three probes, the columns j = c mod 3 summed (c = 0, 1, 2): row i of the image holds
    /// A_ij for the one j in {i - 1, i, i + 1} with j = c mod 3.
    #[inline(always)]
    fn assemble_by_products(
        &mut self, probe: &mut [T], image: &mut [T], product: &mut impl Product<T>,
    ) {
        let m = probe.len();
        let (zero, one) = (probe[0].splat_like(0.0), probe[0].splat_like(1.0));
        for colour in 0..3 {
            for (j, p) in probe.iter_mut().enumerate() {
                *p = if j % 3 == colour { one } else { zero };
            }
            product.product(probe, image);
            for (i, value) in image.iter().enumerate() {
                for j in i.saturating_sub(1)..(i + 2).min(m) {
                    if j % 3 == colour {
                        match j.cmp(&i) {
                            std::cmp::Ordering::Less => self.lower[j] = *value,
                            std::cmp::Ordering::Equal => self.diag[i] = *value,
                            std::cmp::Ordering::Greater => self.upper[i] = *value,
                        }
                    }
                }
            }
        }
    }
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

/// The [`GramShape`] of a structure with its storage and factorization (`Gram` is the
/// storage over `f64`).
macro_rules! gram_shape {
    ($shape:ident, $structure:ident, $matrix:ident, $factor:ident) => {
        impl GramShape for $shape {
            const STRUCTURE: GramStructure = GramStructure::$structure;
            type Matrix<T: Real> = $matrix<T>;
            type Factor<T: Real> = $factor<T>;
            type Gram = $matrix;
            #[inline(always)]
            fn one_path(gram: &mut $matrix) -> &mut $matrix {
                gram
            }
        }
    };
}

gram_shape!(Scalar, Scalar, ScalarGram, ScalarFactor);
gram_shape!(Tridiagonal, Tridiagonal, TridiagonalGram, ThomasFactor);
gram_shape!(Dense, Dense, DenseGram, LuFactor);
