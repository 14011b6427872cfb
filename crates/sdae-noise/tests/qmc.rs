//! Randomized quasi-Monte Carlo paths: the net property and uniformity of the scrambled Sobol'
//! points, the unbiasedness and small variance of their means, the covariance of the bridge's
//! increments, the padding beyond the quasi-random coordinates, and the ensemble layout, made
//! W paths at a time in lanes with the numbers of one path at a time.

use sdae_lanes::LaneWidth;
use sdae_noise::{
    BrownianBridge, Coarsened, IncrementSource, MAX_SOBOL_DIMS, NoiseError, QuasiBrownian,
    QuasiIncrements, SobolPoints, StandardNormals, inverse_normal_cdf,
};
use statrs::distribution::{ChiSquared, ContinuousCDF};

const SEED: u64 = 2026;

/// The cell k of u in a grid of `cells` equal intervals of (0, 1).
fn cell(u: f64, cells: usize) -> usize {
    (u * cells as f64) as usize
}

/// Checks the means of independent randomizations of one rule: their grand mean is within four
/// standard errors of `exact`, and their standard deviation is below a fifth of `mc_sd`, the
/// standard deviation plain Monte Carlo would have with as many points.
fn check_randomized_means(means: &[f64], exact: f64, mc_sd: f64) {
    let replicates = means.len() as f64;
    let grand = means.iter().sum::<f64>() / replicates;
    let var_of_mean = means.iter().map(|m| (m - grand).powi(2)).sum::<f64>() / (replicates - 1.0);
    let standard_error = (var_of_mean / replicates).sqrt();
    assert!(
        (grand - exact).abs() < 4.0 * standard_error,
        "{grand} ± {standard_error} vs {exact}"
    );
    assert!(
        var_of_mean.sqrt() < 0.2 * mc_sd,
        "{} vs {mc_sd}",
        var_of_mean.sqrt()
    );
}

#[test]
fn scrambled_points_are_stratified_in_every_dimension() {
    let dims = [0, 1, 2, 7, 999, 21_000, MAX_SOBOL_DIMS - 1];
    for randomization in 0..3 {
        let points = SobolPoints::scrambled(MAX_SOBOL_DIMS, SEED, randomization).unwrap();
        for m in [1, 4, 10] {
            let n = 1usize << m;
            for &j in &dims {
                let mut count = vec![0; n];
                for i in 0..n as u32 {
                    count[cell(points.coordinate(i, j), n)] += 1;
                }
                assert!(
                    count.iter().all(|&c| c == 1),
                    "r {randomization}, n {n}, dim {j}"
                );
            }
        }
    }
}

#[test]
fn scrambled_pairs_pass_a_chi_square_test() {
    let (n, side) = (4096u32, 8);
    let cells = (side * side) as f64;
    let bound = ChiSquared::new(cells - 1.0).unwrap().inverse_cdf(0.999);
    let expected = n as f64 / cells;
    let pairs = [
        (0, 1),
        (1, 2),
        (3, 17),
        (100, 101),
        (999, 1000),
        (20_000, 21_200),
    ];
    for randomization in 0..2 {
        let points = SobolPoints::scrambled(MAX_SOBOL_DIMS, SEED, randomization).unwrap();
        for &(a, b) in &pairs {
            let mut count = vec![0.0; side * side];
            for i in 0..n {
                let (x, y) = (points.coordinate(i, a), points.coordinate(i, b));
                count[cell(x, side) * side + cell(y, side)] += 1.0;
            }
            let chi2: f64 = count
                .iter()
                .map(|c| (c - expected).powi(2) / expected)
                .sum();
            assert!(
                chi2 < bound,
                "r {randomization}, dims ({a}, {b}): {chi2} >= {bound}"
            );
            if b < 3 {
                // The first pairs are nets fine enough that every cell holds exactly 64 points.
                assert_eq!(chi2, 0.0, "dims ({a}, {b})");
            }
        }
    }
}

