//! Reductions over slices with four independent accumulators, so that the compiler can
//! vectorize them (a single running float sum is a chain of dependent additions).

use sdae_lanes::Real;

const LANES: usize = 4;

/// a . b over the common length.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    dot_with(0.0, a, b)
}

/// a . b over the common length with four partial sums, for one path (`f64`) or for lanes;
/// `zero` is 0 of the kind of the entries (the value of an empty sum).
#[inline(always)]
pub fn dot_with<T: Real>(zero: T, a: &[T], b: &[T]) -> T {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    // Indices rather than zipped iterators: a zip's constructor is not always inlined where
    // this function is.
    let full = n - n % LANES;
    let mut tail = zero;
    for i in full..n {
        tail = tail + a[i] * b[i];
    }
    if n < LANES {
        // (0 + 0) + (0 + 0) + tail is tail: a sum that starts at +0 is never -0.
        return tail;
    }
    let mut acc = [zero; LANES];
    let b = &b[..full];
    for (i, x) in a[..full].chunks_exact(LANES).enumerate() {
        let y = &b[i * LANES..i * LANES + LANES];
        for k in 0..LANES {
            acc[k] = acc[k] + x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// |x|^2 of a vector that is not empty, with the partial sums of [`dot`], for one path or for
/// lanes.
#[inline(always)]
pub fn sum_squares<T: Real>(x: &[T]) -> T {
    dot_with(x[0].splat_like(0.0), x, x)
}

/// |x|^2.
#[inline]
pub fn norm2_squared(x: &[f64]) -> f64 {
    dot(x, x)
}

/// |x| (Euclidean).
#[inline]
pub fn norm2(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

/// max_i |x_i|; NaN if an entry is NaN, infinite if an entry is infinite.
///
/// The maximum is a plain compare-and-select (one `maxpd` per two entries), which drops NaN;
/// the running sum, one addition per entry, finds them instead. A NaN sum without a NaN entry
/// (infinities of both signs) is told apart by a scan that runs only then.
#[inline]
pub fn max_abs(x: &[f64]) -> f64 {
    let mut acc = [0.0_f64; LANES];
    let mut sum = [0.0_f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let mut tail_max = 0.0_f64;
    let mut tail_sum = 0.0;
    for v in chunks.remainder() {
        tail_max = larger(tail_max, v.abs());
        tail_sum += v;
    }
    for c in chunks {
        for k in 0..LANES {
            acc[k] = larger(acc[k], c[k].abs());
            sum[k] += c[k];
        }
    }
    let total = (sum[0] + sum[1]) + (sum[2] + sum[3]) + tail_sum;
    if total.is_nan() && x.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    acc.iter().fold(tail_max, |s, v| larger(s, *v))
}

/// The larger of `current` and `candidate`, `current` if `candidate` is NaN: the select the
/// processor's maximum instruction makes, without `f64::max`'s NaN handling.
#[inline(always)]
fn larger(current: f64, candidate: f64) -> f64 {
    if candidate > current {
        candidate
    } else {
        current
    }
}

/// a . b of three coordinates, summed in order: a_0 b_0 + a_1 b_1 + a_2 b_2, for one path
/// (`f64`) or for lanes.
#[inline(always)]
pub fn dot3<T: Real>(a: &[T; 3], b: &[T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// g = 1/2 - |d|^2 / (2 L^2) of a rigid distance L with d the difference of its two points (a
/// chain's segment, a bond), given 1 / L^2, for one path or for lanes.
#[inline(always)]
pub fn distance_value<T: Real>(d: &[T; 3], inv_l2: f64) -> T {
    // 1/2 - x is 1/2 + (-x), bit for bit.
    -(dot3(d, d) * 0.5 * inv_l2) + 0.5
}

/// max_j |a_j|^2 over the blocks a_j of three coordinates of `a` (not empty), in order from 0.
#[inline(always)]
pub fn max_norm3_squared<T: Real>(a: &[T]) -> T {
    let mut largest = a[0].splat_like(0.0);
    for f in a.chunks_exact(3) {
        largest = largest.max(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reductions_match_plain_loops() {
        for n in [0, 1, 2, 3, 4, 5, 7, 8, 13, 100] {
            let x: Vec<f64> = (0..n).map(|k| ((k * 7 % 11) as f64 - 5.0) * 0.3).collect();
            let y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.7).cos()).collect();
            let plain: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
            assert!((dot(&x, &y) - plain).abs() < 1e-13, "n={n}");
            let m = x.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
            assert_eq!(max_abs(&x), m, "n={n}");
        }
    }

    #[test]
    fn max_abs_reports_non_finite_entries() {
        assert!(max_abs(&[1.0, f64::NAN, 2.0]).is_nan());
        assert!(max_abs(&[1.0, 2.0, 3.0, 4.0, 5.0, f64::NAN]).is_nan());
        assert_eq!(max_abs(&[1.0, f64::INFINITY, 2.0, 0.0, 1.0]), f64::INFINITY);
        assert_eq!(max_abs(&[-3.0, 2.0]), 3.0);
        // Infinities of both signs sum to NaN; no entry is NaN.
        assert_eq!(
            max_abs(&[f64::INFINITY, 1.0, f64::NEG_INFINITY]),
            f64::INFINITY
        );
        assert_eq!(
            max_abs(&[1.0, 2.0, 3.0, f64::NEG_INFINITY, f64::INFINITY]),
            f64::INFINITY
        );
        // A sum that overflows is not an infinite entry.
        assert_eq!(max_abs(&[f64::MAX, f64::MAX, -1.0]), f64::MAX);
    }
}
