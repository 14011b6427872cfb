//! W paths at once: a value per path in the lanes of a SIMD register.
//!
//! [`Lanes`] wraps a vector of W f64 of a [`pulp::Simd`] instruction set (W = 1 for
//! [`pulp::Scalar`], 4 with AVX2, 8 with AVX-512) with the arithmetic of a plain f64, so that a
//! formula is written once and runs on any width. Every operation is a correctly rounded IEEE
//! operation on each lane (no fused multiply-add), so lane i computes exactly what the scalar
//! formula computes for path i, whatever W is.
//!
//! The crate sits below every other crate of the workspace, so that the constraints, the
//! solvers, the systems and the schemes can write a formula once over [`T: Real`](Real), for
//! `f64` and for lanes:
//!
//! ```
//! use pulp::{Simd, WithSimd};
//! use sdae_lanes::{LaneWidth, Lanes, Real};
//!
//! /// x^2 + 1 over any number type.
//! fn energy<T: Real>(x: T) -> T {
//!     x * x + 1.0
//! }
//!
//! /// `energy` of every value, W at a time.
//! struct Energies<'a>(&'a [f64], &'a mut [f64]);
//! impl WithSimd for Energies<'_> {
//!     type Output = ();
//!     fn with_simd<S: Simd>(self, simd: S) {
//!         let w = Lanes::<S>::WIDTH;
//!         for (x, out) in self.0.chunks_exact(w).zip(self.1.chunks_exact_mut(w)) {
//!             energy(Lanes::load(simd, x)).store(out);
//!         }
//!     }
//! }
//!
//! let x = [0.5, -1.25, 3.0, 1e-3, 7.5, -2.0, 0.0, 1e9];
//! let mut lanes = [0.0; 8];
//! LaneWidth::Best.dispatch(Energies(&x, &mut lanes));
//! for (xi, e) in x.iter().zip(lanes) {
//!     assert_eq!(e.to_bits(), energy(*xi).to_bits());
//! }
//! ```
//!
//! [`LineVec`] is a buffer whose values start on a cache line: the ensembles keep their states,
//! rows and scratch in it. [`LineAligned`] is a global allocator that starts every buffer of a
//! cache line or more on a cache line, for the buffers a program allocates itself; programs
//! opt in with `#[global_allocator]` (the command line and the Python package do).

use std::ops::{Add, Div, Mul, Neg, Not, Sub};

mod aligned;
mod line_vec;
pub use aligned::{LINE, LineAligned};
pub use line_vec::LineVec;

use pulp::bytemuck;
use pulp::{Simd, WithSimd};

/// Paths are laid out in blocks of this many lanes, the widest SIMD width (8 f64 with
/// AVX-512).
pub const LANE_BLOCK: usize = 8;

/// The stride of an ensemble of `paths` paths: `paths` rounded up to a multiple of
/// [`LANE_BLOCK`]. Coordinate j of path p of the increments passed to an ensemble's step
/// (`sdae_model::PathEnsemble::step`) is entry `j * stride + p`. (An ensemble's constructor
/// refuses a count too large to round up, `sdae_model::ModelError::Allocation`.)
pub fn lane_stride(paths: usize) -> usize {
    paths.next_multiple_of(LANE_BLOCK)
}

/// The instruction set, and with it the number W of paths stepped at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LaneWidth {
    /// The widest this processor runs: 8 with AVX-512, 4 with AVX2, else the processor's own
    /// (1 on other x86-64).
    #[default]
    Best,
    /// One path at a time, in plain f64.
    One,
    /// Four paths with AVX2; one at a time on a processor without it.
    Four,
    /// Eight paths with AVX-512; on a processor without it, as [`LaneWidth::Best`].
    Eight,
}

impl LaneWidth {
    /// Every width, narrowest first (one lane, four, eight, the machine's widest): what a check
    /// that results do not depend on W runs through.
    pub const ALL: [LaneWidth; 4] = [
        LaneWidth::One,
        LaneWidth::Four,
        LaneWidth::Eight,
        LaneWidth::Best,
    ];

