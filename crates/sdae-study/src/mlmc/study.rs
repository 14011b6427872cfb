//! The MLMC study of a scene, as Giles's `mlmc_test` runs it: a convergence test (a fixed
//! number of samples on levels 0..=L) with its table and the fitted rates, then the adaptive
//! algorithm for each eps of a list (the complexity table), the savings against standard
//! Monte Carlo from the measured variances and the work per sample (the measured seconds
//! beside them), one direct standard Monte Carlo run for comparison (its work capped by the
//! MLMC part's), and the warnings.

use serde::{Deserialize, Serialize};

use super::coupled::CoupledSampler;
use super::settings::MlmcSpec;
use crate::convergence::{MAX_THREADS, MIN_STEP};
use crate::integrator::{SchemeKind, StudyScheme};
use crate::scene::{Prepared, Scene};
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::{
    AdaptiveSettings, MlmcEstimate, Plan, adaptive, check_counts, optimal_counts, run_plan,
    standard_monte_carlo, work_of,
};
use sdae_mlmc::error::{check_eps, samples_exceed_memory};
use sdae_mlmc::fit::{Rates, fit_rates};
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::sampler::{LevelSampler, RunControl};

use super::coarsest::{CoarsestMoved, first_level_that_runs};
use super::quasi::{QmcReport, QmcSettings, run_qmc};
use sdae_mlmc::sums::{LevelStats, level_stats};
use sdae_stats::Interval;

/// Kurtosis above which `mlmc_test` warns that a few rare paths dominate the level.
pub const KURTOSIS_WARNING: f64 = 100.0;

/// Everything an MLMC study of a scene runs with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlmcSettings {
    /// The scene's `[mlmc]` table (or its defaults) with the command line's changes.
    pub spec: MlmcSpec,
    /// Final time T.
    pub t_end: f64,
    /// Seed of the sample streams.
    pub seed: u64,
    /// Worker threads (the numbers do not depend on them).
    pub threads: usize,
    /// Giles's N_0: samples on a level when it is first run.
    pub initial_samples: u64,
    /// Run standard Monte Carlo directly at the largest eps, or at the accuracy the MLMC
    /// part's work affords (for the measured speed-up).
    pub standard_run: bool,
    /// Randomized quasi-Monte Carlo paths beside the MLMC runs (`--qmc`): multilevel QMC at
    /// every eps and single-level QMC beside the direct standard run ([`super::quasi`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qmc: Option<QmcSettings>,
}

/// The largest step exponent a level may have (2^24 steps per path).
pub const MAX_STEP_EXPONENT: u32 = 24;

/// The [`MlmcError::Setting`] refusing the setting `key` of `value` by `rule`.
fn setting<T>(key: &'static str, value: String, rule: String) -> Result<T, MlmcError> {
    Err(MlmcError::Setting { key, value, rule })
}

/// Refuses a final time whose smallest step T / 2^`finest` is below [`MIN_STEP`].
fn check_step(t_end: f64, finest: u32) -> Result<(), MlmcError> {
    let h = t_end / 2f64.powi(finest as i32);
    if h >= MIN_STEP {
        return Ok(());
    }
    Err(MlmcError::Setting {
        key: "T",
        value: format!("{t_end:e}"),
        rule: format!(
            "gives the step h = T / 2^{finest} = {h:e} on the finest level: every step must be at \
             least {MIN_STEP:e} (2^-511), else the squared differences of the levels underflow"
        ),
    })
}

impl MlmcSettings {
    /// The scene's settings (its `[mlmc]` table, or the defaults), seed 2026 and every core (at
    /// most [`MAX_THREADS`]).
    pub fn for_scene(scene: &Scene) -> Self {
        Self {
            spec: scene.mlmc.clone().unwrap_or_default(),
            t_end: scene.t_end,
            seed: 2026,
            threads: std::thread::available_parallelism()
                .map_or(1, |n| n.get())
                .min(MAX_THREADS),
            initial_samples: 1024,
            standard_run: true,
            qmc: None,
        }
    }

