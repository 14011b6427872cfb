//! The quasi-Monte Carlo increments of P paths in the ensembles' layout
//! ([`QuasiEnsembleIncrements`]).

use sdae_lanes::{LaneWidth, lane_stride};

use crate::error::{NoiseError, check_step_size, whole_rows};
use crate::qmc::quasi_brownian::QuasiBrownian;

/// The increments of P quasi-Monte Carlo Brownian paths, laid out as
/// [`EnsembleIncrements::fill`](crate::EnsembleIncrements::fill) lays them out: step k,
/// coordinate j < m, path p at `dw[(k * m + j) * stride + p]`, stride =
/// [`lane_stride`]`(P)`, the padding lanes p >= P repeating path 0. Path p's numbers are bit
/// for bit those of [`QuasiBrownian::path`]`(indices[p])`: all N steps are computed up front,
/// W paths at a time in SIMD lanes ([`QuasiBrownian::unit_ensemble`]).
///
/// ```
/// use sdae_noise::{IncrementSource, QuasiBrownian};
/// let quasi = QuasiBrownian::new(7, 1, 3, 16)?;
/// let mut lanes = quasi.ensemble(&[0, 1, 2, 3, 4])?;
/// let stride = lanes.stride();
/// let mut dw = vec![0.0; 2 * 3 * stride];
/// assert_eq!(lanes.fill(0.1, &mut dw)?, 2);
/// let mut path = quasi.path(4)?;
/// let mut step = [0.0; 3];
/// for k in 0..2 {
///     path.next_increment(0.1, &mut step);
///     for j in 0..3 {
///         assert_eq!(dw[(k * 3 + j) * stride + 4], step[j]);
///     }
/// }
/// assert_eq!(lanes.remaining(), 14);
/// # Ok::<(), sdae_noise::NoiseError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiEnsembleIncrements {
    /// The unit-step increments: step k, coordinate j, lane p at `(k * m + j) * stride + p`.
    unit: Vec<f64>,
    paths: usize,
    dim: usize,
    stride: usize,
    position: usize,
}

impl QuasiBrownian {
    /// The increments of the paths `indices` (points `indices[p]` of the Sobol' points) in
    /// the ensembles' layout, made W at a time at the processor's widest lane width
    /// ([`QuasiBrownian::unit_ensemble`]); fails if an index is >= 2^32.
    pub fn ensemble(&self, indices: &[u64]) -> Result<QuasiEnsembleIncrements, NoiseError> {
        self.ensemble_with_width(indices, LaneWidth::Best)
    }

    /// [`QuasiBrownian::ensemble`] at lane width `width`: the same numbers at every width.
    pub fn ensemble_with_width(
        &self, indices: &[u64], width: LaneWidth,
    ) -> Result<QuasiEnsembleIncrements, NoiseError> {
        let stride = lane_stride(indices.len());
        let mut unit = vec![0.0; self.steps() * self.dim() * stride];
        self.unit_ensemble(indices, width, &mut unit)?;
        Ok(QuasiEnsembleIncrements {
            unit,
            paths: indices.len(),
            dim: self.dim(),
            stride,
            position: 0,
        })
    }
}

impl QuasiEnsembleIncrements {
    /// The number P of paths.
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// The dimension m of each path's increments.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The stride of the layout, [`lane_stride`]`(P)`.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// How many steps are left.
    pub fn remaining(&self) -> usize {
        (self.unit.len() - self.position)
            .checked_div(self.dim * self.stride)
            .unwrap_or(0)
    }

    /// Fills `dw` with the next increments over steps of size h of every path, sqrt(h) times
    /// the unit-step ones, as many steps as `dw` holds, and returns that number of steps (the
    /// contract of [`EnsembleIncrements::fill`](crate::EnsembleIncrements::fill)). Fails,
    /// drawing nothing, if h is not finite and > 0, if `dw`'s length is not a multiple of
    /// m * stride, or if it holds more steps than are left.
    pub fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError> {
        check_step_size(h)?;
        let Some(steps) = whole_rows(dw.len(), self.dim * self.stride)? else {
            return Ok(0);
        };
        let left = self.unit.len() - self.position;
        if dw.len() > left {
            return Err(NoiseError::DimensionMismatch {
                what: "increments buffer (at most the steps left times dim * stride)",
                expected: left,
                found: dw.len(),
            });
        }
        let scale = h.sqrt();
        let end = self.position + dw.len();
        for (o, xi) in dw.iter_mut().zip(&self.unit[self.position..end]) {
            *o = scale * xi;
        }
        self.position = end;
        Ok(steps)
    }
}
