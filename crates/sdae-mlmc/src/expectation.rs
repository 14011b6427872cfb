//! E\[P\] to a requested root mean square accuracy eps by whichever of standard Monte Carlo,
//! randomized QMC, MLMC and multilevel QMC a short pilot predicts cheapest.
//!
//! The pilot is the convergence test: `test_samples` pairs on levels 0..=2, then one level more
//! while the bias estimate ([`bias_estimate`]) exceeds eps / sqrt(2), up to `test_levels`. Its
//! finest level L is the one the bias needs (when the test resolved it). For a sampler of
//! quasi-random paths ([`expectation_quasi`]) a QMC pilot follows: R randomizations of
//! n_0 / 8, n_0 / 4, n_0 / 2 and n_0 points on levels 0..=L, whose variances give each level's decay
//! rate. From both, [`predict`] gives the work (steps) and the seconds (at the measured
//! seconds per step of each kind of path) of every estimator; the cheapest by the measure asked
//! ([`CostMeasure`]) runs:
//!
//! - MLMC: Giles's adaptive algorithm ([`adaptive`]);
//! - standard Monte Carlo: the predicted paths on level L ([`standard_monte_carlo`]);
//! - MLQMC: the adaptive algorithm of Giles and Waterhouse carried on from the QMC pilot's
//!   levels ([`mlqmc_from`]);
//! - randomized QMC: R randomizations of the predicted points on level L, doubled until the
//!   variance of the estimate is at most eps^2 / 2.
//!
//! Where the test's levels do not resolve the bias, only the multilevel methods (which add
//! levels) are offered, compared on the test's levels. The QMC pilot is left out where MLMC's
//! or standard Monte Carlo's predicted work is already below the least work a QMC method can
//! take (R n_0 points on each level it runs). Single-level methods widen their interval by the
//! test's bias estimate at L; the multilevel ones by their own.

pub mod predict;

use serde::Serialize;

use crate::algorithm::{
    AdaptiveSettings, adaptive, bias_estimate, estimate_of, standard_monte_carlo, work_of,
};
use crate::error::{MlmcError, check_eps};
use crate::qmc::adaptive::doubled;
use crate::qmc::{MlqmcEstimate, QuasiLevel, QuasiSampler, QuasiSettings, mlqmc, mlqmc_from};
use crate::sampler::{LevelSampler, RunControl, level_stats};
use crate::sums::{LevelStats, LevelSums};
pub use predict::{CostMeasure, Method, PilotLevel, Prediction, cheapest};
use sdae_stats::Interval;

/// What an expectation is asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpectationSettings {
    /// Root mean square accuracy eps.
    pub eps: f64,
    /// The convergence test runs levels 0..=2 and adds levels up to this one (at least 2)
    /// while the bias needs them.
    pub test_levels: u32,
    /// Pairs per level of the convergence test.
    pub test_samples: u64,
    /// Giles's N_0 for the adaptive algorithm.
    pub initial_samples: u64,
    /// The finest level the adaptive algorithms may add.
    pub max_level: u32,
    /// Randomizations R of the QMC methods (at least 2).
    pub randomizations: u32,
    /// Points n_0 of each randomization when an MLQMC level is first run, and the QMC
    /// pilot's largest (a power of two).
    pub initial_points: u64,
    /// What the cheapest is judged by.
    pub by: CostMeasure,
    /// Run this estimator whatever the prediction (`None`: the cheapest).
    pub method: Option<Method>,
}

impl ExpectationSettings {
    /// Accuracy `eps` with a test of 4096 pairs on up to levels 0..=6, N_0 = 1024, L_max = 12,
    /// R = 32 randomizations of n_0 = 32 points, picked by work.
    pub fn new(eps: f64) -> Self {
        Self {
            eps,
            test_levels: 6,
            test_samples: 4096,
            initial_samples: 1024,
            max_level: 12,
            randomizations: 32,
            initial_points: 32,
            by: CostMeasure::Work,
            method: None,
        }
    }
}