    /// A quick run for CI: two test levels fewer, 1024 test samples and the two largest eps.
    pub fn quick(mut self) -> Self {
        let s = &mut self.spec;
        s.test_levels = s.test_levels.saturating_sub(2).max(2);
        s.test_samples = s.test_samples.min(1024);
        s.eps.sort_by(|a, b| b.total_cmp(a));
        s.eps.truncate(2);
        self.initial_samples = self.initial_samples.min(256);
        self
    }

    /// Checks every setting before anything runs, naming a bad one by its scene-file key
    /// (`mlmc.coarsest`, `T`, `threads`): the accuracies (finite, at least
    /// [`MIN_EPS`](sdae_mlmc::error::MIN_EPS)), the levels (their step exponents summed in
    /// checked arithmetic, at most [`MAX_STEP_EXPONENT`]), the smallest step T / 2^(k0 + L_max)
    /// at least [`MIN_STEP`], the threads (at most [`MAX_THREADS`]), and the convergence
    /// test's samples within the memory available ([`samples_exceed_memory`]).
    pub fn validate(&self) -> Result<(), MlmcError> {
        if let Some(qmc) = &self.qmc {
            qmc.validate()?;
        }
        self.validate_eps_and_time()?;
        let finest = self.finest_exponent()?;
        check_step(self.t_end, finest)?;
        self.validate_test()?;
        if self.threads == 0 || self.threads > MAX_THREADS {
            return setting(
                "threads",
                self.threads.to_string(),
                format!("must be in 1..={MAX_THREADS}"),
            );
        }
        let s = &self.spec;
        if SchemeKind::from_name(&s.scheme).is_none() {
            return setting(
                "mlmc.scheme",
                s.scheme.clone(),
                format!(
                    "one of {}",
                    SchemeKind::ALL.map(SchemeKind::name).join(", ")
                ),
            );
        }
        Ok(())
    }

    /// Checks the accuracies (at least one, each as [`check_eps`] does) and the final time
    /// (finite and > 0).
    fn validate_eps_and_time(&self) -> Result<(), MlmcError> {
        let s = &self.spec;
        if s.eps.is_empty() {
            return setting("mlmc.eps", "[]".into(), "at least one accuracy".into());
        }
        for &eps in &s.eps {
            check_eps(eps)?;
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return setting(
                "T",
                self.t_end.to_string(),
                "the final time must be finite and > 0".into(),
            );
        }
        Ok(())
    }

    /// The step exponent k0 + L_max of the finest level, checked: level 0 on at least 2 steps
    /// and at most 2^[`MAX_STEP_EXPONENT`] (else `mlmc.coarsest` is refused), and the sum in
    /// checked arithmetic at most [`MAX_STEP_EXPONENT`] (else `mlmc.max_level`).
    fn finest_exponent(&self) -> Result<u32, MlmcError> {
        let s = &self.spec;
        if s.coarsest == 0 {
            return setting(
                "mlmc.coarsest",
                "0".into(),
                "level 0 must have at least 2 steps (coarsest >= 1): one step of the \
                 half-explicit schemes moves the position by h v_0 alone, so P_0 of a \
                 position observable has no variance and N_l ~ sqrt(V_l) gives level 0 \
                 no samples"
                    .into(),
            );
        }
        let reach = u64::from(s.coarsest) + u64::from(s.max_level);
        if s.coarsest > MAX_STEP_EXPONENT {
            return setting(
                "mlmc.coarsest",
                s.coarsest.to_string(),
                format!(
                    "level 0 on 2^{} steps is above the 2^{MAX_STEP_EXPONENT} steps per path a \
                     level may have (with levels 0..={} the finest would have 2^{reach} steps)",
                    s.coarsest, s.max_level
                ),
            );
        }
        let finest = s
            .coarsest
            .checked_add(s.max_level)
            .filter(|&k| k <= MAX_STEP_EXPONENT);
        let Some(finest) = finest else {
            return setting(
                "mlmc.max_level",
                s.max_level.to_string(),
                format!(
                    "the levels 0..={} on 2^{} steps at level 0 reach 2^{reach} steps per path \
                     at the finest, above 2^{MAX_STEP_EXPONENT}",
                    s.max_level, s.coarsest
                ),
            );
        };
        Ok(finest)
    }

