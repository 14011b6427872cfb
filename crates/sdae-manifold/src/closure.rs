//! User-defined constraints from closures, without touching this crate.

use crate::constraint::{Constraint, Curvature, assemble_dense_by_columns};
use crate::error::ManifoldError;
use crate::gram::DenseGram;
use crate::mass::Mass;

/// Marker for a closure constraint without a second derivative.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoCurvature;

/// A constraint given by closures for g(x), Dg(x) u and grad g(x) z (and optionally
/// D^2 g(x)(u, w)); its Gram matrix is dense and assembled column by column.
///
/// ```
/// use sdae_manifold::{ClosureConstraint, Constraint};
/// // The parabola y = x^2 in R^2: g(x, y) = y - x^2.
/// let parabola = ClosureConstraint::new(
///     2,
///     1,
///     |x: &[f64], g: &mut [f64]| g[0] = x[1] - x[0] * x[0],
///     |x: &[f64], u: &[f64], out: &mut [f64]| out[0] = -2.0 * x[0] * u[0] + u[1],
///     |x: &[f64], z: &[f64], out: &mut [f64]| {
///         out[0] = -2.0 * x[0] * z[0];
///         out[1] = z[0];
///     },
/// )
/// .unwrap();
/// let mut g = [0.0];
/// parabola.value(&[2.0, 4.0], &mut g);
/// assert_eq!(g[0], 0.0);
/// ```
#[derive(Clone)]
pub struct ClosureConstraint<G, J, JT, H = NoCurvature> {
    dim: usize,
    n_constraints: usize,
    value: G,
    jacobian: J,
    jacobian_transpose: JT,
    second_derivative: H,
}

impl<G, J, JT, H> std::fmt::Debug for ClosureConstraint<G, J, JT, H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClosureConstraint")
            .field("dim", &self.dim)
            .field("n_constraints", &self.n_constraints)
            .finish_non_exhaustive()
    }
}

impl<G, J, JT> ClosureConstraint<G, J, JT, NoCurvature>
where
    G: Fn(&[f64], &mut [f64]),
    J: Fn(&[f64], &[f64], &mut [f64]),
    JT: Fn(&[f64], &[f64], &mut [f64]),
{
    /// n coordinates, 1 <= m < n constraints; `value(x, g)`, `jacobian(x, u, Dg u)`,
    /// `jacobian_transpose(x, z, grad g z)`.
    pub fn new(
        dim: usize, n_constraints: usize, value: G, jacobian: J, jacobian_transpose: JT,
    ) -> Result<Self, ManifoldError> {
        if n_constraints == 0 || n_constraints >= dim {
            return Err(ManifoldError::InvalidParameter {
                name: "n_constraints",
                value: n_constraints as f64,
                reason: "need 1 <= m < n",
            });
        }
        Ok(Self {
            dim,
            n_constraints,
            value,
            jacobian,
            jacobian_transpose,
            second_derivative: NoCurvature,
        })
    }

    /// Adds D^2 g(x)(u, w), so that inherent-SDE solvers can use this constraint.
    pub fn with_second_derivative<H>(self, second_derivative: H) -> ClosureConstraint<G, J, JT, H>
    where
        H: Fn(&[f64], &[f64], &[f64], &mut [f64]),
    {
        ClosureConstraint {
            dim: self.dim,
            n_constraints: self.n_constraints,
            value: self.value,
            jacobian: self.jacobian,
            jacobian_transpose: self.jacobian_transpose,
            second_derivative,
        }
    }
}

impl<G, J, JT, H> Constraint for ClosureConstraint<G, J, JT, H>
where
    G: Fn(&[f64], &mut [f64]),
    J: Fn(&[f64], &[f64], &mut [f64]),
    JT: Fn(&[f64], &[f64], &mut [f64]),
{
    type Gram = DenseGram;
    fn dim(&self) -> usize {
        self.dim
    }
    fn n_constraints(&self) -> usize {
        self.n_constraints
    }
    fn value(&self, x: &[f64], out: &mut [f64]) {
        (self.value)(x, out)
    }
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        (self.jacobian)(x, u, out)
    }
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        (self.jacobian_transpose)(x, z, out)
    }
    fn new_gram(&self) -> DenseGram {
        DenseGram::zeros(self.n_constraints)
    }
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut DenseGram,
    ) {
        assemble_dense_by_columns(self, x1, x2, mass, scratch, out);
    }
}

impl<G, J, JT, H> Curvature for ClosureConstraint<G, J, JT, H>
where
    G: Fn(&[f64], &mut [f64]),
    J: Fn(&[f64], &[f64], &mut [f64]),
    JT: Fn(&[f64], &[f64], &mut [f64]),
    H: Fn(&[f64], &[f64], &[f64], &mut [f64]),
{
    fn second_derivative(&self, x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        (self.second_derivative)(x, u, w, out)
    }
}
