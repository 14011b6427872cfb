//! The convergence study: strong errors of every scheme at several step sizes against a
//! fine-step reference on the same Brownian paths, with observed orders and run time.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use sdae_model::FailureKind;

use crate::error::StudyError;
use crate::integrator::{SchemeKind, StudyScheme};
use crate::lockstep::{BLOCK_PATHS, Limits, Observing, PathPlan, PathRecord, TrackOutcome};
use crate::observable::Observable;
use crate::parallel::{Control, PathSelection, Skipped, applicable, run_paths};
use crate::scene::{Output, Prepared, Scene, SceneRunner};
use sdae_stats::Interval;
use sdae_stats::memory;
use sdae_stats::{
    INDICATIVE_BELOW, OrderFit, PathErrors, effective_paths, fit_order_and_errors, lp_error,
    lp_estimate, mean_interval,
};

/// The most worker threads a study starts.
pub const MAX_THREADS: usize = 1024;

/// The smallest step size a study runs: 2^-511 = sqrt(f64::MIN_POSITIVE), about 1.5e-154.
/// Errors and differences of size h are squared (L^2 norms, variances): below this their
/// squares are 0 or subnormal, and the errors and orders would be those of the underflow,
/// not of the scheme.
pub const MIN_STEP: f64 = 1.4916681462400413e-154;

use sdae_stats::PRE_ASYMPTOTIC_TOLERANCE;

/// The finest grid observables are kept on: 2^8 points per path and track.
const MAX_OBSERVED_LEVEL: u32 = 8;

/// What to run (the scene gives the system, T and the defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceSettings {
    /// Number of Monte Carlo paths.
    pub paths: usize,
    /// Levels use N = 2^k steps for k in `coarsest..=finest`.
    pub coarsest: u32,
    /// See `coarsest`.
    pub finest: u32,
    /// The reference uses 2^`reference` steps on the same Brownian path (`None`: no reference,
    /// no errors; the increments are then drawn on the finest level).
    pub reference: Option<u32>,
    /// Final time T.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// Seed of the path streams.
    pub seed: u64,
    /// The errors are L^p norms over paths.
    pub p: f64,
    /// Worker threads (the results do not depend on it).
    pub threads: usize,
    /// The schemes compared (those that do not apply to the scene are reported as skipped).
    pub schemes: Vec<SchemeKind>,
    /// The scheme that computes the reference.
    pub reference_scheme: SchemeKind,
    /// Bounds beyond which a path counts as failed.
    pub limits: Limits,
    /// Average the kinetic energy over the grid points with t >= this time.
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub kinetic_after: Option<f64>,
    /// Observables evaluated on every path at the coarsest level's grid points (by name: the
    /// scene's built-in ones, or the user's closures given to [`run_observed_on`]); none by
    /// default.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub observables: Vec<String>,
    /// A built-in observable of the scene averaged in time with the kinetic energy (after
    /// `kinetic_after`): the equipartition study's configurational average.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_averaged: Option<String>,
    /// The reference also runs at 2^(`reference` - 1) steps on the same paths, its
    /// observables recorded beside the reference's (the weak study's Richardson-extrapolated
    /// reference and its bias bound, the weak study); needs observables and a reference.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub paired_reference: bool,
    /// Randomized quasi-Monte Carlo paths (the weak study's `--qmc`): R randomizations of
    /// n = `paths` / R scrambled Sobol' points, path p being point p % n of randomization
    /// p / n ([`QuasiPaths`](crate::lockstep::QuasiPaths)); `paths` must be R n with R >= 2 and
    /// n a power of two. `None`: each path draws from its own pseudo-random streams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub randomizations: Option<usize>,
}

/// A setting that does not hold: `key = value` breaks `rule`.
fn setting_error(key: &'static str, value: String, rule: String) -> Result<(), StudyError> {
    Err(StudyError::Setting { key, value, rule })
}

impl ConvergenceSettings {
    /// The scene's defaults: its paths, levels and reference (else 1000 paths, levels 3..8,
    /// reference 13), its T, seed 2026, p = 2, all schemes, the practical half-explicit scheme
    /// as reference, and one thread per core.
    pub fn for_scene(scene: &Scene) -> Self {
        let [coarsest, finest] = scene.study.levels.unwrap_or([3, 8]);
        Self {
            paths: scene.study.paths.unwrap_or(1000),
            coarsest,
            finest,
            reference: Some(scene.study.reference.unwrap_or(finest + 5)),
            t_end: scene.t_end,
            seed: 2026,
            p: 2.0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            schemes: SchemeKind::ALL.to_vec(),
            reference_scheme: SchemeKind::HalfExplicitPractical,
            limits: Limits::default(),
            kinetic_after: None,
            observables: Vec::new(),
            time_averaged: None,
            paired_reference: false,
            randomizations: None,
        }
    }

    /// Checks the settings; the error names the bad one by its scene-file key (`study.paths`)
    /// or settings field (`p`). Besides the ranges: every step size T / 2^k (levels and
    /// reference) must be at least [`MIN_STEP`] (a normal float whose square is normal), at most [`MAX_THREADS`]
    /// threads, and the paths' records must fit in the available memory
    /// ([`memory::available`]; see [`ConvergenceSettings::fits_in_memory`]).
    pub fn validate(&self) -> Result<(), StudyError> {
        self.validate_levels()?;
        self.validate_run()
    }

    /// The paths, the levels and the reference.
    fn validate_levels(&self) -> Result<(), StudyError> {
        let bad = setting_error;
        if self.paths < 2 {
            return bad("study.paths", self.paths.to_string(), "must be >= 2".into());
        }
        if self.coarsest > self.finest {
            let levels = format!("{}..{}", self.coarsest, self.finest);
            return bad("study.levels", levels, "is empty".into());
        }
        if self.finest > 25 && self.reference.is_some() {
            let levels = format!("{}..{}", self.coarsest, self.finest);
            let rule = "at most 2^25 steps below a reference of at most 2^26".into();
            return bad("study.levels", levels, rule);
        }
        match self.reference {
            Some(r) if r <= self.finest || r > 26 => {
                let rule = format!(
                    "must be above the finest level {} and at most 26",
                    self.finest
                );
                return bad("study.reference", r.to_string(), rule);
            }
            None if self.finest > 26 => {
                let rule = "at most 2^26 steps".into();
                return bad("study.levels", format!("..{}", self.finest), rule);
            }
            _ => {}
        }
        self.validate_randomizations()
    }

