//! The bootstrap over whole paths: statistics of per-path data resampled path by path, so that
//! everything a path carries (its values at every level and grid point) stays together and the
//! correlation between levels is kept. Resampling draws from a fixed stream: an interval is a
//! function of the data. A resample is held as counts per path, so that its means are dot
//! products streamed over the paths in order rather than gathers at random indices.

use rand::RngExt;
use sdae_manifold::vector::dot;
use sdae_noise::path_rng;

use sdae_stats::Interval;
use sdae_stats::bootstrap::{BOOTSTRAP_RESAMPLES, index, quantile};

/// Seed of the resampling stream.
const SEED: u64 = 0x5eed_3eac;

/// A sample of paths the statistics are computed on: all paths once (the estimate), or a
/// resample of n paths drawn with replacement, held as the number of times each path was
/// drawn, so that a mean over the sample is one dot product over the paths in their order
/// (streamed, not gathered path by path).
pub struct Resample<'a> {
    /// Per path, the times it was drawn (`None`: all paths once).
    counts: Option<&'a [f64]>,
}

impl Resample<'_> {
    /// All paths once: the sample the estimates are computed on.
    pub fn all() -> Self {
        Resample { counts: None }
    }

    /// The mean of `values` (one per path) over the sample.
    pub fn mean(&self, values: &[f64]) -> f64 {
        let sum = match self.counts {
            None => values.iter().sum::<f64>(),
            Some(counts) => dot(counts, values),
        };
        sum / values.len() as f64
    }
}

/// Statistics of `paths` paths with 95% percentile bootstrap intervals: `statistic` maps a
/// sample of the paths ([`Resample`]) to a vector of values, of the same length for every
/// sample; the estimate is its value on all paths, the interval the 2.5% and 97.5% quantiles
/// of its values over [`BOOTSTRAP_RESAMPLES`] resamples of n paths drawn with replacement. An
/// entry is `None` where the estimate is not finite or fewer than half of the resamples give a
/// finite value (say a slope over errors that vanish).
pub fn path_bootstrap(
    paths: usize, statistic: impl Fn(&Resample<'_>) -> Vec<f64>,
) -> Vec<Option<Interval>> {
    let estimate = statistic(&Resample::all());
    if paths < 2 {
        return vec![None; estimate.len()];
    }
    let mut rng = path_rng(SEED, paths as u64);
    let mut samples: Vec<Vec<f64>> = vec![Vec::with_capacity(BOOTSTRAP_RESAMPLES); estimate.len()];
    let mut counts = vec![0.0; paths];
    for _ in 0..BOOTSTRAP_RESAMPLES {
        counts.fill(0.0);
        for _ in 0..paths {
            counts[index(rng.random::<u64>(), paths)] += 1.0;
        }
        let resample = Resample {
            counts: Some(&counts),
        };
        for (s, x) in samples.iter_mut().zip(statistic(&resample)) {
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
        let mean = |sample: &Resample<'_>| vec![sample.mean(&values)];
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
