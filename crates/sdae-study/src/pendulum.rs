//! Strong errors of the scheme on the stochastic pendulum against a fine-step reference.

use std::time::Instant;

use sdae_scheme::{
    Coarsened, GaussianIncrements, IncrementSource, Observer, PathDiagnostics, Pendulum,
    PendulumParams, RecordedIncrements, Recorder, Stepper, StepperConfig, TimeGrid, pendulum,
    run_path,
};
use serde::{Deserialize, Serialize};

use crate::stats::{Interval, OrderFit, fit_order, lp_error};

/// What to run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PendulumStudy {
    /// Number of Monte Carlo paths.
    pub paths: usize,
    /// Levels use N = 2^k steps for k in `coarsest..=finest`.
    pub coarsest: u32,
    /// See `coarsest`.
    pub finest: u32,
    /// The reference uses 2^`reference` steps on the same Brownian path.
    pub reference: u32,
    /// Final time T.
    pub t_end: f64,
    /// Truncation constant C_eta (the theory value for the unit pendulum is 1/4).
    pub c_eta: f64,
    /// Seed of the path streams.
    pub seed: u64,
    /// The errors are L^p norms over paths.
    pub p: f64,
    /// Worker threads.
    pub threads: usize,
}

impl PendulumStudy {
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
        if self.finest >= self.reference || self.reference > 24 {
            return Err(format!(
                "--ref-level must be above the finest level {} and at most 24, got {}",
                self.finest, self.reference
            ));
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return Err(format!("--T must be finite and > 0, got {}", self.t_end));
        }
        if !(self.p.is_finite() && self.p >= 1.0) {
            return Err(format!("--p must be finite and >= 1, got {}", self.p));
        }
        if !(self.c_eta.is_finite() && self.c_eta > 0.0) {
            return Err(format!(
                "--c-eta must be finite and > 0, got {}",
                self.c_eta
            ));
        }
        Ok(())
    }
}

impl Default for PendulumStudy {
    fn default() -> Self {
        Self {
            paths: 10_000,
            coarsest: 3,
            finest: 10,
            reference: 15,
            t_end: 1.0,
            c_eta: 0.25,
            seed: 2026,
            p: 2.0,
            threads: 2,
        }
    }
}

/// Results of one level (one step size).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelReport {
    /// N.
    pub n_steps: usize,
    /// h = T / N.
    pub h: f64,
    /// L^p norms over the finished paths of sup_k |r_k - r_ref(t_k)|, sup_k |v_k - v_ref(t_k)|,
    /// sup_k |mu_k - mu_ref(t_k)| (k over this level's grid), with 95% confidence intervals.
    pub error: Errors,
    /// Mean wall-clock seconds per path at this level.
    pub seconds_per_path: f64,
    /// Share of steps with eta < 1.
    pub truncated_fraction: f64,
    /// Mean Newton iterations per step.
    pub newton_iterations_per_step: f64,
    /// Steps that needed the homotopy fallback.
    pub homotopy_steps: usize,
    /// Paths that failed (not counted in the errors).
    pub failures: usize,
    /// Largest |g(r_k)| seen.
    pub max_position_residual: f64,
}

/// Errors of r, v and mu.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Errors {
    /// Position.
    pub r: Interval,
    /// Velocity.
    pub v: Interval,
    /// Multiplier.
    pub mu: Interval,
}

/// Fitted orders of r, v and mu.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Orders {
    /// Position.
    pub r: OrderFit,
    /// Velocity.
    pub v: OrderFit,
    /// Multiplier.
    pub mu: OrderFit,
}

/// The whole study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyReport {
    /// Scene name.
    pub scene: &'static str,
    /// Settings.
    pub settings: PendulumStudy,
    /// Levels from coarse to fine.
    pub levels: Vec<LevelReport>,
    /// Least-squares slope of log(error) against log(h) with 95% intervals; coarse levels whose
    /// local slope departs from the finer ones by more than 0.15 are flagged, not fitted.
    pub observed_order: Orders,
    /// Reference paths that failed (their paths are left out entirely).
    pub reference_failures: usize,
}

