//! Points of a Sobol' sequence, point i and coordinate j computed directly ([`SobolPoints`]).

use crate::error::NoiseError;
use crate::qmc::joe_kuo::{INDEX_BITS, MAX_SOBOL_DIMS, direction_numbers};

/// The first `dims` coordinates of the points of a Sobol' sequence (Joe and Kuo's direction
/// numbers), plain ([`SobolPoints::new`]) or randomized ([`SobolPoints::scrambled`]).
///
/// Coordinate j of point i is the 64-bit word
///
/// ```text
/// x_(i,j) = e_j ^ XOR_k { v_(j,k) : bit k of g(i) is set },   g(i) = i ^ (i >> 1),
/// ```
///
/// the direction numbers v_(j,k) taken over the set bits of the Gray code g(i) of i (the
/// ordering of Antonov and Saleev that SciPy and the `sobol` crate use) and e_j = 0 for the
/// plain sequence. Since g is a permutation of 0..2^m, the first 2^m points are the same set as
/// in the natural ordering (bits of i itself): a (t, m, s)-net. Each point is computed from its
/// index alone, so path i can be drawn on any thread, lane or shard. Indices are below 2^32.
///
/// ```
/// use sdae_noise::SobolPoints;
/// let sobol = SobolPoints::new(2)?;
/// let first: Vec<[f64; 2]> = (0..4)
///     .map(|i| [sobol.coordinate_bits(i, 0), sobol.coordinate_bits(i, 1)])
///     .map(|x| x.map(|b| b as f64 / 2f64.powi(64)))
///     .collect();
/// assert_eq!(first, [[0.0, 0.0], [0.5, 0.5], [0.75, 0.25], [0.25, 0.75]]);
/// # Ok::<(), sdae_noise::NoiseError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SobolPoints {
    /// v_(j,k) of dimension j, k = 1..32, left-aligned in 64 bits (randomized ones if
    /// scrambled), bit by bit: v_(j,k) at `(k - 1) * dims + j`, so that the coordinates of a
    /// point are XORs of whole rows ([`SobolPoints::fill_bits`]).
    by_bit: Vec<u64>,
    /// The digital shift e_j of dimension j (0 for the plain sequence).
    pub(crate) shifts: Vec<u64>,
}

impl SobolPoints {
    /// The plain Sobol' points in `dims` dimensions, 1 <= `dims` <= [`MAX_SOBOL_DIMS`].
    pub fn new(dims: usize) -> Result<Self, NoiseError> {
        check_dims(dims)?;
        let directions: Vec<_> = (0..dims).map(direction_numbers).collect();
        Ok(Self::from_parts(&directions, vec![0; dims]))
    }

    /// The points of the direction numbers `directions[j]` and the shifts `shifts[j]` of
    /// each dimension j (of equal lengths).
    pub(crate) fn from_parts(directions: &[[u64; INDEX_BITS]], shifts: Vec<u64>) -> Self {
        let dims = directions.len();
        let mut by_bit = vec![0; INDEX_BITS * dims];
        for (j, v) in directions.iter().enumerate() {
            for (k, vk) in v.iter().enumerate() {
                by_bit[k * dims + j] = *vk;
            }
        }
        Self { by_bit, shifts }
    }

    /// The number of dimensions.
    pub fn dims(&self) -> usize {
        self.shifts.len()
    }

    /// v_(j,k+1), direction number k + 1 of dimension j (k < 32).
    pub(crate) fn direction(&self, dim: usize, k: usize) -> u64 {
        self.by_bit[k * self.dims() + dim]
    }

    /// x_(i,j), coordinate `dim` of point `index` as a 64-bit binary fraction (the formula of
    /// [`SobolPoints`]). Panics if `dim` >= [`SobolPoints::dims`].
    pub fn coordinate_bits(&self, index: u32, dim: usize) -> u64 {
        assert!(dim < self.dims(), "dimension {dim} of {}", self.dims());
        let mut x = self.shifts[dim];
        let mut gray = index ^ (index >> 1);
        while gray != 0 {
            x ^= self.direction(dim, gray.trailing_zeros() as usize);
            gray &= gray - 1;
        }
        x
    }

    /// out_j = x_(i,first+j), coordinates `first..first + out.len()` of point `index` as 64-bit
    /// binary fractions: the shifts XOR the rows of direction numbers of the set bits of g(i),
    /// a pass over out per set bit (the same numbers as [`SobolPoints::coordinate_bits`]).
    /// Panics if first + out.len() exceeds [`SobolPoints::dims`].
    #[inline(always)]
    pub fn fill_bits(&self, index: u32, first: usize, out: &mut [u64]) {
        let (dims, end) = (self.dims(), first + out.len());
        out.copy_from_slice(&self.shifts[first..end]);
        let mut gray = index ^ (index >> 1);
        while gray != 0 {
            let row = gray.trailing_zeros() as usize * dims;
            for (x, v) in out.iter_mut().zip(&self.by_bit[row + first..row + end]) {
                *x ^= v;
            }
            gray &= gray - 1;
        }
    }

    /// u_(i,j) = [`unit_interval`](x_(i,j)), coordinate `dim` of point `index` in (0, 1).
    /// Panics if `dim` >= [`SobolPoints::dims`].
    pub fn coordinate(&self, index: u32, dim: usize) -> f64 {
        unit_interval(self.coordinate_bits(index, dim))
    }