    /// Runs `op` with the instruction set of this width.
    ///
    /// Only the instruction sets of [`LaneWidth::Best`] are used (AVX-512, AVX2 and plain
    /// f64), so a kernel is compiled three times and not again for emulated widths: a width
    /// the processor lacks falls back to one it has, with the same numbers (a path's results
    /// do not depend on W).
    pub fn dispatch<Op: WithSimd>(self, op: Op) -> Op::Output {
        match self {
            LaneWidth::Best => pulp::Arch::new().dispatch(op),
            LaneWidth::One => Simd::vectorize(pulp::Scalar, op),
            LaneWidth::Four => {
                #[cfg(target_arch = "x86_64")]
                if let Some(simd) = pulp::x86::V3::try_new() {
                    return Simd::vectorize(simd, op);
                }
                Simd::vectorize(pulp::Scalar, op)
            }
            LaneWidth::Eight => {
                #[cfg(target_arch = "x86_64")]
                if let Some(simd) = pulp::x86::V4::try_new() {
                    return Simd::vectorize(simd, op);
                }
                pulp::Arch::new().dispatch(op)
            }
        }
    }

    /// W: the number of paths this width steps at once on this processor.
    pub fn lanes(self) -> usize {
        struct Width;
        impl WithSimd for Width {
            type Output = usize;
            fn with_simd<S: Simd>(self, _simd: S) -> usize {
                S::F64_LANES
            }
        }
        self.dispatch(Width)
    }
}

/// W values, one per path, of the instruction set `S`. Laid out as its W f64 where the
/// instruction set is zero-sized ([`Lanes::rows`]).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub struct Lanes<S: Simd> {
    simd: S,
    x: S::f64s,
}

/// W booleans, one per path (the result of a comparison of [`Lanes`]).
#[derive(Debug, Clone, Copy)]
pub struct LaneMask<S: Simd> {
    simd: S,
    m: S::m64s,
}

impl<S: Simd> Lanes<S> {
    /// The number W of lanes.
    pub const WIDTH: usize = S::F64_LANES;

    /// x in every lane.
    #[inline(always)]
    pub fn splat(simd: S, x: f64) -> Self {
        Self {
            simd,
            x: simd.splat_f64s(x),
        }
    }

    /// The lanes from `from[..W]` (panics if `from` is shorter: a caller's layout error).
    #[inline(always)]
    pub fn load(simd: S, from: &[f64]) -> Self {
        let bytes: &[u8] = bytemuck::cast_slice(&from[..Self::WIDTH]);
        Self {
            simd,
            x: bytemuck::pod_read_unaligned(bytes),
        }
    }

    /// `values` as rows of W lanes (row i from `values[i W..(i + 1) W]`) without a copy, or
    /// `None` where the layout does not allow it: `Lanes<S>` must be laid out as its W f64 (a
    /// zero-sized instruction set, as pulp's are), `values` aligned for it and a whole number
    /// of rows.
    #[inline(always)]
    pub fn rows(simd: S, values: &[f64]) -> Option<&[Self]> {
        let _ = simd;
        let w = Self::WIDTH;
        let fits = size_of::<S>() == 0
            && size_of::<Self>() == w * size_of::<f64>()
            && values.len().is_multiple_of(w)
            && values.as_ptr().cast::<Self>().is_aligned();
        // SAFETY: `Lanes` is repr(C): the zero-sized `simd`, then `x`, at offset 0 and, by the
        // size check, exactly W f64 wide, for which every bit pattern is valid; the pointer is
        // aligned for `Lanes<S>` and the rows cover `values` exactly; the result borrows
        // `values`. The instruction set's token is zero-sized and the caller holds one
        // (`simd`), so the rows carry a set this processor runs.
        fits.then(|| unsafe {
            std::slice::from_raw_parts(values.as_ptr().cast::<Self>(), values.len() / w)
        })
    }

    /// Writes the lanes to `to[..W]`.
    #[inline(always)]
    pub fn store(self, to: &mut [f64]) {
        let values: &[f64] = bytemuck::cast_slice(std::slice::from_ref(&self.x));
        to[..Self::WIDTH].copy_from_slice(values);
    }