/// What one level of one path produced: the study's per-path data (what a shard stores).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LevelOutcome {
    /// sup over the coarse grid of |r - r_ref|, |v - v_ref|, |mu - mu_ref|; `None` if the path
    /// failed.
    pub distances: Option<[f64; 3]>,
    /// Wall-clock seconds of the path.
    pub seconds: f64,
    /// Steps done.
    pub steps: usize,
    /// Steps with eta < 1.
    pub truncated_steps: usize,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Steps that needed the homotopy.
    pub homotopy_steps: usize,
    /// Largest |g(r_k)|.
    pub max_position_residual: f64,
}

/// One Monte Carlo path: whether its reference finished, and each level's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathRecord {
    /// Path index i (its random stream is `path_rng(seed, i)`).
    pub index: usize,
    /// Whether the reference solution finished (otherwise the path is left out).
    pub reference_ok: bool,
    /// Outcomes from the coarsest to the finest level.
    pub levels: Vec<LevelOutcome>,
}

/// The paths of one shard `index` of `count` (paths i with i % count == index).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Shard {
    /// The study's settings.
    pub settings: PendulumStudy,
    /// This shard's index.
    pub index: usize,
    /// The number of shards.
    pub count: usize,
    /// Its paths.
    pub records: Vec<PathRecord>,
}

fn scene() -> PendulumParams {
    PendulumParams {
        gravity: 1.0,
        noise: 1.0,
        ..PendulumParams::default()
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Sums groups of `factor` consecutive fine increments (rows of length 2) into coarse ones.
fn coarsen(fine: &[f64], factor: usize) -> Vec<f64> {
    let mut source = Coarsened::new(RecordedIncrements::new(fine, 2), factor);
    let mut coarse = vec![0.0; fine.len() / factor];
    for dw in coarse.chunks_exact_mut(2) {
        source.next_increment(0.0, dw);
    }
    coarse
}

/// Runs one path with the given increments (one row of 2 per step), reporting to `observer`;
/// returns whether it finished, the wall-clock seconds of the path (increments prepared
/// beforehand) and its diagnostics.
fn run_level<O: Observer>(
    study: &PendulumStudy,
    stepper: &mut Stepper<Pendulum>,
    increments: &[f64],
    observer: &mut O,
) -> (bool, f64, PathDiagnostics) {
    let steps = increments.len() / 2;
    let grid = TimeGrid::new(study.t_end, steps).expect("validated by PendulumStudy::validate");
    let mut source = RecordedIncrements::new(increments, 2);
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    let start = Instant::now();
    let outcome = run_path(stepper, &mut r, &mut v, grid, &mut source, observer);
    let seconds = start.elapsed().as_secs_f64();
    match outcome {
        Ok(d) => (true, seconds, d),
        Err(failure) => (false, seconds, *failure.diagnostics),
    }
}

/// sup over the coarse grid of |r_k - r_ref(t_k)|, |v_k - v_ref(t_k)|, |mu_k - mu_ref(t_k)|,
/// computed while the coarse path runs: coarse step k is reference record k * stride.
struct SupDistance<'a> {
    reference: &'a Recorder,
    stride: usize,
    max: [f64; 3],
}

impl Observer for SupDistance<'_> {
    fn wants_mu(&self) -> bool {
        true
    }
    fn observe(&mut self, k: usize, _t: f64, r: &[f64], v: &[f64], mu: &[f64]) {
        let j = k * self.stride;
        let d = [
            distance(r, self.reference.position(j)),
            distance(v, self.reference.velocity(j)),
            distance(mu, self.reference.multiplier(j)),
        ];
        for (m, x) in self.max.iter_mut().zip(d) {
            *m = m.max(x);
        }
    }
}

/// One Monte Carlo path: the reference and every level on the same Brownian path.
/// The study's stepper; one per worker thread (it keeps no state from one path to the next).
fn new_stepper(study: &PendulumStudy) -> Stepper<Pendulum> {
    let system = pendulum(scene()).expect("the built-in scene is valid");
    let config = StepperConfig::for_system(&system)
        .and_then(|c| c.with_c_eta(study.c_eta))
        .expect("validated by PendulumStudy::validate");
    Stepper::new(system, config).expect("the built-in scene is valid")
}