    /// Checks the convergence test: at least 3 levels within L_max, at least 2 samples per
    /// level (of the test and initially), and its samples within the memory available.
    fn validate_test(&self) -> Result<(), MlmcError> {
        let s = &self.spec;
        if s.test_levels < 2 || s.test_levels > s.max_level {
            return setting(
                "mlmc.test_levels",
                s.test_levels.to_string(),
                format!(
                    "the convergence test's levels 0..={} must number at least 3 and stay \
                     within L_max = {}",
                    s.test_levels, s.max_level
                ),
            );
        }
        if s.test_samples < 2 || self.initial_samples < 2 {
            return setting(
                "mlmc.test_samples",
                s.test_samples.min(self.initial_samples).to_string(),
                "at least 2 samples per level".into(),
            );
        }
        let test = vec![s.test_samples as f64; s.test_levels as usize + 1];
        if let Some(rule) = samples_exceed_memory(&test, "the convergence test's levels") {
            return setting("mlmc.test_samples", s.test_samples.to_string(), rule);
        }
        Ok(())
    }

    /// Checks a plan against these settings before it runs, naming what is wrong by the plan's
    /// key: its eps as [`check_eps`] does, at least one level, at most
    /// [`MAX_STEP_EXPONENT`] - k0 levels above level 0 (so at most 2^24 steps per path), the
    /// smallest step T / 2^(k0 + L) at least [`MIN_STEP`], at least 2 samples per level, and
    /// all its samples within the memory available ([`samples_exceed_memory`]).
    pub fn validate_plan(&self, plan: &Plan) -> Result<(), MlmcError> {
        check_eps(plan.eps).map_err(|e| match e {
            MlmcError::Eps { value } => MlmcError::Setting {
                key: "plan.eps",
                value: value.to_string(),
                rule: "the accuracy must be finite and > 0".into(),
            },
            MlmcError::Setting { value, rule, .. } => MlmcError::Setting {
                key: "plan.eps",
                value,
                rule,
            },
            other => other,
        })?;
        let Some(top) = plan.samples.len().checked_sub(1) else {
            return setting("plan.samples", "[]".into(), "names no level".into());
        };
        let k0 = self.spec.coarsest;
        let finest = u32::try_from(top)
            .ok()
            .and_then(|l| k0.checked_add(l))
            .filter(|&k| k <= MAX_STEP_EXPONENT);
        let Some(finest) = finest else {
            return setting(
                "plan.samples",
                format!("{} levels", plan.samples.len()),
                format!(
                    "levels 0..={top} on 2^{k0} steps at level 0 reach 2^{} steps per path, \
                     above 2^{MAX_STEP_EXPONENT}: at most {} levels",
                    top as u64 + u64::from(k0),
                    MAX_STEP_EXPONENT.saturating_sub(k0) + 1
                ),
            );
        };
        check_step(self.t_end, finest)?;
        if let Some((l, n)) = plan.samples.iter().enumerate().find(|(_, n)| **n < 2) {
            return setting(
                "plan.samples",
                format!("{n} at level {l}"),
                "at least 2 samples per level".into(),
            );
        }
        let samples: Vec<f64> = plan.samples.iter().map(|&n| n as f64).collect();
        if let Some(rule) = samples_exceed_memory(&samples, "the plan's levels") {
            let total: u128 = plan.samples.iter().map(|&n| u128::from(n)).sum();
            return setting("plan.samples", format!("{total} in all"), rule);
        }
        Ok(())
    }

    /// [`Self::validate`], and the observable checked against the scene (its system has it,
    /// and the scene computes the outputs it reads): every input error before anything runs.
    pub fn validate_for(&self, scene: &Scene) -> Result<(), MlmcError> {
        self.validate()?;
        crate::observable::check(scene, &self.spec.observable)?;
        Ok(())
    }
}

