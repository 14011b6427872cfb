//! The random streams of randomization r of a study: its scrambles and its paths' padding.

use rand::{RngExt, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};

/// Which word of the study's SplitMix64 sequence a family of streams is keyed on: word 0 is
/// that of the paths' own streams ([`path_rng`](crate::path_rng)), so the families differ.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Family {
    /// The scrambling matrices and shifts of a randomization.
    Scramble = 1,
    /// The seed of the pseudo-random padding coordinates of a randomization's paths.
    Padding = 2,
}

/// The stream of member r of a family of a study with seed `seed`: as in
/// [`path_rng`](crate::path_rng), a xoshiro256++ whose state is four words of
/// SplitMix64(b ^ r 0x9E3779B97F4A7C15), b the family's word of SplitMix64(seed).
pub(crate) fn family_rng(seed: u64, family: Family, r: u64) -> Xoshiro256PlusPlus {
    let mut mixer = SplitMix64::seed_from_u64(seed);
    let mut base: u64 = mixer.random();
    for _ in 0..family as usize {
        base = mixer.random();
    }
    let mut stream = SplitMix64::seed_from_u64(base ^ r.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut state = [0u8; 32];
    for chunk in state.chunks_exact_mut(8) {
        chunk.copy_from_slice(&stream.random::<u64>().to_le_bytes());
    }
    Xoshiro256PlusPlus::from_seed(state)
}