fn one_path(study: &PendulumStudy, stepper: &mut Stepper<Pendulum>, index: usize) -> PathRecord {
    let fine_steps = 1usize << study.reference;
    let h_fine = study.t_end / fine_steps as f64;
    let mut increments = vec![0.0; 2 * fine_steps];
    let mut noise = GaussianIncrements::for_path(study.seed, index as u64, 2);
    for dw in increments.chunks_exact_mut(2) {
        noise.next_increment(h_fine, dw);
    }
    // The reference is recorded on the finest level's grid, which contains every coarser one.
    let mut reference = Recorder::every(fine_steps >> study.finest).with_mu();
    let (ok, _, _) = run_level(study, stepper, &increments, &mut reference);
    if !ok {
        return PathRecord {
            index,
            reference_ok: false,
            levels: Vec::new(),
        };
    }
    let levels = (study.coarsest..=study.finest)
        .map(|k| {
            let coarse = coarsen(&increments, fine_steps >> k);
            let mut sup = SupDistance {
                reference: &reference,
                stride: 1 << (study.finest - k),
                max: [0.0; 3],
            };
            let (ok, seconds, d) = run_level(study, stepper, &coarse, &mut sup);
            LevelOutcome {
                distances: ok.then_some(sup.max),
                seconds,
                steps: d.steps,
                truncated_steps: d.truncated_steps,
                newton_iterations: d.newton_iterations,
                homotopy_steps: d.homotopy_steps,
                max_position_residual: d.max_position_residual,
            }
        })
        .collect();
    PathRecord {
        index,
        reference_ok: true,
        levels,
    }
}

/// A coarse level is pre-asymptotic when its local slope departs from the finer levels' by more.
const PRE_ASYMPTOTIC_TOLERANCE: f64 = 0.15;

