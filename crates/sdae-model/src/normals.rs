//! Gaussian increments of many paths, drawn W paths at once ([`EnsembleIncrements`]).

use std::convert::Infallible;
use std::sync::OnceLock;

use pulp::{Simd, bytemuck};
use rand::{RngExt, SeedableRng, TryRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::ensemble::{LANE_BLOCK, lane_stride};
use crate::error::{ModelError, check_step_size};
use crate::increments::path_rng;
use crate::lanes::LaneWidth;

/// The Gaussian increments sqrt(h) N(0, I_l) of P paths, each path from its own xoshiro256++
/// stream, drawn W paths at once into the ensembles' layout ([`lane_stride`]).
///
/// It keeps the streams in structure-of-arrays layout and draws one standard normal for W
/// paths per pass: the generator's 64-bit additions, shifts and xors run in the lanes of a SIMD
/// register (W = 4 with AVX2, 8 with AVX-512, 1 otherwise; [`LaneWidth`]), the ziggurat's fast
/// path follows lane by lane. Path p's numbers are bit for bit those of
/// [`GaussianIncrements::for_path`](crate::GaussianIncrements::for_path)`(seed, index_p, l)`,
/// whatever W is: the lanes use rand_distr's own ziggurat abscissae (read from its
/// `StandardNormal` sampler), and a lane the fast path does not accept (1.5% of draws) is
/// drawn again by rand_distr's `StandardNormal` from that lane's state before the draw.
///
/// ```
/// use sdae_model::{EnsembleIncrements, GaussianIncrements, IncrementSource};
/// let indices: Vec<u64> = (0..10).collect();
/// let mut lanes = EnsembleIncrements::for_paths(7, &indices, 3);
/// let stride = lanes.stride();
/// // Five steps of every path: step k, coordinate j, path p at dw[(k * 3 + j) * stride + p].
/// let mut dw = vec![0.0; 5 * 3 * stride];
/// assert_eq!(lanes.fill(1e-2, &mut dw)?, 5);
/// let mut one_path = GaussianIncrements::for_path(7, 4, 3);
/// let mut step = [0.0; 3];
/// for k in 0..5 {
///     one_path.next_increment(1e-2, &mut step);
///     for j in 0..3 {
///         assert_eq!(dw[(k * 3 + j) * stride + 4], step[j]);
///     }
/// }
/// # Ok::<(), sdae_model::ModelError>(())
/// ```
#[derive(Debug, Clone)]
pub struct EnsembleIncrements {
    /// Word i of the streams' states, one entry per lane (the stride's padding lanes repeat
    /// path 0's stream; their numbers are drawn and not used).
    words: [Vec<u64>; 4],
    paths: usize,
    dim: usize,
    width: LaneWidth,
}

impl EnsembleIncrements {
    /// The increments of dimension `dim` of the paths `indices` of a study with seed `seed`:
    /// path p draws from [`path_rng`]`(seed, indices[p])`.
    pub fn for_paths(seed: u64, indices: &[u64], dim: usize) -> Self {
        let streams: Vec<_> = indices.iter().map(|&i| path_rng(seed, i)).collect();
        Self::from_streams(&streams, dim)
    }

    /// The increments of dimension `dim` of one path per stream, each continuing its stream
    /// (the streams are copied, not advanced).
    pub fn from_streams(streams: &[Xoshiro256PlusPlus], dim: usize) -> Self {
        let stride = lane_stride(streams.len());
        let mut words: [Vec<u64>; 4] = std::array::from_fn(|_| Vec::with_capacity(stride));
        // No lanes without streams; padding lanes copy the first stream.
        for lane in 0..stride {
            let state = streams.get(lane).unwrap_or(&streams[0]).state();
            for (i, word) in words.iter_mut().enumerate() {
                let bytes = state[8 * i..8 * i + 8].try_into().expect("8 bytes");
                word.push(u64::from_le_bytes(bytes));
            }
        }
        Self {
            words,
            paths: streams.len(),
            dim,
            width: LaneWidth::Best,
        }
    }

    /// The number P of paths.
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// The dimension l of each path's increments.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The stride of the layout, [`lane_stride`]`(P)`.
    pub fn stride(&self) -> usize {
        self.words[0].len()
    }

    /// Draws with the instruction set of `width` (default [`LaneWidth::Best`]): W = 8 or 4
    /// paths at once where it has 8 or 4 lanes, else one at a time. The numbers do not depend
    /// on it.
    pub fn with_width(mut self, width: LaneWidth) -> Self {
        self.width = width;
        self
    }

    /// Path p's stream as it stands (None if p >= P): continuing it gives the numbers path p
    /// would draw next.
    pub fn stream(&self, p: usize) -> Option<Xoshiro256PlusPlus> {
        (p < self.paths).then(|| stream_of(&self.words, p))
    }

    /// Fills `dw` with the next increments over steps of size h of every path: step k,
    /// coordinate j < l, path p at `dw[(k * l + j) * stride + p]`, as many steps as `dw`
    /// holds. Returns that number of steps. The stride's padding lanes (p >= P) repeat path
    /// 0's numbers: an ensemble of P' paths needs increments drawn for exactly P' paths, since
    /// for P < P' <= stride its paths P.. would silently share path 0's noise
    /// ([`PathEnsemble::step_drawing`](crate::PathEnsemble::step_drawing) checks this). Fails if h is not finite and > 0, or if `dw`'s
    /// length is not a multiple of l * stride (nothing is drawn then).
    pub fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, ModelError> {
        check_step_size(h)?;
        let Some(row) = self.dim.checked_mul(self.stride()) else {
            return Err(ModelError::InvalidSetting {
                name: "dim * stride",
                value: self.dim as f64,
                reason: "the increments of one step overflow the address space",
            });
        };
        if row == 0 || dw.is_empty() {
            return Ok(0);
        }
        if !dw.len().is_multiple_of(row) {
            return Err(ModelError::DimensionMismatch {
                what: "increments buffer (a multiple of dim * stride)",
                expected: dw.len().div_ceil(row) * row,
                found: dw.len(),
            });
        }
        self.width.dispatch(FillAll {
            increments: self,
            scale: h.sqrt(),
            dw,
        });
        Ok(dw.len() / row)
    }
}

/// The 64-bit lane operations of xoshiro256++ that pulp's generic [`Simd`] does not have.
trait WordLanes: Simd {
    fn shr12(self, a: Self::u64s) -> Self::u64s;
    fn shl17(self, a: Self::u64s) -> Self::u64s;
    fn rotl23(self, a: Self::u64s) -> Self::u64s;
    fn rotl45(self, a: Self::u64s) -> Self::u64s;
}

impl WordLanes for pulp::Scalar {
    #[inline(always)]
    fn shr12(self, a: u64) -> u64 {
        a >> 12
    }
    #[inline(always)]
    fn shl17(self, a: u64) -> u64 {
        a << 17
    }
    #[inline(always)]
    fn rotl23(self, a: u64) -> u64 {
        a.rotate_left(23)
    }
    #[inline(always)]
    fn rotl45(self, a: u64) -> u64 {
        a.rotate_left(45)
    }
}

/// The portable widths (4 and 8 u64 in turn, where the processor lacks AVX2 or AVX-512): the
/// same operations lane by lane.
macro_rules! portable_word_lanes {
    ($simd:ty) => {
        impl WordLanes for $simd {
            #[inline(always)]
            fn shr12(self, a: Self::u64s) -> Self::u64s {
                each_word(a, |x| x >> 12)
            }
            #[inline(always)]
            fn shl17(self, a: Self::u64s) -> Self::u64s {
                each_word(a, |x| x << 17)
            }
            #[inline(always)]
            fn rotl23(self, a: Self::u64s) -> Self::u64s {
                each_word(a, |x| x.rotate_left(23))
            }
            #[inline(always)]
            fn rotl45(self, a: Self::u64s) -> Self::u64s {
                each_word(a, |x| x.rotate_left(45))
            }
        }
    };
}

portable_word_lanes!(pulp::Scalar256b);
portable_word_lanes!(pulp::Scalar512b);

/// `op` applied to each u64 of a vector.
#[inline(always)]
fn each_word<V: bytemuck::Pod>(mut a: V, op: impl Fn(u64) -> u64) -> V {
    for x in bytemuck::cast_slice_mut::<V, u64>(std::slice::from_mut(&mut a)) {
        *x = op(*x);
    }
    a
}

#[cfg(target_arch = "x86_64")]
impl WordLanes for pulp::x86::V3 {
    #[inline(always)]
    fn shr12(self, a: Self::u64s) -> Self::u64s {
        self.shr_const_u64x4::<12>(a)
    }
    #[inline(always)]
    fn shl17(self, a: Self::u64s) -> Self::u64s {
        self.shl_const_u64x4::<17>(a)
    }
    #[inline(always)]
    fn rotl23(self, a: Self::u64s) -> Self::u64s {
        self.or_u64x4(self.shl_const_u64x4::<23>(a), self.shr_const_u64x4::<41>(a))
    }
    #[inline(always)]
    fn rotl45(self, a: Self::u64s) -> Self::u64s {
        self.or_u64x4(self.shl_const_u64x4::<45>(a), self.shr_const_u64x4::<19>(a))
    }
}

#[cfg(target_arch = "x86_64")]
impl WordLanes for pulp::x86::V4 {
    #[inline(always)]
    fn shr12(self, a: Self::u64s) -> Self::u64s {
        self.shr_const_u64x8::<12>(a)
    }
    #[inline(always)]
    fn shl17(self, a: Self::u64s) -> Self::u64s {
        self.shl_const_u64x8::<17>(a)
    }
    #[inline(always)]
    fn rotl23(self, a: Self::u64s) -> Self::u64s {
        self.or_u64x8(self.shl_const_u64x8::<23>(a), self.shr_const_u64x8::<41>(a))
    }
    #[inline(always)]
    fn rotl45(self, a: Self::u64s) -> Self::u64s {
        self.or_u64x8(self.shl_const_u64x8::<45>(a), self.shr_const_u64x8::<19>(a))
    }
}

/// One [`EnsembleIncrements::fill`], run with the instruction set of its width.
struct FillAll<'a> {
    increments: &'a mut EnsembleIncrements,
    scale: f64,
    dw: &'a mut [f64],
}

