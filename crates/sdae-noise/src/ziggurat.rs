//! The standard normal's ziggurat (Marsaglia and Tsang, symmetric, [`LAYERS`] layers), split
//! into a fast path that reads one word and a slow path that finishes the rare draws the fast
//! path rejects from a second stream.
//!
//! With f(x) = exp(-x^2 / 2), the region under f on x >= 0 is covered by n = [`LAYERS`]
//! pieces of equal area v: layer 0 is the rectangle [0, r] x [0, f(r)] with the tail x > r, of
//! width x_0 = v / f(r); layer i >= 1 is the rectangle [0, x_i] x [f(x_i), f(x_{i+1})], where
//! x_1 = r and f(x_{i+1}) = f(x_i) + v / x_i, with x_n = 0 (which fixes r). A draw takes one
//! 64-bit word b: layer i = b mod n (its low bits) and u in [-1, 1) from its upper 52 bits,
//! and returns x = u x_i when |x| < x_{i+1} (the part of the layer under the density): the
//! fast path, which accepts 99.8% of draws with n = 2048. The rest are finished by
//! [`finish_draw`], with further words from a second stream: the tail beyond r for layer 0,
//! the density test for the other layers, and a new draw where that test fails. The result is
//! exactly N(0, 1): a rejection sampler's law does not depend on which independent words it
//! reads after the first.
//!
//! 2048 layers (a 16 KiB table of abscissae) instead of the 256 of rand_distr's sampler cut
//! the rejected draws from 1.5% to 0.23%, which matters most when W paths draw at once: a
//! draw of 8 lanes has a rejected lane 1.8% of the time instead of 11%.

use rand::Rng;

mod table;

/// The number n of layers.
pub(crate) const LAYERS: usize = 2048;

/// The layer's bits of a word: its low log2(n) bits.
pub(crate) const LAYER_MASK: u64 = LAYERS as u64 - 1;

/// The exponent bits that make (b >> 12) a float in [2, 4), so that it minus 3 is u in
/// [-1, 1) with 52 random bits (the layer's 11 bits are below them).
pub(crate) const U_EXPONENT: u64 = (1023 + 1) << 52;

/// The abscissae x_0 > x_1 = r > ... > x_n = 0 (n + 1 entries).
pub(crate) static X: &[f64; LAYERS + 1] = &table::X;

/// u in [-1, 1) of a word: its upper 52 bits as the fraction of a float in [2, 4), minus 3.
#[inline(always)]
pub(crate) fn signed_uniform(word: u64) -> f64 {
    f64::from_bits((word >> 12) | U_EXPONENT) - 3.0
}

/// The fast path for one word b: (x = u x_i, whether |x| < x_{i+1}) with i = b mod n.
#[inline(always)]
pub(crate) fn fast_path(word: u64) -> (f64, bool) {
    let layer = (word & LAYER_MASK) as usize;
    let x = signed_uniform(word) * X[layer];
    (x, x.abs() < X[layer + 1])
}

/// The standard normal whose first word is `word`, for a word the fast path rejected: the
/// tail (layer 0) or the density test (other layers) with words from `side`, and while that
/// test fails, whole new draws from `side`. (For a word the fast path accepts it returns that
/// number.)
pub(crate) fn finish_draw<R: Rng + ?Sized>(word: u64, side: &mut R) -> f64 {
    let mut word = word;
    loop {
        let (x, accepted) = fast_path(word);
        if accepted {
            return x;
        }
        let layer = (word & LAYER_MASK) as usize;
        if layer == 0 {
            return tail(x, side);
        }
        if under_density(layer, x, side) {
            return x;
        }
        word = side.next_u64();
    }
}

/// The density test of layer i >= 1 for x with x_{i+1} <= |x| < x_i: whether a height y
/// uniform in [f(x_i), f(x_{i+1})) (one word of `side`) lies below f(x).
#[inline]
fn under_density<R: Rng + ?Sized>(layer: usize, x: f64, side: &mut R) -> bool {
    let (low, high) = (table::F[layer], table::F[layer + 1]);
    low + unit_uniform(side.next_u64()) * (high - low) < (-0.5 * x * x).exp()
}

/// A draw from the tail |x| > r with the sign of `sign` (Marsaglia's method): a = -ln(U1) / r,
/// b = -ln(U2) with U1, U2 uniform in (0, 1), until 2 b >= a^2; then r + a.
fn tail<R: Rng + ?Sized>(sign: f64, side: &mut R) -> f64 {
    loop {
        let a = -open_uniform(side.next_u64()).ln() / table::R;
        let b = -open_uniform(side.next_u64()).ln();
        if 2.0 * b >= a * a {
            return (table::R + a).copysign(sign);
        }
    }
}