/// E\[P\] to accuracy eps, with how it was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Expectation {
    /// The accuracy asked for.
    pub eps: f64,
    /// The estimator that ran.
    pub method: Method,
    /// Whether it was asked for (`settings.method`) rather than predicted cheapest.
    pub asked: bool,
    /// What the cheapest was judged by.
    pub by: CostMeasure,
    /// The estimate with its 95% interval from the sampling variance (a t interval over the
    /// randomizations for the QMC methods), an interval for E\[P_L\] (the bias is not in it:
    /// see `with_bias`).
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
    /// Samples per level 0..=L (single-level methods: 0 below L); for the QMC methods the
    /// points n_l of each randomization.
    pub samples: Vec<u64>,
    /// Randomizations R of a QMC method.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub randomizations: Option<u32>,
    /// Samples whose path failed (their values are left out of the estimate).
    pub failed: u64,
    /// Whether the convergence test's levels brought the bias estimate within eps / sqrt(2)
    /// (else only the multilevel methods were offered).
    pub resolved: bool,
    /// The predicted cost of every estimator (empty when one was asked for without a pilot).
    pub predicted: Vec<Prediction>,
    /// Work of the pilot (the convergence test and the QMC pilot), in steps.
    pub test_work: f64,
    /// Work of the run after the pilot, in steps.
    pub work: f64,
    /// Measured seconds of the pilot and the run, all threads together.
    pub seconds: f64,
    /// The convergence test, level by level.
    pub test: Vec<LevelStats>,
    /// The QMC pilot, level by level (empty when it did not run).
    pub quasi_pilot: Vec<PilotLevel>,
}

impl Expectation {
    /// The prediction of `method`, if one was made.
    pub fn prediction(&self, method: Method) -> Option<&Prediction> {
        self.predicted.iter().find(|p| p.method == method)
    }
}

/// What the QMC estimators need of a [`QuasiSampler`], without its type.
trait QuasiOps: Sync {
    /// Runs points up to `points` of every randomization of `q`.
    fn extend(
        &self, q: &mut QuasiLevel, control: &RunControl<'_>, points: u64, coupled: bool,
    ) -> Result<(), MlmcError>;
    /// Steps of one path of level l (`coupled = false`) or of a pair.
    fn steps(&self, level: u32, coupled: bool) -> u64;
    /// Points per randomized sequence.
    fn max_points(&self) -> u64;
    /// MLQMC from scratch, or carried on from `levels` when they are given.
    fn mlqmc(
        &self, control: &RunControl<'_>, settings: &QuasiSettings, levels: Option<Vec<QuasiLevel>>,
    ) -> Result<MlqmcEstimate, MlmcError>;
}

impl<Q: QuasiSampler> QuasiOps for Q {
    fn extend(
        &self, q: &mut QuasiLevel, control: &RunControl<'_>, points: u64, coupled: bool,
    ) -> Result<(), MlmcError> {
        q.extend_to(self, control, points, coupled)
    }
    fn steps(&self, level: u32, coupled: bool) -> u64 {
        if coupled {
            self.pair_steps(level)
        } else {
            self.path_steps(level)
        }
    }
    fn max_points(&self) -> u64 {
        QuasiSampler::max_points(self)
    }
    fn mlqmc(
        &self, control: &RunControl<'_>, settings: &QuasiSettings, levels: Option<Vec<QuasiLevel>>,
    ) -> Result<MlqmcEstimate, MlmcError> {
        match levels {
            Some(levels) => mlqmc_from(self, control, settings, levels),
            None => mlqmc(self, control, settings),
        }
    }
}

/// E\[P\] of `sampler`'s finest levels to accuracy `settings.eps` by MLMC or standard Monte
/// Carlo, whichever the convergence test predicts cheaper (the sampler has no quasi-random
/// paths: the QMC methods are not offered).
pub fn expectation<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, settings: &ExpectationSettings,
) -> Result<Expectation, MlmcError> {
    choose(sampler, None, control, settings)
}

/// E\[P\] of `sampler`'s finest levels to accuracy `settings.eps` by whichever of standard
/// Monte Carlo, randomized QMC, MLMC and MLQMC the pilot predicts cheapest (see the module's
/// documentation).
pub fn expectation_quasi<Q: LevelSampler + QuasiSampler>(
    sampler: &Q, control: &RunControl<'_>, settings: &ExpectationSettings,
) -> Result<Expectation, MlmcError> {
    choose(sampler, Some(sampler), control, settings)
}