impl pulp::WithSimd for FillAll<'_> {
    type Output = ();
    /// `with_simd` receives pulp's generic instruction set; the generator needs the concrete
    /// one's 64-bit shifts, so its width picks it again: AVX-512 or AVX2 for 8 or 4 lanes
    /// where the processor has them, the portable 8 or 4 lanes otherwise, one lane for any
    /// other width.
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        match S::F64_LANES {
            8 => {
                #[cfg(target_arch = "x86_64")]
                if let Some(simd) = pulp::x86::V4::try_new() {
                    return simd.vectorize(move || fill_lanes(simd, self));
                }
                fill_lanes(pulp::Scalar512b, self)
            }
            4 => {
                #[cfg(target_arch = "x86_64")]
                if let Some(simd) = pulp::x86::V3::try_new() {
                    return simd.vectorize(move || fill_lanes(simd, self));
                }
                fill_lanes(pulp::Scalar256b, self)
            }
            _ => fill_lanes(pulp::Scalar, self),
        }
    }
}

/// Every lane group of `fill`, a tile of steps at a time: W streams' states stay in registers
/// across the group's draws of a tile.
#[inline(always)]
fn fill_lanes<S: WordLanes>(simd: S, fill: FillAll<'_>) {
    let FillAll {
        increments,
        scale,
        dw,
    } = fill;
    let table = ZigguratTable::get();
    let (dim, w) = (increments.dim, S::F64_LANES);
    let stride = increments.words[0].len();
    // `fill` checked that dim * stride does not overflow and that dw holds whole steps.
    let row_len = dim * stride;
    debug_assert!(w <= LANE_BLOCK && stride.is_multiple_of(w));
    let words = &mut increments.words;
    for tile in dw.chunks_mut(row_len * TILE_ROWS.min(dw.len() / row_len)) {
        for at in (0..stride).step_by(w) {
            let mut state: [S::u64s; 4] = std::array::from_fn(|i| load_words(&words[i][at..]));
            for row in tile.chunks_exact_mut(row_len) {
                for j in 0..dim {
                    let out = &mut row[j * stride + at..j * stride + at + w];
                    draw(simd, &mut state, table, scale, out);
                }
            }
            for (i, s) in state.iter().enumerate() {
                store_words::<S>(*s, &mut words[i][at..]);
            }
        }
    }
}

