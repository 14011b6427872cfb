//! Randomization r of the quasi-Monte Carlo Brownian paths of a study ([`QuasiBrownian`]).

use rand::Rng;
use sdae_lanes::Real;

use crate::error::NoiseError;
use crate::path_streams::{PathStreams, StandardNormals};
use crate::qmc::bridge::BrownianBridge;
use crate::qmc::inverse_normal::inverse_normal_cdf;
use crate::qmc::joe_kuo::MAX_SOBOL_DIMS;
use crate::qmc::seeds::{Family, family_rng};
use crate::qmc::sobol::{SobolPoints, unit_interval};

/// Randomization r of the quasi-Monte Carlo Brownian paths of a study with seed `seed`: paths
/// of an m-dimensional Brownian motion over N steps, path i the image of point i of the
/// randomized Sobol' points ([`SobolPoints::scrambled`]) in d = N m dimensions.
///
/// Coordinate c of point i, u_c, gives the standard normal z_c = Phi^-1(u_c)
/// ([`inverse_normal_cdf`]); coordinate c drives normal c / m of the Brownian bridge
/// ([`BrownianBridge`]) of component c % m, so the first, best distributed coordinates carry
/// the coarse shape (W(T), then W(T/2), ...) of every component. Coordinates from
/// [`QuasiBrownian::quasi_dims`] on (beyond the 21 201 Sobol' dimensions, or a smaller limit)
/// are pseudo-random: the standard normals of [`QuasiBrownian::padding_streams`]`(i)`, in the
/// order of the coordinates.
///
/// The scrambled direction numbers and the bridge are made once here and shared by the paths
/// ([`QuasiBrownian::path`], [`QuasiBrownian::ensemble`]); each path is computed from its index
/// alone. Its increments over unit steps are those of a standard Brownian motion; over steps
/// of size h they are sqrt(h) times these (Brownian scaling), which is what the sources hand
/// out.
///
/// ```
/// use sdae_noise::{IncrementSource, QuasiBrownian};
/// // Randomization 0 of study 42: 2-dimensional paths over 64 steps of h = 1/64.
/// let quasi = QuasiBrownian::new(42, 0, 2, 64)?;
/// assert_eq!(quasi.quasi_dims(), 128);
/// let (n, h) = (256, 1.0 / 64.0);
/// let mut mean_w1 = 0.0;
/// for i in 0..n {
///     let mut path = quasi.path(i)?;
///     let mut dw = [0.0; 2];
///     let mut w = [0.0; 2];
///     while path.remaining() != Some(0) {
///         path.next_increment(h, &mut dw);
///         w[0] += dw[0];
///         w[1] += dw[1];
///     }
///     mean_w1 += w[0] / n as f64;
/// }
/// // Stratified: the mean of W(1) over the 256 points is far closer to 0 than 1/16.
/// assert!(mean_w1.abs() < 0.01);
/// # Ok::<(), sdae_noise::NoiseError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiBrownian {
    points: SobolPoints,
    bridge: BrownianBridge,
    dim: usize,
    padding_seed: u64,
}

impl QuasiBrownian {
    /// Randomization `randomization` of the paths of dimension `dim` = m over `steps` = N
    /// steps of a study with seed `seed`, quasi-random in the first min(N m, 21 201)
    /// coordinates. Fails unless m >= 1 and N >= 1.
    pub fn new(
        seed: u64, randomization: u64, dim: usize, steps: usize,
    ) -> Result<Self, NoiseError> {
        Self::with_quasi_limit(seed, randomization, dim, steps, MAX_SOBOL_DIMS)
    }

    /// As [`QuasiBrownian::new`], quasi-random in the first min(N m, `limit`) coordinates
    /// only; fails also unless 1 <= `limit` <= 21 201.
    pub fn with_quasi_limit(
        seed: u64, randomization: u64, dim: usize, steps: usize, limit: usize,
    ) -> Result<Self, NoiseError> {
        let coordinates = coordinates(dim, steps)?;
        if !(1..=MAX_SOBOL_DIMS).contains(&limit) {
            return Err(NoiseError::InvalidSetting {
                name: "quasi-random coordinates",
                value: limit as f64,
                reason: "must be between 1 and 21 201 (the Joe and Kuo direction numbers)",
            });
        }
        Ok(Self {
            points: SobolPoints::scrambled(coordinates.min(limit), seed, randomization)?,
            bridge: BrownianBridge::new(steps)?,
            dim,
            padding_seed: family_rng(seed, Family::Padding, randomization).next_u64(),
        })
    }

