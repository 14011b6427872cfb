//! The convergence study: strong errors of every scheme at several step sizes against a
//! fine-step reference on the same Brownian paths, with observed orders and run time.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::integrator::{FailureKind, SchemeKind};
use crate::lockstep::{Limits, PathPlan, PathRecord, TrackOutcome};
use crate::parallel::{PathSelection, Skipped, applicable, run_paths};
use crate::scene::{Output, Prepared, Scene, SceneError, SceneRunner};
use crate::stats::{Interval, OrderFit, fit_order, lp_error, mean_interval};

/// A coarse level is pre-asymptotic when its local slope departs from the finer levels' by more.
const PRE_ASYMPTOTIC_TOLERANCE: f64 = 0.15;

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
    pub kinetic_after: Option<f64>,
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
        }
    }

    /// Checks the settings; the message names the bad one.
    pub fn validate(&self) -> Result<(), String> {
        if self.paths < 2 {
            return Err(format!("--paths must be >= 2, got {}", self.paths));
        }
        if self.coarsest > self.finest {
            return Err(format!(
                "--levels {}..{} is empty",
                self.coarsest, self.finest
            ));
        }
        match self.reference {
            Some(r) if r <= self.finest || r > 26 => {
                return Err(format!(
                    "--ref-level must be above the finest level {} and at most 26, got {r}",
                    self.finest
                ));
            }
            None if self.finest > 26 => {
                return Err(format!(
                    "--levels: at most 2^26 steps, got 2^{}",
                    self.finest
                ));
            }
            _ => {}
        }
        if let Some(tol) = self.limits.drift_tolerance {
            if tol.is_nan() || tol <= 0.0 {
                return Err(format!("drift tolerance must be > 0, got {tol}"));
            }
        }
        if self.limits.blow_up.is_nan() || self.limits.blow_up <= 0.0 {
            return Err(format!(
                "blow-up bound must be > 0, got {}",
                self.limits.blow_up
            ));
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return Err(format!("--T must be finite and > 0, got {}", self.t_end));
        }
        if !(self.p.is_finite() && self.p >= 1.0) {
            return Err(format!("--p must be finite and >= 1, got {}", self.p));
        }
        if self.schemes.is_empty() {
            return Err("--schemes names no scheme".into());
        }
        Ok(())
    }

    fn levels(&self) -> Vec<u32> {
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
    /// The schemes that ran, in the order of the records' tracks.
    pub schemes: Vec<SchemeKind>,
    /// The schemes left out.
    pub skipped: Vec<Skipped>,
    /// The equipartition value of the kinetic energy, for Langevin scenes.
    pub kinetic_target: Option<f64>,
    /// This run is shard `shard.0` of `shard.1` (paths i with i % shard.1 == shard.0).
    pub shard: (usize, usize),
    /// One record per path, by index.
    pub records: Vec<PathRecord>,
}

/// Runs the paths of shard `index` of `count`; `progress` is called with the number of
/// finished paths. Path i draws from its own stream, so the records do not depend on the
/// thread count or the sharding.
pub fn run_convergence(
    scene: &Scene,
    settings: &ConvergenceSettings,
    (index, count): (usize, usize),
    progress: impl Fn(usize) + Sync,
) -> Result<ConvergenceRun, SceneError> {
    settings.validate().map_err(|message| SceneError::Invalid {
        scene: scene.name.clone(),
        message,
    })?;
    scene.run(Runner {
        settings,
        shard: (index, count.max(1)),
        progress: &progress,
    })?
}

struct Runner<'a> {
    settings: &'a ConvergenceSettings,
    shard: (usize, usize),
    progress: &'a (dyn Fn(usize) + Sync),
}