    /// x in every lane, with the instruction set of `self`.
    #[inline(always)]
    pub fn splat_like(self, x: f64) -> Self {
        Self::splat(self.simd, x)
    }

    /// The square root of each lane.
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.with(self.simd.sqrt_f64s(self.x))
    }

    /// |x| of each lane.
    #[inline(always)]
    pub fn abs(self) -> Self {
        self.with(self.simd.abs_f64s(self.x))
    }

    /// The larger of each pair, as `if self < other { other } else { self }` (a NaN in `other`
    /// is not taken, one in `self` stays).
    #[inline(always)]
    pub fn max(self, other: Self) -> Self {
        Self::select(self.lt(other), other, self)
    }

    /// Lane-wise `self < other` (false where either is NaN).
    #[inline(always)]
    pub fn lt(self, other: Self) -> LaneMask<S> {
        self.mask(self.simd.less_than_f64s(self.x, other.x))
    }

    /// Lane-wise `self <= other` (false where either is NaN).
    #[inline(always)]
    pub fn le(self, other: Self) -> LaneMask<S> {
        self.mask(self.simd.less_than_or_equal_f64s(self.x, other.x))
    }

    /// Lane-wise `self == other`.
    #[inline(always)]
    pub fn eq(self, other: Self) -> LaneMask<S> {
        self.mask(self.simd.equal_f64s(self.x, other.x))
    }

    /// Lanes that are finite (neither infinite nor NaN).
    #[inline(always)]
    pub fn is_finite(self) -> LaneMask<S> {
        self.abs().lt(self.splat_like(f64::INFINITY))
    }

    /// `if_true` where `mask` holds, `if_false` elsewhere.
    #[inline(always)]
    pub fn select(mask: LaneMask<S>, if_true: Self, if_false: Self) -> Self {
        if_true.with(mask.simd.select_f64s(mask.m, if_true.x, if_false.x))
    }

    /// `f` of each lane (a scalar function such as a transcendental of the standard library,
    /// which has no lane form): lane i is `f(self.lane(i))`, bit for bit.
    #[inline(always)]
    pub fn map_each(self, mut f: impl FnMut(f64) -> f64) -> Self {
        let mut values = [0.0; crate::LANE_BLOCK];
        self.store(&mut values);
        for x in values.iter_mut().take(Self::WIDTH) {
            *x = f(*x);
        }
        Self::load(self.simd, &values)
    }

    /// `f` of each pair of lanes: lane i is `f(self.lane(i), other.lane(i))`, bit for bit
    /// (e.g. `f64::atan2`).
    #[inline(always)]
    pub fn zip_map_each(self, other: Self, mut f: impl FnMut(f64, f64) -> f64) -> Self {
        let (mut values, mut others) = ([0.0; crate::LANE_BLOCK], [0.0; crate::LANE_BLOCK]);
        self.store(&mut values);
        other.store(&mut others);
        for (x, y) in values.iter_mut().zip(others).take(Self::WIDTH) {
            *x = f(*x, y);
        }
        Self::load(self.simd, &values)
    }

    /// The instruction set.
    #[inline(always)]
    pub fn simd(self) -> S {
        self.simd
    }

    /// The value of lane `i` < W.
    #[inline(always)]
    pub fn lane(self, i: usize) -> f64 {
        let values: &[f64] = bytemuck::cast_slice(std::slice::from_ref(&self.x));
        values[i]
    }

    #[inline(always)]
    fn with(self, x: S::f64s) -> Self {
        Self { simd: self.simd, x }
    }

    #[inline(always)]
    fn mask(self, m: S::m64s) -> LaneMask<S> {
        LaneMask { simd: self.simd, m }
    }
}

