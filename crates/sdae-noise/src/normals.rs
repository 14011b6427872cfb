//! Gaussian increments of many paths, drawn W paths at once ([`EnsembleIncrements`]).

use std::convert::Infallible;

use pulp::{Simd, bytemuck};
use rand::{SeedableRng, TryRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use sdae_lanes::{LANE_BLOCK, LaneWidth, lane_stride};

use crate::error::{NoiseError, check_step_size, whole_rows};
use crate::path_streams::PathStreams;
use crate::ziggurat::{LAYER_MASK, U_EXPONENT, X, finish_draw};

/// The Gaussian increments sqrt(h) N(0, I_l) of P paths, each path from its own
/// [`PathStreams`], drawn W paths at once into the ensembles' layout ([`lane_stride`]).
///
/// It keeps the streams in structure-of-arrays layout and draws one standard normal for W
/// paths per pass: the main streams' xoshiro256++ additions, shifts and xors run in the lanes
/// of a SIMD register (W = 4 with AVX2, 8 with AVX-512, 1 otherwise; [`LaneWidth`]), and so
/// does the ziggurat's fast path (2048 layers; [`PathStreams`]). A lane the fast path rejects
/// (0.23% of draws) does not hold the others up: the main streams go on one word per number,
/// the draw's word is put aside without a branch, and the rejected draws are finished later,
/// in order, from each lane's side stream. Path p's numbers are therefore bit for bit those of
/// [`GaussianIncrements::for_path`](crate::GaussianIncrements::for_path)`(seed, index_p, l)`,
/// whatever W is.
///
/// ```
/// use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
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
/// # Ok::<(), sdae_noise::NoiseError>(())
/// ```
#[derive(Debug, Clone)]
pub struct EnsembleIncrements {
    /// Word i of the main streams' states, one entry per lane (the stride's padding lanes
    /// repeat path 0's streams; their numbers are drawn and not used).
    words: [Vec<u64>; 4],
    /// Word i of the side streams' states, laid out as `words`.
    side: [Vec<u64>; 4],
    paths: usize,
    dim: usize,
    width: LaneWidth,
}

impl EnsembleIncrements {
    /// The increments of dimension `dim` of the paths `indices` of a study with seed `seed`:
    /// path p draws from [`PathStreams::for_path`]`(seed, indices[p])`.
    pub fn for_paths(seed: u64, indices: &[u64], dim: usize) -> Self {
        let streams: Vec<_> = indices
            .iter()
            .map(|&i| PathStreams::for_path(seed, i))
            .collect();
        Self::from_streams(&streams, dim)
    }

    /// The increments of dimension `dim` of one path per element of `streams`, each
    /// continuing its streams (they are copied, not advanced).
    pub fn from_streams(streams: &[PathStreams], dim: usize) -> Self {
        let stride = lane_stride(streams.len());
        let mut words: [Vec<u64>; 4] = std::array::from_fn(|_| Vec::with_capacity(stride));
        let mut side = words.clone();
        // No lanes without streams; padding lanes copy the first path's.
        for lane in 0..stride {
            let path = streams.get(lane).unwrap_or(&streams[0]);
            push_state(&mut words, path.main());
            push_state(&mut side, path.side());
        }
        Self {
            words,
            side,
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

    /// Path p's streams as they stand (None if p >= P): continuing them gives the numbers
    /// path p would draw next.
    pub fn stream(&self, p: usize) -> Option<PathStreams> {
        (p < self.paths)
            .then(|| PathStreams::from_parts(stream_of(&self.words, p), stream_of(&self.side, p)))
    }

    /// Fills `dw` with the next increments over steps of size h of every path: step k,
    /// coordinate j < l, path p at `dw[(k * l + j) * stride + p]`, as many steps as `dw`
    /// holds. Returns that number of steps. The stride's padding lanes (p >= P) repeat path
    /// 0's numbers: an ensemble of P' paths needs increments drawn for exactly P' paths, since
    /// for P < P' <= stride its paths P.. would silently share path 0's noise
    /// (`sdae_model::PathEnsemble::step_drawing` checks this).
    /// Fails if h is not finite and > 0, or if `dw`'s length is not a multiple of l * stride
    /// (nothing is drawn then).
    pub fn fill(&mut self, h: f64, dw: &mut [f64]) -> Result<usize, NoiseError> {
        check_step_size(h)?;
        let Some(row) = self.dim.checked_mul(self.stride()) else {
            return Err(NoiseError::InvalidSetting {
                name: "dim * stride",
                value: self.dim as f64,
                reason: "the increments of one step overflow the address space",
            });
        };
        let Some(steps) = whole_rows(dw.len(), row)? else {
            return Ok(0);
        };
        self.width.dispatch(FillAll {
            increments: self,
            scale: h.sqrt(),
            dw,
        });
        Ok(steps)
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

/// [`WordLanes`] for an x86 instruction set from its shifts and or of 64-bit words.
macro_rules! x86_word_lanes {
    ($simd:ty, $shr:ident, $shl:ident, $or:ident) => {
        #[cfg(target_arch = "x86_64")]
        impl WordLanes for $simd {
            #[inline(always)]
            fn shr12(self, a: Self::u64s) -> Self::u64s {
                self.$shr::<12>(a)
            }
            #[inline(always)]
            fn shl17(self, a: Self::u64s) -> Self::u64s {
                self.$shl::<17>(a)
            }
            #[inline(always)]
            fn rotl23(self, a: Self::u64s) -> Self::u64s {
                self.$or(self.$shl::<23>(a), self.$shr::<41>(a))
            }
            #[inline(always)]
            fn rotl45(self, a: Self::u64s) -> Self::u64s {
                self.$or(self.$shl::<45>(a), self.$shr::<19>(a))
            }
        }
    };
}

x86_word_lanes!(pulp::x86::V3, shr_const_u64x4, shl_const_u64x4, or_u64x4);
x86_word_lanes!(pulp::x86::V4, shr_const_u64x8, shl_const_u64x8, or_u64x8);

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

/// Every lane group of `fill`, a tile of steps at a time: W main streams' states stay in
/// registers across the group's draws of a tile; the draws their fast path rejects are put
/// aside ([`Rejected`]) and finished from the side streams before the group's states are
/// stored.
#[inline(always)]
fn fill_lanes<S: WordLanes>(simd: S, fill: FillAll<'_>) {
    let FillAll {
        increments,
        scale,
        dw,
    } = fill;
    let (dim, w) = (increments.dim, S::F64_LANES);
    let stride = increments.words[0].len();
    // `fill` checked that dim * stride does not overflow and that dw holds whole steps.
    let row_len = dim * stride;
    debug_assert!(w <= LANE_BLOCK && stride.is_multiple_of(w));
    let (words, side) = (&mut increments.words, &mut increments.side);
    let mut rejected = Rejected::<S>::new(simd);
    let mut pending = 0;
    for tile in dw.chunks_mut(row_len * TILE_ROWS.min(dw.len() / row_len)) {
        let rows = tile.len() / row_len;
        for at in (0..stride).step_by(w) {
            let mut streams = SideStreams {
                states: &mut *side,
                at,
            };
            let mut state: [S::u64s; 4] = std::array::from_fn(|i| load_words(&words[i][at..]));
            for row in 0..rows {
                for j in 0..dim {
                    let offset = row * row_len + j * stride + at;
                    let bits = next_words(simd, &mut state);
                    let (x, accepted) = fast_path(simd, bits);
                    let z = simd.mul_f64s(simd.splat_f64s(scale), x);
                    store_f64s::<S>(z, &mut tile[offset..]);
                    // Kept in a register: a count in memory would chain the draws.
                    pending = rejected.put(
                        simd,
                        pending,
                        Draw {
                            offset,
                            bits,
                            accepted,
                        },
                    );
                    if pending == REJECTED_CAPACITY {
                        rejected.finish(simd, pending, Scaled { scale, out: tile }, &mut streams);
                        pending = 0;
                    }
                }
            }
            rejected.finish(simd, pending, Scaled { scale, out: tile }, &mut streams);
            pending = 0;
            for (i, s) in state.iter().enumerate() {
                store_words::<S>(*s, &mut words[i][at..]);
            }
        }
    }
}

/// Steps filled lane group by lane group before going on: their rows stay in cache while every
/// group writes its lanes.
const TILE_ROWS: usize = 32;

/// A draw of a lane group: where it was written, its words and the lanes the fast path
/// accepted.
struct Draw<S: Simd> {
    offset: usize,
    bits: S::u64s,
    accepted: S::m64s,
}

/// Where standard normals go, scaled: out[i] = scale z.
struct Scaled<'a> {
    scale: f64,
    out: &'a mut [f64],
}

/// The side streams of a lane group: the states `states[i][at + lane]` of its lanes.
struct SideStreams<'a> {
    states: &'a mut [Vec<u64>; 4],
    at: usize,
}

/// How many draws with a rejected lane are put aside before they are finished.
const REJECTED_CAPACITY: usize = 64;

/// A lane group's draws with a lane the fast path rejected, in the order drawn: where each
/// was written, its words and which lanes it accepted (the count is the caller's).
///
/// Every draw is written into the next entry and the count moves on only if a lane was
/// rejected (1.8% of draws of 8 lanes), so drawing takes no branch that depends on the
/// numbers: such a branch, mispredicted at each rejection, and the rejected lane's state
/// blended back before the next draw, cost more than half of the time drawing took.
struct Rejected<S: Simd> {
    offsets: [usize; REJECTED_CAPACITY],
    bits: [S::u64s; REJECTED_CAPACITY],
    accepted: [S::m64s; REJECTED_CAPACITY],
}

impl<S: WordLanes> Rejected<S> {
    #[inline(always)]
    fn new(simd: S) -> Self {
        Self {
            offsets: [0; REJECTED_CAPACITY],
            bits: [simd.splat_u64s(0); REJECTED_CAPACITY],
            accepted: [simd.mask_between_m64s(0, 0).mask(); REJECTED_CAPACITY],
        }
    }

    /// Writes the draw at `offset` (its words and accepted lanes) into entry `len` (<
    /// [`REJECTED_CAPACITY`]) and returns the new count: `len + 1` if a lane was rejected,
    /// else `len`.
    #[inline(always)]
    fn put(&mut self, simd: S, len: usize, draw: Draw<S>) -> usize {
        let Draw {
            offset,
            bits,
            accepted,
        } = draw;
        self.offsets[len] = offset;
        self.bits[len] = bits;
        self.accepted[len] = accepted;
        // pulp's first_true is below the width exactly when some lane is true.
        let any_rejected = simd.first_true_m64s(simd.not_m64s(accepted)) < S::F64_LANES;
        len + any_rejected as usize
    }

    /// Finishes the first `len` draws put aside, in the order drawn: each rejected lane's
    /// number is the ziggurat's from its word and then its side stream's words ([`finish_draw`])
    /// (tile[offset + lane] = scale z). The lane group's side streams are the states
    /// `side[i][at + lane]`, read and written only for a rejected lane.
    #[inline(always)]
    fn finish(&self, simd: S, len: usize, scaled: Scaled<'_>, streams: &mut SideStreams<'_>) {
        let (scale, tile) = (scaled.scale, scaled.out);
        let lane_bits: S::f64s = load_words(bytemuck::cast_slice(&LANE_BITS));
        let zero = simd.splat_f64s(0.0);
        for e in 0..len {
            // The rejected lanes as bits (lane k is 2^k).
            let lanes = simd.reduce_sum_f64s(simd.select_f64s(self.accepted[e], zero, lane_bits));
            let mut words = [0u64; LANE_BLOCK];
            store_words::<S>(self.bits[e], &mut words);
            let out = &mut tile[self.offsets[e]..];
            finish_lanes(lanes as u32, &words, streams, Scaled { scale, out });
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

/// For each lane in `lanes` (lane k is bit k): out[lane] = scale z, z the standard normal
/// whose first ziggurat word is words[lane], finished from that lane's side stream (state
/// `side[i][at + lane]`, advanced in place; [`finish_draw`]).
#[inline(never)]
fn finish_lanes(
    mut lanes: u32, words: &[u64; LANE_BLOCK], streams: &mut SideStreams<'_>, scaled: Scaled<'_>,
) {
    let SideStreams { states: side, at } = streams;
    let at = *at;
    let Scaled { scale, out } = scaled;
    while lanes != 0 {
        let lane = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        let mut rng = LaneRng(std::array::from_fn(|i| side[i][at + lane]));
        out[lane] = scale * finish_draw(words[lane], &mut rng);
        for (words, word) in side.iter_mut().zip(rng.0) {
            words[at + lane] = word;
        }
    }
}

/// The ziggurat's fast path for the words b of every lane: (u x_i, whether |u x_i| < x_{i+1}),
/// with layer i = b mod 2048 and u in [-1, 1) from b's upper 52 bits (as
/// [`crate::ziggurat::fast_path`] for one word).
#[inline(always)]
fn fast_path<S: WordLanes>(simd: S, bits: S::u64s) -> (S::f64s, S::m64s) {
    let mantissa = simd.or_u64s(simd.shr12(bits), simd.splat_u64s(U_EXPONENT));
    let u = simd.sub_f64s(bytemuck::cast(mantissa), simd.splat_f64s(3.0));
    // Only the two table entries are read lane by lane (gathers measured slower).
    let mut lane_bits = [0u64; LANE_BLOCK];
    store_words::<S>(bits, &mut lane_bits);
    let (mut x_layer, mut x_above) = ([0.0; LANE_BLOCK], [0.0; LANE_BLOCK]);
    for ((b, lo), hi) in lane_bits.iter().zip(&mut x_layer).zip(&mut x_above) {
        let layer = (b & LAYER_MASK) as usize;
        (*lo, *hi) = (X[layer], X[layer + 1]);
    }
    let x = simd.mul_f64s(u, load_words(bytemuck::cast_slice(&x_layer)));
    let above = load_words(bytemuck::cast_slice(&x_above));
    (x, simd.less_than_f64s(simd.abs_f64s(x), above))
}

/// One lane's xoshiro256++ in scalar form (a side stream).
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
    rng: &mut R, dst: &mut [u8],
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

/// Appends the four state words of `stream` to `words`, one to each.
fn push_state(words: &mut [Vec<u64>; 4], stream: &Xoshiro256PlusPlus) {
    let state = stream.state();
    for (i, word) in words.iter_mut().enumerate() {
        let bytes = state[8 * i..8 * i + 8].try_into().expect("8 bytes");
        word.push(u64::from_le_bytes(bytes));
    }
}

/// Lane `lane`'s stream from the four state words of every lane.
fn stream_of(words: &[Vec<u64>; 4], lane: usize) -> Xoshiro256PlusPlus {
    let mut seed = [0u8; 32];
    for (i, word) in words.iter().enumerate() {
        seed[8 * i..8 * i + 8].copy_from_slice(&word[lane].to_le_bytes());
    }
    Xoshiro256PlusPlus::from_seed(seed)
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::increments::{GaussianIncrements, IncrementSource};
    use crate::seeding::path_rng;

    #[test]
    fn the_lanes_fast_path_is_the_one_words() {
        // Every layer, with fractions at both ends of u's range and random ones, 8 words at a
        // time through AVX-512 (where the processor has it), 4 through AVX2 and one.
        let mut mixer = path_rng(5, 5);
        let mut fractions = vec![0, 1, 1 << 51, (1 << 51) + 1, (1 << 52) - 1, 1 << 50];
        fractions.extend((0..10).map(|_| rand::Rng::next_u64(&mut mixer) >> 12));
        let words: Vec<u64> = (0..crate::ziggurat::LAYERS as u64)
            .flat_map(|layer| fractions.iter().map(move |&f| (f << 12) | layer))
            .collect();
        let expected: Vec<(f64, bool)> = words
            .iter()
            .map(|&w| crate::ziggurat::fast_path(w))
            .collect();
        assert!(expected.iter().any(|e| e.1) && expected.iter().any(|e| !e.1));
        let check = |got: &[(f64, bool)]| {
            for ((g, e), w) in got.iter().zip(&expected).zip(&words) {
                assert_eq!((g.0.to_bits(), g.1), (e.0.to_bits(), e.1), "word {w:#x}");
            }
        };
        check(
            &words
                .iter()
                .map(|&w| fast_path(pulp::Scalar, w))
                .collect::<Vec<_>>(),
        );
        #[cfg(target_arch = "x86_64")]
        if let Some(simd) = pulp::x86::V3::try_new() {
            check(&lanes_fast_path(simd, &words));
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(simd) = pulp::x86::V4::try_new() {
            check(&lanes_fast_path(simd, &words));
        }
    }

    /// The lanes' fast path over `words`, W at a time (words.len() a multiple of W).
    fn lanes_fast_path<S: WordLanes>(simd: S, words: &[u64]) -> Vec<(f64, bool)> {
        let lane_bits: S::f64s = load_words(bytemuck::cast_slice(&LANE_BITS));
        let zero = simd.splat_f64s(0.0);
        let mut out = Vec::new();
        for group in words.chunks_exact(S::F64_LANES) {
            let (x, accepted) = fast_path(simd, load_words(group));
            let mut values = [0.0; LANE_BLOCK];
            store_f64s::<S>(x, &mut values);
            let bits = simd.reduce_sum_f64s(simd.select_f64s(accepted, lane_bits, zero)) as u32;
            for (lane, value) in values[..S::F64_LANES].iter().enumerate() {
                out.push((*value, bits & (1 << lane) != 0));
            }
        }
        out
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
        for width in LaneWidth::ALL {
            check_against_scalar(width, 13, 2, 10_000);
            // Draws per lane group and tile (7 a step, 32 steps a tile, 13 in the last) not a
            // multiple of a batch: the last batch of each is partial.
            check_against_scalar(width, 5, 7, 301);
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
            Err(NoiseError::DimensionMismatch { found, .. }) if found == 2 * 8 + 1
        ));
        let mut dw = vec![0.0; 2 * lanes.stride()];
        for h in [0.0, -1.0, f64::NAN] {
            assert!(matches!(
                lanes.fill(h, &mut dw),
                Err(NoiseError::InvalidSetting { name: "h", .. })
            ));
        }
        // A step too large for the address space.
        assert!(matches!(
            EnsembleIncrements::for_paths(1, &[0], usize::MAX / 4).fill(1.0, &mut dw),
            Err(NoiseError::InvalidSetting {
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