#[test]
fn randomized_means_are_unbiased_with_a_small_variance() {
    // f(u) = prod_j (1 + (u_j - 1/2)) over 8 dimensions: integral 1, variance (13/12)^8 - 1.
    let (dims, n, replicates) = (8, 256u32, 64);
    let f = |u: &[f64]| u.iter().map(|x| 0.5 + x).product::<f64>();
    let mut means = Vec::new();
    let mut u = vec![0.0; dims];
    for r in 0..replicates {
        let points = SobolPoints::scrambled(dims, SEED, r).unwrap();
        let sum: f64 = (0..n)
            .map(|i| {
                points.fill_point(i, &mut u);
                f(&u)
            })
            .sum();
        means.push(sum / n as f64);
    }
    // Monte Carlo with n points would have a standard deviation of sqrt(Var f / n) ~ 0.059;
    // the randomized nets have about a tenth of it (0.0064 with this seed).
    let mc_sd = ((13.0f64 / 12.0).powi(8) - 1.0).sqrt() / (n as f64).sqrt();
    check_randomized_means(&means, 1.0, mc_sd);
}

#[test]
fn bridge_increments_have_covariance_h_identity() {
    for (dim, steps) in [(2, 8), (2, 6), (1, 13)] {
        let coordinates = dim * steps;
        let (n, randomizations) = (1024, 4);
        let mut second = vec![0.0; coordinates * coordinates];
        let mut xi = vec![0.0; coordinates];
        for r in 0..randomizations {
            let quasi = QuasiBrownian::new(SEED, r, dim, steps).unwrap();
            for i in 0..n {
                quasi.unit_increments(i, &mut xi).unwrap();
                for a in 0..coordinates {
                    for b in 0..coordinates {
                        second[a * coordinates + b] += xi[a] * xi[b];
                    }
                }
            }
        }
        let samples = (n * randomizations) as f64;
        // Standard errors sqrt(2 / n) on the diagonal, sqrt(1 / n) off it.
        for a in 0..coordinates {
            for b in 0..coordinates {
                let cov = second[a * coordinates + b] / samples;
                let (want, se) = if a == b {
                    (1.0, (2.0 / samples).sqrt())
                } else {
                    (0.0, (1.0 / samples).sqrt())
                };
                assert!(
                    (cov - want).abs() < 5.0 * se,
                    "m {dim}, N {steps}: ({a}, {b}) {cov}"
                );
            }
        }
    }
}

#[test]
fn the_path_ends_at_sqrt_t_times_the_first_normals() {
    let (dim, steps, horizon) = (3, 10, 2.5);
    let h = horizon / steps as f64;
    let points = SobolPoints::scrambled(dim * steps, SEED, 5).unwrap();
    for index in [0, 1, 77] {
        let mut path = QuasiIncrements::new(SEED, 5, index, dim, steps).unwrap();
        let mut w = vec![0.0; dim];
        let mut dw = vec![0.0; dim];
        assert_eq!(path.remaining(), Some(steps));
        while path.remaining() != Some(0) {
            path.next_increment(h, &mut dw);
            for (wj, d) in w.iter_mut().zip(&dw) {
                *wj += d;
            }
        }
        for (j, wj) in w.iter().enumerate() {
            let z = inverse_normal_cdf(points.coordinate(index as u32, j));
            let want = horizon.sqrt() * z;
            assert!(
                (wj - want).abs() < 1e-12 * (1.0 + want.abs()),
                "{j}: {wj} vs {want}"
            );
        }
        path.next_increment(h, &mut dw);
        assert!(dw.iter().all(|x| x.is_nan()), "past the end");
    }
}

