//! The block: the unit in which a run takes, stores and shards its samples.
//!
//! Samples are taken in blocks of [`BLOCK`] consecutive indices starting at multiples of
//! [`BLOCK`]; a block is named by its [`BlockKey`] in a run's checkpoint and in its shards.

/// Samples per block (a multiple of the widest SIMD width).
pub const BLOCK: u64 = 32;

/// One block of samples: its level, its index b (samples b BLOCK .. (b + 1) BLOCK), and
/// whether its samples are pairs (`coupled`) or fine paths alone (standard Monte Carlo).
/// Its sums depend on nothing else (and the seed and the sampler's settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BlockKey {
    /// Level l.
    pub level: u32,
    /// Block index b.
    pub block: u64,
    /// Pairs of paths (true) or the fine path alone (false).
    pub coupled: bool,
}
