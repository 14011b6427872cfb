//! The direction numbers of Sobol' points with the Joe and Kuo parameters (new-joe-kuo-6.21201).
//!
//! The parameters (per dimension j >= 2: the degree s of its primitive polynomial, the
//! polynomial's inner coefficients a and the initial m_1..m_s) are those the `sobol` crate
//! (1.0.2, BSD-3-Clause) ships as `sobol::params::JoeKuoD6::extended()`. It was chosen over its
//! fork `sobol-qmc` (2.x, also BSD-3-Clause) for its lighter dependencies: a gzip decoder
//! (`libflate`) and `num-traits`, where `sobol-qmc` depends on `statrs` 0.18 with its default
//! features (nalgebra, rand 0.8) and turns the 21 201 dimensions into Rust source at build time.
//! Only the parameters are taken from it; the direction numbers are computed here, as 64-bit
//! words.

use std::sync::OnceLock;

use sobol::params::JoeKuoD6;

/// The number of dimensions the Joe and Kuo parameters cover.
pub const MAX_SOBOL_DIMS: usize = 21_201;

/// The number of bits of a point index, and of the direction numbers: points 0..2^32.
pub(crate) const INDEX_BITS: usize = 32;

/// The Joe and Kuo parameters of dimensions 2..=21 201, decompressed once per process (a few
/// tens of milliseconds, at the first Sobol' points made).
fn parameters() -> &'static JoeKuoD6 {
    static PARAMETERS: OnceLock<JoeKuoD6> = OnceLock::new();
    PARAMETERS.get_or_init(JoeKuoD6::extended)
}

/// The direction numbers v_1..v_32 of dimension `dim` (0-based; dimension 1 of Joe and Kuo is
/// `dim` = 0), left-aligned in 64 bits: v_k = m_k 2^(64 - k) with m_k odd and < 2^k.
///
/// Dimension 1 has m_k = 1 (van der Corput). Dimension j >= 2 takes m_1..m_s from the
/// parameters and continues with Bratley and Fox's recurrence
///
/// ```text
/// v_k = a_1 v_(k-1) ^ a_2 v_(k-2) ^ ... ^ a_(s-1) v_(k-s+1) ^ v_(k-s) ^ (v_(k-s) >> s),
/// ```
///
/// a_1 the most significant of the s - 1 bits of a. `dim` must be < [`MAX_SOBOL_DIMS`].
pub(crate) fn direction_numbers(dim: usize) -> [u64; INDEX_BITS] {
    let mut v = [0u64; INDEX_BITS];
    if dim == 0 {
        for (k, vk) in v.iter_mut().enumerate() {
            *vk = 1 << (63 - k);
        }
        return v;
    }
    let p = &parameters().dim_params[dim - 1];
    let s = p.m.len();
    for (k, (vk, &mk)) in v.iter_mut().zip(&p.m).enumerate() {
        *vk = u64::from(mk) << (63 - k);
    }
    for k in s..INDEX_BITS {
        v[k] = v[k - s] ^ (v[k - s] >> s);
        for i in 1..s {
            let a_i = (p.a >> (s - 1 - i)) & 1;
            if a_i == 1 {
                v[k] ^= v[k - i];
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parameters_cover_every_dimension() {
        let params = parameters();
        assert_eq!(params.dim_params.len() + 1, MAX_SOBOL_DIMS);
        assert_eq!(params.dim_params[0].d, 2);
        assert_eq!(
            params.dim_params[MAX_SOBOL_DIMS - 2].d as usize,
            MAX_SOBOL_DIMS
        );
    }

    #[test]
    fn direction_numbers_are_odd_multiples_of_their_bit() {
        for dim in [0, 1, 2, 7, 999, 21_200] {
            for (k, vk) in direction_numbers(dim).iter().enumerate() {
                // m_k odd and < 2^k: bit 63 - k set, nothing below it.
                assert_eq!(vk.trailing_zeros() as usize, 63 - k, "dim {dim}, k {k}");
            }
        }
    }
}