/// A number of one path (`f64`) or of W paths ([`Lanes`]): a formula written once over `Real`
/// runs on both, lane i of the [`Lanes`] form computing exactly what the `f64` form computes
/// for path i (the systems of `sdae-systems` write their forces this way).
pub trait Real:
    Copy
    + std::fmt::Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A boolean per path (`bool`, or [`LaneMask`]).
    type Mask: PathMask;
    /// Whether a value is one path's (`f64`), not W paths' (lanes): a formula over `Real` may
    /// then take a decision per value, such as a row interchange by index rather than by
    /// selects, with the same result.
    const ONE_PATH: bool;
    /// x in every path, of the kind of `self`.
    fn splat_like(self, x: f64) -> Self;
    /// The square root.
    fn sqrt(self) -> Self;
    /// The absolute value.
    fn abs(self) -> Self;
    /// The larger of `self` and `other` (of a NaN and a number: as `f64::max` for `f64`, the
    /// instruction set's choice for lanes).
    fn max(self, other: Self) -> Self;
    /// `self == other` per path.
    fn equal(self, other: Self) -> Self::Mask;
    /// `self < other` per path (false where either is NaN).
    fn less(self, other: Self) -> Self::Mask;
    /// `self <= other` per path (false where either is NaN).
    fn at_most(self, other: Self) -> Self::Mask;
    /// Whether each path's value is finite.
    fn finite(self) -> Self::Mask;
    /// `holds` in every path, of the kind of `self`'s masks.
    fn mask_like(self, holds: bool) -> Self::Mask;
    /// `if_true` where `mask` holds, `if_false` elsewhere.
    fn select(mask: Self::Mask, if_true: Self, if_false: Self) -> Self;
    /// `f` of each path's value ([`Lanes::map_each`]).
    fn map_each(self, f: impl FnMut(f64) -> f64) -> Self;
    /// `f` of each path's pair of values ([`Lanes::zip_map_each`]).
    fn zip_map_each(self, other: Self, f: impl FnMut(f64, f64) -> f64) -> Self;
    /// A function of one path's coordinates evaluated on every path: for one path, `f` on the
    /// slices themselves; for lanes, lane by lane ([`per_lane`]: lane k computes exactly what
    /// `f` computes for path k alone). `out` holds its values before the call (so `f` may add
    /// to them). Returns `false`, leaving `out` alone, where lanes have no such evaluation (a
    /// slice longer than [`PER_LANE_MAX_DIM`]); one path always has it. This is how a closure
    /// written for one path serves a method generic over `Real`.
    fn each_path<const K: usize>(
        inputs: [&[Self]; K], out: &mut [Self], f: impl FnMut([&[f64]; K], &mut [f64]),
    ) -> bool;
}

/// A boolean per path: `bool` for one path, [`LaneMask`] for W.
pub trait PathMask: Copy + Not<Output = Self> {
    /// `self` and `other` per path.
    fn and(self, other: Self) -> Self;
    /// `self` or `other` per path.
    fn or(self, other: Self) -> Self;
    /// Whether every path holds.
    fn all(self) -> bool;
    /// Whether any path holds.
    #[inline(always)]
    fn any(self) -> bool {
        !(!self).all()
    }
}

impl PathMask for bool {
    #[inline(always)]
    fn and(self, other: Self) -> Self {
        self & other
    }
    #[inline(always)]
    fn or(self, other: Self) -> Self {
        self | other
    }
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
}

impl<S: Simd> PathMask for LaneMask<S> {
    #[inline(always)]
    fn and(self, other: Self) -> Self {
        LaneMask::and(self, other)
    }
    #[inline(always)]
    fn or(self, other: Self) -> Self {
        LaneMask::or(self, other)
    }
    #[inline(always)]
    fn all(self) -> bool {
        LaneMask::all(self)
    }
    #[inline(always)]
    fn any(self) -> bool {
        LaneMask::any(self)
    }
}

