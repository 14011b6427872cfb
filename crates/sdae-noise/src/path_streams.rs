//! A path's two random-number streams and the standard normals drawn from them.

use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::seeding::path_rng;
use crate::ziggurat::{fast_path, finish_draw};

/// The random numbers of one path: a main xoshiro256++ stream that gives exactly one 64-bit
/// word per standard normal, and a side stream (the main one 2^192 words ahead, its
/// `long_jump`) that finishes the 0.23% of draws whose word the ziggurat's fast path rejects
/// (a ziggurat of 2048 layers).
///
/// One word per normal on the main stream is what lets W paths draw in the lanes of a SIMD
/// register without waiting on each other ([`EnsembleIncrements`](crate::EnsembleIncrements)):
/// a rejected lane is finished later from its side stream, and path p's numbers are the same
/// bits whatever W is.
///
/// ```
/// use sdae_noise::{PathStreams, StandardNormals};
/// let mut streams = PathStreams::for_path(7, 3);
/// let z: Vec<f64> = (0..1000).map(|_| streams.next_normal()).collect();
/// let mean = z.iter().sum::<f64>() / 1000.0;
/// assert!(mean.abs() < 5.0 / 1000f64.sqrt());
/// // The same seed and path give the same numbers.
/// assert_eq!(PathStreams::for_path(7, 3).next_normal(), z[0]);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PathStreams {
    main: Xoshiro256PlusPlus,
    side: Xoshiro256PlusPlus,
}

impl PathStreams {
    /// The streams of path `index` of a study with seed `seed`: the main stream is
    /// [`path_rng`]`(seed, index)`.
    pub fn for_path(seed: u64, index: u64) -> Self {
        Self::new(path_rng(seed, index))
    }

    /// The streams whose main stream is `main` and whose side stream is `main` 2^192 words
    /// ahead.
    pub fn new(main: Xoshiro256PlusPlus) -> Self {
        let mut side = main.clone();
        side.long_jump();
        Self { main, side }
    }

    /// Streams as they stood somewhere along a path (from [`PathStreams::main`] and
    /// [`PathStreams::side`]): continuing them continues that path's numbers.
    pub fn from_parts(main: Xoshiro256PlusPlus, side: Xoshiro256PlusPlus) -> Self {
        Self { main, side }
    }

    /// The main stream: one word per standard normal.
    pub fn main(&self) -> &Xoshiro256PlusPlus {
        &self.main
    }

    /// The side stream: the words of the draws the fast path rejects.
    pub fn side(&self) -> &Xoshiro256PlusPlus {
        &self.side
    }
}

/// A source of independent standard normals.
pub trait StandardNormals {
    /// The next standard normal.
    fn next_normal(&mut self) -> f64;

    /// out_k = scale z_k for the next out.len() standard normals z_k, in order: the numbers of
    /// that many calls of [`StandardNormals::next_normal`]. A source may override it to keep
    /// its state in registers over the loop.
    #[inline]
    fn fill_scaled(&mut self, scale: f64, out: &mut [f64]) {
        for o in out.iter_mut() {
            *o = scale * self.next_normal();
        }
    }
}

impl StandardNormals for PathStreams {
    /// The ziggurat on the main stream's next word, finished from the side stream if its fast
    /// path rejects it.
    #[inline]
    fn next_normal(&mut self) -> f64 {
        let word = self.main.next_u64();
        match fast_path(word) {
            (x, true) => x,
            _ => finish_draw(word, &mut self.side),
        }
    }

    /// The main stream's state stays in registers over the loop: kept in the struct (or
    /// spilled around a call), every draw would store it and the next one load it back, a
    /// store-to-load round trip on the generator's chain of dependent updates. So the loop
    /// makes no call: the 0.23% of draws the fast path rejects are put aside and finished
    /// from the side stream after it, in the order drawn (the side stream gives the same
    /// words to the same draws).
    #[inline]
    fn fill_scaled(&mut self, scale: f64, out: &mut [f64]) {
        let mut main = self.main.clone();
        let mut rejected = [(0, 0); REJECTED_CAPACITY];
        let mut pending = 0;
        for k in 0..out.len() {
            let word = main.next_u64();
            let (x, accepted) = fast_path(word);
            out[k] = scale * x;
            if !accepted {
                rejected[pending] = (k, word);
                pending += 1;
                if pending == REJECTED_CAPACITY {
                    self.finish_rejected(&rejected, scale, out);
                    pending = 0;
                }
            }
        }
        self.finish_rejected(&rejected[..pending], scale, out);
        self.main = main;
    }
}

/// How many rejected draws [`PathStreams::fill_scaled`] puts aside before it finishes them.
const REJECTED_CAPACITY: usize = 16;

impl PathStreams {
    /// out[k] = scale z for each rejected draw (k, word) in order, z the standard normal whose
    /// first ziggurat word is `word`, finished from the side stream ([`finish_draw`]).
    #[cold]
    #[inline(never)]
    fn finish_rejected(&mut self, rejected: &[(usize, u64)], scale: f64, out: &mut [f64]) {
        for &(k, word) in rejected {
            out[k] = scale * finish_draw(word, &mut self.side);
        }
    }
}

/// Any random-number generator, through rand_distr's `StandardNormal`.
impl<R: Rng> StandardNormals for R {
    #[inline]
    fn next_normal(&mut self) -> f64 {
        self.sample(StandardNormal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_main_stream_gives_one_word_per_normal() {
        let mut streams = PathStreams::for_path(1, 2);
        let mut main = path_rng(1, 2);
        for _ in 0..100_000 {
            streams.next_normal();
            main.next_u64();
        }
        assert_eq!(streams.main(), &main);
        // About 0.23% of 100 000 draws were finished from the side stream.
        let fresh = PathStreams::for_path(1, 2);
        assert_ne!(streams.side(), fresh.side());
        let resumed = PathStreams::from_parts(streams.main().clone(), streams.side().clone());
        assert_eq!(resumed, streams);
    }

    #[test]
    fn filling_gives_the_numbers_of_single_draws_bit_for_bit() {
        let scale = 0.03;
        // 20 000 draws reject about 46, more than are put aside at once; lengths 0 and 1 too.
        for len in [0, 1, 7, 20_000] {
            let mut one_by_one = PathStreams::for_path(4, 11);
            let expected: Vec<u64> = (0..len)
                .map(|_| (scale * one_by_one.next_normal()).to_bits())
                .collect();
            let mut filled = PathStreams::for_path(4, 11);
            let mut out = vec![f64::NAN; len];
            filled.fill_scaled(scale, &mut out);
            let got: Vec<u64> = out.iter().map(|x| x.to_bits()).collect();
            assert_eq!(got, expected, "len {len}");
            assert_eq!(filled, one_by_one, "len {len}: the streams go on alike");
            if len == 20_000 {
                assert_ne!(filled.side(), PathStreams::for_path(4, 11).side());
            }
        }
        // Several calls continue one sequence.
        let mut one_by_one = PathStreams::for_path(2, 0);
        let mut filled = PathStreams::for_path(2, 0);
        let mut out = vec![0.0; 3001];
        for _ in 0..5 {
            filled.fill_scaled(1.0, &mut out);
            for x in &out {
                assert_eq!(x.to_bits(), one_by_one.next_normal().to_bits());
            }
        }
    }

    #[test]
    fn the_side_stream_is_the_main_one_far_ahead() {
        let streams = PathStreams::for_path(5, 9);
        let mut ahead = path_rng(5, 9);
        ahead.long_jump();
        assert_eq!(streams.side(), &ahead);
        assert_ne!(streams.side(), streams.main());
    }
}
