//! Quasi-Monte Carlo paths W at a time in the lanes of a SIMD register
//! ([`QuasiBrownian::unit_ensemble`]).

use pulp::{Simd, WithSimd};
use sdae_lanes::{LaneWidth, Lanes, lane_stride};

use crate::error::NoiseError;
use crate::path_streams::StandardNormals;
use crate::qmc::inverse_normal::{central_quantile, is_central, tail_log, tail_quantile};
use crate::qmc::quasi_brownian::{QuasiBrownian, point_index};
use crate::qmc::sobol::unit_interval;

impl QuasiBrownian {
    /// `unit[c * stride + p]` = coordinate c = k m + j of the unit-step increments of path
    /// `indices[p]` ([`QuasiBrownian::unit_increments`]), stride = [`lane_stride`]`(P)` for P =
    /// `indices.len()`, the padding lanes p >= P repeating path `indices[0]`: the ensembles'
    /// layout. The paths are made W at a time at lane width `width`: their Sobol' words path by
    /// path (a pass over the coordinates per set bit of the index's Gray code), then the
    /// inverse normal and the Brownian bridge in the lanes, so that path p's numbers are bit
    /// for bit those of `unit_increments(indices[p])` whatever W is.
    ///
    /// Fails, writing nothing, if an index is >= 2^32 or if `unit`'s length is not N m stride.
    ///
    /// ```
    /// use sdae_lanes::LaneWidth;
    /// use sdae_noise::QuasiBrownian;
    /// let quasi = QuasiBrownian::new(7, 1, 2, 16)?;
    /// let (indices, stride) = ([3, 9, 4], 8);
    /// let mut unit = vec![0.0; 16 * 2 * stride];
    /// quasi.unit_ensemble(&indices, LaneWidth::Best, &mut unit)?;
    /// let mut path = vec![0.0; 16 * 2];
    /// quasi.unit_increments(9, &mut path)?;
    /// for (c, x) in path.iter().enumerate() {
    ///     assert_eq!(unit[c * stride + 1].to_bits(), x.to_bits());
    /// }
    /// # Ok::<(), sdae_noise::NoiseError>(())
    /// ```
    pub fn unit_ensemble(
        &self, indices: &[u64], width: LaneWidth, unit: &mut [f64],
    ) -> Result<(), NoiseError> {
        let stride = lane_stride(indices.len());
        let coordinates = self.steps() * self.dim();
        if unit.len() != coordinates * stride {
            return Err(NoiseError::DimensionMismatch {
                what: "increments of the paths (steps * dim * lane stride)",
                expected: coordinates * stride,
                found: unit.len(),
            });
        }
        let mut lanes = Vec::with_capacity(stride);
        for p in 0..stride {
            let index = *indices.get(p).unwrap_or(&indices[0]);
            lanes.push((point_index(index)?, index));
        }
        width.dispatch(LaneKernel {
            quasi: self,
            lanes: &lanes,
            unit,
        });
        Ok(())
    }
}

/// The paths of [`QuasiBrownian::unit_ensemble`] at one instruction set: (Sobol' point,
/// path index) of every lane, padding lanes included.
struct LaneKernel<'a> {
    quasi: &'a QuasiBrownian,
    lanes: &'a [(u32, u64)],
    unit: &'a mut [f64],
}

impl WithSimd for LaneKernel<'_> {
    type Output = ();

    /// W paths at a time: their coordinates path by path, the central region's quantiles in
    /// the lanes, the tails' (0.15 of the coordinates) gathered into lanes of their own after
    /// their logarithms, then the bridges in the lanes.
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let w = Lanes::<S>::WIDTH;
        let quasi = self.quasi;
        let stride = self.lanes.len();
        let mut s = Scratch::new(simd, quasi);
        for first in (0..stride).step_by(w) {
            let tails = s.gather(quasi, &self.lanes[first..first + w]);
            s.tail_quantiles(simd, tails);
            s.normals(simd, quasi.quasi_dims(), tails);
            quasi.bridge_increments(&s.normals, &mut s.bridge, &mut s.out);
            for (c, x) in s.out.iter().enumerate() {
                x.store(&mut self.unit[c * stride + first..]);
            }
        }
    }
}

