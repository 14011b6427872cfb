//! E\[P\] to a requested root mean square accuracy eps by whichever of MLMC and standard Monte
//! Carlo a short convergence test predicts cheaper.
//!
//! The test runs a fixed number of pairs on levels 0..=L_test. From its means and variances,
//! [`plan_from_test`] gives the finest level L whose bias estimate is within eps / sqrt(2) and
//! the optimal N_l; MLMC is predicted to cost sum_l N_l C_l steps, and standard Monte Carlo on
//! level L to cost N C_L with N = 2 V\[P_L\] / eps^2 (the variance half of eps^2, as MLMC's)
//! and C_L the steps of one path. The cheaper one runs: Giles's adaptive algorithm
//! ([`adaptive`]), or N single paths on level L ([`standard_monte_carlo`]). Costs are counted in
//! steps, not seconds, so the choice is the same on every machine and thread count.

use serde::Serialize;

use crate::algorithm::{
    AdaptiveSettings, adaptive, bias_estimate, estimate_of, plan_from_test, run_plan,
    standard_monte_carlo, work_of,
};
use crate::error::{MlmcError, check_eps};
use crate::sampler::{LevelSampler, RunControl};
use crate::sums::{LevelStats, level_stats};
use sdae_stats::Interval;

/// What an expectation is asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpectationSettings {
    /// Root mean square accuracy eps.
    pub eps: f64,
    /// The convergence test runs levels 0..=this (at least 2).
    pub test_levels: u32,
    /// Pairs per level of the convergence test.
    pub test_samples: u64,
    /// Giles's N_0 for the adaptive algorithm.
    pub initial_samples: u64,
    /// The finest level the adaptive algorithm may add.
    pub max_level: u32,
}

/// The estimator that ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Multilevel Monte Carlo (Giles's adaptive algorithm).
    Mlmc,
    /// Standard Monte Carlo on one level.
    Standard,
}

/// The predicted work in steps of each estimator at one accuracy, from a convergence test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PredictedWork {
    /// The finest level whose bias estimate is within eps / sqrt(2).
    pub level: u32,
    /// sum_l N_l C_l with the optimal N_l.
    pub mlmc: f64,
    /// 2 V\[P_L\] / eps^2 paths (at least 2) of C_L steps each.
    pub standard: f64,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::Mlmc => "mlmc",
            Method::Standard => "standard",
        })
    }
}

impl PredictedWork {
    /// The estimator predicted cheaper (MLMC on a tie: its levels also estimate the bias).
    pub fn cheaper(&self) -> Method {
        if self.standard < self.mlmc {
            Method::Standard
        } else {
            Method::Mlmc
        }
    }
}

/// The predicted work of both estimators at accuracy `eps` from the convergence `test`; `None`
/// when the test's levels do not bring the bias estimate within eps / sqrt(2) (then only the
/// adaptive algorithm, which adds levels, can reach eps).
pub fn predicted_work<L: LevelSampler>(
    sampler: &L, test: &[LevelStats], eps: f64,
) -> Option<PredictedWork> {
    let plan = plan_from_test(sampler, test, eps).ok()?;
    let level = (plan.samples.len() - 1) as u32;
    let mlmc = plan
        .samples
        .iter()
        .enumerate()
        .map(|(l, &n)| n as f64 * sampler.pair_steps(l as u32) as f64)
        .sum();
    let paths = (2.0 * test[level as usize].var_p / (eps * eps)).max(2.0);
    Some(PredictedWork {
        level,
        mlmc,
        standard: paths.ceil() * sampler.path_steps(level) as f64,
    })
}

