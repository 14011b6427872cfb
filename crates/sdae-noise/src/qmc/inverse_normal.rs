//! The inverse of the standard normal distribution function, Wichura's algorithm AS 241.

use sdae_lanes::{PathMask, Real};

/// z = Phi^-1(u), the standard normal quantile of u in (0, 1), by Wichura's algorithm AS 241
/// (PPND16, Applied Statistics 37, 1988), relative accuracy about 1e-16:
///
/// - central region |u - 1/2| <= 0.425: with q = u - 1/2 and r = 0.180625 - q^2,
///   z = q A(r) / B(r);
/// - tails: with r = sqrt(-ln min(u, 1 - u)), z = ±C(r - 1.6) / D(r - 1.6) for r <= 5 and
///   z = ±E(r - 5) / F(r - 5) beyond, the sign that of u - 1/2;
///
/// A to F polynomials of degree 7. The map is monotone, as quasi-Monte Carlo needs (each
/// coordinate of a point goes to one normal, its order kept). u = 0 and u = 1 give -inf and
/// +inf, u outside [0, 1] or NaN gives NaN.
pub fn inverse_normal_cdf(u: f64) -> f64 {
    let q = u - 0.5;
    if is_central(q) {
        central_quantile(q)
    } else {
        tail_quantile(u, q, tail_log(u, q))
    }
}

/// Whether q = u - 1/2 is in the central region |q| <= 0.425 (false for NaN).
#[inline(always)]
pub(crate) fn is_central(q: f64) -> bool {
    q.abs() <= 0.425
}

/// ln min(u, 1 - u), as the tails take it: ln u where q = u - 1/2 < 0, else ln(1 - u).
#[inline(always)]
pub(crate) fn tail_log(u: f64, q: f64) -> f64 {
    let tail = if q < 0.0 { u } else { 1.0 - u };
    tail.ln()
}

/// q A(r) / B(r) with r = 0.180625 - q^2, the quantile of the central region, of one path's
/// q (`f64`) or of W paths' ([`Lanes`](sdae_lanes::Lanes)): lane i computes exactly what
/// `f64` computes for lane i's q.
#[inline(always)]
pub(crate) fn central_quantile<T: Real>(q: T) -> T {
    let r = q.splat_like(0.180625) - q * q;
    q * polynomial(&A, r) / polynomial(&B, r)
}

/// The quantile of u in the tails (|q| > 0.425, q = u - 1/2) from `log` = [`tail_log`]`(u,
/// q)`, with the special values (u = 0 or 1, u outside [0, 1], NaN), of one path or of W
/// paths (lane by lane the same operations). The logarithm is taken outside: it has no lane
/// form with the standard library's rounding.
#[inline(always)]
pub(crate) fn tail_quantile<T: Real>(u: T, q: T, log: T) -> T {
    let (zero, one) = (u.splat_like(0.0), u.splat_like(1.0));
    let r = (-log).sqrt();
    let near = r.at_most(r.splat_like(5.0));
    let z = if near.all() {
        near_tail(r)
    } else if !near.any() {
        far_tail(r)
    } else {
        T::select(near, near_tail(r), far_tail(r))
    };
    let z = T::select(q.less(zero), -z, z);
    let open = zero.less(u).and(u.less(one));
    if open.all() {
        z
    } else {
        T::select(open, z, u.map_each(special_quantile))
    }
}

/// C(r - 1.6) / D(r - 1.6), the tail r <= 5.
#[inline(always)]
fn near_tail<T: Real>(r: T) -> T {
    let x = r - 1.6;
    polynomial(&C, x) / polynomial(&D, x)
}

/// E(r - 5) / F(r - 5), the tail r > 5 (min(u, 1 - u) < exp(-25)).
#[inline(always)]
fn far_tail<T: Real>(r: T) -> T {
    let x = r - 5.0;
    polynomial(&E, x) / polynomial(&F, x)
}

/// The quantile of u outside (0, 1): -inf at 0, +inf at 1, NaN elsewhere (and for NaN).
fn special_quantile(u: f64) -> f64 {
    if !(0.0..=1.0).contains(&u) {
        f64::NAN
    } else {
        (u - 0.5).signum() * f64::INFINITY
    }
}

/// sum_k c_k x^k by Horner's rule (c_0 first), from 0 x + c_7.
#[inline(always)]
fn polynomial<T: Real>(c: &[f64; 8], x: T) -> T {
    let mut acc = x.splat_like(0.0);
    for &ck in c.iter().rev() {
        acc = acc * x + ck;
    }
    acc
}