/// The coordinates made at a time for each of W paths (their rows, 16 KiB at W = 8, stay in
/// the first-level cache).
const CHUNK: usize = 256;

/// The buffers of a block of W paths.
struct Scratch<S: Simd> {
    /// Lane l's coordinate c at `grid[c * W + l]`: u_c, then its normal (a padding normal
    /// beyond the quasi-random coordinates).
    grid: Vec<f64>,
    /// One path's padding normals (beyond the quasi-random coordinates).
    padding: Vec<f64>,
    /// One path's Sobol' words of a chunk of coordinates, their u and whether each is in
    /// the tails (1) or not (0).
    bits: Vec<u64>,
    chunk: Vec<f64>,
    in_tail: Vec<usize>,
    /// Where in `grid` the coordinates in the tails are (one slot more, for a write that
    /// does not count).
    slots: Vec<usize>,
    /// Their u, then their normals, and their logarithms, in whole rows of W.
    tail_u: Vec<f64>,
    tail_log: Vec<f64>,
    /// The normals, the bridge's nodes and the increments, in lanes.
    normals: Vec<Lanes<S>>,
    bridge: Vec<Lanes<S>>,
    out: Vec<Lanes<S>>,
}

impl<S: Simd> Scratch<S> {
    #[inline(always)]
    fn new(simd: S, quasi: &QuasiBrownian) -> Self {
        let w = Lanes::<S>::WIDTH;
        let coordinates = quasi.steps() * quasi.dim();
        let tails = quasi.quasi_dims() * w;
        let zero = Lanes::splat(simd, 0.0);
        Self {
            grid: vec![0.0; coordinates * w],
            padding: vec![0.0; coordinates - quasi.quasi_dims()],
            bits: vec![0; CHUNK],
            chunk: vec![0.0; CHUNK],
            in_tail: vec![0; CHUNK],
            slots: vec![0; tails + 1],
            tail_u: vec![0.0; tails.next_multiple_of(w)],
            tail_log: vec![0.0; tails.next_multiple_of(w)],
            normals: vec![zero; coordinates],
            bridge: vec![zero; quasi.steps() + 1],
            out: vec![zero; coordinates],
        }
    }

    /// Fills `grid` with the coordinates of the paths of `lanes` and `slots` with where the
    /// quasi-random ones in the tails are; returns their number. The coordinates go in
    /// chunks of [`CHUNK`], lane after lane, so that the grid's rows being written stay in the
    /// first-level cache.
    #[inline(always)]
    fn gather(&mut self, quasi: &QuasiBrownian, lanes: &[(u32, u64)]) -> usize {
        let w = lanes.len();
        let quasi_random = quasi.quasi_dims();
        let mut tails = 0;
        for first in (0..quasi_random).step_by(CHUNK) {
            let bits = &mut self.bits[..CHUNK.min(quasi_random - first)];
            let (uniforms, in_tail) = (&mut self.chunk[..bits.len()], &mut self.in_tail);
            for (l, &(point, _)) in lanes.iter().enumerate() {
                quasi.sobol_bits(point, first, bits);
                // In the lanes of the instruction set, a whole chunk at a time.
                for ((u, t), &x) in uniforms.iter_mut().zip(in_tail.iter_mut()).zip(bits.iter()) {
                    *u = unit_interval(x);
                    *t = usize::from(!is_central(*u - 0.5));
                }
                for (c, (&u, &t)) in (first..).zip(uniforms.iter().zip(in_tail.iter())) {
                    let slot = c * w + l;
                    self.grid[slot] = u;
                    // A push without a branch: the slot is kept only for a tail.
                    self.slots[tails] = slot;
                    tails += t;
                }
            }
        }
        if !self.padding.is_empty() {
            for (l, &(_, index)) in lanes.iter().enumerate() {
                let mut streams = quasi.padding_streams(index);
                streams.fill_scaled(1.0, &mut self.padding);
                for (c, &z) in (quasi_random..).zip(&self.padding) {
                    self.grid[c * w + l] = z;
                }
            }
        }
        tails
    }