    /// The dimension m of the increments.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The number N of steps of a path.
    pub fn steps(&self) -> usize {
        self.bridge.steps()
    }

    /// How many of a path's N m coordinates are quasi-random (the rest are padding).
    pub fn quasi_dims(&self) -> usize {
        self.points.dims()
    }

    /// The streams whose standard normals pad path `index`'s coordinates beyond
    /// [`QuasiBrownian::quasi_dims`]: [`PathStreams::for_path`]`(s_r, index)` with s_r a seed
    /// drawn for this randomization, so that the R randomizations of a study stay independent
    /// in the padded coordinates too.
    pub fn padding_streams(&self, index: u64) -> PathStreams {
        PathStreams::for_path(self.padding_seed, index)
    }

    /// out[k m + j] = component j of the increment W(k + 1) - W(k) over unit step k of path
    /// `index` (the construction of [`QuasiBrownian`]). Fails if `index` >= 2^32 (the Sobol'
    /// points' range) or if out's length is not N m.
    pub fn unit_increments(&self, index: u64, out: &mut [f64]) -> Result<(), NoiseError> {
        let point = point_index(index)?;
        let (steps, dim) = (self.steps(), self.dim);
        if out.len() != steps * dim {
            return Err(NoiseError::DimensionMismatch {
                what: "increments of a path (steps * dim)",
                expected: steps * dim,
                found: out.len(),
            });
        }
        let mut bits = vec![0; self.quasi_dims()];
        let mut normals = vec![0.0; steps * dim];
        self.uniforms(point, index, &mut bits, &mut normals);
        for z in &mut normals[..bits.len()] {
            *z = inverse_normal_cdf(*z);
        }
        let mut w = vec![0.0; steps + 1];
        self.bridge_increments(&normals, &mut w, out);
        Ok(())
    }

    /// The coordinates of path `index` (point `point` of the Sobol' points) before the
    /// inverse normal: `out[c]` = u_c, c < [`QuasiBrownian::quasi_dims`] (`bits` holds the
    /// Sobol' words on return, its length that number), and beyond them the padding normals.
    #[inline(always)]
    pub(crate) fn uniforms(&self, point: u32, index: u64, bits: &mut [u64], out: &mut [f64]) {
        let quasi = bits.len();
        self.sobol_bits(point, 0, bits);
        for (u, x) in out.iter_mut().zip(bits.iter()) {
            *u = unit_interval(*x);
        }
        if quasi < out.len() {
            self.padding_streams(index)
                .fill_scaled(1.0, &mut out[quasi..]);
        }
    }

    /// The Sobol' words of coordinates `first..first + bits.len()` of point `point`
    /// ([`SobolPoints::fill_bits`]).
    #[inline(always)]
    pub(crate) fn sobol_bits(&self, point: u32, first: usize, bits: &mut [u64]) {
        self.points.fill_bits(point, first, bits);
    }

    /// `out[k m + j]` = W_j(k + 1) - W_j(k), W_j the bridge ([`BrownianBridge`]) of the
    /// normals `normals[k m + j]`, k = 0..N, of one path or of W paths in lanes (the same
    /// operations); `w` holds N + 1 values of scratch.
    #[inline(always)]
    pub(crate) fn bridge_increments<T: Real>(&self, normals: &[T], w: &mut [T], out: &mut [T]) {
        let (steps, dim) = (self.steps(), self.dim);
        for j in 0..dim {
            self.bridge.fill_strided(normals, j, dim, w);
            for k in 0..steps {
                out[k * dim + j] = w[k + 1] - w[k];
            }
        }
    }
}

/// N m, the number of coordinates of a path; fails unless m >= 1, N >= 1 and N m fits.
fn coordinates(dim: usize, steps: usize) -> Result<usize, NoiseError> {
    let invalid = |name, value: usize, reason| NoiseError::InvalidSetting {
        name,
        value: value as f64,
        reason,
    };
    if dim == 0 {
        return Err(invalid(
            "dim",
            dim,
            "the increments need at least one component",
        ));
    }
    if steps == 0 {
        return Err(invalid("steps", steps, "a path needs at least one step"));
    }
    steps
        .checked_mul(dim)
        .ok_or_else(|| invalid("steps * dim", steps, "a path's coordinates overflow"))
}

/// The Sobol' index of path `index`; fails if it is >= 2^32.
pub(crate) fn point_index(index: u64) -> Result<u32, NoiseError> {
    u32::try_from(index).map_err(|_| NoiseError::InvalidSetting {
        name: "path index",
        value: index as f64,
        reason: "quasi-random paths are points 0..2^32 of the Sobol' sequence",
    })
}