    /// With randomized QMC paths: R >= 2 randomizations of n points, n a power of two, and
    /// paths = R n.
    fn validate_randomizations(&self) -> Result<(), StudyError> {
        let Some(r) = self.randomizations else {
            return Ok(());
        };
        if r < 2 {
            let rule = "must be at least 2 (the spread of the randomizations gives the intervals)";
            return setting_error("weak.randomizations", r.to_string(), rule.into());
        }
        let n = self.paths / r;
        if !self.paths.is_multiple_of(r) || !n.is_power_of_two() || n > 1 << 32 {
            let rule = format!(
                "with randomized QMC paths must be R n, R = {r} randomizations of n points, n a \
                 power of two (at most 2^32)"
            );
            return setting_error("study.paths", self.paths.to_string(), rule);
        }
        Ok(())
    }

    /// The limits, T and the step sizes it gives, p, the threads, the schemes, the memory of
    /// the records and the observed grid.
    fn validate_run(&self) -> Result<(), StudyError> {
        let bad = setting_error;
        if let Some(tol) = self.limits.drift_tolerance
            && (tol.is_nan() || tol <= 0.0)
        {
            let rule = "must be > 0".into();
            return bad("limits.drift_tolerance", tol.to_string(), rule);
        }
        if self.limits.blow_up.is_nan() || self.limits.blow_up <= 0.0 {
            let rule = "must be > 0".into();
            return bad("limits.blow_up", self.limits.blow_up.to_string(), rule);
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return bad(
                "T",
                format!("{:e}", self.t_end),
                "must be finite and > 0".into(),
            );
        }
        // The finest grid gives the smallest step: h = T / 2^k underflows there first.
        let finest = self.reference.unwrap_or(self.finest);
        let h = self.t_end / 2f64.powi(finest as i32);
        if h < MIN_STEP {
            let rule = format!(
                "gives the step h = T / 2^{finest} = {h:e} at level {finest}: every step size \
                 must be a normal float whose square is one too (h >= {MIN_STEP:e} = 2^-511), \
                 else the squared errors underflow"
            );
            return bad("T", format!("{:e}", self.t_end), rule);
        }
        if !(self.p.is_finite() && self.p >= 1.0) {
            return bad("p", self.p.to_string(), "must be finite and >= 1".into());
        }
        if self.threads == 0 || self.threads > MAX_THREADS {
            let rule = format!("must be in 1..={MAX_THREADS}");
            return bad("threads", self.threads.to_string(), rule);
        }
        if self.schemes.is_empty() {
            return bad("schemes", "[]".into(), "names no scheme".into());
        }
        if let Some(rule) = memory::exceeded(self.record_bytes(), "the records of the paths") {
            return bad("study.paths", self.paths.to_string(), rule);
        }
        if !self.observables.is_empty() && self.coarsest > MAX_OBSERVED_LEVEL {
            let rule = format!(
                "observables are kept at the coarsest level's 2^{} grid points: at most {MAX_OBSERVED_LEVEL}",
                self.coarsest
            );
            return bad(
                "study.levels",
                format!("{}..{}", self.coarsest, self.finest),
                rule,
            );
        }
        Ok(())
    }

    /// The bytes the records of all paths take at least (a merge holds them all at once):
    /// per path, one [`PathRecord`] with a [`TrackOutcome`] per scheme and level, and its index.
    pub fn record_bytes(&self) -> u64 {
        let tracks = self.schemes.len() * self.levels().len();
        let per_path = size_of::<PathRecord>() + tracks * size_of::<TrackOutcome>() + 8;
        (self.paths as u64).saturating_mul(per_path as u64)
    }

    /// The bytes the paths in flight take at least with a system of `coordinates`
    /// coordinates: per thread, a block of up to [`BLOCK_PATHS`] paths of every scheme at every
    /// level and of the reference, each holding r and v.
    pub fn in_flight_bytes(&self, coordinates: usize) -> u64 {
        let tracks = self.schemes.len() * self.levels().len() + 1;
        let block = BLOCK_PATHS.min(self.paths);
        [
            self.threads.min(self.paths),
            block,
            tracks,
            2 * 8,
            coordinates,
        ]
        .into_iter()
        .fold(1u64, |bytes, factor| bytes.saturating_mul(factor as u64))
    }

    /// Fails when the paths in flight with a system of `coordinates` coordinates
    /// ([`ConvergenceSettings::in_flight_bytes`]) need more than the available memory; the
    /// error names the thread count, the one setting that shrinks it without changing the
    /// numbers.
    pub fn fits_in_memory(&self, coordinates: usize) -> Result<(), StudyError> {
        let what = format!(
            "the paths in flight ({} coordinates, blocks of {} paths per thread)",
            coordinates,
            BLOCK_PATHS.min(self.paths)
        );
        match memory::exceeded(self.in_flight_bytes(coordinates), &what) {
            None => Ok(()),
            Some(rule) => Err(StudyError::Setting {
                key: "threads",
                value: self.threads.to_string(),
                rule,
            }),
        }
    }

    /// [`ConvergenceSettings::validate`], then [`ConvergenceSettings::fits_in_memory`] with the
    /// coordinates of `scene`'s system (known before it is built): everything that can be
    /// checked before a run starts.
    pub fn validate_for(&self, scene: &Scene) -> Result<(), StudyError> {
        self.validate()?;
        self.fits_in_memory(scene.coordinates().unwrap_or(0))
    }

    /// Whether `other` gives the same numbers: equal but perhaps for the thread count.
    pub fn same_numbers(&self, other: &ConvergenceSettings) -> bool {
        let threads = |s: &ConvergenceSettings| ConvergenceSettings {
            threads: 1,
            ..s.clone()
        };
        threads(self) == threads(other)
    }