    /// `tail_u[i]` = the normal of the i-th of the `tails` coordinates in the tails: the
    /// logarithms one by one, the rest in the lanes, W at a time.
    #[inline(always)]
    fn tail_quantiles(&mut self, simd: S, tails: usize) {
        let w = Lanes::<S>::WIDTH;
        for (i, &slot) in self.slots[..tails].iter().enumerate() {
            let u = self.grid[slot];
            self.tail_u[i] = u;
            self.tail_log[i] = tail_log(u, u - 0.5);
        }
        // The last row's unused lanes repeat the first tail (a value of no use, computed as
        // any other).
        let rows = tails.div_ceil(w);
        for i in tails..rows * w {
            self.tail_u[i] = self.tail_u[0];
            self.tail_log[i] = self.tail_log[0];
        }
        for row in 0..rows {
            let u = Lanes::load(simd, &self.tail_u[row * w..]);
            let log = Lanes::load(simd, &self.tail_log[row * w..]);
            tail_quantile(u, u - 0.5, log).store(&mut self.tail_u[row * w..]);
        }
    }

    /// `normals[c]` = the W normals of coordinate c: the central region's quantile of the
    /// first `quasi` coordinates in the lanes, the `tails` normals put in their place, the
    /// padding as it is.
    #[inline(always)]
    fn normals(&mut self, simd: S, quasi: usize, tails: usize) {
        let w = Lanes::<S>::WIDTH;
        for c in 0..quasi {
            let u = Lanes::load(simd, &self.grid[c * w..]);
            central_quantile(u - 0.5).store(&mut self.grid[c * w..]);
        }
        for (&slot, &z) in self.slots[..tails].iter().zip(&self.tail_u) {
            self.grid[slot] = z;
        }
        for (c, z) in self.normals.iter_mut().enumerate() {
            *z = Lanes::load(simd, &self.grid[c * w..]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit increments of the paths `indices` made by the kernel at instruction set
    /// `simd` (W = 1, 4 or 8 whatever the processor).
    fn at_width<S: Simd>(simd: S, quasi: &QuasiBrownian, indices: &[u64]) -> Vec<f64> {
        let stride = lane_stride(indices.len());
        let mut unit = vec![f64::NAN; quasi.steps() * quasi.dim() * stride];
        let lanes: Vec<(u32, u64)> = (0..stride)
            .map(|p| indices.get(p).unwrap_or(&indices[0]))
            .map(|&i| (point_index(i).unwrap(), i))
            .collect();
        simd.vectorize(LaneKernel {
            quasi,
            lanes: &lanes,
            unit: &mut unit,
        });
        unit
    }

    #[test]
    fn every_width_makes_the_one_path_numbers() {
        // Steps not a power of two, three components, padding beyond 40 coordinates.
        let quasi = QuasiBrownian::with_quasi_limit(11, 2, 3, 37, 40).unwrap();
        let indices = [5, 0, 1 << 31, 77, 3, 12, 9, 1000, 64, 2, u32::MAX as u64];
        let stride = lane_stride(indices.len());
        let mut path = vec![0.0; 37 * 3];
        for (w, unit) in [
            (1, at_width(pulp::Scalar, &quasi, &indices)),
            (4, at_width(pulp::Scalar256b, &quasi, &indices)),
            (8, at_width(pulp::Scalar512b, &quasi, &indices)),
        ] {
            for p in 0..stride {
                quasi
                    .unit_increments(*indices.get(p).unwrap_or(&indices[0]), &mut path)
                    .unwrap();
                for (c, x) in path.iter().enumerate() {
                    let got = unit[c * stride + p];
                    assert_eq!(
                        got.to_bits(),
                        x.to_bits(),
                        "W = {w}, lane {p}, coordinate {c}"
                    );
                }
            }
        }
    }
}