/// Checks the settings: eps, the test's levels, the QMC design; returns eps.
fn check_settings(settings: &ExpectationSettings, quasi: bool) -> Result<f64, MlmcError> {
    let eps = check_eps(settings.eps)?;
    if settings.test_levels < 2 {
        return Err(MlmcError::Levels {
            reason: format!(
                "the convergence test needs levels 0..=2 at least to fit the bias, got 0..={}",
                settings.test_levels
            ),
        });
    }
    if let Some(m) = settings.method.filter(|m| m.quasi() && !quasi) {
        return Err(MlmcError::Setting {
            key: "expect.method",
            value: m.to_string(),
            rule: "this sampler has no quasi-random paths".into(),
        });
    }
    if quasi {
        crate::qmc::level::check_design(
            settings.randomizations,
            settings.initial_points,
            "mlqmc.initial_points",
        )?;
    }
    Ok(eps)
}

/// The pilot: the convergence test and, for a QMC method, the QMC pilot.
struct Pilot {
    /// The test's statistics, levels 0..=L.
    test: Vec<LevelStats>,
    /// Whether the test resolved the bias at eps.
    resolved: bool,
    /// Every estimator's prediction, in the order of [`Method::ALL`].
    predicted: Vec<Prediction>,
    /// The QMC pilot's levels (empty when it did not run).
    quasi: Vec<QuasiLevel>,
    /// Its records.
    records: Vec<PilotLevel>,
    /// Work (steps) and seconds (all threads) of the test and the QMC pilot.
    work: f64,
    seconds: f64,
}

/// The convergence test, the QMC pilot where it may pay, and every prediction.
fn pilot<L: LevelSampler>(
    sampler: &L, quasi: Option<&dyn QuasiOps>, control: &RunControl<'_>,
    settings: &ExpectationSettings, eps: f64,
) -> Result<Pilot, MlmcError> {
    let (test_sums, resolved) = convergence_test(sampler, control, settings, eps)?;
    let test = level_stats(&test_sums, sampler);
    let mut predicted = pseudo_predictions(sampler, &test, resolved, eps);
    let wants_quasi = matches!(settings.method, None | Some(Method::Rqmc));
    let (quasi_predicted, levels, records) = match quasi {
        Some(q) if wants_quasi => {
            quasi_predictions(q, control, settings, &test, resolved, &predicted)?
        }
        _ => (no_quasi(&test, quasi.is_some()), Vec::new(), Vec::new()),
    };
    predicted.extend(quasi_predicted);
    predicted.sort_by_key(|p| Method::ALL.iter().position(|m| *m == p.method));
    let quasi_work: f64 = levels.iter().map(|q| q.work).sum();
    let quasi_seconds: f64 = levels.iter().map(QuasiLevel::seconds).sum();
    Ok(Pilot {
        work: work_of(sampler, &test_sums) + quasi_work,
        seconds: test_sums.iter().map(|s| s.seconds).sum::<f64>() + quasi_seconds,
        test,
        resolved,
        predicted,
        quasi: levels,
        records,
    })
}

/// The pilot, the prediction and the run of the estimator picked (or asked for).
fn choose<L: LevelSampler>(
    sampler: &L, quasi: Option<&dyn QuasiOps>, control: &RunControl<'_>,
    settings: &ExpectationSettings,
) -> Result<Expectation, MlmcError> {
    let eps = check_settings(settings, quasi.is_some())?;
    if let Some(method @ (Method::Mlmc | Method::Mlqmc)) = settings.method {
        // The multilevel methods find their levels themselves: no pilot.
        let mut found = match (method, quasi) {
            (Method::Mlqmc, Some(q)) => multilevel_quasi(q, control, settings, eps, None)?,
            _ => multilevel(sampler, control, settings, eps)?,
        };
        found.asked = true;
        found.by = settings.by;
        return Ok(found);
    }
    let mut pilot = pilot(sampler, quasi, control, settings, eps)?;
    let pick = match settings.method {
        Some(m) => pilot.predicted.iter().find(|p| p.method == m && p.offered),
        None => cheapest(&pilot.predicted, settings.by),
    };
    let Some(pick) = pick.cloned() else {
        return Err(MlmcError::Levels {
            reason: not_offered(&pilot.predicted, settings.method),
        });
    };
    let levels = std::mem::take(&mut pilot.quasi);
    let carried: (f64, f64) = match pick.method {
        // MLQMC carries on from the QMC pilot's levels: their work is the pilot's.
        Method::Mlqmc => (
            levels.iter().map(|q| q.work).sum(),
            levels.iter().map(QuasiLevel::seconds).sum(),
        ),
        _ => (0.0, 0.0),
    };
    let mut found = match (pick.method, quasi) {
        (Method::Standard, _) => standard(sampler, control, &pilot.test, &pick, eps)?,
        (Method::Mlmc, _) | (_, None) => multilevel(sampler, control, settings, eps)?,
        (Method::Mlqmc, Some(q)) => multilevel_quasi(q, control, settings, eps, Some(levels))?,
        (Method::Rqmc, Some(q)) => single_quasi(q, control, settings, &pilot.test, &pick)?,
    };
    found.asked = settings.method.is_some();
    found.by = settings.by;
    found.resolved = pilot.resolved;
    found.predicted = pilot.predicted;
    found.work -= carried.0;
    found.seconds += pilot.seconds - carried.1;
    found.test_work = pilot.work;
    found.test = pilot.test;
    found.quasi_pilot = pilot.records;
    Ok(found)
}