/// One row of the complexity table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ComplexityRow {
    /// The adaptive run.
    pub run: MlmcEstimate,
    /// N_l attempted per level.
    pub samples: Vec<u64>,
    /// MLMC work in steps, sum_l N_l C_l with C_l the work per sample of level l.
    pub mlmc_work: f64,
    /// Standard Monte Carlo's work for the same eps on the finest level L: 2 V\[P_L\] / eps^2
    /// paths of 2^(k0 + L) steps.
    pub standard_work: f64,
    /// standard_work / mlmc_work.
    pub savings: f64,
    /// MLMC cost in seconds, sum_l N_l c_l with c_l the test's measured seconds per sample
    /// (beside the work: not used by anything).
    pub mlmc_cost: f64,
    /// Standard Monte Carlo's cost in seconds, its paths at the test's measured seconds per
    /// path.
    pub standard_cost: f64,
}

/// A direct standard Monte Carlo run next to the MLMC run of the largest eps.
///
/// Its work is capped by the MLMC part's (the convergence test and the adaptive runs, in
/// steps): it runs 2 V\[P_L\] / eps^2 paths of 2^(k0 + L) steps at the largest eps when that
/// work is within the cap, else at the accuracy the cap affords,
/// eps_run = eps sqrt(work(eps) / cap) (as many paths as the cap's steps allow). The cap
/// counts steps rather than seconds so that a resumed run makes the same choice as an
/// uninterrupted one; its predicted seconds, at the test's measured seconds per path on level
/// L (all threads together: the wall-clock time is at most that), are printed with it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StandardRun {
    /// The accuracy of the MLMC run compared (the largest of the list).
    pub target_eps: f64,
    /// The accuracy run: `target_eps`, or the larger one the cap affords.
    pub eps: f64,
    /// The level run (the MLMC run's finest).
    pub level: u32,
    /// Paths run, 2 V\[P_L\] / eps^2 rounded up to whole blocks.
    pub samples: u64,
    /// Paths that failed.
    pub failed: u64,
    /// E\[P_L\] with its 95% sampling interval (the bias is not in it: see `with_bias`).
    pub estimate: Interval,
    /// The bias estimate |E\[P - P_L\]| of level L: the MLMC run's at `target_eps`, whose
    /// finest level L is.
    pub bias: f64,
    /// The interval for E\[P\] the reports print: `estimate` widened by `bias` on each side.
    pub with_bias: Interval,
    /// Work in steps that standard Monte Carlo needs at `target_eps`.
    pub target_work: f64,
    /// The cap on the work: the MLMC part's steps.
    pub cap_work: f64,
    /// Predicted seconds at `target_eps`: its paths at the test's measured seconds per path
    /// (the seconds of all threads together, which bound the wall-clock time).
    pub predicted_seconds: f64,
    /// The cap in predicted seconds (all threads together).
    pub cap_seconds: f64,
    /// Measured seconds (all threads).
    pub seconds: f64,
    /// The MLMC run's measured seconds at `target_eps`.
    pub mlmc_seconds: f64,
    /// The measured seconds scaled to `target_eps` by the 1 / eps^2 law,
    /// seconds (eps / target_eps)^2, over mlmc_seconds.
    pub speedup: f64,
}

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

/// The sampler of a scene's system for `settings` (its scheme and observable checked).
pub fn sampler_for<S>(
    scene: &Scene, prepared: &Prepared<S>, settings: &MlmcSettings,
) -> Result<CoupledSampler<S>, MlmcError>
where
    S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
{
    settings.validate()?;
    let spec = &settings.spec;
    let kind = SchemeKind::from_name(&spec.scheme).expect("validated");
    let scheme = StudyScheme::built_in(kind, &prepared.system, &prepared.constants);
    scheme.build()?;
    let observable = crate::observable::built_in(scene, prepared, &spec.observable)?;
    Ok(CoupledSampler::new(
        scheme,
        (prepared.position.clone(), prepared.velocity.clone()),
        settings.t_end,
        spec.coarsest,
        observable,
        settings.seed,
        spec.antithetic,
    ))
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

/// Work to do with the level sampler of a scene, whatever its system's type.
pub trait SamplerTask {
    /// What the work returns.
    type Output;
    /// Does the work.
    fn run<L: LevelSampler + QuasiSampler>(self, sampler: &L) -> Result<Self::Output, MlmcError>;
}

/// Hands a [`SamplerTask`] the sampler of a scene's system.
struct WithSampler<'a, T> {
    settings: &'a MlmcSettings,
    task: T,
}