    /// The level exponents k, coarse to fine.
    pub(crate) fn levels(&self) -> Vec<u32> {
        (self.coarsest..=self.finest).collect()
    }
}

/// The per-path results of a run (or of one shard of it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRun {
    /// The scene.
    pub scene: Scene,
    /// The settings.
    pub settings: ConvergenceSettings,
    /// The names of the schemes that ran, in the order of the records' tracks.
    pub schemes: Vec<String>,
    /// The schemes left out.
    pub skipped: Vec<Skipped>,
    /// The equipartition value of the kinetic energy, for Langevin scenes.
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub kinetic_target: Option<f64>,
    /// This run is shard `shard.0` of `shard.1` (paths i with i % shard.1 == shard.0).
    pub shard: (usize, usize),
    /// The size of each output's state, [|r_0|, |v_0|, 0] (Euclidean norms of the initial
    /// state; the multiplier has none): an error within [`ROUNDING_LEVEL`] of it is the
    /// arithmetic's ([`at_rounding_level`]).
    #[serde(default)]
    pub state_scale: [f64; 3],
    /// One record per path, by index.
    pub records: Vec<PathRecord>,
}

/// Runs the paths of shard `index` of `count` of a scene file's system with the built-in
/// schemes of `settings`, steered by `control` (progress, an early stop, paths already done).
/// Path i draws from its own stream, so the records do not depend on the thread count, the
/// sharding or an interruption.
pub fn run_convergence(
    scene: &Scene, settings: &ConvergenceSettings, shard: (usize, usize), control: Control<'_>,
) -> Result<ConvergenceRun, StudyError> {
    scene.run(Runner {
        settings,
        shard,
        control,
    })?
}

struct Runner<'a> {
    settings: &'a ConvergenceSettings,
    shard: (usize, usize),
    control: Control<'a>,
}

impl SceneRunner for Runner<'_> {
    type Output = Result<ConvergenceRun, StudyError>;

    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
    {
        let observables =
            crate::observable::built_in_all(scene, &prepared, &self.settings.observables)?;
        run_observed_on(
            scene,
            &prepared,
            &[],
            &observables,
            self.settings,
            self.shard,
            self.control,
        )
    }
}

/// The convergence study of any system (`prepared`: the system, its initial state and the
/// constants of the built-in schemes; [`Scene::custom`] describes it for the report) with the
/// built-in schemes of `settings` and the user's `extra` schemes, side by side on the same
/// Brownian paths. Runs the paths of shard `index` of `count`, steered by `control`. The
/// observables `settings` names are the scene's built-in ones.
pub fn run_convergence_on<S>(
    scene: &Scene, prepared: &Prepared<S>, extra: &[StudyScheme<S>],
    settings: &ConvergenceSettings, shard: (usize, usize), control: Control<'_>,
) -> Result<ConvergenceRun, StudyError>
where
    S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
{
    let observables = crate::observable::built_in_all(scene, prepared, &settings.observables)?;
    run_observed_on(
        scene,
        prepared,
        extra,
        &observables,
        settings,
        shard,
        control,
    )
}

/// [`run_convergence_on`] with the user's `extra` schemes and the `observables` evaluated on
/// every path (at the grid points of the coarsest level; the run's settings name them, in
/// place of the names `settings` gives).
pub fn run_observed_on<S>(
    scene: &Scene, prepared: &Prepared<S>, extra: &[StudyScheme<S>], observables: &[Observable],
    settings: &ConvergenceSettings, shard: (usize, usize), control: Control<'_>,
) -> Result<ConvergenceRun, StudyError>
where
    S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
{
    let (index, count) = shard;
    let settings = ConvergenceSettings {
        observables: observables.iter().map(|o| o.name().to_string()).collect(),
        ..settings.clone()
    };
    let st = &settings;
    st.validate()?;
    st.fits_in_memory(prepared.position.len())?;
    let (schemes, skipped) = applicable(&st.schemes, extra, prepared);
    let (reference, reference_skipped) = applicable(&[st.reference_scheme], &[], prepared);
    if let (Some(_), Some(skipped)) = (st.reference, reference_skipped.first()) {
        return Err(StudyError::SchemeNotApplicable {
            scheme: skipped.name.clone(),
            reason: format!("as the reference: {}", skipped.reason),
        });
    }
    let plan = PathPlan {
        t_end: st.t_end,
        fine: st.reference.unwrap_or(st.finest),
        levels: st.levels(),
        want_mu: scene.wants(Output::Multiplier) && st.reference.is_some(),
        limits: st.limits,
        kinetic_after: st
            .kinetic_after
            .filter(|_| scene.wants(Output::KineticEnergy)),
        time_averaged: st
            .time_averaged
            .as_deref()
            .filter(|_| st.kinetic_after.is_some() && scene.wants(Output::KineticEnergy))
            .map(|name| {
                crate::observable::check_known(scene, name)?;
                crate::observable::build(scene, prepared, name)
            })
            .transpose()?,
        observing: (!observables.is_empty()).then(|| Observing {
            observables: observables.to_vec(),
            grid_level: st.coarsest,
        }),
        paired_reference: st.paired_reference && st.reference.is_some() && !observables.is_empty(),
    };
    let records = run_paths(
        &plan,
        &schemes,
        st.reference.and(reference.first()),
        prepared,
        PathSelection {
            seed: st.seed,
            paths: st.paths,
            shard: (index, count.max(1)),
            threads: st.threads,
            randomizations: st.randomizations,
        },
        control,
    )?;
    Ok(ConvergenceRun {
        scene: scene.clone(),
        settings: st.clone(),
        schemes: schemes.iter().map(|s| s.name().to_string()).collect(),
        skipped,
        kinetic_target: prepared.kinetic_target,
        shard: (index, count.max(1)),
        state_scale: [norm(&prepared.position), norm(&prepared.velocity), 0.0],
        records,
    })
}

