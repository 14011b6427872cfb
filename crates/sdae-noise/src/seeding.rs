//! The random-number stream of each path, from the study's seed and the path's index.

use rand::{RngExt, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};

/// The random-number stream of path `index` of a study with seed `seed`: a xoshiro256++ whose
/// 256-bit state comes from SplitMix64 applied to the pair (seed, index). It is the main
/// stream of the path's [`PathStreams`](crate::PathStreams), which draw its standard normals.
pub fn path_rng(seed: u64, index: u64) -> Xoshiro256PlusPlus {
    let mut mixer = SplitMix64::seed_from_u64(seed);
    let base: u64 = mixer.random();
    let mut stream = SplitMix64::seed_from_u64(base ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut state = [0u8; 32];
    for chunk in state.chunks_exact_mut(8) {
        chunk.copy_from_slice(&stream.random::<u64>().to_le_bytes());
    }
    Xoshiro256PlusPlus::from_seed(state)
}