/// Why no estimator could run.
fn not_offered(predicted: &[Prediction], asked: Option<Method>) -> String {
    let why: Vec<String> = predicted
        .iter()
        .filter(|p| asked.is_none_or(|m| m == p.method))
        .map(|p| format!("{}: {}", p.method, p.note))
        .collect();
    format!(
        "no estimator can reach the accuracy asked: {}",
        why.join("; ")
    )
}

/// The convergence test: levels 0..=2, then one more while the bias estimate of the levels run
/// exceeds eps / sqrt(2), up to `settings.test_levels`. Returns the sums and whether the bias
/// was resolved.
fn convergence_test<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, settings: &ExpectationSettings, eps: f64,
) -> Result<(Vec<LevelSums>, bool), MlmcError> {
    let n = settings.test_samples.max(2);
    let mut sums = Vec::new();
    loop {
        let level = sums.len() as u32;
        let mut s = LevelSums::default();
        control.extend(sampler, level, &mut s, 0, n, true)?;
        sums.push(s);
        if sums.len() < 3 {
            continue;
        }
        let means: Vec<(f64, f64)> = level_stats(&sums, sampler)
            .iter()
            .map(|s| (s.mean_y, s.se_y))
            .collect();
        let resolved = bias_estimate(&means).0 <= eps / 2f64.sqrt();
        if resolved || level >= settings.test_levels {
            return Ok((sums, resolved));
        }
    }
}

/// The predictions of MLMC and standard Monte Carlo from the test.
fn pseudo_predictions<L: LevelSampler>(
    sampler: &L, test: &[LevelStats], resolved: bool, eps: f64,
) -> Vec<Prediction> {
    let top = (test.len() - 1) as u32;
    let mut mlmc = predict::mlmc(test, eps);
    let standard = if resolved {
        predict::standard(test, sampler.path_steps(top), eps)
    } else {
        mlmc.note = format!(
            "on the test's levels 0..={top}, which do not resolve the bias: a lower bound (the \
             adaptive algorithm adds levels)"
        );
        Prediction::not_offered(Method::Standard, top, unresolved(top))
    };
    vec![mlmc, standard]
}

/// Why a single-level method is not offered when the test did not resolve the bias.
fn unresolved(top: u32) -> String {
    format!(
        "the test's levels 0..={top} do not bring the bias estimate within eps / sqrt(2), so \
         the level one path needs is not known (test more levels)"
    )
}

/// The QMC methods' entries for a sampler without quasi-random paths (`has_quasi` false) or
/// when they were not asked for.
fn no_quasi(test: &[LevelStats], has_quasi: bool) -> Vec<Prediction> {
    let top = (test.len() - 1) as u32;
    let note = if has_quasi {
        "not asked for"
    } else {
        "the sampler has no quasi-random paths"
    };
    [Method::Mlqmc, Method::Rqmc]
        .map(|m| Prediction::not_offered(m, top, note.into()))
        .to_vec()
}

/// The QMC methods' predictions with the pilot's levels and records.
type QuasiPredictions = (Vec<Prediction>, Vec<QuasiLevel>, Vec<PilotLevel>);

