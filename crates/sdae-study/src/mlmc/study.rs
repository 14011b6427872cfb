//! The MLMC study of a scene, as Giles's `mlmc_test` runs it: a convergence test (a fixed
//! number of samples on levels 0..=L) with its table and the fitted rates, then the adaptive
//! algorithm for each eps of a list (the complexity table), the savings against standard
//! Monte Carlo from the measured variances and the work per sample (the measured seconds
//! beside them), one direct standard Monte Carlo run for comparison (its work capped by the
//! MLMC part's), and the warnings.

use serde::Serialize;

use super::coarsest::{CoarsestMoved, first_level_that_runs};
use super::quasi::{QmcReport, run_qmc};
use super::rows::{ComplexityRow, StandardRun};
use crate::scene::Scene;
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::{
    AdaptiveSettings, MlmcEstimate, adaptive, check_counts, optimal_counts, run_plan,
    standard_monte_carlo, work_of,
};
use sdae_mlmc::fit::{Rates, fit_rates};
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::sampler::{LevelSampler, RunControl, level_stats};
use sdae_mlmc::sums::LevelStats;

// The settings and the sampler a study runs with, also under the paths its callers use.
pub use super::run_settings::MlmcSettings;
pub use super::sampler::{SamplerTask, with_sampler};

/// Kurtosis above which `mlmc_test` warns that a few rare paths dominate the level.
pub const KURTOSIS_WARNING: f64 = 100.0;

/// The report of an MLMC study of one scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MlmcReport {
    /// The scene.
    pub scene: String,
    /// The scheme on both paths of each pair.
    pub scheme: String,
    /// The observable f of E[f(X_T)].
    pub observable: String,
    /// The settings.
    pub settings: MlmcSettings,
    /// The convergence test, level by level.
    pub test: Vec<LevelStats>,
    /// alpha, beta, gamma.
    pub rates: Rates,
    /// The adaptive runs, one per eps.
    pub complexity: Vec<ComplexityRow>,
    /// The direct standard Monte Carlo run at the largest eps (or what its cap affords).
    pub standard: Option<StandardRun>,
    /// Giles's warnings (kurtosis, consistency, weak convergence) and the failed paths.
    pub warnings: Vec<String>,
    /// The randomized QMC part (`--qmc`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub qmc: Option<QmcReport>,
    /// Level 0 moved to finer steps because the asked one did not run (then `settings` hold
    /// the levels run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarsest_moved: Option<CoarsestMoved>,
}

/// The measured seconds per sample of level l: the test's, or beyond its levels its finest
/// level's scaled by the work.
fn seconds_per_sample<L: LevelSampler>(sampler: &L, test: &[LevelStats], level: u32) -> f64 {
    match test.get(level as usize) {
        Some(s) => s.seconds_per_sample,
        None => {
            let last = test.last().expect("the test has levels");
            last.seconds_per_sample * sampler.pair_steps(level) as f64
                / sampler.pair_steps(last.level) as f64
        }
    }
}

/// The measured seconds of one path of level l alone (standard Monte Carlo): the test's per
/// sample, scaled by the work.
fn seconds_per_path<L: LevelSampler>(sampler: &L, test: &[LevelStats], level: u32) -> f64 {
    seconds_per_sample(sampler, test, level) * sampler.path_steps(level) as f64
        / sampler.pair_steps(level) as f64
}

/// V\[P_l\] from the test (its finest level's beyond it).
fn variance_of_p(test: &[LevelStats], level: u32) -> f64 {
    test.get(level as usize)
        .or(test.last())
        .map_or(f64::NAN, |s| s.var_p)
}

/// The complexity row of an adaptive run from the test's variances, the work per sample and
/// the measured seconds.
fn complexity_row<L: LevelSampler>(
    sampler: &L, test: &[LevelStats], run: MlmcEstimate,
) -> ComplexityRow {
    let samples: Vec<u64> = run.levels.iter().map(|s| s.attempted()).collect();
    let top = (samples.len() - 1) as u32;
    let mlmc_cost = samples
        .iter()
        .enumerate()
        .map(|(l, &n)| n as f64 * seconds_per_sample(sampler, test, l as u32))
        .sum::<f64>();
    // Two paths at least, as the direct run takes: a variance of 0 (a final time so short
    // that every path ends where it started) would make standard Monte Carlo free.
    let paths = (2.0 * variance_of_p(test, top) / (run.eps * run.eps)).max(2.0);
    let standard_work = paths * sampler.path_steps(top) as f64;
    ComplexityRow {
        samples,
        mlmc_work: run.work,
        standard_work,
        savings: standard_work / run.work,
        mlmc_cost,
        standard_cost: paths * seconds_per_path(sampler, test, top),
        run,
    }
}

