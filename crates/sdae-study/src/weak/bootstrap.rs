//! The bootstrap over whole paths: statistics of per-path data resampled path by path, so that
//! everything a path carries (its values at every level and grid point) stays together and the
//! correlation between levels is kept. Resampling draws from a fixed stream: an interval is a
//! function of the data.

use rand::RngExt;
use sdae_model::path_rng;

use crate::bootstrap::{BOOTSTRAP_RESAMPLES, index, quantile};
use crate::stats::Interval;

/// Seed of the resampling stream.
const SEED: u64 = 0x5eed_3eac;

/// Statistics of `paths` paths with 95% percentile bootstrap intervals: `statistic` maps the
/// indices of a sample of paths (with repetitions) to a vector of values, of the same length
/// for every sample; the estimate is its value on all paths (0..paths), the interval the 2.5%
/// and 97.5% quantiles of its values over [`BOOTSTRAP_RESAMPLES`] resamples of n paths drawn
/// with replacement. An entry is `None` where the estimate is not finite or fewer than half of
/// the resamples give a finite value (say a slope over errors that vanish).
pub fn path_bootstrap(
    paths: usize, statistic: impl Fn(&[usize]) -> Vec<f64>,
) -> Vec<Option<Interval>> {
    let all: Vec<usize> = (0..paths).collect();
    let estimate = statistic(&all);
    if paths < 2 {
        return vec![None; estimate.len()];
    }
    let mut rng = path_rng(SEED, paths as u64);
    let mut samples: Vec<Vec<f64>> = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); estimate.len()];
    let mut indices = vec![0; paths];
    for _ in 0..BOOTSTRAP_RESAMPLES {
        for i in &mut indices {
            *i = index(rng.random::<u64>(), paths);
        }
        for (s, x) in samples.iter_mut().zip(statistic(&indices)) {
            if x.is_finite() {
                s.push(x);
            }
        }
    }
    estimate
        .into_iter()
        .zip(samples)
        .map(|(estimate, mut s)| {
            if !estimate.is_finite() || s.len() < BOOTSTRAP_RESAMPLES / 2 {
                return None;
            }
            s.sort_by(f64::total_cmp);
            Some(Interval {
                estimate,
                ci_low: quantile(&s, 0.025),
                ci_high: quantile(&s, 0.975),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_of_a_normal_sample_gets_the_t_interval() {
        // Deterministic normal scores: the percentile interval of the mean is close to
        // mean +- 1.96 s / sqrt(n).
        let n = 2000;
        let values: Vec<f64> = (0..n)
            .map(|i| {
                let u = (i as f64 + 0.5) / n as f64;
                statrs::function::erf::erf_inv(2.0 * u - 1.0) * std::f64::consts::SQRT_2
            })
            .collect();
        let mean =
            |idx: &[usize]| vec![idx.iter().map(|&i| values[i]).sum::<f64>() / idx.len() as f64];
        let interval = path_bootstrap(n, mean)[0].unwrap();
        let half = 1.96 / (n as f64).sqrt();
        assert!(interval.estimate.abs() < 1e-12);
        // 400 resamples put the 2.5% quantile within about 15% of its value.
        for end in [-interval.ci_low, interval.ci_high] {
            assert!(
                (end / half - 1.0).abs() < 0.15,
                "{interval:?} against +-{half}"
            );
        }
    }
}
