//! The expectation helper picks the estimator that the exact level variances say is cheaper,
//! and its interval covers the exact E[X_T] = e^(a T) of a scalar linear SDE.

use std::ops::Range;

use sdae_mlmc::expectation::Method;
use sdae_mlmc::{
    Expectation, ExpectationSettings, LevelSampler, MlmcError, RunControl, Sample, expectation,
};

use crate::linear::Linear;

/// The pairs of `Linear` with the coarse path on a stream of its own: the levels' differences
/// vary as much as two paths do, so MLMC cannot gain on standard Monte Carlo.
struct Independent(Linear);

impl Independent {
    /// The fine values of level `level`'s samples `indices` of `linear`.
    fn fine(
        linear: &Linear, worker: &mut <Linear as LevelSampler>::Worker, level: u32,
        indices: Range<u64>,
    ) -> Result<Vec<f64>, MlmcError> {
        Ok(linear
            .run_block(worker, level, indices, false)?
            .into_iter()
            .map(|s| match s {
                Sample::Value { fine, .. } => fine,
                other => panic!("a linear path does not fail: {other:?}"),
            })
            .collect())
    }
}

impl LevelSampler for Independent {
    type Worker = <Linear as LevelSampler>::Worker;
    fn worker(&self) -> Result<Self::Worker, MlmcError> {
        self.0.worker()
    }
    fn run_block(
        &self, worker: &mut Self::Worker, level: u32, indices: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        let fine = Self::fine(&self.0, worker, level, indices.clone())?;
        let coarse = if coupled && level > 0 {
            let other = self.0.with_seed(self.0.seed ^ 0x5eed);
            Self::fine(&other, worker, level - 1, indices)?
        } else {
            vec![0.0; fine.len()]
        };
        Ok(fine
            .into_iter()
            .zip(coarse)
            .map(|(fine, coarse)| Sample::Value { fine, coarse })
            .collect())
    }
    fn path_steps(&self, level: u32) -> u64 {
        self.0.path_steps(level)
    }
    fn pair_steps(&self, level: u32) -> u64 {
        self.0.pair_steps(level)
    }
}

fn settings(eps: f64) -> ExpectationSettings {
    ExpectationSettings {
        test_levels: 5,
        max_level: 10,
        ..ExpectationSettings::new(eps)
    }
}

/// The exact variance of P_l = X_N on level `level`'s fine path.
fn path_variance(linear: &Linear, level: u32) -> f64 {
    let (ef, _, ff, ..) = linear.moments(level);
    ff - ef * ef
}

/// The exact variance of P_l - P_{l-1} with the paths coupled (or independent).
fn difference_variance(linear: &Linear, level: u32, coupled: bool) -> f64 {
    if level == 0 {
        return path_variance(linear, 0);
    }
    if !coupled {
        return path_variance(linear, level) + path_variance(linear, level - 1);
    }
    let (ef, ec, ff, cc, fc) = linear.moments(level);
    ff - 2.0 * fc + cc - (ef - ec).powi(2)
}

/// The estimator the exact variances say is cheaper at accuracy `eps` on levels 0..=`top`:
/// MLMC's optimal work 2 eps^-2 (sum_l sqrt(V_l C_l))^2 against 2 V[P_L] / eps^2 paths of
/// C_L steps.
fn exact_verdict<L: LevelSampler>(
    sampler: &L, linear: &Linear, top: u32, eps: f64, coupled: bool,
) -> Method {
    let root_sum: f64 = (0..=top)
        .map(|l| (difference_variance(linear, l, coupled) * sampler.pair_steps(l) as f64).sqrt())
        .sum();
    let mlmc = 2.0 * root_sum * root_sum / (eps * eps);
    let standard = 2.0 * path_variance(linear, top) / (eps * eps) * sampler.path_steps(top) as f64;
    if standard < mlmc {
        Method::Standard
    } else {
        Method::Mlmc
    }
}

/// The estimate is within its bias bound plus 3.3 standard errors of e^(a T) (the 95% half
/// width is 1.96 standard errors).
fn assert_covers(found: &Expectation, linear: &Linear) {
    let exact = (linear.a * linear.t_end).exp();
    let i = &found.estimate;
    let se = (i.ci_high - i.ci_low) / (2.0 * 1.96);
    let miss = (i.estimate - exact).abs();
    assert!(
        miss <= found.bias.abs() + 3.3 * se,
        "{} misses e^(aT) = {exact} by {miss:e} (bias {:e}, se {se:e})",
        i.estimate,
        found.bias
    );
    assert!(found.converged);
    assert_eq!(found.failed, 0);
}