/// Numerator of the central region.
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const A: [f64; 8] = [
    3.387_132_872_796_366_608_0,
    1.331_416_678_917_843_774_5e2,
    1.971_590_950_306_551_442_7e3,
    1.373_169_376_550_946_112_5e4,
    4.592_195_393_154_987_145_7e4,
    6.726_577_092_700_870_085_3e4,
    3.343_057_558_358_812_810_5e4,
    2.509_080_928_730_122_672_7e3,
];
/// Denominator of the central region.
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const B: [f64; 8] = [
    1.0,
    4.231_333_070_160_091_125_2e1,
    6.871_870_074_920_579_083_0e2,
    5.394_196_021_424_751_107_7e3,
    2.121_379_430_158_659_586_7e4,
    3.930_789_580_009_271_061_0e4,
    2.872_908_573_572_194_267_4e4,
    5.226_495_278_852_854_561_0e3,
];
/// Numerator of the near tail (r <= 5).
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const C: [f64; 8] = [
    1.423_437_110_749_683_577_34,
    4.630_337_846_156_545_295_90,
    5.769_497_221_460_691_405_50,
    3.647_848_324_763_204_605_04,
    1.270_458_252_452_368_382_58,
    2.417_807_251_774_506_117_70e-1,
    2.272_384_498_926_918_458_33e-2,
    7.745_450_142_783_414_076_40e-4,
];
/// Denominator of the near tail.
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const D: [f64; 8] = [
    1.0,
    2.053_191_626_637_758_821_87,
    1.676_384_830_183_803_849_40,
    6.897_673_349_851_000_045_50e-1,
    1.481_039_764_274_800_745_90e-1,
    1.519_866_656_361_645_719_66e-2,
    5.475_938_084_995_344_946_00e-4,
    1.050_750_071_644_416_843_24e-9,
];
/// Numerator of the far tail (r > 5, min(u, 1 - u) < exp(-25)).
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const E: [f64; 8] = [
    6.657_904_643_501_103_777_20,
    5.463_784_911_164_114_369_90,
    1.784_826_539_917_291_335_80,
    2.965_605_718_285_048_912_30e-1,
    2.653_218_952_657_612_309_30e-2,
    1.242_660_947_388_078_438_60e-3,
    2.711_555_568_743_487_578_15e-5,
    2.010_334_399_292_288_132_65e-7,
];
/// Denominator of the far tail.
#[allow(clippy::excessive_precision, reason = "AS 241 digits as published")]
const F: [f64; 8] = [
    1.0,
    5.998_322_065_558_879_376_90e-1,
    1.369_298_809_227_358_053_10e-1,
    1.487_536_129_085_061_485_25e-2,
    7.868_691_311_456_132_591_00e-4,
    1.846_318_317_510_054_681_80e-5,
    1.421_511_758_316_445_888_70e-7,
    2.044_263_103_389_939_785_64e-15,
];

#[cfg(test)]
mod tests {
    use super::*;
    use statrs::distribution::{ContinuousCDF, Normal};

    fn reference(u: f64) -> f64 {
        Normal::standard().inverse_cdf(u)
    }

    /// AS 241 as published, branch by branch (the control flow the one-path code had before
    /// its pieces were shared with the lanes): an independent reader of `inverse_normal_cdf`.
    fn published(u: f64) -> f64 {
        if !(0.0..=1.0).contains(&u) {
            return f64::NAN;
        }
        if u == 0.0 || u == 1.0 {
            return (u - 0.5).signum() * f64::INFINITY;
        }
        let q = u - 0.5;
        if q.abs() <= 0.425 {
            let r = 0.180625 - q * q;
            return q * polynomial(&A, r) / polynomial(&B, r);
        }
        let r = (-(if q < 0.0 { u } else { 1.0 - u }).ln()).sqrt();
        let z = if r <= 5.0 {
            polynomial(&C, r - 1.6) / polynomial(&D, r - 1.6)
        } else {
            polynomial(&E, r - 5.0) / polynomial(&F, r - 5.0)
        };
        if q < 0.0 { -z } else { z }
    }