/// Errors of r, v and mu (those the scene asked for).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Errors {
    /// Position.
    pub r: Option<Interval>,
    /// Velocity.
    pub v: Option<Interval>,
    /// Multiplier.
    pub mu: Option<Interval>,
    /// The outputs ("r", "v", "mu") whose interval is indicative only: it rests on fewer than
    /// [`INDICATIVE_BELOW`] effective paths
    /// ([`effective_paths`]), too few for its 95% on errors this heavy-tailed.
    pub indicative: Vec<&'static str>,
}

/// Fitted orders of r, v and mu.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Orders {
    /// Position.
    pub r: Option<OrderFit>,
    /// Velocity.
    pub v: Option<OrderFit>,
    /// Multiplier.
    pub mu: Option<OrderFit>,
}

/// One scheme at one step size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelReport {
    /// N.
    pub n_steps: usize,
    /// h = T / N.
    #[serde(with = "sdae_stats::json_f64")]
    pub h: f64,
    /// L^p norms over the compared paths of sup_k |r_k - r_ref(t_k)|, sup_k |v_k - v_ref(t_k)|,
    /// sup_k |mu_k - mu_ref(t_k)| (k over this level's grid), with 95% confidence intervals
    /// (`None` where not asked for, without a reference, or with fewer than 2 compared paths).
    pub error: Errors,
    /// Paths counted (those whose reference finished).
    pub paths: usize,
    /// Paths whose errors are compared: those that finished at every level of the scheme (one
    /// set of paths for all its levels).
    pub compared_paths: usize,
    /// Paths that finished at this level but failed at another level of the scheme, and so
    /// are left out of the errors here too.
    pub failed_elsewhere: usize,
    /// Share of the counted paths that finished (0 when no path could be counted).
    #[serde(with = "sdae_stats::json_f64")]
    pub finished_fraction: f64,
    /// Mean over the finished paths of the time-averaged kinetic energy v^T M v / 2, with a 95%
    /// confidence interval (when the scene asks for it).
    pub kinetic_energy: Option<Interval>,
    /// Mean wall-clock seconds of stepping per path.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds_per_path: f64,
    /// The spread of the repeated timings behind `seconds_per_path` ([`TimeSpread`]).
    #[serde(default)]
    pub seconds: TimeSpread,
    /// Steps per second of stepping.
    #[serde(with = "sdae_stats::json_f64")]
    pub steps_per_second: f64,
    /// Paths that failed (not counted in the errors).
    pub failures: usize,
    /// Failures by kind.
    pub failures_by_kind: BTreeMap<FailureKind, usize>,
    /// Share of steps with a truncated drift.
    #[serde(with = "sdae_stats::json_f64")]
    pub truncated_fraction: f64,
    /// Mean Newton iterations per step.
    #[serde(with = "sdae_stats::json_f64")]
    pub newton_iterations_per_step: f64,
    /// Steps that needed the homotopy fallback.
    pub homotopy_steps: usize,
    /// Steps whose kappa reached C_kappa and was certified with the part that only corrects
    /// rounding set aside (the residual floor mattered).
    pub rounding_certified_steps: usize,
    /// More than [`TRUNCATION_DOMINATED`](sdae_model::TRUNCATION_DOMINATED) of the steps were
    /// truncated: the level is stable but biased.
    pub stable_but_biased: bool,
    /// Mean over paths of the clock lag sum_k (1 - eta_k) h: the time the truncated drift
    /// did not integrate (0 without truncation).
    #[serde(with = "sdae_stats::json_f64")]
    pub clock_lag: f64,
    /// Largest |g(r_k)| on the grid.
    #[serde(with = "sdae_stats::json_f64")]
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| on the grid.
    #[serde(with = "sdae_stats::json_f64")]
    pub max_velocity_residual: f64,
}

/// Repeated timings of one level: a block of paths is stepped together and each of its paths
/// is charged the block's time shared among them, so the run times per path of the finished
/// paths are one timing per block; their median and range (min..max) show how much a run time
/// per path varies between blocks (all 0 in reports written before it was recorded).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TimeSpread {
    /// Median seconds per path.
    #[serde(with = "sdae_stats::json_f64")]
    pub median: f64,
    /// Smallest seconds per path.
    #[serde(with = "sdae_stats::json_f64")]
    pub min: f64,
    /// Largest seconds per path.
    #[serde(with = "sdae_stats::json_f64")]
    pub max: f64,
}

impl TimeSpread {
    /// The median and range of `seconds` (all 0 when empty; NaN timings left out).
    pub fn of(mut seconds: Vec<f64>) -> Self {
        seconds.retain(|s| !s.is_nan());
        seconds.sort_by(f64::total_cmp);
        let n = seconds.len();
        if n == 0 {
            return Self::default();
        }
        Self {
            median: 0.5 * (seconds[(n - 1) / 2] + seconds[n / 2]),
            min: seconds[0],
            max: seconds[n - 1],
        }
    }
}

/// One scheme over all levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SchemeReport {
    /// The scheme's name.
    pub name: String,
    /// Levels from coarse to fine.
    pub levels: Vec<LevelReport>,
    /// Least-squares slope of log(error) against log(h) with 95% intervals from the Monte Carlo
    /// error (symmetric percentile-t of the paired bootstrap of the compared paths, every level of a path
    /// drawn together; `indicative` below [`INDICATIVE_BELOW`]
    /// paths); coarse levels whose local slope departs from the finer ones beyond that error
    /// (and by more than 0.05) are flagged, not fitted.
    pub observed_order: Orders,
    /// Levels left out of the fit because their failure count differs from the finest level's
    /// (or they lie beyond such a level).
    pub not_fitted_for_failures: Vec<usize>,
    /// Levels left out of the fit because more than
    /// [`TRUNCATION_DOMINATED`](sdae_model::TRUNCATION_DOMINATED) of their steps are truncated
    /// (`stable_but_biased`): their error measures the truncation, a step of eta h, not the
    /// order of the scheme's step.
    pub not_fitted_truncated: Vec<usize>,
    /// Levels left out of an output's fit because their error underflowed: zero or subnormal
    /// ([`underflowed`]), the scheme's and the reference's paths equal to the last bit or
    /// closer than f64 resolves, or within the rounding of the state it measures
    /// ([`at_rounding_level`]). Such an error measures the arithmetic, not the scheme.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unresolved: Vec<Unresolved>,
}