/// Steps filled lane group by lane group before going on: their rows stay in cache while every
/// group writes its lanes.
const TILE_ROWS: usize = 32;

/// out[lane] = scale z for one standard normal z per lane (rand_distr's ziggurat, symmetric,
/// 256 layers): the next word b of each lane's xoshiro256++, layer i = b & 0xff, u in [-1, 1)
/// from b's upper 52 bits, z = u x_i if |u x_i| < x_{i+1}; a lane that is not accepted is
/// drawn again by rand_distr from its state before the draw. The arithmetic runs on all lanes
/// at once; only x_i and x_{i+1} are read lane by lane.
#[inline(always)]
fn draw<S: WordLanes>(
    simd: S,
    state: &mut [S::u64s; 4],
    table: &ZigguratTable,
    scale: f64,
    out: &mut [f64],
) {
    let before = *state;
    let bits = next_words(simd, state);
    let (x, accepted) = fast_path(simd, table, bits);
    let z = simd.mul_f64s(simd.splat_f64s(scale), x);
    store_f64s::<S>(z, out);
    if simd.first_true_m64s(simd.not_m64s(accepted)) < S::F64_LANES {
        // Only here do the states leave the registers: each rejected lane is drawn again from
        // its state before the draw, and the state rand_distr leaves is blended into its lane.
        let mut lanes_before = [[0u64; LANE_BLOCK]; 4];
        for (words, b) in lanes_before.iter_mut().zip(&before) {
            store_words::<S>(*b, words);
        }
        // The rejected lanes as bits (lane k is 2^k), visited without a branch per lane
        // (which the processor mispredicts).
        let lane_bits: S::f64s = load_words(bytemuck::cast_slice(&LANE_BITS));
        let zero = simd.splat_f64s(0.0);
        let rejected = simd.reduce_sum_f64s(simd.select_f64s(accepted, zero, lane_bits));
        let mut pending = rejected as u32;
        while pending != 0 {
            let lane = pending.trailing_zeros() as usize;
            pending &= pending - 1;
            let words = [
                lanes_before[0][lane],
                lanes_before[1][lane],
                lanes_before[2][lane],
                lanes_before[3][lane],
            ];
            let (z, after) = redraw(words);
            out[lane] = scale * z;
            let this = simd.mask_between_m64s(lane as u64, lane as u64 + 1).mask();
            for (s, word) in state.iter_mut().zip(after) {
                *s = simd.select_u64s(this, simd.splat_u64s(word), *s);
            }
        }
    }
}