#[test]
fn coordinates_beyond_the_limit_are_the_padding_streams_normals() {
    let (dim, steps, limit, r, index) = (2, 8, 5, 3, 9);
    let quasi = QuasiBrownian::with_quasi_limit(SEED, r, dim, steps, limit).unwrap();
    assert_eq!(quasi.quasi_dims(), limit);
    let points = SobolPoints::scrambled(limit, SEED, r).unwrap();
    let mut padding = quasi.padding_streams(index);
    let normals: Vec<f64> = (0..dim * steps)
        .map(|c| match c < limit {
            true => inverse_normal_cdf(points.coordinate(index as u32, c)),
            false => padding.next_normal(),
        })
        .collect();
    // Coordinate c drives normal c / m of component c % m's bridge.
    let bridge = BrownianBridge::new(steps).unwrap();
    let mut expected = vec![0.0; dim * steps];
    let mut w = vec![0.0; steps + 1];
    for j in 0..dim {
        let z: Vec<f64> = (0..steps).map(|k| normals[k * dim + j]).collect();
        bridge.fill_path(&z, &mut w);
        for k in 0..steps {
            expected[k * dim + j] = w[k + 1] - w[k];
        }
    }
    let mut got = vec![0.0; dim * steps];
    quasi.unit_increments(index, &mut got).unwrap();
    assert_eq!(got, expected);
    // Other randomizations pad with other numbers; the quasi-random count is N m when it fits.
    let other = QuasiBrownian::with_quasi_limit(SEED, r + 1, dim, steps, limit).unwrap();
    assert_ne!(other.padding_streams(index), quasi.padding_streams(index));
    assert_eq!(
        QuasiBrownian::new(SEED, r, dim, steps)
            .unwrap()
            .quasi_dims(),
        16
    );
    let long = QuasiBrownian::new(SEED, r, 1, MAX_SOBOL_DIMS + 10).unwrap();
    assert_eq!(long.quasi_dims(), MAX_SOBOL_DIMS);
}

#[test]
fn ensemble_fill_equals_the_paths_bit_for_bit() {
    let (dim, steps, h) = (2, 12, 0.01);
    let quasi = QuasiBrownian::new(SEED, 1, dim, steps).unwrap();
    let indices: Vec<u64> = (100..111).collect();
    let mut lanes = quasi.ensemble(&indices).unwrap();
    let stride = lanes.stride();
    assert_eq!((lanes.paths(), stride, lanes.dim()), (11, 16, dim));
    let mut dw = vec![0.0; steps * dim * stride];
    let (first, rest) = dw.split_at_mut(5 * dim * stride);
    assert_eq!(lanes.fill(h, first).unwrap(), 5);
    assert_eq!(lanes.fill(h, rest).unwrap(), steps - 5);
    assert_eq!(lanes.remaining(), 0);
    for lane in 0..stride {
        let index = indices.get(lane).copied().unwrap_or(indices[0]);
        let mut path = quasi.path(index).unwrap();
        let mut step = vec![0.0; dim];
        for k in 0..steps {
            path.next_increment(h, &mut step);
            for j in 0..dim {
                let got = dw[(k * dim + j) * stride + lane];
                assert_eq!(got.to_bits(), step[j].to_bits(), "lane {lane}, step {k}");
            }
        }
    }
}

#[test]
fn ensemble_fill_refuses_bad_inputs_and_draws_nothing() {
    let quasi = QuasiBrownian::new(SEED, 0, 2, 4).unwrap();
    let mut lanes = quasi.ensemble(&[0, 1, 2]).unwrap();
    let row = 2 * lanes.stride();
    let step_size = lanes.fill(0.0, &mut vec![0.0; row]);
    assert!(matches!(
        step_size,
        Err(NoiseError::InvalidSetting { name: "h", .. })
    ));
    let ragged = lanes.fill(0.1, &mut vec![0.0; row + 1]);
    assert!(matches!(ragged, Err(NoiseError::DimensionMismatch { .. })));
    let too_many = lanes.fill(0.1, &mut vec![0.0; 5 * row]);
    assert!(matches!(
        too_many,
        Err(NoiseError::DimensionMismatch { .. })
    ));
    assert_eq!(lanes.remaining(), 4);
    assert_eq!(lanes.fill(0.1, &mut []).unwrap(), 0);
    let mut empty = quasi.ensemble(&[]).unwrap();
    assert_eq!(
        (empty.stride(), empty.fill(0.1, &mut [0.0; 4]).unwrap()),
        (0, 0)
    );
}