    /// u over the central region, both tails down to 1e-300, the region's boundaries and the
    /// special values.
    fn probes() -> Vec<f64> {
        let mut u: Vec<f64> = (0..4000).map(|k| (k as f64 + 0.5) / 4000.0).collect();
        u.extend((1..=300).flat_map(|e| [10f64.powi(-e), 1.0 - 10f64.powi(-e)]));
        u.extend([
            0.075,
            0.925,
            0.075 - 1e-17,
            0.925 + 1e-16,
            f64::MIN_POSITIVE,
        ]);
        u.extend([0.0, -0.0, 1.0, -0.5, 1.5, f64::NAN, f64::INFINITY]);
        u
    }

    #[test]
    fn the_shared_pieces_are_the_published_algorithm_bit_for_bit() {
        for u in probes() {
            let (got, want) = (inverse_normal_cdf(u), published(u));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "u {u:e}: {got:e} vs {want:e}"
            );
        }
    }

    /// The quantiles of `u` in lanes of `simd` as the ensembles take them: the central region
    /// in the lanes, the tails from their logarithms lane by lane.
    fn in_lanes<S: pulp::Simd>(simd: S, u: &[f64]) -> Vec<f64> {
        use sdae_lanes::Lanes;
        let w = S::F64_LANES;
        let mut out = vec![0.0; u.len()];
        for (u, out) in u.chunks_exact(w).zip(out.chunks_exact_mut(w)) {
            let lanes = Lanes::load(simd, u);
            let q = lanes - 0.5;
            let log = q.zip_map_each(lanes, |q, u| tail_log(u, q));
            let central = central_quantile(q);
            let tails = tail_quantile(lanes, q, log);
            Lanes::select(q.abs().le(q.splat_like(0.425)), central, tails).store(out);
        }
        out
    }

    #[test]
    fn lanes_give_the_one_path_numbers_at_every_width() {
        let mut u = probes();
        u.truncate(u.len() / 8 * 8);
        for (w, got) in [
            (1, in_lanes(pulp::Scalar, &u)),
            (4, in_lanes(pulp::Scalar256b, &u)),
            (8, in_lanes(pulp::Scalar512b, &u)),
        ] {
            for (u, z) in u.iter().zip(got) {
                let want = inverse_normal_cdf(*u);
                assert!(
                    z.to_bits() == want.to_bits() || (z.is_nan() && want.is_nan()),
                    "W = {w}, u {u:e}: {z:e} vs {want:e}"
                );
            }
        }
    }

    #[test]
    fn matches_statrs_in_the_central_region() {
        for k in 1..2000 {
            let u = 0.075 + 0.85 * k as f64 / 2000.0;
            let (z, want) = (inverse_normal_cdf(u), reference(u));
            let error = (z - want).abs() / want.abs().max(1e-3);
            assert!(error < 1e-14, "u {u}: {z} vs {want}");
        }
    }

    #[test]
    fn matches_statrs_in_the_tails() {
        let mut tails: Vec<f64> = (1..=300).map(|e| 10f64.powi(-e)).collect();
        tails.extend((1..200).map(|k| 0.075 * k as f64 / 200.0));
        for &u in &tails {
            // 1 - u rounds to 1 for u < 2^-54: no upper tail there.
            for v in [u, 1.0 - u].into_iter().filter(|&v| v < 1.0) {
                let (z, want) = (inverse_normal_cdf(v), reference(v));
                assert!(
                    (z - want).abs() <= 1e-13 * want.abs(),
                    "u {v}: {z} vs {want}"
                );
            }
        }
        let (z, want) = (inverse_normal_cdf(1.0 - 1e-16), reference(1.0 - 1e-16));
        assert!((z - want).abs() <= 1e-13 * want, "{z} vs {want}");
    }

    #[test]
    fn is_odd_monotone_and_total() {
        let mut previous = f64::NEG_INFINITY;
        // Dyadic u, so that 1 - u and u - 1/2 are exact.
        for k in 1..131_072 {
            let u = k as f64 / 131_072.0;
            let z = inverse_normal_cdf(u);
            assert!(z > previous, "not increasing at u {u}");
            previous = z;
            assert_eq!(z, -inverse_normal_cdf(1.0 - u), "u {u}");
        }
        assert_eq!(inverse_normal_cdf(0.5), 0.0);
        assert_eq!(inverse_normal_cdf(0.0), f64::NEG_INFINITY);
        assert_eq!(inverse_normal_cdf(1.0), f64::INFINITY);
        assert!(inverse_normal_cdf(1.5).is_nan() && inverse_normal_cdf(f64::NAN).is_nan());
    }
}