/// Runs the paths i < `study.paths` with i % `count` == `index` on `study.threads` threads;
/// `progress` is called with the number of finished paths. Path i draws from its own stream, so
/// the records do not depend on the thread count or the sharding.
pub fn run_paths(
    study: &PendulumStudy,
    index: usize,
    count: usize,
    progress: impl Fn(usize) + Sync,
) -> Vec<PathRecord> {
    let mine: Vec<usize> = (0..study.paths)
        .filter(|i| i % count.max(1) == index)
        .collect();
    let threads = study.threads.max(1);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut records: Vec<PathRecord> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|t| {
                let (done, progress, mine) = (&done, &progress, &mine);
                scope.spawn(move || {
                    let mut stepper = new_stepper(study);
                    mine.iter()
                        .skip(t)
                        .step_by(threads)
                        .map(|&i| {
                            let record = one_path(study, &mut stepper, i);
                            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
                            record
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().expect("a study worker panicked"))
            .collect()
    });
    records.sort_by_key(|r| r.index);
    records
}

/// The report from the records of all paths (in any order).
pub fn build_report(study: &PendulumStudy, mut records: Vec<PathRecord>) -> StudyReport {
    records.sort_by_key(|r| r.index);
    let reference_failures = records.iter().filter(|r| !r.reference_ok).count();
    let good: Vec<&PathRecord> = records.iter().filter(|r| r.reference_ok).collect();
    let levels: Vec<LevelReport> = (study.coarsest..=study.finest)
        .enumerate()
        .map(|(j, k)| level_report(study, 1usize << k, good.iter().map(|p| &p.levels[j])))
        .collect();
    let fit = |pick: fn(&Errors) -> f64| {
        let points: Vec<(f64, f64)> = levels.iter().map(|l| (l.h, pick(&l.error))).collect();
        fit_order(&points, PRE_ASYMPTOTIC_TOLERANCE)
    };
    let observed_order = Orders {
        r: fit(|e| e.r.estimate),
        v: fit(|e| e.v.estimate),
        mu: fit(|e| e.mu.estimate),
    };
    StudyReport {
        scene: "pendulum",
        settings: *study,
        levels,
        observed_order,
        reference_failures,
    }
}

/// Runs the whole study; `progress` is called with the number of finished paths.
pub fn pendulum_study(study: PendulumStudy, progress: impl Fn(usize) + Sync) -> StudyReport {
    build_report(&study, run_paths(&study, 0, 1, progress))
}

/// Merges shards into exactly the report an unsharded run gives (timings aside): same
/// settings (the thread count may differ), and every path index present exactly once.
pub fn merge_shards(shards: Vec<Shard>) -> Result<StudyReport, String> {
    let first = shards.first().ok_or("no shards to merge")?;
    let settings = PendulumStudy {
        threads: 1,
        ..first.settings
    };
    let count = first.count;
    let mut seen = vec![false; settings.paths];
    let mut records = Vec::with_capacity(settings.paths);
    for shard in shards {
        let same = PendulumStudy {
            threads: 1,
            ..shard.settings
        };
        if same != settings || shard.count != count {
            return Err(format!(
                "shard {}/{} was run with other settings than shard {}/{}",
                shard.index,
                shard.count,
                first_index(&seen),
                count
            ));
        }
        for record in shard.records {
            match seen.get_mut(record.index) {
                Some(s) if !*s => *s = true,
                _ => {
                    return Err(format!(
                        "path {} appears twice or is out of range",
                        record.index
                    ));
                }
            }
            records.push(record);
        }
    }
    if let Some(missing) = seen.iter().position(|s| !s) {
        return Err(format!(
            "path {missing} is missing: merge needs all {count} shards"
        ));
    }
    Ok(build_report(&settings, records))
}

fn first_index(seen: &[bool]) -> usize {
    seen.iter().position(|s| *s).unwrap_or(0)
}

fn level_report<'a>(
    study: &PendulumStudy,
    steps: usize,
    paths: impl Iterator<Item = &'a LevelOutcome>,
) -> LevelReport {
    let mut distances: [Vec<f64>; 3] = Default::default();
    let (mut seconds, mut count, mut failures) = (0.0, 0usize, 0usize);
    let (mut steps_total, mut truncated, mut iterations) = (0usize, 0usize, 0usize);
    let (mut homotopy_steps, mut max_position_residual) = (0usize, 0.0_f64);
    for p in paths {
        count += 1;
        seconds += p.seconds;
        truncated += p.truncated_steps;
        iterations += p.newton_iterations;
        steps_total += p.steps;
        homotopy_steps += p.homotopy_steps;
        max_position_residual = max_position_residual.max(p.max_position_residual);
        match p.distances {
            Some(e) => (0..3).for_each(|c| distances[c].push(e[c])),
            None => failures += 1,
        }
    }
    let steps_total = steps_total.max(1) as f64;
    LevelReport {
        n_steps: steps,
        h: study.t_end / steps as f64,
        error: Errors {
            r: lp_error(&distances[0], study.p),
            v: lp_error(&distances[1], study.p),
            mu: lp_error(&distances[2], study.p),
        },
        seconds_per_path: seconds / count.max(1) as f64,
        truncated_fraction: truncated as f64 / steps_total,
        newton_iterations_per_step: iterations as f64 / steps_total,
        homotopy_steps,
        failures,
        max_position_residual,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let study = PendulumStudy {
            paths: 6,
            coarsest: 2,
            finest: 4,
            reference: 8,
            ..PendulumStudy::default()
        };
        let one = pendulum_study(
            PendulumStudy {
                threads: 1,
                ..study
            },
            |_| {},
        );
        let two = pendulum_study(
            PendulumStudy {
                threads: 2,
                ..study
            },
            |_| {},
        );
        for (a, b) in one.levels.iter().zip(&two.levels) {
            assert_eq!(a.error, b.error);
        }
        assert!(
            one.levels
                .iter()
                .all(|l| l.error.r.estimate > 0.0 && l.failures == 0)
        );
    }
}