/// A level whose error of one output underflowed or lies at the rounding level of its state
/// (see [`SchemeReport::unresolved`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unresolved {
    /// The output: `r`, `v` or `mu`.
    pub output: &'static str,
    /// The level's index (into the scheme's levels).
    pub level: usize,
    /// Its L^p error: 0, subnormal, or within [`ROUNDING_LEVEL`] of its state's size.
    #[serde(with = "sdae_stats::json_f64")]
    pub error: f64,
}

/// How many units of rounding (f64::EPSILON) of an output's state an error must exceed to be
/// the scheme's: 2^6, about 1.4e-14 of the state.
pub const ROUNDING_LEVEL: f64 = 64.0 * f64::EPSILON;

/// Whether an error lies at the rounding level of the state it measures, of size `scale`:
/// at most [`ROUNDING_LEVEL`] times it. At T = 1e-100 the paths move by about 1e-100 and their
/// errors, some 1e-114 at every N, measure the rounding of that move, not the scheme: an order
/// fitted to them is 0 with an interval of zero width.
pub fn at_rounding_level(error: f64, scale: f64) -> bool {
    error <= ROUNDING_LEVEL * scale
}

/// The Euclidean norm of `x`.
fn norm(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Whether an error underflowed: zero or subnormal (below `f64::MIN_POSITIVE`), or not a
/// number. An order fitted to it would be the arithmetic's, not the scheme's.
pub fn underflowed(error: f64) -> bool {
    error.is_nan() || error < f64::MIN_POSITIVE
}

/// The reference solution.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceReport {
    /// Its scheme.
    pub scheme: &'static str,
    /// Its number of steps.
    pub n_steps: usize,
    /// Paths whose reference failed (left out entirely).
    pub failures: usize,
    /// Failures by kind.
    pub failures_by_kind: BTreeMap<FailureKind, usize>,
    /// Mean wall-clock seconds per path.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds_per_path: f64,
}

impl ReferenceReport {
    /// The report's line on the reference: its failures among `paths` and its time per path.
    pub fn summary(&self, paths: usize) -> String {
        format!(
            "\nReference: {} failures of {paths} paths; {:.1} ms per path.\n",
            self.failures,
            self.seconds_per_path * 1e3
        )
    }
}

impl ReferenceReport {
    /// The reference of a run with `settings` from its records, `finished` of which have a
    /// reference that finished (`None` when the run had no reference).
    pub fn of(
        settings: &ConvergenceSettings, records: &[PathRecord], finished: usize,
    ) -> Option<ReferenceReport> {
        settings.reference.map(|level| ReferenceReport {
            scheme: settings.reference_scheme.name(),
            n_steps: 1 << level,
            failures: records.len() - finished,
            failures_by_kind: count_kinds(records.iter().filter_map(|r| r.reference_failure)),
            seconds_per_path: records.iter().map(|r| r.reference_seconds).sum::<f64>()
                / records.len().max(1) as f64,
        })
    }
}

/// The report of a convergence study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConvergenceReport {
    /// The scene's name.
    pub scene: String,
    /// Seed of the path streams.
    pub seed: u64,
    /// Monte Carlo paths.
    pub paths: usize,
    /// The errors are L^p norms over paths.
    pub p: f64,
    /// Final time.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// All settings.
    pub settings: ConvergenceSettings,
    /// The reference (`None` when the study ran without one).
    pub reference: Option<ReferenceReport>,
    /// The schemes compared.
    pub schemes: Vec<SchemeReport>,
    /// Schemes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// The equipartition value (n - m) kT / 2 of the kinetic energy, for Langevin scenes.
    #[serde(with = "sdae_stats::json_f64::option", default)]
    pub kinetic_target: Option<f64>,
    /// The scene as run.
    pub scene_definition: Scene,
}