/// 2^k for lane k < LANE_BLOCK.
const LANE_BITS: [f64; LANE_BLOCK] = {
    let mut bits = [0.0; LANE_BLOCK];
    let mut i = 0;
    while i < LANE_BLOCK {
        bits[i] = (1u32 << i) as f64;
        i += 1;
    }
    bits
};

/// The ziggurat's fast path for the words b of every lane: (u x_i, whether |u x_i| < x_{i+1}),
/// with layer i = b & 0xff and u in [-1, 1) from b's upper 52 bits.
#[inline(always)]
fn fast_path<S: WordLanes>(simd: S, table: &ZigguratTable, bits: S::u64s) -> (S::f64s, S::m64s) {
    let mantissa = simd.or_u64s(simd.shr12(bits), simd.splat_u64s(U_EXPONENT));
    let u = simd.sub_f64s(bytemuck::cast(mantissa), simd.splat_f64s(3.0));
    // Only the two table entries are read lane by lane (gathers measured slower).
    let mut lane_bits = [0u64; LANE_BLOCK];
    store_words::<S>(bits, &mut lane_bits);
    let (mut x_layer, mut x_above) = ([0.0; LANE_BLOCK], [0.0; LANE_BLOCK]);
    for ((b, lo), hi) in lane_bits.iter().zip(&mut x_layer).zip(&mut x_above) {
        let layer = (b & 0xff) as usize;
        (*lo, *hi) = (table.x[layer], table.x[layer + 1]);
    }
    let x = simd.mul_f64s(u, load_words(bytemuck::cast_slice(&x_layer)));
    let above = load_words(bytemuck::cast_slice(&x_above));
    (x, simd.less_than_f64s(simd.abs_f64s(x), above))
}