impl SceneRunner for Runner<'_> {
    type Output = Result<ConvergenceRun, SceneError>;

    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
    {
        let st = self.settings;
        let invalid = |message: String| SceneError::Invalid {
            scene: scene.name.clone(),
            message,
        };
        let (schemes, skipped) = applicable(&st.schemes, &prepared);
        let (reference_ok, reference_skipped) = applicable(&[st.reference_scheme], &prepared);
        if st.reference.is_some() && reference_ok.is_empty() {
            return Err(invalid(format!(
                "the reference scheme {} does not apply: {}",
                st.reference_scheme.name(),
                reference_skipped[0].reason
            )));
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
        };
        let records = run_paths(
            &plan,
            &schemes,
            st.reference.map(|_| st.reference_scheme),
            &prepared,
            PathSelection {
                seed: st.seed,
                paths: st.paths,
                shard: self.shard,
                threads: st.threads,
            },
            self.progress,
        )
        .map_err(invalid)?;
        Ok(ConvergenceRun {
            scene: scene.clone(),
            settings: st.clone(),
            schemes,
            skipped,
            kinetic_target: prepared.kinetic_target,
            shard: self.shard,
            records,
        })
    }
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
    pub h: f64,
    /// L^p norms over the finished paths of sup_k |r_k - r_ref(t_k)|, sup_k |v_k - v_ref(t_k)|,
    /// sup_k |mu_k - mu_ref(t_k)| (k over this level's grid), with 95% confidence intervals.
    pub error: Errors,
    /// Paths counted (those whose reference finished).
    pub paths: usize,
    /// Share of the paths that finished.
    pub finished_fraction: f64,
    /// Mean over the finished paths of the time-averaged kinetic energy v^T M v / 2, with a 95%
    /// confidence interval (when the scene asks for it).
    pub kinetic_energy: Option<Interval>,
    /// Mean wall-clock seconds of stepping per path.
    pub seconds_per_path: f64,
    /// Steps per second of stepping.
    pub steps_per_second: f64,
    /// Paths that failed (not counted in the errors).
    pub failures: usize,
    /// Failures by kind.
    pub failures_by_kind: BTreeMap<FailureKind, usize>,
    /// Share of steps with a truncated drift.
    pub truncated_fraction: f64,
    /// Mean Newton iterations per step.
    pub newton_iterations_per_step: f64,
    /// Steps that needed the homotopy fallback.
    pub homotopy_steps: usize,
    /// Largest |g(r_k)| on the grid.
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| on the grid.
    pub max_velocity_residual: f64,
}

/// One scheme over all levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SchemeReport {
    /// The scheme's name.
    pub name: &'static str,
    /// Levels from coarse to fine.
    pub levels: Vec<LevelReport>,
    /// Least-squares slope of log(error) against log(h) with 95% intervals; coarse levels whose
    /// local slope departs from the finer ones by more than 0.15 are flagged, not fitted.
    pub observed_order: Orders,
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
    pub seconds_per_path: f64,
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
    pub kinetic_target: Option<f64>,
    /// The scene as run.
    pub scene_definition: Scene,
}

fn count_kinds(kinds: impl Iterator<Item = FailureKind>) -> BTreeMap<FailureKind, usize> {
    let mut map = BTreeMap::new();
    for k in kinds {
        *map.entry(k).or_insert(0) += 1;
    }
    map
}

fn level_report<'a>(
    scene: &Scene,
    settings: &ConvergenceSettings,
    steps: usize,
    paths: impl Iterator<Item = &'a TrackOutcome>,
) -> LevelReport {
    let mut distances: [Vec<f64>; 3] = Default::default();
    let (mut seconds, mut count, mut failures) = (0.0, 0usize, Vec::new());
    let (mut steps_total, mut truncated, mut iterations, mut homotopy) = (0, 0, 0, 0);
    let (mut max_g, mut max_dgv) = (0.0_f64, 0.0_f64);
    let mut kinetic = Vec::new();
    for p in paths {
        count += 1;
        seconds += p.seconds;
        truncated += p.truncated_steps;
        iterations += p.newton_iterations;
        steps_total += p.steps;
        homotopy += p.homotopy_steps;
        max_g = max_g.max(p.max_position_residual);
        max_dgv = max_dgv.max(p.max_velocity_residual);
        if let Some(e) = p.distances {
            (0..3).for_each(|c| distances[c].push(e[c]));
        }
        if let Some(kind) = p.failure {
            failures.push(kind);
        } else if let Some(k) = p.kinetic_energy {
            kinetic.push(k);
        }
    }
    let error = |c: usize, output: Output| {
        (scene.wants(output) && settings.reference.is_some())
            .then(|| lp_error(&distances[c], settings.p))
    };
    let per_step = |x: usize| x as f64 / steps_total.max(1) as f64;
    LevelReport {
        n_steps: steps,
        h: settings.t_end / steps as f64,
        error: Errors {
            r: error(0, Output::Position),
            v: error(1, Output::Velocity),
            mu: error(2, Output::Multiplier),
        },
        paths: count,
        finished_fraction: 1.0 - failures.len() as f64 / count.max(1) as f64,
        kinetic_energy: (!kinetic.is_empty()).then(|| mean_interval(&kinetic)),
        seconds_per_path: seconds / count.max(1) as f64,
        steps_per_second: if seconds > 0.0 {
            steps_total as f64 / seconds
        } else {
            0.0
        },
        failures: failures.len(),
        failures_by_kind: count_kinds(failures.into_iter()),
        truncated_fraction: per_step(truncated),
        newton_iterations_per_step: per_step(iterations),
        homotopy_steps: homotopy,
        max_position_residual: max_g,
        max_velocity_residual: max_dgv,
    }
}