impl ConvergenceReport {
    /// What could not be compared with the reference, one sentence each naming the failure
    /// kinds and counts: the reference itself when it failed on every path, and each scheme
    /// none of whose paths finished every level. Empty when every scheme was compared (or the
    /// study ran without a reference).
    pub fn uncompared(&self) -> Vec<String> {
        let Some(reference) = &self.reference else {
            return Vec::new();
        };
        let kinds = |map: &BTreeMap<FailureKind, usize>| {
            map.iter()
                .map(|(k, n)| format!("{} {n}", k.name()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if reference.failures >= self.paths {
            return vec![format!(
                "the reference ({}) failed on all {} paths [{}]: no error could be measured",
                reference.scheme,
                self.paths,
                kinds(&reference.failures_by_kind)
            )];
        }
        self.schemes
            .iter()
            .filter(|s| s.levels.iter().all(|l| l.compared_paths == 0))
            .map(|s| {
                let mut all = BTreeMap::new();
                for l in &s.levels {
                    for (k, n) in &l.failures_by_kind {
                        *all.entry(*k).or_insert(0) += n;
                    }
                }
                format!(
                    "{}: no path finished every level [failures over all levels: {}]",
                    s.name,
                    kinds(&all)
                )
            })
            .collect()
    }
}

pub(crate) fn count_kinds(
    kinds: impl Iterator<Item = FailureKind>,
) -> BTreeMap<FailureKind, usize> {
    let mut map = BTreeMap::new();
    for k in kinds {
        *map.entry(k).or_insert(0) += 1;
    }
    map
}

/// The outcomes of scheme `s` at level `j` of the paths whose reference finished.
fn outcomes<'a>(
    good: &'a [&PathRecord], s: usize, j: usize, levels: usize,
) -> impl Iterator<Item = &'a TrackOutcome> + 'a {
    good.iter().map(move |p| &p.tracks[s * levels + j])
}

/// The paths of scheme `s` that finished at every level: one set of paths for all levels, so
/// that a path that fails at some level (typically with the largest errors) leaves every level
/// instead of vanishing from one level's average only.
pub(crate) fn common_paths<'a>(
    good: &[&'a PathRecord], s: usize, levels: usize,
) -> Vec<&'a PathRecord> {
    good.iter()
        .copied()
        .filter(|p| (0..levels).all(|j| p.tracks[s * levels + j].failure.is_none()))
        .collect()
}

/// Distances of output `c` (0: r, 1: v, 2: mu) of scheme `s` at level `j` over `paths`.
fn distances(paths: &[&PathRecord], s: usize, j: usize, levels: usize, c: usize) -> Vec<f64> {
    paths
        .iter()
        .filter_map(|p| p.tracks[s * levels + j].distances.map(|d| d[c]))
        .collect()
}

fn level_report<'a>(
    steps: usize, settings: &ConvergenceSettings, paths: impl Iterator<Item = &'a TrackOutcome>,
    error: Errors, compared: usize,
) -> LevelReport {
    let (mut seconds, mut count, mut failures) = (0.0, 0usize, Vec::new());
    let (mut steps_total, mut truncated, mut iterations) = (0, 0, 0);
    let (mut homotopy, mut rounding, mut lag) = (0, 0, 0.0);
    let (mut max_g, mut max_dgv) = (0.0_f64, 0.0_f64);
    let (mut kinetic, mut finished_seconds, mut all_seconds) = (Vec::new(), Vec::new(), Vec::new());
    for p in paths {
        count += 1;
        seconds += p.seconds;
        all_seconds.push(p.seconds);
        truncated += p.truncated_steps;
        iterations += p.newton_iterations;
        steps_total += p.steps;
        homotopy += p.homotopy_steps;
        rounding += p.rounding_certified_steps;
        lag += p.clock_lag;
        max_g = max_g.max(p.max_position_residual);
        max_dgv = max_dgv.max(p.max_velocity_residual);
        if let Some(kind) = p.failure {
            failures.push(kind);
        } else {
            finished_seconds.push(p.seconds);
            kinetic.extend(p.kinetic_energy);
        }
    }
    let per_step = |x: usize| x as f64 / steps_total.max(1) as f64;
    let finished = count - failures.len();
    LevelReport {
        n_steps: steps,
        h: settings.t_end / steps as f64,
        error,
        paths: count,
        compared_paths: compared,
        failed_elsewhere: finished.saturating_sub(compared),
        finished_fraction: if count == 0 {
            0.0
        } else {
            finished as f64 / count as f64
        },
        kinetic_energy: mean_interval(&kinetic),
        seconds_per_path: seconds / count.max(1) as f64,
        // The finished paths took every step; failed ones only where all failed.
        seconds: TimeSpread::of(if finished_seconds.is_empty() {
            all_seconds
        } else {
            finished_seconds
        }),
        steps_per_second: if seconds > 0.0 {
            steps_total as f64 / seconds
        } else {
            0.0
        },
        failures: failures.len(),
        failures_by_kind: count_kinds(failures.into_iter()),
        truncated_fraction: per_step(truncated),
        stable_but_biased: per_step(truncated) > sdae_model::TRUNCATION_DOMINATED,
        newton_iterations_per_step: per_step(iterations),
        homotopy_steps: homotopy,
        rounding_certified_steps: rounding,
        clock_lag: lag / count.max(1) as f64,
        max_position_residual: max_g,
        max_velocity_residual: max_dgv,
    }
}

/// The levels an order is fitted over: the finest level and the coarser ones next to it with
/// the same number of failed paths and not truncation-dominated (no fit across levels whose
/// failure counts differ, nor over levels that measure the truncation rather than the step).
fn fittable(levels: &[LevelReport]) -> Vec<usize> {
    let Some(finest) = levels.last() else {
        return Vec::new();
    };
    let mut fit: Vec<usize> = (0..levels.len())
        .rev()
        .take_while(|&j| levels[j].failures == finest.failures && !levels[j].stable_but_biased)
        .collect();
    fit.reverse();
    fit
}

/// An order fit over the levels `fitted` (indices into all levels), with every index it
/// reports mapped back to all levels, and the L^p error intervals of these levels from the
/// fit's resamples.
fn fit_levels(
    fitted: &[usize], h: &[f64], errors: &[Vec<f64>], p: f64,
) -> Option<(OrderFit, Vec<Interval>)> {
    let data = PathErrors { h, errors, p };
    let (mut fit, level_errors) = fit_order_and_errors(data, PRE_ASYMPTOTIC_TOLERANCE)?;
    let map = |i: &mut usize| *i = fitted[*i];
    fit.fitted.iter_mut().for_each(map);
    fit.pre_asymptotic.iter_mut().for_each(map);
    fit.curvature.iter_mut().for_each(map);
    for l in &mut fit.local_slopes {
        map(&mut l.coarse);
        map(&mut l.fine);
    }
    Some((fit, level_errors))
}

/// The outputs' names, in the order of [`Errors::output`].
const OUTPUT_NAMES: [&str; 3] = ["r", "v", "mu"];

impl Errors {
    /// The error of output `c` (0: r, 1: v, 2: mu).
    fn output(&mut self, c: usize) -> &mut Option<Interval> {
        match c {
            0 => &mut self.r,
            1 => &mut self.v,
            _ => &mut self.mu,
        }
    }
}

/// The levels of `fittable` whose error of output `c` is resolved, to be fitted; the others,
/// whose error underflowed or lies at the rounding level of the state (of size `scale`), are
/// named in `unresolved`. Only the estimate is computed here: the fitted levels' intervals
/// come from the fit's bootstrap.
fn resolved(
    fittable: &[usize], c: usize, scale: f64, p: f64, errors_of: impl Fn(usize) -> Vec<f64>,
    unresolved: &mut Vec<Unresolved>,
) -> Vec<usize> {
    let mut fitted = Vec::new();
    for &j in fittable {
        let error = lp_estimate(&errors_of(j), p).unwrap_or(f64::NAN);
        if (underflowed(error) || at_rounding_level(error, scale)) && !error.is_nan() {
            unresolved.push(Unresolved {
                output: OUTPUT_NAMES[c],
                level: j,
                error,
            });
        } else {
            fitted.push(j);
        }
    }
    fitted
}