/// Giles's warnings and the failures.
fn warnings(test: &[LevelStats], complexity: &[ComplexityRow]) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(last) = test.last()
        && last.kurtosis > KURTOSIS_WARNING
    {
        out.push(format!(
            "kurtosis on the finest level {} is {:.1} > {KURTOSIS_WARNING}: the correction is \
             dominated by a few rare paths and its variance estimate is unreliable",
            last.level, last.kurtosis
        ));
    }
    if let Some(worst) = test
        .iter()
        .max_by(|a, b| a.consistency.total_cmp(&b.consistency))
        && worst.consistency > 1.0
    {
        out.push(format!(
            "consistency check on level {} is {:.2} > 1: E[P_l - P_l-1] = E[P_l] - E[P_l-1] is \
             not satisfied (the coarse path of a pair does not have level l-1's law)",
            worst.level, worst.consistency
        ));
    }
    for s in test.iter().filter(|s| s.failed_fine + s.failed_coarse > 0) {
        out.push(format!(
            "convergence test, level {}: {} fine and {} coarse paths failed (those samples are \
             left out of the sums and counted here)",
            s.level, s.failed_fine, s.failed_coarse
        ));
    }
    for row in complexity {
        let r = &row.run;
        if !r.converged {
            out.push(format!(
                "eps = {}: failed to achieve weak convergence: the bias estimate {:.3e} exceeds \
                 eps / sqrt(2) at L_max = {}",
                r.eps,
                r.bias,
                r.levels.len() - 1
            ));
        }
        for (l, s) in r.levels.iter().enumerate() {
            if s.failed > 0 {
                out.push(format!(
                    "eps = {}, level {l}: {} fine and {} coarse paths failed",
                    r.eps, s.failed_fine, s.failed_coarse
                ));
            }
        }
    }
    out
}

/// The whole study with any level sampler: the convergence test, the adaptive runs, the
/// direct standard Monte Carlo run and the warnings (`scene` names the report).
pub fn run_study<L: LevelSampler>(
    scene: &str, sampler: &L, settings: &MlmcSettings, control: &RunControl<'_>,
) -> Result<MlmcReport, MlmcError> {
    settings.validate()?;
    let spec = &settings.spec;
    let test_sums = run_plan(
        sampler,
        control,
        &vec![spec.test_samples; spec.test_levels as usize + 1],
    )?;
    let test = level_stats(&test_sums, sampler);
    let rates = fit_rates(&test, 1);
    check_accuracies(sampler, &test, &spec.eps)?;
    let mut complexity = Vec::with_capacity(spec.eps.len());
    for &eps in &spec.eps {
        let adaptive_settings =
            AdaptiveSettings::from_three_levels(eps, settings.initial_samples, spec.max_level);
        let run = adaptive(sampler, control, &adaptive_settings)?;
        complexity.push(complexity_row(sampler, &test, run));
    }
    let standard = if settings.standard_run {
        let cap_work = complexity
            .iter()
            .fold(work_of(sampler, &test_sums), |work, row| {
                work + row.run.work
            });
        Some(standard_run(
            sampler,
            control,
            &test,
            &complexity,
            cap_work,
        )?)
    } else {
        None
    };
    Ok(MlmcReport {
        scene: scene.into(),
        scheme: spec.scheme.clone(),
        observable: spec.observable.clone(),
        settings: settings.clone(),
        warnings: warnings(&test, &complexity),
        test,
        rates,
        complexity,
        standard,
        qmc: None,
        coarsest_moved: None,
    })
}

/// [`run_study`], and with `settings.qmc` its randomized QMC part ([`run_qmc`]): MLQMC at
/// every eps, and single-level QMC beside the direct standard run within its cap.
/// ([`run_study`] alone leaves `settings.qmc` aside: a [`LevelSampler`] has no quasi-random
/// paths.)
pub fn run_study_quasi<L: LevelSampler + QuasiSampler>(
    scene: &str, sampler: &L, settings: &MlmcSettings, control: &RunControl<'_>,
) -> Result<MlmcReport, MlmcError> {
    let mut report = run_study(scene, sampler, settings, control)?;
    if let Some(qmc) = &settings.qmc {
        let beside = report.standard.as_ref().map(|run| (run, run.cap_work));
        report.qmc = Some(run_qmc(
            sampler,
            settings,
            qmc,
            control,
            &report.complexity,
            beside,
        )?);
    }
    Ok(report)
}