fn fit(levels: &[LevelReport], pick: fn(&Errors) -> Option<Interval>) -> Option<OrderFit> {
    let points: Option<Vec<(f64, f64)>> = levels
        .iter()
        .map(|l| pick(&l.error).map(|e| (l.h, e.estimate)))
        .collect();
    points.map(|p| fit_order(&p, PRE_ASYMPTOTIC_TOLERANCE))
}

/// The report from the records of all paths (in any order).
pub fn build_report(run: ConvergenceRun) -> ConvergenceReport {
    let ConvergenceRun {
        scene,
        settings,
        schemes,
        skipped,
        kinetic_target,
        mut records,
        ..
    } = run;
    records.sort_by_key(|r| r.index);
    let good: Vec<&PathRecord> = records
        .iter()
        .filter(|r| r.reference_failure.is_none())
        .collect();
    let levels = settings.levels();
    let schemes = schemes
        .iter()
        .enumerate()
        .map(|(s, kind)| {
            let reports: Vec<LevelReport> = levels
                .iter()
                .enumerate()
                .map(|(j, &k)| {
                    let outcomes = good.iter().map(|p| &p.tracks[s * levels.len() + j]);
                    level_report(&scene, &settings, 1usize << k, outcomes)
                })
                .collect();
            SchemeReport {
                name: kind.name(),
                observed_order: Orders {
                    r: fit(&reports, |e| e.r),
                    v: fit(&reports, |e| e.v),
                    mu: fit(&reports, |e| e.mu),
                },
                levels: reports,
            }
        })
        .collect();
    let reference = settings.reference.map(|level| ReferenceReport {
        scheme: settings.reference_scheme.name(),
        n_steps: 1 << level,
        failures: records.len() - good.len(),
        failures_by_kind: count_kinds(records.iter().filter_map(|r| r.reference_failure)),
        seconds_per_path: records.iter().map(|r| r.reference_seconds).sum::<f64>()
            / records.len().max(1) as f64,
    });
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

/// Merges shards into exactly the report an unsharded run gives (timings aside): same scene
/// and settings (the thread count may differ), every path index present exactly once.
pub fn merge_shards(shards: Vec<ConvergenceRun>) -> Result<ConvergenceReport, String> {
    let mut shards = shards.into_iter();
    let mut merged = shards.next().ok_or("no shards to merge")?;
    let count = merged.shard.1;
    let same = |a: &ConvergenceRun, b: &ConvergenceRun| {
        let threads = |s: &ConvergenceSettings| ConvergenceSettings {
            threads: 1,
            ..s.clone()
        };
        a.scene == b.scene
            && threads(&a.settings) == threads(&b.settings)
            && a.schemes == b.schemes
            && a.shard.1 == b.shard.1
    };
    for shard in shards {
        if !same(&merged, &shard) {
            return Err(format!(
                "shard {}/{} was run with another scene or other settings than shard {}/{}",
                shard.shard.0, shard.shard.1, merged.shard.0, count
            ));
        }
        merged.records.extend(shard.records);
    }
    let mut seen = vec![false; merged.settings.paths];
    for record in &merged.records {
        match seen.get_mut(record.index) {
            Some(s) if !*s => *s = true,
            _ => {
                return Err(format!(
                    "path {} appears twice or is out of range",
                    record.index
                ));
            }
        }
    }
    if let Some(missing) = seen.iter().position(|s| !s) {
        return Err(format!(
            "path {missing} is missing: merge needs all {count} shards"
        ));
    }
    merged.shard = (0, 1);
    Ok(build_report(merged))
}