/// The report of scheme `s` (named `name`) from the paths whose reference finished. The
/// fitted levels' error intervals come from their order fit's bootstrap (the same intervals
/// [`lp_error`] gives, one bootstrap for all levels), the others' from [`lp_error`].
fn scheme_report(
    s: usize, name: &str, good: &[&PathRecord], scene: &Scene, settings: &ConvergenceSettings,
    scale: [f64; 3],
) -> SchemeReport {
    let levels = settings.levels();
    let count = levels.len();
    let common = common_paths(good, s, count);
    let wanted = |output: Output| scene.wants(output) && settings.reference.is_some();
    let outputs = [Output::Position, Output::Velocity, Output::Multiplier].map(wanted);
    let mut reports: Vec<LevelReport> = levels
        .iter()
        .enumerate()
        .map(|(j, &k)| {
            let paths = outcomes(good, s, j, count);
            let errors = Errors {
                r: None,
                v: None,
                mu: None,
                indicative: Vec::new(),
            };
            level_report(1usize << k, settings, paths, errors, common.len())
        })
        .collect();
    let fittable = fittable(&reports);
    let mut fits: [Option<OrderFit>; 3] = [None, None, None];
    let mut unresolved = Vec::new();
    for (c, fit) in fits.iter_mut().enumerate().filter(|(c, _)| outputs[*c]) {
        let errors_of = |j: usize| distances(&common, s, j, count, c);
        let fitted = resolved(
            &fittable,
            c,
            scale[c],
            settings.p,
            errors_of,
            &mut unresolved,
        );
        let h: Vec<f64> = fitted.iter().map(|&j| reports[j].h).collect();
        let errors: Vec<Vec<f64>> = fitted
            .iter()
            .map(|&j| distances(&common, s, j, count, c))
            .collect();
        if let Some((order, level_errors)) = fit_levels(&fitted, &h, &errors, settings.p) {
            *fit = Some(order);
            for (&j, e) in fitted.iter().zip(level_errors) {
                *reports[j].error.output(c) = Some(e);
            }
        }
        for (j, report) in reports.iter_mut().enumerate() {
            let distances = distances(&common, s, j, count, c);
            let error = report.error.output(c);
            if error.is_none() {
                *error = lp_error(&distances, settings.p);
            }
            if error.is_some() && effective_paths(&distances, settings.p) < INDICATIVE_BELOW as f64
            {
                report.error.indicative.push(OUTPUT_NAMES[c]);
            }
        }
    }
    let [r, v, mu] = fits;
    SchemeReport {
        name: name.to_string(),
        observed_order: Orders { r, v, mu },
        not_fitted_for_failures: (0..reports.len())
            .filter(|&j| !fittable.contains(&j) && !reports[j].stable_but_biased)
            .collect(),
        not_fitted_truncated: (0..reports.len())
            .filter(|&j| !fittable.contains(&j) && reports[j].stable_but_biased)
            .collect(),
        unresolved,
        levels: reports,
    }
}

/// The report from the records of all paths (in any order).
pub fn build_report(run: ConvergenceRun) -> ConvergenceReport {
    let ConvergenceRun {
        scene,
        settings,
        schemes,
        skipped,
        kinetic_target,
        state_scale,
        mut records,
        ..
    } = run;
    records.sort_by_key(|r| r.index);
    let good: Vec<&PathRecord> = records
        .iter()
        .filter(|r| r.reference_failure.is_none())
        .collect();
    // The schemes' statistics (bootstrap intervals, order fits) on the study's threads; each
    // report depends only on the records.
    let report =
        |(s, name): (usize, &String)| scheme_report(s, name, &good, &scene, &settings, state_scale);
    let on_threads = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads.max(1))
        .build();
    let schemes = match on_threads {
        Ok(pool) => pool.install(|| schemes.par_iter().enumerate().map(report).collect()),
        Err(_) => schemes.iter().enumerate().map(report).collect(),
    };
    let reference = ReferenceReport::of(&settings, &records, good.len());
    ConvergenceReport {
        scene: scene.name.clone(),
        seed: settings.seed,
        paths: settings.paths,
        p: settings.p,
        t_end: settings.t_end,
        settings,
        reference,
        schemes,
        skipped,
        kinetic_target,
        scene_definition: scene,
    }
}

impl ConvergenceRun {
    /// Whether `other` is a part of the same study: same scene, settings (the thread count
    /// aside), schemes and number of shards.
    pub fn same_study(&self, other: &ConvergenceRun) -> bool {
        self.scene == other.scene
            && self.settings.same_numbers(&other.settings)
            && self.schemes == other.schemes
            && self.shard.1 == other.shard.1
    }

    /// The indices of the paths this run holds.
    pub fn finished_paths(&self) -> Vec<usize> {
        self.records.iter().map(|r| r.index).collect()
    }

    /// Adds the records of `later`, a continuation of this run (same study and shard) that ran
    /// the paths this one had not finished; the records together pass
    /// [`ConvergenceRun::check_records`].
    pub fn resume_with(mut self, later: ConvergenceRun) -> Result<ConvergenceRun, StudyError> {
        if !self.same_study(&later) || self.shard != later.shard {
            return Err(StudyError::Merge {
                reason: "the saved paths come from another scene, settings or shard".into(),
            });
        }
        self.records.extend(later.records);
        self.records.sort_by_key(|r| r.index);
        self.check_records()
            .map_err(|reason| StudyError::Merge { reason })?;
        Ok(self)
    }

    /// Checks the records as [`build_report`] needs them (see [`check_records`]), with one
    /// track per scheme and level of this run. The error says which record is wrong and how.
    pub fn check_records(&self) -> Result<(), String> {
        let tracks = self.schemes.len() * self.settings.levels().len();
        check_records(&self.records, &self.settings, self.shard, Some(tracks)).map_err(|m| {
            if m.contains("scheme-level results where") {
                format!(
                    "{m} ({} schemes x {} levels)",
                    self.schemes.len(),
                    self.settings.levels().len()
                )
            } else {
                m
            }
        })
    }
}