    /// out_j = u_(i,j), the first out.len() coordinates of point `index`. Panics if out is
    /// longer than [`SobolPoints::dims`].
    pub fn fill_point(&self, index: u32, out: &mut [f64]) {
        for (j, u) in out.iter_mut().enumerate() {
            *u = self.coordinate(index, j);
        }
    }
}

/// u = (floor(x / 2^12) + 1/2) 2^-52: the midpoint of the cell of width 2^-52 that the 64-bit
/// binary fraction x falls in. It lies in [2^-53, 1 - 2^-53], never 0 or 1, and is exact, so
/// u(!x) = 1 - u(x) and floor(u 2^m) = x >> (64 - m) for m <= 52. (With 53 bits,
/// (floor(x / 2^11) + 1/2) 2^-53 would round the top cell's midpoint to 1.)
#[inline(always)]
pub fn unit_interval(x: u64) -> f64 {
    // floor(x / 2^12) < 2^52 as a double, exactly: the bits of 2^52 + it, less 2^52 (the
    // conversion without a branch on the sign bit, so that it runs in SIMD lanes).
    let cell = f64::from_bits(TWO_52.to_bits() | (x >> 12)) - TWO_52;
    (cell + 0.5) * UNIT_CELL
}

/// 2^52, whose doubles' last bit is worth 1.
const TWO_52: f64 = (1u64 << 52) as f64;

/// 2^-52, the width of the cells of [`unit_interval`].
const UNIT_CELL: f64 = 1.0 / (1u64 << 52) as f64;

/// Fails with [`NoiseError::InvalidSetting`] unless 1 <= dims <= [`MAX_SOBOL_DIMS`].
pub(crate) fn check_dims(dims: usize) -> Result<(), NoiseError> {
    if (1..=MAX_SOBOL_DIMS).contains(&dims) {
        Ok(())
    } else {
        Err(NoiseError::InvalidSetting {
            name: "Sobol' dimensions",
            value: dims as f64,
            reason: "must be between 1 and 21 201 (the Joe and Kuo direction numbers)",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_points_are_the_known_ones() {
        let sobol = SobolPoints::new(3).unwrap();
        let column = |j| -> Vec<f64> {
            (0..8)
                .map(|i| sobol.coordinate_bits(i, j) as f64 / 2f64.powi(64))
                .collect()
        };
        // Dimension 1, van der Corput in Gray-code order; dimension 2 of Joe and Kuo; dimension 3
        // (SciPy's `Sobol(3, scramble=False)` gives the same rows).
        let expected = [
            [0.0, 0.5, 0.75, 0.25, 0.375, 0.875, 0.625, 0.125],
            [0.0, 0.5, 0.25, 0.75, 0.375, 0.875, 0.125, 0.625],
            [0.0, 0.5, 0.25, 0.75, 0.625, 0.125, 0.875, 0.375],
        ];
        for (j, want) in expected.iter().enumerate() {
            assert_eq!(column(j), want, "dimension {}", j + 1);
        }
    }

    #[test]
    fn the_points_are_those_of_the_sobol_crate() {
        use sobol::{Sobol, params::JoeKuoD6};
        let dims = MAX_SOBOL_DIMS;
        let points = SobolPoints::new(dims).unwrap();
        let reference = Sobol::<u32>::new(dims, &JoeKuoD6::extended());
        for (i, point) in reference.take(300).enumerate() {
            for j in (0..40).chain([999, 5000, 21_200]) {
                let ours = (points.coordinate_bits(i as u32, j) >> 32) as u32;
                assert_eq!(ours, point[j], "point {i}, dimension {j}");
            }
        }
    }

    #[test]
    fn rows_of_a_point_are_its_coordinates() {
        let points = SobolPoints::scrambled(300, 5, 2).unwrap();
        for index in [0, 1, 2, 7, 1000, 0x8000_0001, u32::MAX] {
            for (first, len) in [(0, 300), (17, 100), (299, 1), (40, 0)] {
                let mut bits = vec![0; len];
                points.fill_bits(index, first, &mut bits);
                for (c, x) in (first..).zip(bits) {
                    assert_eq!(
                        x,
                        points.coordinate_bits(index, c),
                        "point {index}, dim {c}"
                    );
                }
            }
        }
    }

    #[test]
    fn unit_interval_is_open_exact_and_symmetric() {
        assert_eq!(unit_interval(0), 2f64.powi(-53));
        assert_eq!(unit_interval(u64::MAX), 1.0 - 2f64.powi(-53));
        for x in [0, 1, 1 << 12, 0x8000_0000_0000_0000, u64::MAX / 3, u64::MAX] {
            assert_eq!(unit_interval(!x), 1.0 - unit_interval(x));
            assert_eq!(unit_interval(x), ((x >> 12) as f64 + 0.5) * UNIT_CELL);
            assert_eq!((unit_interval(x) * 2f64.powi(20)).floor() as u64, x >> 44);
        }
    }

    #[test]
    fn dimensions_out_of_range_are_refused() {
        assert!(SobolPoints::new(0).is_err());
        assert!(SobolPoints::new(MAX_SOBOL_DIMS + 1).is_err());
        assert_eq!(SobolPoints::new(5).unwrap().dims(), 5);
    }
}