/// The predictions of MLQMC and randomized QMC, from a QMC pilot on the test's levels unless
/// MLMC or standard Monte Carlo is predicted to cost less than the least a QMC method takes.
fn quasi_predictions(
    q: &dyn QuasiOps, control: &RunControl<'_>, settings: &ExpectationSettings,
    test: &[LevelStats], resolved: bool, pseudo: &[Prediction],
) -> Result<QuasiPredictions, MlmcError> {
    let top = (test.len() - 1) as u32;
    let (r, n0) = (settings.randomizations, settings.initial_points);
    let least = |steps: u64| f64::from(r) * n0 as f64 * steps as f64;
    let multilevel_least: f64 = (0..=top).map(|l| least(q.steps(l, true))).sum();
    let single_least = least(q.steps(top, false));
    let best = cheapest(pseudo, CostMeasure::Work).map_or(f64::INFINITY, |p| p.work);
    if best <= multilevel_least.min(single_least) && settings.method.is_none() {
        let note = |least: f64| {
            format!(
                "not piloted: its least work, R n_0 = {} points per level or {least:.3e} steps, \
                 exceeds the {best:.3e} steps predicted for a pseudo-random method",
                u64::from(r) * n0
            )
        };
        let skipped = vec![
            Prediction::not_offered(Method::Mlqmc, top, note(multilevel_least)),
            Prediction::not_offered(Method::Rqmc, top, note(single_least)),
        ];
        return Ok((skipped, Vec::new(), Vec::new()));
    }
    let (levels, records) = quasi_pilot(q, control, settings, top)?;
    let max = q.max_points();
    let rqmc = if resolved {
        predict::rqmc(&records, r, max, settings.eps)
    } else {
        Prediction::not_offered(Method::Rqmc, top, unresolved(top))
    };
    let mlqmc = predict::mlqmc(&records, r, max, settings.eps);
    Ok((vec![mlqmc, rqmc], levels, records))
}

/// The QMC pilot: levels 0..=`top`, R randomizations of n_0 / 8, n_0 / 4, n_0 / 2 and n_0 points each
/// (the counts of at least one point), with the variances after each count.
fn quasi_pilot(
    q: &dyn QuasiOps, control: &RunControl<'_>, settings: &ExpectationSettings, top: u32,
) -> Result<(Vec<QuasiLevel>, Vec<PilotLevel>), MlmcError> {
    let n0 = settings.initial_points;
    if n0 > q.max_points() {
        return Err(MlmcError::Setting {
            key: "mlqmc.initial_points",
            value: n0.to_string(),
            rule: format!("the sequence offers {} points", q.max_points()),
        });
    }
    let mut levels = Vec::new();
    let mut records = Vec::new();
    for level in 0..=top {
        let mut quasi = QuasiLevel::new(level, settings.randomizations, q.steps(level, true));
        let mut history = Vec::new();
        for points in [n0 / 8, n0 / 4, n0 / 2, n0] {
            if points > quasi.points {
                q.extend(&mut quasi, control, points, true)?;
                history.push((points, quasi.variance, fine_variance(&quasi)));
            }
        }
        records.push(PilotLevel {
            level,
            pair_steps: quasi.cost,
            path_steps: q.steps(level, false),
            history,
            seconds_per_step: quasi.seconds() / quasi.work,
            monte_carlo: independent_variances(&quasi),
        });
        levels.push(quasi);
    }
    Ok((levels, records))
}

/// V\[Y_l\] / (R n) and V\[P_l\] / (R n) from the values at all points of `q`: the variances
/// of the two means with as many independent paths.
fn independent_variances(q: &QuasiLevel) -> (f64, f64) {
    let mut all = LevelSums::default();
    for s in &q.randomizations {
        all.merge(s);
    }
    let n = all.samples as f64;
    (all.var_y() / n, all.var_p() / n)
}

/// The variance of the mean of P_l (the fine values) over the randomizations of `q`: the
/// variance of randomized QMC's estimate on level l at its points.
fn fine_variance(q: &QuasiLevel) -> f64 {
    let means: Vec<f64> = q.randomizations.iter().map(LevelSums::mean_p).collect();
    let r = means.len() as f64;
    let mean = means.iter().sum::<f64>() / r;
    means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (r - 1.0) / r
}