/// A draw the fast path did not accept, drawn again by rand_distr's `StandardNormal` from the
/// lane's xoshiro256++ state before the draw (`before`): the standard normal and the state
/// rand_distr leaves.
#[cold]
#[inline(never)]
fn redraw(before: [u64; 4]) -> (f64, [u64; 4]) {
    let mut rng = LaneRng(before);
    let z: f64 = rng.sample(StandardNormal);
    (z, rng.0)
}

/// One lane's xoshiro256++ in scalar form, for rand_distr's sampler.
struct LaneRng([u64; 4]);

impl TryRng for LaneRng {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((self.try_next_u64()? >> 32) as u32)
    }
    #[inline]
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        Ok(next_words(pulp::Scalar, &mut self.0))
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        fill_bytes_from(self, dst)
    }
}

/// `dst` from consecutive words of `rng`, little-endian.
fn fill_bytes_from<R: TryRng<Error = Infallible>>(
    rng: &mut R,
    dst: &mut [u8],
) -> Result<(), Infallible> {
    for chunk in dst.chunks_mut(8) {
        let word = rng.try_next_u64()?.to_le_bytes();
        chunk.copy_from_slice(&word[..chunk.len()]);
    }
    Ok(())
}

/// xoshiro256++: the next word of each lane and the state after it.
#[inline(always)]
fn next_words<S: WordLanes>(simd: S, s: &mut [S::u64s; 4]) -> S::u64s {
    let out = simd.add_u64s(simd.rotl23(simd.add_u64s(s[0], s[3])), s[0]);
    let t = simd.shl17(s[1]);
    s[2] = simd.xor_u64s(s[2], s[0]);
    s[3] = simd.xor_u64s(s[3], s[1]);
    s[1] = simd.xor_u64s(s[1], s[2]);
    s[0] = simd.xor_u64s(s[0], s[3]);
    s[2] = simd.xor_u64s(s[2], t);
    s[3] = simd.rotl45(s[3]);
    out
}

/// Lane `lane`'s stream from the four state words of every lane.
fn stream_of(words: &[Vec<u64>; 4], lane: usize) -> Xoshiro256PlusPlus {
    let mut seed = [0u8; 32];
    for (i, word) in words.iter().enumerate() {
        seed[8 * i..8 * i + 8].copy_from_slice(&word[lane].to_le_bytes());
    }
    Xoshiro256PlusPlus::from_seed(seed)
}

/// The exponent bits that make (b >> 12) a float in [2, 4) (rand's `into_float_with_exponent(1)`).
const U_EXPONENT: u64 = (1023 + 1) << 52;

#[inline(always)]
fn load_words<V: bytemuck::Pod>(from: &[u64]) -> V {
    let n = size_of::<V>() / 8;
    bytemuck::pod_read_unaligned(bytemuck::cast_slice(&from[..n]))
}