#[test]
fn coupled_levels_take_multilevel_monte_carlo() {
    let linear = Linear::ou(7);
    let eps = 5e-3;
    let control = RunControl::new(2).unwrap();
    let found = expectation(&linear, &control, &settings(eps)).unwrap();
    assert!(found.resolved, "the test's levels reach the bias");
    let mlmc = found.prediction(Method::Mlmc).unwrap();
    let standard = found.prediction(Method::Standard).unwrap();
    assert_eq!(found.method, Method::Mlmc);
    assert_eq!(
        found.method,
        exact_verdict(&linear, &linear, mlmc.level, eps, true)
    );
    assert!(standard.work > 2.0 * mlmc.work, "{standard:?} {mlmc:?}");
    assert_covers(&found, &linear);
    // The test stops at the first level whose bias estimate is within eps / sqrt(2).
    assert_eq!(found.test.len() as u32, mlmc.level + 1);
}

#[test]
fn independent_levels_take_standard_monte_carlo() {
    let linear = Linear::ou(11);
    let sampler = Independent(Linear::ou(11));
    let eps = 3e-2;
    let control = RunControl::new(2).unwrap();
    // The test must resolve the bias with levels as variable as two paths.
    let settings = ExpectationSettings {
        test_samples: 1 << 15,
        ..settings(eps)
    };
    let found = expectation(&sampler, &control, &settings).unwrap();
    assert!(found.resolved, "the test's levels reach the bias");
    let predicted = found.prediction(Method::Standard).unwrap();
    assert_eq!(found.method, Method::Standard);
    assert_eq!(
        found.method,
        exact_verdict(&sampler, &linear, predicted.level, eps, false)
    );
    let level = predicted.level as usize;
    assert!(found.samples[..level].iter().all(|&n| n == 0));
    assert!(found.samples[level] as f64 * 2f64.powi(1 + level as i32) >= predicted.work);
    assert_covers(&found, &linear);
}

#[test]
fn the_numbers_do_not_depend_on_the_threads() {
    let linear = Linear::ou(3);
    let one = expectation(&linear, &RunControl::new(1).unwrap(), &settings(1e-2)).unwrap();
    let two = expectation(&linear, &RunControl::new(2).unwrap(), &settings(1e-2)).unwrap();
    assert_eq!(one.estimate, two.estimate);
    assert_eq!(one.samples, two.samples);
}

#[test]
fn bad_accuracies_and_test_levels_are_refused() {
    let linear = Linear::ou(3);
    let control = RunControl::new(1).unwrap();
    for eps in [0.0, -1.0, f64::NAN] {
        let e = expectation(&linear, &control, &settings(eps)).unwrap_err();
        assert!(
            matches!(e, MlmcError::Setting { .. } | MlmcError::Eps { .. }),
            "{e:?}"
        );
    }
    let few = ExpectationSettings {
        test_levels: 1,
        ..settings(1e-2)
    };
    let e = expectation(&linear, &control, &few).unwrap_err();
    assert!(e.to_string().contains("levels 0..=2 at least"), "{e}");
}

/// The runs of 100 seeds whose interval, widened by the bias estimate, covers e^(a T); a 95%
/// interval covers in about 95 of them, and fewer than 90 (2.3 binomial standard deviations
/// below 95) means the interval or the bias is off.
fn covered<L: LevelSampler>(
    sampler: impl Fn(u64) -> L, exact: f64, settings: ExpectationSettings, method: Method,
) -> usize {
    let control = RunControl::new(2).unwrap();
    (0..100)
        .filter(|&seed| {
            let found = expectation(&sampler(1000 + seed), &control, &settings).unwrap();
            assert_eq!(found.method, method, "seed {seed}");
            let i = &found.estimate;
            let bias = found.bias.abs();
            i.ci_low - bias <= exact && exact <= i.ci_high + bias
        })
        .count()
}

#[test]
fn intervals_cover_the_exact_mean_in_at_least_90_of_100_runs() {
    let ou = Linear::ou(0);
    let exact = (ou.a * ou.t_end).exp();
    let n = covered(Linear::ou, exact, settings(2e-2), Method::Mlmc);
    assert!(n >= 90, "MLMC: {n} of 100 cover {exact}");
    // Levels as variable as two paths: the test needs more samples to resolve the bias.
    let resolved = ExpectationSettings {
        test_levels: 3,
        test_samples: 1 << 15,
        ..settings(6e-2)
    };
    let n = covered(
        |seed| Independent(Linear::ou(seed)),
        exact,
        resolved,
        Method::Standard,
    );
    assert!(n >= 90, "standard Monte Carlo: {n} of 100 cover {exact}");
}

/// Multiplicative noise makes X_T lognormal, heavy-tailed: dX = X dt / 20 + X dW / 2.
#[test]
fn intervals_cover_a_lognormal_mean_in_at_least_90_of_100_runs() {
    let gbm = |seed| Linear {
        a: 0.05,
        b: 0.5,
        multiplicative: true,
        t_end: 1.0,
        coarsest: 1,
        seed,
    };
    let exact = 0.05f64.exp();
    let n = covered(gbm, exact, settings(2e-2), Method::Mlmc);
    assert!(n >= 90, "{n} of 100 cover {exact}");
}