/// An expectation with what every estimator fills; the caller sets the pilot's fields.
fn found(eps: f64, method: Method, estimate: Interval, bias: f64, level: u32) -> Expectation {
    Expectation {
        eps,
        method,
        asked: false,
        by: CostMeasure::Work,
        estimate,
        with_bias: estimate.widened(bias),
        bias,
        converged: true,
        level,
        samples: Vec::new(),
        randomizations: None,
        failed: 0,
        resolved: false,
        predicted: Vec::new(),
        test_work: 0.0,
        work: 0.0,
        seconds: 0.0,
        test: Vec::new(),
        quasi_pilot: Vec::new(),
    }
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
    let level = (run.levels.len() - 1) as u32;
    Ok(Expectation {
        with_bias: run.with_bias,
        converged: run.converged,
        samples: run.levels.iter().map(|s| s.attempted()).collect(),
        failed: run.levels.iter().map(|s| s.failed).sum(),
        work: run.work,
        seconds: run.seconds,
        ..found(eps, Method::Mlmc, run.estimate, run.bias, level)
    })
}

/// The adaptive MLQMC algorithm at accuracy `eps`, carried on from the QMC pilot's `levels`
/// where given.
fn multilevel_quasi(
    q: &dyn QuasiOps, control: &RunControl<'_>, settings: &ExpectationSettings, eps: f64,
    levels: Option<Vec<QuasiLevel>>,
) -> Result<Expectation, MlmcError> {
    let quasi_settings = QuasiSettings {
        eps,
        randomizations: settings.randomizations,
        initial_points: settings.initial_points,
        min_levels: 2,
        max_level: settings.max_level.max(2),
    };
    let run = q.mlqmc(control, &quasi_settings, levels)?;
    let level = (run.levels.len() - 1) as u32;
    Ok(Expectation {
        with_bias: run.with_bias,
        converged: run.converged,
        samples: run.levels.iter().map(|l| l.points).collect(),
        randomizations: Some(run.randomizations),
        failed: run.levels.iter().map(|l| l.failed).sum(),
        work: run.work,
        seconds: run.seconds,
        ..found(eps, Method::Mlqmc, run.estimate, run.bias, level)
    })
}

/// The bias estimate of the test's levels 0..=`level`.
fn test_bias(test: &[LevelStats], level: u32) -> f64 {
    let means: Vec<(f64, f64)> = test[..=level as usize]
        .iter()
        .map(|s| (s.mean_y, s.se_y))
        .collect();
    bias_estimate(&means).0
}

/// Standard Monte Carlo on the level `predicted` names, with the paths it predicts.
fn standard<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, test: &[LevelStats], predicted: &Prediction, eps: f64,
) -> Result<Expectation, MlmcError> {
    let level = predicted.level;
    let paths = predicted.samples[level as usize];
    let sums = standard_monte_carlo(sampler, control, level, paths)?;
    let mut samples = vec![0; level as usize + 1];
    samples[level as usize] = sums.attempted();
    let estimate = estimate_of(std::slice::from_ref(&sums));
    Ok(Expectation {
        samples,
        failed: sums.failed,
        work: sums.attempted() as f64 * sampler.path_steps(level) as f64,
        seconds: sums.seconds,
        ..found(
            eps,
            Method::Standard,
            estimate,
            test_bias(test, level),
            level,
        )
    })
}

/// Randomized QMC on the level `predicted` names: R randomizations of the predicted points,
/// doubled until the variance of the estimate is at most eps^2 / 2.
fn single_quasi(
    q: &dyn QuasiOps, control: &RunControl<'_>, settings: &ExpectationSettings,
    test: &[LevelStats], predicted: &Prediction,
) -> Result<Expectation, MlmcError> {
    let (eps, r, level) = (settings.eps, settings.randomizations, predicted.level);
    let mut quasi = QuasiLevel::new(level, r, q.steps(level, false));
    let mut points = predicted.samples[level as usize].max(1);
    loop {
        q.extend(&mut quasi, control, points, false)?;
        if quasi.variance <= eps * eps / 2.0 {
            break;
        }
        points = doubled(points, r, q.max_points(), level, eps)?;
    }
    let estimate = quasi.interval().ok_or_else(|| MlmcError::Levels {
        reason: format!("{r} randomizations give no interval"),
    })?;
    let mut samples = vec![0; level as usize + 1];
    samples[level as usize] = quasi.points;
    Ok(Expectation {
        samples,
        randomizations: Some(r),
        failed: quasi.failed,
        work: quasi.work,
        seconds: quasi.seconds(),
        ..found(eps, Method::Rqmc, estimate, test_bias(test, level), level)
    })
}