impl Real for f64 {
    type Mask = bool;
    const ONE_PATH: bool = true;
    #[inline(always)]
    fn splat_like(self, x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }
    #[inline(always)]
    fn equal(self, other: Self) -> bool {
        self == other
    }
    #[inline(always)]
    fn less(self, other: Self) -> bool {
        self < other
    }
    #[inline(always)]
    fn at_most(self, other: Self) -> bool {
        self <= other
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn mask_like(self, holds: bool) -> bool {
        holds
    }
    #[inline(always)]
    fn select(mask: bool, if_true: Self, if_false: Self) -> Self {
        if mask { if_true } else { if_false }
    }
    #[inline(always)]
    fn map_each(self, mut f: impl FnMut(f64) -> f64) -> Self {
        f(self)
    }
    #[inline(always)]
    fn zip_map_each(self, other: Self, mut f: impl FnMut(f64, f64) -> f64) -> Self {
        f(self, other)
    }
    #[inline(always)]
    fn each_path<const K: usize>(
        inputs: [&[Self]; K], out: &mut [Self], mut f: impl FnMut([&[f64]; K], &mut [f64]),
    ) -> bool {
        f(inputs, out);
        true
    }
}

impl<S: Simd> Real for Lanes<S> {
    type Mask = LaneMask<S>;
    const ONE_PATH: bool = false;
    #[inline(always)]
    fn splat_like(self, x: f64) -> Self {
        Lanes::splat_like(self, x)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Lanes::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Lanes::abs(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        Lanes::max(self, other)
    }
    #[inline(always)]
    fn equal(self, other: Self) -> LaneMask<S> {
        Lanes::eq(self, other)
    }
    #[inline(always)]
    fn less(self, other: Self) -> LaneMask<S> {
        Lanes::lt(self, other)
    }
    #[inline(always)]
    fn at_most(self, other: Self) -> LaneMask<S> {
        Lanes::le(self, other)
    }
    #[inline(always)]
    fn finite(self) -> LaneMask<S> {
        Lanes::is_finite(self)
    }
    #[inline(always)]
    fn mask_like(self, holds: bool) -> LaneMask<S> {
        let zero = self.splat_like(0.0);
        let all = zero.eq(zero);
        if holds { all } else { !all }
    }
    #[inline(always)]
    fn select(mask: LaneMask<S>, if_true: Self, if_false: Self) -> Self {
        Lanes::select(mask, if_true, if_false)
    }
    #[inline(always)]
    fn map_each(self, f: impl FnMut(f64) -> f64) -> Self {
        Lanes::map_each(self, f)
    }
    #[inline(always)]
    fn zip_map_each(self, other: Self, f: impl FnMut(f64, f64) -> f64) -> Self {
        Lanes::zip_map_each(self, other, f)
    }
    #[inline(always)]
    fn each_path<const K: usize>(
        inputs: [&[Self]; K], out: &mut [Self], f: impl FnMut([&[f64]; K], &mut [f64]),
    ) -> bool {
        per_lane(inputs, out, f)
    }
}

/// a . b over N coordinates of W lanes, summed in order: a_0 b_0 + a_1 b_1 + ... (what
/// `sdae_manifold::vector::dot` computes for fewer than four coordinates, up to the sign of a
/// zero).
#[inline(always)]
pub fn dot<S: Simd, const N: usize>(a: &[Lanes<S>; N], b: &[Lanes<S>; N]) -> Lanes<S> {
    let mut sum = a[0] * b[0];
    for i in 1..N {
        sum = sum + a[i] * b[i];
    }
    sum
}

/// The most coordinates (and noise components) a scalar function is evaluated on lane by lane
/// ([`per_lane`]).
pub const PER_LANE_MAX_DIM: usize = 16;

/// A scalar function evaluated lane by lane: for each lane k < W, `f(inputs[0] lane k, ...,
/// out lane k)` with every slice of `inputs` and `out` holding one [`Lanes`] per coordinate;
/// `out` holds the lanes' values before the call (so `f` may add to them). Lane k computes
/// exactly what `f` computes for path k alone. Returns `false`, and leaves `out` alone, if a
/// slice is longer than [`PER_LANE_MAX_DIM`].
#[inline(always)]
pub fn per_lane<S: Simd, const K: usize>(
    inputs: [&[Lanes<S>]; K], out: &mut [Lanes<S>], f: impl FnMut([&[f64]; K], &mut [f64]),
) -> bool {
    let longest = inputs.iter().map(|x| x.len()).fold(out.len(), usize::max);
    // Buffers sized for the common small systems, so that their setup costs little.
    if longest <= 4 {
        per_lane_within::<S, K, 4>(inputs, out, f)
    } else if longest <= PER_LANE_MAX_DIM {
        per_lane_within::<S, K, PER_LANE_MAX_DIM>(inputs, out, f)
    } else {
        false
    }
}

/// [`per_lane`] with buffers of `MAX` >= every slice's length coordinates.
#[inline(always)]
fn per_lane_within<S: Simd, const K: usize, const MAX: usize>(
    inputs: [&[Lanes<S>]; K], out: &mut [Lanes<S>], mut f: impl FnMut([&[f64]; K], &mut [f64]),
) -> bool {
    let Some(simd) = out
        .first()
        .or(inputs.iter().find_map(|x| x.first()))
        .map(|x| x.simd)
    else {
        return true;
    };
    let mut values = [[0.0; MAX]; K];
    let mut result = [0.0; MAX];
    let mut lanes = [[0.0; crate::LANE_BLOCK]; MAX];
    for k in 0..Lanes::<S>::WIDTH {
        for (value, input) in values.iter_mut().zip(&inputs) {
            for (x, lane) in value.iter_mut().zip(input.iter()) {
                *x = lane.lane(k);
            }
        }
        for (x, lane) in result.iter_mut().zip(out.iter()) {
            *x = lane.lane(k);
        }
        let args: [&[f64]; K] = std::array::from_fn(|i| &values[i][..inputs[i].len()]);
        f(args, &mut result[..out.len()]);
        for (row, x) in lanes.iter_mut().zip(&result[..out.len()]) {
            row[k] = *x;
        }
    }
    for (o, row) in out.iter_mut().zip(&lanes) {
        *o = Lanes::load(simd, row);
    }
    true
}

/// A scalar function evaluated path by path on lanes of any length (the fallback of a lane
/// form for systems too large for [`per_lane`]): for each lane k < W, `f(inputs[0] lane k, ...,
/// out lane k)` on contiguous copies in `scratch` (grown as needed), with `out` holding the
/// lanes' values before the call. Lane k computes exactly what `f` computes for path k alone.
pub fn per_path<S: Simd, const K: usize>(
    inputs: [&[Lanes<S>]; K], out: &mut [Lanes<S>], scratch: &mut Vec<f64>,
    mut f: impl FnMut([&[f64]; K], &mut [f64]),
) {
    let Some(simd) = out
        .first()
        .or(inputs.iter().find_map(|x| x.first()))
        .map(|x| x.simd)
    else {
        return;
    };
    let width = Lanes::<S>::WIDTH;
    let lens: [usize; K] = std::array::from_fn(|i| inputs[i].len());
    let total = lens.iter().sum::<usize>() + out.len();
    scratch.resize(total * width, 0.0);
    // Lane k of slice s at `starts[s] + k * len_s`: one contiguous copy per path.
    let (inputs_area, out_area) = scratch.split_at_mut(width * (total - out.len()));
    let mut start = 0;
    let mut starts = [0; K];
    for (s, input) in inputs.iter().enumerate() {
        starts[s] = start;
        transpose_into(input, &mut inputs_area[start..start + width * input.len()]);
        start += width * input.len();
    }
    transpose_into(out, out_area);
    let out_len = out.len();
    for k in 0..width {
        let args: [&[f64]; K] =
            std::array::from_fn(|s| &inputs_area[starts[s] + k * lens[s]..][..lens[s]]);
        f(args, &mut out_area[k * out_len..(k + 1) * out_len]);
    }
    for (i, o) in out.iter_mut().enumerate() {
        let mut row = [0.0; crate::LANE_BLOCK];
        for (k, x) in row.iter_mut().enumerate().take(width) {
            *x = out_area[k * out_len + i];
        }
        *o = Lanes::load(simd, &row);
    }
}

/// The lanes' words of a vector of u64.
#[inline(always)]
fn lane_words<V: bytemuck::Pod>(words: &V) -> &[u64] {
    bytemuck::cast_slice(std::slice::from_ref(words))
}

/// to[k * len + i] = lane k of from[i].
#[inline(always)]
fn transpose_into<S: Simd>(from: &[Lanes<S>], to: &mut [f64]) {
    let len = from.len();
    for (i, x) in from.iter().enumerate() {
        let mut row = [0.0; crate::LANE_BLOCK];
        x.store(&mut row);
        for (k, value) in row.iter().enumerate().take(Lanes::<S>::WIDTH) {
            to[k * len + i] = *value;
        }
    }
}

impl<S: Simd> LaneMask<S> {
    /// The instruction set.
    #[inline(always)]
    pub fn simd(self) -> S {
        self.simd
    }

