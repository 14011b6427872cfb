//! Where the Brownian paths of a block come from: each path's own pseudo-random streams, or its
//! point of a randomization of scrambled Sobol' points, computed up front for the block.

use std::sync::OnceLock;

use sdae_lanes::lane_stride;
use sdae_model::ModelError;
use sdae_noise::{EnsembleNoise, NoiseError, QuasiBrownian};

/// Where the Brownian paths of a block come from.
#[derive(Clone, Copy)]
pub enum PathNoise<'a> {
    /// Path i draws from its own pseudo-random streams (`seed`, i).
    Pseudo {
        /// Seed of the path streams.
        seed: u64,
    },
    /// Randomized quasi-Monte Carlo: path p is point p % n of randomization p / n.
    Quasi(&'a QuasiPaths),
}

/// The randomized quasi-Monte Carlo paths of a study of R n paths: R randomizations of n
/// scrambled Sobol' points ([`QuasiBrownian`]). Global path p is point i = p % n of
/// randomization r = p / n, i.e. the increments of [`QuasiBrownian::new`]`(seed, r, l, 2^fine)`
/// at index i: a path's numbers depend on (seed, p) alone, not on the block, thread or shard it
/// runs in. Each randomization's scrambled points are made once, on first use, and shared by
/// every block (and thread) that runs paths of it; a block may hold paths of several
/// randomizations.
pub struct QuasiPaths {
    seed: u64,
    points: usize,
    /// The randomizations' scrambled points, made on first use (or why they could not be).
    randomizations: Vec<OnceLock<Result<QuasiBrownian, NoiseError>>>,
}

impl QuasiPaths {
    /// R = `randomizations` randomizations of n = `points` points each, for a study with seed
    /// `seed`.
    pub fn new(seed: u64, randomizations: usize, points: usize) -> Self {
        Self {
            seed,
            points,
            randomizations: (0..randomizations).map(|_| OnceLock::new()).collect(),
        }
    }

    /// Where global path `index` is: (randomization r, point i) = (index / n, index % n).
    pub fn locate(&self, index: usize) -> (usize, usize) {
        (index / self.points.max(1), index % self.points.max(1))
    }

    /// The increments of the paths `indices` of a block of `paths` lanes (the lanes beyond the
    /// block's paths repeat its first path) with l = `dim` components over 2^`fine` steps, all
    /// of them computed up front.
    pub(crate) fn block(
        &self, indices: &[usize], paths: usize, dim: usize, fine: u32,
    ) -> Result<QuasiBlock, ModelError> {
        let steps = 1usize << fine;
        let stride = lane_stride(paths);
        let mut unit = vec![0.0; steps * dim * stride];
        let mut path = vec![0.0; steps * dim];
        for lane in 0..stride {
            let Some(&index) = indices.get(lane).or(indices.first()) else {
                break;
            };
            let (r, i) = self.locate(index);
            let Some(cell) = self.randomizations.get(r) else {
                return Err(ModelError::DimensionMismatch {
                    what: "paths of a randomized QMC study (randomizations times points)",
                    expected: self.randomizations.len() * self.points,
                    found: index + 1,
                });
            };
            let quasi = cell
                .get_or_init(|| QuasiBrownian::new(self.seed, r as u64, dim, steps))
                .as_ref()
                .map_err(|e| ModelError::from(e.clone()))?;
            if quasi.dim() != dim || quasi.steps() != steps {
                return Err(ModelError::DimensionMismatch {
                    what: "increments of a randomized QMC path (steps * dim)",
                    expected: quasi.steps() * quasi.dim(),
                    found: steps * dim,
                });
            }
            quasi.unit_increments(i as u64, &mut path)?;
            for (c, xi) in path.iter().enumerate() {
                unit[c * stride + lane] = *xi;
            }
        }
        Ok(QuasiBlock {
            unit,
            paths,
            dim,
            stride,
            position: 0,
        })
    }
}

/// The quasi-Monte Carlo increments of a block of paths (of one or several randomizations), in
/// the ensembles' layout, computed up front over unit steps (as
/// [`QuasiEnsembleIncrements`](sdae_noise::QuasiEnsembleIncrements), whose numbers they are).
pub(crate) struct QuasiBlock {
    /// Step k, coordinate j, lane p at `(k * dim + j) * stride + p`, over unit steps.
    unit: Vec<f64>,
    paths: usize,
    dim: usize,
    stride: usize,
    position: usize,
}

impl EnsembleNoise for QuasiBlock {
    fn paths(&self) -> usize {
        self.paths
    }
    fn dim(&self) -> usize {
        self.dim
    }
    fn stride(&self) -> usize {
        self.stride
    }
    fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError> {
        let row = self.dim * self.stride;
        if row == 0 || dw.is_empty() {
            return Ok(0);
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(NoiseError::InvalidSetting {
                name: "h",
                value: h,
                reason: "step size must be finite and > 0",
            });
        }
        let end = self.position + dw.len();
        if !dw.len().is_multiple_of(row) || end > self.unit.len() {
            return Err(NoiseError::DimensionMismatch {
                what: "increments buffer (whole steps of dim * stride, at most those left)",
                expected: self.unit.len() - self.position,
                found: dw.len(),
            });
        }
        let scale = h.sqrt();
        for (o, xi) in dw.iter_mut().zip(&self.unit[self.position..end]) {
            *o = scale * xi;
        }
        self.position = end;
        Ok(dw.len() / row)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quasi_block_spanning_randomizations_holds_each_paths_point() {
        // 3 randomizations of 4 points; a block of paths 2..8 (randomizations 0 and 1) and 11
        // (randomization 2, point 3) on 16 lanes.
        let (seed, dim, fine) = (5, 2, 4);
        let quasi = QuasiPaths::new(seed, 3, 4);
        assert_eq!(quasi.locate(6), (1, 2));
        let indices = [2, 3, 4, 5, 6, 7, 11];
        let mut block = quasi.block(&indices, 16, dim, fine).unwrap();
        let stride = block.stride();
        let steps = 1usize << fine;
        let mut dw = vec![0.0; steps * dim * stride];
        assert_eq!(block.fill(0.25, &mut dw).unwrap(), steps);
        for (lane, &p) in indices.iter().enumerate() {
            let (r, i) = (p / 4, p % 4);
            let own = QuasiBrownian::new(seed, r as u64, dim, steps).unwrap();
            let mut alone = own.ensemble(&[i as u64]).unwrap();
            let mut expected = vec![0.0; steps * dim * alone.stride()];
            alone.fill(0.25, &mut expected).unwrap();
            for c in 0..steps * dim {
                assert_eq!(
                    dw[c * stride + lane],
                    expected[c * alone.stride()],
                    "path {p}"
                );
            }
        }
        // Nothing is left; a path beyond R n is refused.
        assert!(block.fill(0.25, &mut dw[..dim * stride]).is_err());
        assert!(quasi.block(&[12], 4, dim, fine).is_err());
    }
}