/// E\[P\] to accuracy eps, with how it was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Expectation {
    /// The accuracy asked for.
    pub eps: f64,
    /// The estimator that ran.
    pub method: Method,
    /// The estimate with its 95% interval from the sampling variance, an interval for
    /// E\[P_L\] (the bias is not in it: see `with_bias`).
    pub estimate: Interval,
    /// The interval for E\[P\]: `estimate` widened by `bias` on each side.
    pub with_bias: Interval,
    /// The bias estimate |E[P - P_L]| at the finest level L used.
    #[serde(with = "sdae_stats::json_f64")]
    pub bias: f64,
    /// False if the bias estimate exceeded eps / sqrt(2) at the finest level allowed.
    pub converged: bool,
    /// The finest level L used.
    pub level: u32,
    /// Samples per level 0..=L (standard Monte Carlo: 0 below L, its paths on L).
    pub samples: Vec<u64>,
    /// Samples whose path failed (their values are left out of the estimate).
    pub failed: u64,
    /// The work predicted from the test (`None` when its levels did not reach the bias).
    pub predicted: Option<PredictedWork>,
    /// Work of the convergence test, in steps.
    pub test_work: f64,
    /// Work of the run after the test, in steps.
    pub work: f64,
    /// Measured seconds of the test and the run, all threads together.
    pub seconds: f64,
    /// The convergence test, level by level.
    pub test: Vec<LevelStats>,
}

/// E\[P\] of `sampler`'s finest levels to accuracy `settings.eps`: the convergence test, then
/// the estimator it predicts cheaper ([`predicted_work`]); the adaptive algorithm when the
/// test's levels do not reach the bias.
pub fn expectation<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, settings: &ExpectationSettings,
) -> Result<Expectation, MlmcError> {
    let eps = check_eps(settings.eps)?;
    if settings.test_levels < 2 {
        return Err(MlmcError::Levels {
            reason: format!(
                "the convergence test needs levels 0..=2 at least to fit the bias, got 0..={}",
                settings.test_levels
            ),
        });
    }
    let samples = vec![settings.test_samples.max(2); settings.test_levels as usize + 1];
    let test_sums = run_plan(sampler, control, &samples)?;
    let test = level_stats(&test_sums, sampler);
    let test_work = work_of(sampler, &test_sums);
    let test_seconds: f64 = test_sums.iter().map(|s| s.seconds).sum();
    let predicted = predicted_work(sampler, &test, eps);
    let mut found = match predicted {
        Some(p) if p.cheaper() == Method::Standard => standard(sampler, control, &test, p, eps)?,
        _ => multilevel(sampler, control, settings, eps)?,
    };
    found.predicted = predicted;
    found.test_work = test_work;
    found.seconds += test_seconds;
    found.test = test;
    Ok(found)
}

/// Giles's adaptive algorithm at accuracy `eps`.
fn multilevel<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, settings: &ExpectationSettings, eps: f64,
) -> Result<Expectation, MlmcError> {
    let adaptive_settings = AdaptiveSettings::from_three_levels(
        eps,
        settings.initial_samples,
        settings.max_level.max(2),
    );
    let run = adaptive(sampler, control, &adaptive_settings)?;
    Ok(Expectation {
        eps,
        method: Method::Mlmc,
        estimate: run.estimate,
        with_bias: run.with_bias,
        bias: run.bias,
        converged: run.converged,
        level: (run.levels.len() - 1) as u32,
        samples: run.levels.iter().map(|s| s.attempted()).collect(),
        failed: run.levels.iter().map(|s| s.failed).sum(),
        predicted: None,
        test_work: 0.0,
        work: run.work,
        seconds: run.seconds,
        test: Vec::new(),
    })
}

/// Standard Monte Carlo on the level `predicted` names, with the paths it predicts.
fn standard<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, test: &[LevelStats], predicted: PredictedWork, eps: f64,
) -> Result<Expectation, MlmcError> {
    let level = predicted.level;
    let steps = sampler.path_steps(level);
    let paths = (predicted.standard / steps as f64).ceil() as u64;
    let sums = standard_monte_carlo(sampler, control, level, paths)?;
    let means: Vec<(f64, f64)> = test[..=level as usize]
        .iter()
        .map(|s| (s.mean_y, s.se_y))
        .collect();
    let mut samples = vec![0; level as usize + 1];
    samples[level as usize] = sums.attempted();
    let estimate = estimate_of(std::slice::from_ref(&sums));
    let bias = bias_estimate(&means).0;
    Ok(Expectation {
        eps,
        method: Method::Standard,
        estimate,
        with_bias: estimate.widened(bias),
        bias,
        converged: true,
        level,
        samples,
        failed: sums.failed,
        predicted: None,
        test_work: 0.0,
        work: sums.attempted() as f64 * steps as f64,
        seconds: sums.seconds,
        test: Vec::new(),
    })
}