#[inline(always)]
fn store_f64s<S: Simd>(v: S::f64s, to: &mut [f64]) {
    let values: &[f64] = bytemuck::cast_slice(std::slice::from_ref(&v));
    to[..values.len()].copy_from_slice(values);
}

#[inline(always)]
fn store_words<S: Simd>(v: S::u64s, to: &mut [u64]) {
    let values: &[u64] = bytemuck::cast_slice(std::slice::from_ref(&v));
    to[..values.len()].copy_from_slice(values);
}

/// rand_distr's ziggurat abscissae x_0 > x_1 > ... > x_255 > x_256 = 0 of `StandardNormal`.
#[derive(Debug)]
struct ZigguratTable {
    x: [f64; 257],
}

impl ZigguratTable {
    /// The table, read once from rand_distr's sampler: the word whose layer is i and whose
    /// u is 2^-51 makes it return 2^-51 x_i exactly (at once for i < 255, where
    /// 2^-51 x_i < x_{i+1}; through the density test with a uniform just below 1 for
    /// i = 255).
    fn get() -> &'static Self {
        static TABLE: OnceLock<ZigguratTable> = OnceLock::new();
        TABLE.get_or_init(|| {
            let mut x = [0.0; 257];
            for (layer, x) in x.iter_mut().enumerate().take(256) {
                let mut words = Words::new(probe_word(layer));
                let value: f64 = words.sample(StandardNormal);
                *x = value * (1u64 << 51) as f64;
            }
            Self { x }
        })
    }
}

/// The word of layer `layer` with u = 2^-51: its upper 52 bits 2^51 + 1, as the mantissa of a
/// float with exponent 1, give 3 + 2^-51, and u is that minus 3.
fn probe_word(layer: usize) -> u64 {
    (((1u64 << 51) | 1) << 12) | layer as u64
}

/// A generator that returns a given word, then u64::MAX (a uniform just below 1 for the
/// density test), then words that the fast path accepts (layer 1, u = 2^-51), so that every
/// draw from it ends.
struct Words {
    words: [u64; 3],
    next: usize,
}

impl Words {
    fn new(first: u64) -> Self {
        Self {
            words: [first, u64::MAX, probe_word(1)],
            next: 0,
        }
    }
}