/// Refuses, before the adaptive runs, an accuracy whose samples cannot fit in memory: the
/// optimal N_l of the levels 0..=2 every adaptive run starts with, from the convergence test's
/// variances (a lower bound of what the run takes: more levels only raise the counts).
fn check_accuracies<L: LevelSampler>(
    sampler: &L, test: &[LevelStats], eps: &[f64],
) -> Result<(), MlmcError> {
    let first = &test[..test.len().min(3)];
    let variances: Vec<f64> = first.iter().map(|s| s.var_y).collect();
    if !variances.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    let costs: Vec<f64> = (0..first.len())
        .map(|l| sampler.pair_steps(l as u32) as f64)
        .collect();
    for &eps in eps {
        check_counts(&optimal_counts(&variances, &costs, eps), eps)?;
    }
    Ok(())
}

/// The direct standard Monte Carlo run at the largest eps of `complexity`, its work capped by
/// `cap_work` steps (see [`StandardRun`]).
fn standard_run<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, test: &[LevelStats], complexity: &[ComplexityRow],
    cap_work: f64,
) -> Result<StandardRun, MlmcError> {
    let row = complexity
        .iter()
        .max_by(|a, b| a.run.eps.total_cmp(&b.run.eps))
        .expect("at least one eps");
    let level = (row.samples.len() - 1) as u32;
    let target_eps = row.run.eps;
    let steps = sampler.path_steps(level) as f64;
    let paths = (2.0 * variance_of_p(test, level) / (target_eps * target_eps)).max(2.0);
    let target_work = paths * steps;
    let (eps, paths) = if target_work <= cap_work {
        (target_eps, paths)
    } else {
        (
            target_eps * (target_work / cap_work).sqrt(),
            (cap_work / steps).max(2.0),
        )
    };
    let sums = standard_monte_carlo(sampler, control, level, paths.ceil() as u64)?;
    let per_step = seconds_per_path(sampler, test, level) / steps;
    let estimate = sdae_mlmc::algorithm::estimate_of(std::slice::from_ref(&sums));
    Ok(StandardRun {
        target_eps,
        eps,
        level,
        samples: sums.attempted(),
        failed: sums.failed,
        estimate,
        bias: row.run.bias,
        with_bias: estimate.widened(row.run.bias),
        target_work,
        cap_work,
        predicted_seconds: target_work * per_step,
        cap_seconds: cap_work * per_step,
        seconds: sums.seconds,
        mlmc_seconds: row.run.seconds,
        speedup: sums.seconds * (eps / target_eps).powi(2) / row.run.seconds,
    })
}

/// The whole study of a scene ([`run_study_quasi`] with its sampler), level 0 on the first
/// step count that runs ([`first_level_that_runs`]; the move is the report's first warning).
pub fn run_mlmc(
    scene: &Scene, settings: &MlmcSettings, control: &RunControl<'_>,
) -> Result<MlmcReport, MlmcError> {
    settings.validate_for(scene)?;
    let (settings, moved) = first_level_that_runs(scene, settings)?;
    let mut report = run_mlmc_as_set(scene, &settings, control)?;
    if let Some(moved) = moved {
        report.warnings.insert(0, moved.describe());
        report.coarsest_moved = Some(moved);
    }
    Ok(report)
}

/// The whole study of a scene on the levels `settings` set.
fn run_mlmc_as_set(
    scene: &Scene, settings: &MlmcSettings, control: &RunControl<'_>,
) -> Result<MlmcReport, MlmcError> {
    struct Study<'a, 'b> {
        name: &'a str,
        settings: &'a MlmcSettings,
        control: &'a RunControl<'b>,
    }
    impl SamplerTask for Study<'_, '_> {
        type Output = MlmcReport;
        fn run<L: LevelSampler + QuasiSampler>(self, sampler: &L) -> Result<MlmcReport, MlmcError> {
            run_study_quasi(self.name, sampler, self.settings, self.control)
        }
    }
    with_sampler(
        scene,
        settings,
        Study {
            name: &scene.name,
            settings,
            control,
        },
    )
}