/// The one check of saved records, for resuming a checkpoint and for merging shards: each path
/// index below the number of paths, of shard `shard` = (index, count) and present once; each
/// record whose reference failed without tracks, else with `tracks` tracks (when known) and,
/// with a paired reference, as many observed values of its coarse reference as of its fine
/// one; each track with distances exactly when it finished against a reference (a failure and
/// no distances otherwise). The error says which record is wrong and how.
pub fn check_records(
    records: &[PathRecord], settings: &ConvergenceSettings, shard: (usize, usize),
    tracks: Option<usize>,
) -> Result<(), String> {
    let (index, count) = shard;
    let mut seen = vec![false; settings.paths];
    for r in records {
        let Some(s) = seen.get_mut(r.index) else {
            return Err(format!(
                "path {} is out of range (the study has {} paths)",
                r.index, settings.paths
            ));
        };
        if *s {
            return Err(format!("path {} appears twice", r.index));
        }
        *s = true;
        if r.index % count.max(1) != index {
            return Err(format!("path {} is not of shard {index}/{count}", r.index));
        }
        check_record(r, settings, tracks)?;
    }
    Ok(())
}

/// The checks of [`check_records`] on one record.
fn check_record(
    r: &PathRecord, settings: &ConvergenceSettings, tracks: Option<usize>,
) -> Result<(), String> {
    let failed = r.reference_failure.is_some();
    let paired = if settings.paired_reference && !failed {
        r.reference_observed.len()
    } else {
        0
    };
    if r.reference_coarse_observed.len() != paired {
        return Err(format!(
            "path {} has {} observed values of the paired reference where {paired} are expected",
            r.index,
            r.reference_coarse_observed.len()
        ));
    }
    let expected = if failed { Some(0) } else { tracks };
    if let Some(expected) = expected.filter(|&e| e != r.tracks.len()) {
        return Err(format!(
            "path {} has {} scheme-level results where {expected} are expected",
            r.index,
            r.tracks.len()
        ));
    }
    let reference = settings.reference.is_some();
    for (k, t) in r.tracks.iter().enumerate() {
        let problem = match (t.distances.is_some(), t.failure.is_some()) {
            (true, true) => Some("has distances and a failure"),
            (true, false) if !reference => Some("has distances but the study has no reference"),
            (false, false) if reference => Some("has neither distances nor a failure"),
            _ => None,
        };
        if let Some(problem) = problem {
            return Err(format!(
                "path {}: scheme-level result {k} {problem}",
                r.index
            ));
        }
    }
    Ok(())
}

/// Merges shards into exactly the report an unsharded run gives (timings aside): same scene
/// and settings (the thread count may differ), every path index present exactly once.
pub fn merge_shards(shards: Vec<ConvergenceRun>) -> Result<ConvergenceReport, StudyError> {
    merge_runs(shards).map(build_report)
}

/// The shards of one study merged into the unsharded run (every path once, as [`merge_shards`]
/// checks them), for a report built from the records: the convergence report or the weak-error
/// report.
pub fn merge_runs(shards: Vec<ConvergenceRun>) -> Result<ConvergenceRun, StudyError> {
    let merge = |reason: String| StudyError::Merge { reason };
    let within = |shard: &ConvergenceRun, reason: String| {
        merge(format!(
            "shard {}/{}: {reason}",
            shard.shard.0, shard.shard.1
        ))
    };
    let mut shards = shards.into_iter();
    let mut merged = shards.next().ok_or_else(|| merge("no shards".into()))?;
    merged.check_records().map_err(|r| within(&merged, r))?;
    let count = merged.shard.1;
    for shard in shards {
        if !merged.same_study(&shard) {
            return Err(merge(format!(
                "shard {}/{} was run with another scene or other settings than shard {}/{}",
                shard.shard.0, shard.shard.1, merged.shard.0, count
            )));
        }
        shard.check_records().map_err(|r| within(&shard, r))?;
        merged.records.extend(shard.records);
    }
    // Every path once over all shards (a shard given twice repeats its paths).
    merged.shard = (0, 1);
    merged.check_records().map_err(merge)?;
    let mut seen = vec![false; merged.settings.paths];
    merged.records.iter().for_each(|r| seen[r.index] = true);
    if let Some(missing) = seen.iter().position(|s| !s) {
        return Err(merge(format!(
            "path {missing} is missing: merge needs all {count} shards"
        )));
    }
    Ok(merged)
}

#[cfg(test)]
mod bound_tests {
    use super::*;

    #[test]
    fn the_smallest_step_is_the_square_root_of_the_smallest_normal_float() {
        assert_eq!(MIN_STEP, f64::MIN_POSITIVE.sqrt());
        assert!((MIN_STEP * MIN_STEP).is_normal());
    }

    #[test]
    fn final_times_whose_steps_square_to_an_underflow_are_refused() {
        let scene = Scene::built_in("pendulum").unwrap();
        let mut s = ConvergenceSettings::for_scene(&scene);
        let finest = s.reference.unwrap();
        s.t_end = MIN_STEP * 2f64.powi(finest as i32);
        assert_eq!(s.validate(), Ok(()));
        for t in [s.t_end / 2.0, 1e-160, 1e-300, 5e-324] {
            s.t_end = t;
            match s.validate() {
                Err(StudyError::Setting { key: "T", rule, .. }) => {
                    assert!(rule.contains("2^-511"), "{rule}")
                }
                other => panic!("T = {t:e}: {other:?}"),
            }
        }
    }

    #[test]
    fn errors_that_underflow_are_not_resolved() {
        assert!(underflowed(0.0));
        assert!(underflowed(1e-310));
        assert!(underflowed(f64::NAN));
        assert!(!underflowed(f64::MIN_POSITIVE));
        assert!(!underflowed(1e-3));
    }
}