impl TryRng for Words {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((self.try_next_u64()? >> 32) as u32)
    }
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        let word = self.words[self.next.min(self.words.len() - 1)];
        self.next += 1;
        Ok(word)
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        fill_bytes_from(self, dst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::increments::{GaussianIncrements, IncrementSource};

    #[test]
    fn the_table_is_the_standard_normal_ziggurat() {
        let x = &ZigguratTable::get().x;
        // x_1 is the tail's start r = 3.654152885361008796 of the 256-layer normal ziggurat.
        assert_eq!(x[1], 3.654_152_885_361_009);
        assert!(x.windows(2).all(|w| w[0] > w[1]), "strictly decreasing");
        assert_eq!(x[256], 0.0);
    }

    #[test]
    fn the_fast_path_accepts_exactly_what_rand_distr_accepts_from_one_word() {
        let table = ZigguratTable::get();
        let mut mixer = path_rng(5, 5);
        let mut fractions = vec![0, 1, 1 << 51, (1 << 51) + 1, (1 << 52) - 1, 1 << 50];
        fractions.extend((0..30).map(|_| rand::Rng::next_u64(&mut mixer) >> 12));
        for layer in 0..256u64 {
            for &fraction in &fractions {
                let word = (fraction << 12) | layer;
                let (x, accepted) = fast_path(pulp::Scalar, table, word);
                let mut words = Words::new(word);
                let z: f64 = words.sample(StandardNormal);
                // rand_distr returns after one word exactly when its fast path accepts.
                assert_eq!(
                    accepted,
                    words.next == 1,
                    "layer {layer}, fraction {fraction}"
                );
                if accepted {
                    assert_eq!(
                        z.to_bits(),
                        x.to_bits(),
                        "layer {layer}, fraction {fraction}"
                    );
                }
            }
        }
    }

    /// Paths 0..p of seed 11 drawn `steps` times with dimension `dim` at `width`, against
    /// each path's scalar stream.
    fn check_against_scalar(width: LaneWidth, paths: usize, dim: usize, steps: usize) {
        let indices: Vec<u64> = (0..paths as u64).map(|p| 3 * p + 1).collect();
        let mut lanes = EnsembleIncrements::for_paths(11, &indices, dim).with_width(width);
        let stride = lanes.stride();
        let mut dw = vec![0.0; steps * dim * stride];
        // In two fills, so the states carry over between calls.
        let half = (steps / 2) * dim * stride;
        assert_eq!(lanes.fill(0.25, &mut dw[..half]).unwrap(), steps / 2);
        assert_eq!(
            lanes.fill(0.25, &mut dw[half..]).unwrap(),
            steps - steps / 2
        );
        for (p, &index) in indices.iter().enumerate() {
            let mut scalar = GaussianIncrements::for_path(11, index, dim);
            let mut one = vec![0.0; dim];
            for k in 0..steps {
                scalar.next_increment(0.25, &mut one);
                for (j, value) in one.iter().enumerate() {
                    let got = dw[(k * dim + j) * stride + p];
                    assert_eq!(
                        got.to_bits(),
                        value.to_bits(),
                        "{width:?} path {p} step {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn every_width_draws_each_paths_scalar_stream() {
        // 20 000 numbers per path: ~300 rejected draws each, tail draws (layer 0) included.
        for width in [
            LaneWidth::One,
            LaneWidth::Four,
            LaneWidth::Eight,
            LaneWidth::Best,
        ] {
            check_against_scalar(width, 13, 2, 10_000);
        }
    }

    #[test]
    fn a_stream_continues_where_the_lanes_stopped() {
        let mut lanes = EnsembleIncrements::for_paths(3, &[5, 6], 1);
        let mut dw = vec![0.0; 100 * lanes.stride()];
        lanes.fill(1.0, &mut dw).unwrap();
        let mut scalar = GaussianIncrements::for_path(3, 6, 1);
        let mut one = [0.0];
        for _ in 0..101 {
            scalar.next_increment(1.0, &mut one);
        }
        let mut continued = GaussianIncrements::new(lanes.stream(1).unwrap(), 1);
        let mut next = [0.0];
        continued.next_increment(1.0, &mut next);
        assert_eq!(next, one);
        assert!(lanes.stream(2).is_none());
    }

    #[test]
    fn bad_buffers_and_step_sizes_are_errors() {
        let mut lanes = EnsembleIncrements::for_paths(1, &[0, 1, 2], 2);
        let mut short = vec![0.0; 2 * lanes.stride() + 1];
        assert!(matches!(
            lanes.fill(1.0, &mut short),
            Err(ModelError::DimensionMismatch { found, .. }) if found == 2 * 8 + 1
        ));
        let mut dw = vec![0.0; 2 * lanes.stride()];
        for h in [0.0, -1.0, f64::NAN] {
            assert!(matches!(
                lanes.fill(h, &mut dw),
                Err(ModelError::InvalidSetting { name: "h", .. })
            ));
        }
        // A step too large for the address space.
        assert!(matches!(
            EnsembleIncrements::for_paths(1, &[0], usize::MAX / 4).fill(1.0, &mut dw),
            Err(ModelError::InvalidSetting {
                name: "dim * stride",
                ..
            })
        ));
        // Nothing to draw without paths, dimensions or room.
        assert_eq!(lanes.fill(1.0, &mut []), Ok(0));
        assert_eq!(
            EnsembleIncrements::for_paths(1, &[], 2).fill(1.0, &mut []),
            Ok(0)
        );
        assert_eq!(
            EnsembleIncrements::for_paths(1, &[4], 0).fill(1.0, &mut []),
            Ok(0)
        );
    }
}