/// A uniform in [0, 1) from the upper 53 bits of a word.
#[inline]
fn unit_uniform(word: u64) -> f64 {
    (word >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform in (0, 1) from the upper 53 bits of a word (the midpoints of 2^53 cells).
#[inline]
fn open_uniform(word: u64) -> f64 {
    ((word >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeding::path_rng;
    use statrs::function::erf::erfc;

    /// f(x) = exp(-x^2 / 2).
    fn f(x: f64) -> f64 {
        (-0.5 * x * x).exp()
    }

    /// The integral of f over [a, b] (0 <= a <= b).
    fn integral(a: f64, b: f64) -> f64 {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        (std::f64::consts::PI / 2.0).sqrt() * (erfc(a * s) - erfc(b * s))
    }

    /// Asserts that `hits` of `n` trials is within 5 binomial standard errors of n p.
    fn assert_binomial(hits: usize, n: usize, p: f64, what: &str) {
        let (mean, sd) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
        assert!(
            (hits as f64 - mean).abs() <= 5.0 * sd,
            "{what}: {hits} of {n}, expected {mean:.1} +- {sd:.1}"
        );
    }

    #[test]
    fn the_table_closes_the_ziggurat() {
        let (x, fx, n) = (&table::X, &table::F, LAYERS);
        assert_eq!((x[1], x[n], fx[n]), (table::R, 0.0, 1.0));
        assert!(x.windows(2).all(|w| w[0] > w[1]), "strictly decreasing");
        for i in 0..=n {
            // x_i is rounded (relative error 2^-53), which moves f(x_i) by x_i^2 2^-53
            // relative; exp adds about one rounding.
            let tolerance = (1.0 + x[i] * x[i]) * 4.0 * f64::EPSILON / 2.0 * f(x[i]);
            assert!((fx[i] - f(x[i])).abs() <= tolerance, "f(x_{i})");
        }
        // Equal areas: the base layer with its tail, and every rectangle above it up to the
        // top one, [0, x_{n-1}] x [f(x_{n-1}), f(0) = 1] (which closes the ziggurat at x_n = 0).
        // (statrs' erfc is good to about 1e-10 relative this far out.)
        let base = table::R * fx[1] + integral(table::R, 40.0);
        assert!((base - table::V).abs() < 1e-10 * table::V, "base {base}");
        assert!((x[0] * fx[1] - table::V).abs() < 1e-15 * table::V);
        let half_ulp = f64::EPSILON / 2.0;
        for i in 1..n {
            // The difference of two rounded heights is off by up to half an ulp of each.
            let area = x[i] * (fx[i + 1] - fx[i]);
            let tolerance = 3.0 * half_ulp * table::V + x[i] * (fx[i + 1] + fx[i]) * half_ulp;
            assert!((area - table::V).abs() <= tolerance, "layer {i}: {area}");
        }
    }

    #[test]
    fn the_fast_path_rejects_as_often_as_the_table_says() {
        // Rejection rate 1 - (1/n) sum_i x_{i+1} / x_i, about 0.23% for n = 2048.
        let p = 1.0 - X.windows(2).map(|w| w[1] / w[0]).sum::<f64>() / LAYERS as f64;
        let mut rng = path_rng(17, 0);
        let n = 2_000_000;
        let rejected = (0..n).filter(|_| !fast_path(rng.next_u64()).1).count();
        assert_binomial(rejected, n, p, "rejected draws");
    }

    #[test]
    fn the_tail_has_the_normal_tails_law() {
        // P(Z > r + t | Z > r) = erfc((r + t) / sqrt 2) / erfc(r / sqrt 2).
        let mut side = path_rng(3, 1);
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| tail(1.0, &mut side)).collect();
        assert!(draws.iter().all(|&z| z >= table::R));
        let r = table::R;
        for t in [0.05, 0.1, 0.2, 0.4, 0.8] {
            let p = integral(r + t, 40.0) / integral(r, 40.0);
            let beyond = draws.iter().filter(|&&z| z > r + t).count();
            assert_binomial(beyond, n, p, &format!("tail beyond r + {t}"));
        }
        assert!(tail(-1.0, &mut side) <= -r, "the sign is the word's");
    }

    #[test]
    fn the_density_test_accepts_the_part_of_the_wedge_under_the_density() {
        // x uniform in [x_{i+1}, x_i): accepted with probability
        // (integral of f - f(x_i)) / ((x_i - x_{i+1}) (f(x_{i+1}) - f(x_i))).
        let mut side = path_rng(4, 2);
        let n = 200_000;
        for layer in [1, 2, 40, 700, 1500, LAYERS - 2, LAYERS - 1] {
            let (hi, lo) = (X[layer], X[layer + 1]);
            let (f_hi, f_lo) = (table::F[layer], table::F[layer + 1]);
            let p = (integral(lo, hi) - (hi - lo) * f_hi) / ((hi - lo) * (f_lo - f_hi));
            let accepted = (0..n)
                .filter(|k| {
                    let x = lo + (hi - lo) * (*k as f64 + 0.5) / n as f64;
                    under_density(layer, x, &mut side)
                })
                .count();
            assert_binomial(accepted, n, p, &format!("layer {layer}"));
        }
    }

    #[test]
    fn finished_draws_are_standard_normal() {
        // Every word of a stream through `finish_draw` (which returns the fast path's number
        // when it accepts): the whole generator's law, against N(0, 1)'s mean, variance,
        // symmetry and the probabilities of |z| beyond points up to the tail's start.
        let mut main = path_rng(8, 3);
        let mut side = path_rng(8, 4);
        let n = 4_000_000;
        let draws: Vec<f64> = (0..n)
            .map(|_| finish_draw(main.next_u64(), &mut side))
            .collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        assert!(mean.abs() < 5.0 / (n as f64).sqrt(), "mean {mean}");
        let var = draws.iter().map(|z| z * z).sum::<f64>() / n as f64;
        assert!(
            (var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(),
            "variance {var}"
        );
        for c in [0.1, 0.5, 1.0, 2.0, 3.0, 3.8, table::R] {
            let p = 2.0 * integral(c, 40.0) / (2.0 * std::f64::consts::PI).sqrt();
            let beyond = draws.iter().filter(|z| z.abs() > c).count();
            assert_binomial(beyond, n, p, &format!("|z| > {c}"));
        }
        let positive = draws.iter().filter(|&&z| z > 0.0).count();
        assert_binomial(positive, n, 0.5, "z > 0");
    }
}