#[test]
fn bad_settings_are_errors() {
    let invalid =
        |r: Result<QuasiBrownian, NoiseError>| matches!(r, Err(NoiseError::InvalidSetting { .. }));
    assert!(invalid(QuasiBrownian::new(SEED, 0, 0, 8)));
    assert!(invalid(QuasiBrownian::new(SEED, 0, 2, 0)));
    assert!(invalid(QuasiBrownian::new(SEED, 0, usize::MAX, 2)));
    assert!(invalid(QuasiBrownian::with_quasi_limit(SEED, 0, 2, 8, 0)));
    assert!(invalid(QuasiBrownian::with_quasi_limit(
        SEED,
        0,
        2,
        8,
        MAX_SOBOL_DIMS + 1
    )));
    let quasi = QuasiBrownian::new(SEED, 0, 2, 8).unwrap();
    assert!(quasi.path(1 << 32).is_err());
    assert!(quasi.ensemble(&[0, 1 << 32]).is_err());
    assert!(matches!(
        quasi.unit_increments(0, &mut [0.0; 3]),
        Err(NoiseError::DimensionMismatch { .. })
    ));
    assert!(SobolPoints::scrambled(0, SEED, 0).is_err());
}

#[test]
fn coarsened_quasi_paths_sum_the_fine_increments() {
    let (dim, steps, h) = (2, 8, 0.125);
    let fine = QuasiIncrements::new(SEED, 2, 3, dim, steps).unwrap();
    let mut coarse = Coarsened::new(fine.clone(), 4);
    assert_eq!(coarse.remaining(), Some(2));
    let mut fine = fine;
    let (mut a, mut b, mut sum) = ([0.0; 2], [0.0; 2], [0.0; 2]);
    coarse.next_increment(4.0 * h, &mut a);
    for _ in 0..4 {
        fine.next_increment(h, &mut b);
        sum[0] += b[0];
        sum[1] += b[1];
    }
    assert_eq!(a, sum);
}

#[test]
fn randomized_path_means_are_unbiased_for_a_path_functional() {
    // A = h sum_(k=1..N) W(t_k) is normal with variance h^3 N (N + 1)(2N + 1) / 6, so
    // E exp(A) = exp(var / 2). R randomizations of n paths each; every step of size h.
    let (steps, n, replicates) = (16usize, 128u64, 32u64);
    let h = 1.0 / steps as f64;
    let var = h.powi(3) * (steps * (steps + 1) * (2 * steps + 1)) as f64 / 6.0;
    let exact = (var / 2.0).exp();
    let mut means = Vec::new();
    for r in 0..replicates {
        let quasi = QuasiBrownian::new(SEED, r, 1, steps).unwrap();
        let mut sum = 0.0;
        for i in 0..n {
            let mut path = quasi.path(i).unwrap();
            let (mut w, mut area, mut dw) = (0.0, 0.0, [0.0]);
            for _ in 0..steps {
                path.next_increment(h, &mut dw);
                w += dw[0];
                area += h * w;
            }
            sum += area.exp();
        }
        means.push(sum / n as f64);
    }
    // Var exp(A) = exp(2 var) - exp(var); Monte Carlo's mean of n paths has sqrt(Var / n),
    // 0.070 here, the randomized nets' about a ninth of it (0.0078).
    let mc_sd = (((2.0 * var).exp() - var.exp()) / n as f64).sqrt();
    check_randomized_means(&means, exact, mc_sd);
}

#[test]
fn increments_are_sqrt_h_times_the_unit_ones() {
    let quasi = QuasiBrownian::new(SEED, 4, 2, 5).unwrap();
    let mut unit = vec![0.0; 10];
    quasi.unit_increments(6, &mut unit).unwrap();
    let h = 0.003;
    let mut path = quasi.path(6).unwrap();
    let mut dw = [0.0; 2];
    for k in 0..5 {
        path.next_increment(h, &mut dw);
        assert_eq!(dw, [h.sqrt() * unit[2 * k], h.sqrt() * unit[2 * k + 1]]);
        assert_eq!(path.remaining(), Some(4 - k));
    }
}

