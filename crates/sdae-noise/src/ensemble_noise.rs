//! What the ensembles draw their increments from, pseudo-random or quasi-random
//! ([`EnsembleNoise`]).

use crate::error::NoiseError;
use crate::normals::EnsembleIncrements;
use crate::qmc::QuasiEnsembleIncrements;

/// The Brownian increments of P paths in the ensembles' layout (step k, coordinate j, path p at
/// `dw[(k * l + j) * stride + p]`): each path's own pseudo-random streams
/// ([`EnsembleIncrements`]) or its point of a randomized Sobol' sequence
/// ([`QuasiEnsembleIncrements`]). A driver written over this trait runs either.
pub trait EnsembleNoise {
    /// The number P of paths.
    fn paths(&self) -> usize;
    /// The dimension l of each path's increments.
    fn dim(&self) -> usize;
    /// The stride of the layout.
    fn stride(&self) -> usize;
    /// Fills `dw` with the next increments over steps of size h of every path, as many steps
    /// as it holds, and returns that number of steps.
    fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError>;
}

impl EnsembleNoise for EnsembleIncrements {
    fn paths(&self) -> usize {
        EnsembleIncrements::paths(self)
    }
    fn dim(&self) -> usize {
        EnsembleIncrements::dim(self)
    }
    fn stride(&self) -> usize {
        EnsembleIncrements::stride(self)
    }
    fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError> {
        EnsembleIncrements::fill(self, h, dw)
    }
}

impl EnsembleNoise for QuasiEnsembleIncrements {
    fn paths(&self) -> usize {
        QuasiEnsembleIncrements::paths(self)
    }
    fn dim(&self) -> usize {
        QuasiEnsembleIncrements::dim(self)
    }
    fn stride(&self) -> usize {
        QuasiEnsembleIncrements::stride(self)
    }
    fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError> {
        QuasiEnsembleIncrements::fill(self, h, dw)
    }
}
