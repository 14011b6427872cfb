//! Randomized Sobol' points: Matousek's random linear matrix scrambling plus a digital shift.

use rand::Rng;

use crate::error::NoiseError;
use crate::qmc::joe_kuo::{INDEX_BITS, direction_numbers};
use crate::qmc::seeds::{Family, family_rng};
use crate::qmc::sobol::{SobolPoints, check_dims};

impl SobolPoints {
    /// Randomization `randomization` of the Sobol' points in `dims` dimensions, for a study with
    /// seed `seed` (1 <= `dims` <= 21 201): per dimension j a random lower-triangular 64 x 64
    /// binary matrix M_j with unit diagonal (Matousek's linear matrix scrambling) and a random
    /// 64-bit digital shift e_j, the randomization SciPy's `Sobol(scramble=True)` makes:
    ///
    /// ```text
    /// x'_(i,j) = M_j x_(i,j) ^ e_j,   so   v'_(j,k) = M_j v_(j,k)   once, for k = 1..32,
    /// ```
    ///
    /// with binary digits ordered most significant first (output digit p depends on input
    /// digits 1..p). Each first 2^m points stay a (t, m, s)-net, each point is uniform on the
    /// unit cube, and a point costs what a plain one does. M_j's 32 columns that meet the
    /// direction numbers and then e_j are drawn in turn, dimension after dimension, from the
    /// randomization's own xoshiro256++ stream (keyed on (seed, randomization) by SplitMix64),
    /// so a study's first d dimensions do not depend on how many it uses.
    pub fn scrambled(dims: usize, seed: u64, randomization: u64) -> Result<Self, NoiseError> {
        check_dims(dims)?;
        let mut rng = family_rng(seed, Family::Scramble, randomization);
        let mut directions = Vec::with_capacity(dims);
        let mut shifts = Vec::with_capacity(dims);
        for j in 0..dims {
            let columns = scrambling_columns(&mut rng);
            directions.push(direction_numbers(j).map(|v| times_matrix(&columns, v)));
            shifts.push(rng.next_u64());
        }
        Ok(Self::from_parts(&directions, shifts))
    }
}

/// Columns q = 1..32 of a random lower-triangular binary matrix with unit diagonal: column q
/// has digit q set and uniform random digits q + 1..64 (the bits below bit 64 - q).
fn scrambling_columns(rng: &mut impl Rng) -> [u64; INDEX_BITS] {
    std::array::from_fn(|q| {
        let diagonal = 1u64 << (63 - q);
        (rng.next_u64() & (diagonal - 1)) | diagonal
    })
}

/// M v = XOR of the columns q of M for the digits q of v that are set (v has digits 1..32 only).
fn times_matrix(columns: &[u64; INDEX_BITS], v: u64) -> u64 {
    let (mut y, mut digits) = (0, v);
    while digits != 0 {
        let q = digits.leading_zeros() as usize;
        y ^= columns[q];
        digits ^= 1 << (63 - q);
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scrambling_keeps_the_leading_digit_structure() {
        // Output digit p of M v is digit p of v plus a combination of digits above it, so the
        // leading set digit of v stays where it is.
        let plain = SobolPoints::new(50).unwrap();
        let scrambled = SobolPoints::scrambled(50, 3, 1).unwrap();
        for j in 0..50 {
            for k in 0..INDEX_BITS {
                let (v, w) = (plain.direction(j, k), scrambled.direction(j, k));
                assert_eq!(v.leading_zeros(), w.leading_zeros());
            }
        }
        assert_ne!(plain, scrambled);
    }

    #[test]
    fn randomizations_are_reproducible_distinct_and_nested() {
        let a = SobolPoints::scrambled(20, 7, 2).unwrap();
        assert_eq!(a, SobolPoints::scrambled(20, 7, 2).unwrap());
        assert_ne!(a, SobolPoints::scrambled(20, 7, 3).unwrap());
        assert_ne!(a, SobolPoints::scrambled(20, 8, 2).unwrap());
        let more = SobolPoints::scrambled(40, 7, 2).unwrap();
        for j in 0..20 {
            for k in 0..INDEX_BITS {
                assert_eq!(a.direction(j, k), more.direction(j, k));
            }
        }
        assert_eq!(a.shifts[..], more.shifts[..20]);
    }
}