    /// Lane-wise and.
    #[inline(always)]
    pub fn and(self, other: Self) -> Self {
        self.with(self.simd.and_m64s(self.m, other.m))
    }

    /// Lane-wise or.
    #[inline(always)]
    pub fn or(self, other: Self) -> Self {
        self.with(self.simd.or_m64s(self.m, other.m))
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        match self.words() {
            Some(words) => lane_words(&words)
                .iter()
                .fold(true, |all, &w| all & (w != 0)),
            None => self.simd.first_true_m64s(self.simd.not_m64s(self.m)) >= S::F64_LANES,
        }
    }

    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        match self.words() {
            Some(words) => lane_words(&words)
                .iter()
                .fold(false, |any, &w| any | (w != 0)),
            None => self.simd.first_true_m64s(self.m) < S::F64_LANES,
        }
    }

    /// The mask as one word per lane (nonzero where the lane holds) where the instruction set
    /// keeps a mask in a vector register; `None` where it keeps one bit per lane. Tested
    /// without a branch per lane, unlike `Simd::first_true_m64s`.
    #[inline(always)]
    fn words(self) -> Option<S::u64s> {
        if const { std::mem::size_of::<S::m64s>() == std::mem::size_of::<S::u64s>() } {
            Some(bytemuck::cast(self.m))
        } else {
            None
        }
    }