impl<T: SamplerTask> crate::scene::SceneRunner for WithSampler<'_, T> {
    type Output = Result<T::Output, MlmcError>;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
    {
        let sampler = sampler_for(scene, &prepared, self.settings)?;
        self.task.run(&sampler)
    }
}

/// Builds the scene's system and its sampler for `settings` and runs `task` with it.
pub fn with_sampler<T: SamplerTask>(
    scene: &Scene, settings: &MlmcSettings, task: T,
) -> Result<T::Output, MlmcError> {
    scene.run(WithSampler { settings, task })?
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

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> MlmcSettings {
        MlmcSettings::for_scene(&Scene::built_in("pendulum").unwrap())
    }

    fn key_of(e: MlmcError) -> &'static str {
        match e {
            MlmcError::Setting { key, .. } => key,
            other => panic!("not a setting: {other}"),
        }
    }

    #[test]
    fn settings_are_bounded_in_checked_arithmetic() {
        let mut s = settings();
        assert_eq!(s.validate(), Ok(()));
        s.spec.coarsest = u32::MAX;
        s.spec.max_level = 2;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("2^4294967297 steps"), "{err}");
        assert_eq!(key_of(err), "mlmc.coarsest");
        s.spec.coarsest = 20;
        s.spec.max_level = 12;
        assert_eq!(key_of(s.validate().unwrap_err()), "mlmc.max_level");
        s.spec.coarsest = 2;
        s.spec.max_level = u32::MAX;
        assert_eq!(key_of(s.validate().unwrap_err()), "mlmc.max_level");
        let mut s = settings();
        s.spec.test_samples = 1_000_000_000_000;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("available"), "{err}");
        assert_eq!(key_of(err), "mlmc.test_samples");
        let mut s = settings();
        s.threads = MAX_THREADS + 1;
        assert_eq!(key_of(s.validate().unwrap_err()), "threads");
        let mut s = settings();
        s.t_end = 5e-324;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("2^-511"), "{err}");
        assert_eq!(key_of(err), "T");
        s.t_end = MIN_STEP * 2f64.powi(14);
        assert_eq!(s.validate(), Ok(()));
        s.t_end /= 2.0;
        assert_eq!(key_of(s.validate().unwrap_err()), "T");
    }

    #[test]
    fn plans_are_checked_before_they_run() {
        let s = settings();
        let plan = |eps: f64, samples: Vec<u64>| Plan { eps, samples };
        assert_eq!(s.validate_plan(&plan(1e-2, vec![4096, 1024, 256])), Ok(()));
        let refused = |p: Plan, words: &[&str]| {
            let err = s.validate_plan(&p).unwrap_err();
            let message = err.to_string();
            for w in words {
                assert!(message.contains(w), "'{w}' not in {message}");
            }
        };
        refused(plan(1e-2, vec![]), &["plan.samples = []", "names no level"]);
        refused(
            plan(-1.0, vec![64; 3]),
            &["plan.eps = -1", "finite and > 0"],
        );
        refused(plan(f64::NAN, vec![64; 3]), &["plan.eps = NaN"]);
        refused(plan(1e-300, vec![64; 3]), &["plan.eps = 1e-300", "2^-511"]);
        refused(
            plan(1e-2, vec![64; 40]),
            &[
                "plan.samples = 40 levels",
                "at most 23 levels",
                "2^41 steps",
            ],
        );
        refused(plan(1e-2, vec![64, 1, 64]), &["1 at level 1", "at least 2"]);
        refused(
            plan(1e-2, vec![1_000_000_000_000_000_000, 64]),
            &["plan.samples", "in all", "available"],
        );
        refused(
            plan(1e-2, vec![u64::MAX; 23]),
            &["plan.samples", "available"],
        );
    }
}