/// The unit increments of path `index` from the public pieces alone: coordinate c of point
/// `index` of the scrambled Sobol' points, its normal, the bridge of component c % m.
fn path_from_the_pieces(seed: u64, r: u64, dim: usize, steps: usize, index: u32) -> Vec<f64> {
    let points = SobolPoints::scrambled(dim * steps, seed, r).unwrap();
    let bridge = BrownianBridge::new(steps).unwrap();
    let (mut out, mut w) = (vec![0.0; dim * steps], vec![0.0; steps + 1]);
    for j in 0..dim {
        let z: Vec<f64> = (0..steps)
            .map(|k| inverse_normal_cdf(points.coordinate(index, k * dim + j)))
            .collect();
        bridge.fill_path(&z, &mut w);
        for k in 0..steps {
            out[k * dim + j] = w[k + 1] - w[k];
        }
    }
    out
}

#[test]
fn paths_in_lanes_are_the_paths_one_at_a_time_at_every_width() {
    // The benchmark's paths (1024 steps, two components), indices out of order and up to
    // 2^32 - 1, a count that leaves padding lanes (which repeat the first path).
    let (dim, steps, r) = (2, 1024, 4);
    let quasi = QuasiBrownian::new(SEED, r, dim, steps).unwrap();
    let indices: Vec<u64> = vec![9, 0, 1, 2, 3, 1 << 20, 31, 5, 4_294_967_295, 64, 17];
    let stride = sdae_lanes::lane_stride(indices.len());
    let expected: Vec<Vec<f64>> = (0..stride)
        .map(|p| *indices.get(p).unwrap_or(&indices[0]))
        .map(|i| path_from_the_pieces(SEED, r, dim, steps, i as u32))
        .collect();
    let mut one = vec![0.0; dim * steps];
    for (p, want) in expected.iter().enumerate().take(indices.len()) {
        quasi.unit_increments(indices[p], &mut one).unwrap();
        assert!(
            one.iter()
                .zip(want)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "path {p}"
        );
    }
    for width in LaneWidth::ALL {
        let mut unit = vec![f64::NAN; dim * steps * stride];
        quasi.unit_ensemble(&indices, width, &mut unit).unwrap();
        for (p, want) in expected.iter().enumerate() {
            for (c, x) in want.iter().enumerate() {
                let got = unit[c * stride + p];
                assert_eq!(
                    got.to_bits(),
                    x.to_bits(),
                    "{width:?}, lane {p}, coordinate {c}"
                );
            }
        }
        let lanes = quasi.ensemble_with_width(&indices, width).unwrap();
        assert_eq!(lanes, quasi.ensemble(&indices).unwrap(), "{width:?}");
    }
}

#[test]
fn paths_in_lanes_refuse_bad_inputs_and_write_nothing() {
    let quasi = QuasiBrownian::new(SEED, 0, 2, 4).unwrap();
    let mut unit = vec![7.0; 2 * 4 * 8];
    assert_eq!(
        quasi.unit_ensemble(&[1, 1 << 32], LaneWidth::Best, &mut unit),
        Err(NoiseError::InvalidSetting {
            name: "path index",
            value: 4_294_967_296.0,
            reason: "quasi-random paths are points 0..2^32 of the Sobol' sequence",
        })
    );
    assert_eq!(
        quasi.unit_ensemble(&[1, 2], LaneWidth::Best, &mut unit[1..]),
        Err(NoiseError::DimensionMismatch {
            what: "increments of the paths (steps * dim * lane stride)",
            expected: 64,
            found: 63,
        })
    );
    assert!(unit.iter().all(|&x| x == 7.0));
    quasi.unit_ensemble(&[], LaneWidth::Best, &mut []).unwrap();
}