    /// Whether lane `i` < W holds.
    #[inline(always)]
    pub fn lane(self, i: usize) -> bool {
        let one = Lanes::splat(self.simd, 1.0);
        Lanes::select(self, one, one.splat_like(0.0)).lane(i) == 1.0
    }

    #[inline(always)]
    fn with(self, m: S::m64s) -> Self {
        Self { simd: self.simd, m }
    }
}

macro_rules! lane_binary {
    ($trait:ident, $method:ident, $simd_op:ident) => {
        impl<S: Simd> $trait for Lanes<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                self.with(self.simd.$simd_op(self.x, other.x))
            }
        }
        impl<S: Simd> $trait<f64> for Lanes<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: f64) -> Self {
                self.$method(self.splat_like(other))
            }
        }
    };
}

lane_binary!(Add, add, add_f64s);
lane_binary!(Sub, sub, sub_f64s);
lane_binary!(Mul, mul, mul_f64s);
lane_binary!(Div, div, div_f64s);

impl<S: Simd> Not for LaneMask<S> {
    type Output = Self;
    /// Lane-wise not.
    #[inline(always)]
    fn not(self) -> Self {
        self.with(self.simd.not_m64s(self.m))
    }
}

impl<S: Simd> Neg for Lanes<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.with(self.simd.neg_f64s(self.x))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values<S: Simd>(simd: S) -> Vec<f64> {
        let x: Vec<f64> = (0..S::F64_LANES).map(|i| i as f64 - 1.5).collect();
        let a = Lanes::load(simd, &x);
        let b = (a * a + 2.0).sqrt() / (a - 7.0) - a.abs().max(a.splat_like(0.25));
        let c = Lanes::select(a.lt(b), -b, b + 1.0);
        let mut out = vec![0.0; S::F64_LANES];
        c.store(&mut out);
        out
    }

    #[test]
    fn every_width_computes_what_the_scalar_formula_computes() {
        for (width, got) in [
            (1, values(pulp::Scalar)),
            (4, values(pulp::Scalar256b)),
            (8, values(pulp::Scalar512b)),
        ] {
            for (i, g) in got.iter().enumerate() {
                let a = i as f64 - 1.5;
                let b = (a * a + 2.0).sqrt() / (a - 7.0) - a.abs().max(0.25);
                let c = if a < b { -b } else { b + 1.0 };
                assert_eq!(g.to_bits(), c.to_bits(), "width {width}, lane {i}");
            }
        }
    }

    /// The rows of `values` in place are the rows loaded one by one; a slice that is not a
    /// whole number of rows has none.
    fn rows_in_place<S: Simd>(simd: S) {
        let w = S::F64_LANES;
        let values: Vec<f64> = (0..3 * w).map(|i| i as f64 * 0.5 - 2.0).collect();
        let rows = Lanes::rows(simd, &values).expect("pulp's instruction sets are zero-sized");
        assert_eq!(rows.len(), 3);
        for (i, row) in rows.iter().enumerate() {
            let loaded = Lanes::load(simd, &values[i * w..]);
            for lane in 0..w {
                assert_eq!(row.lane(lane).to_bits(), loaded.lane(lane).to_bits());
            }
        }
        if w > 1 {
            assert!(Lanes::rows(simd, &values[..2 * w + 1]).is_none());
        }
    }

    #[test]
    fn rows_in_place_are_the_rows_loaded() {
        rows_in_place(pulp::Scalar);
        rows_in_place(pulp::Scalar256b);
        rows_in_place(pulp::Scalar512b);
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(simd) = pulp::x86::V3::try_new() {
                rows_in_place(simd);
            }
            if let Some(simd) = pulp::x86::V4::try_new() {
                rows_in_place(simd);
            }
        }
    }

    #[test]
    fn a_scalar_function_runs_lane_by_lane() {
        let simd = pulp::Scalar512b;
        let row =
            |base: f64| Lanes::load(simd, &std::array::from_fn::<f64, 8, _>(|k| base + k as f64));
        let (r, v) = ([row(1.0), row(10.0)], [row(-3.0), row(0.5)]);
        // out += (r0 v1, r1 - v0, r0 + r1) lane by lane, on top of 7 in every lane.
        let mut out = [Lanes::splat(simd, 7.0); 3];
        assert!(per_lane([&r, &v], &mut out, |[r, v], out| {
            out[0] += r[0] * v[1];
            out[1] += r[1] - v[0];
            out[2] += r[0] + r[1];
        }));
        for k in 0..8 {
            let (r0, r1, v0, v1) = (
                1.0 + k as f64,
                10.0 + k as f64,
                -3.0 + k as f64,
                0.5 + k as f64,
            );
            assert_eq!(out[0].lane(k), 7.0 + r0 * v1);
            assert_eq!(out[1].lane(k), 7.0 + (r1 - v0));
            assert_eq!(out[2].lane(k), 7.0 + (r0 + r1));
        }
        // Beyond the buffers: no lane form, `out` untouched.
        let long = [Lanes::splat(simd, 1.0); PER_LANE_MAX_DIM + 1];
        let mut out = [Lanes::splat(simd, 2.0); 1];
        assert!(!per_lane([&long[..]], &mut out, |_, _| unreachable!()));
        assert_eq!(out[0].lane(3), 2.0);
    }

    #[test]
    fn scalar_functions_map_lane_by_lane() {
        let simd = pulp::Scalar256b;
        let a = Lanes::load(simd, &[0.5, -2.0, 3.0, f64::NAN]);
        let b = Lanes::load(simd, &[1.0, 0.25, -4.0, 1.0]);
        let (sines, angles) = (a.map_each(f64::sin), a.zip_map_each(b, f64::atan2));
        for i in 0..3 {
            assert_eq!(sines.lane(i).to_bits(), a.lane(i).sin().to_bits());
            assert_eq!(
                angles.lane(i).to_bits(),
                a.lane(i).atan2(b.lane(i)).to_bits()
            );
        }
        assert!(sines.lane(3).is_nan() && angles.lane(3).is_nan());
    }

    #[test]
    fn masks_combine_lane_by_lane() {
        let simd = pulp::Scalar256b;
        let a = Lanes::load(simd, &[1.0, f64::NAN, f64::INFINITY, -2.0]);
        let finite = a.is_finite();
        let positive = a.splat_like(0.0).lt(a);
        let both = finite.and(positive);
        let lanes: Vec<bool> = (0..4).map(|i| both.lane(i)).collect();
        assert_eq!(lanes, [true, false, false, false]);
        assert!(!finite.all());
        assert!(finite.or(!finite).all());
    }
}
