//! The command line: one subcommand per study, each taking only its own options.

use std::path::PathBuf;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand};
use sdae_mlmc::expectation::{CostMeasure, Method};
use sdae_study::convergence::{ConvergenceSettings, MAX_THREADS};
use sdae_study::integrator::SchemeKind;
use sdae_study::options::{
    ConvergenceOptions, EnsembleOptions, MLQMC_INITIAL_POINTS, MLQMC_RANDOMIZATIONS, MlmcOptions,
    WEAK_RANDOMIZATIONS, WeakOptions,
};
use sdae_study::scene::{BUILT_IN, Scene, escaped};
use sdae_study::trajectory::TrajectoryFormat;

use crate::shard::ShardArg;

/// Strong errors of the half-explicit drift-truncated Euler scheme and of solvers of the
/// inherent SDE, against a fine-step reference on the same Brownian paths, with run time.
///
/// Without a subcommand it runs the convergence study (default: the pendulum scene). Each
/// scene gets <OUT>/<scene>/report.json, report.csv, report.md, error_vs_h.svg and
/// error_vs_time.svg. Exit codes: 0 the study ran; 1 it ran but something could not be
/// compared or saved (the message names the failures); 2 the command line or a setting is
/// wrong or refused (a locked or unwritable output folder, a bad checkpoint); 130 interrupted,
/// the finished paths are saved (run again with --resume); 131 interrupted, nothing saved.
#[derive(Debug, Parser)]
#[command(name = "sdae-study", version, args_conflicts_with_subcommands = true)]
pub struct Cli {
    /// The study to run.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Options of the default convergence study.
    #[command(flatten)]
    pub convergence: ConvergenceArgs,
}

/// The studies and tools.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Strong errors against a fine reference, orders and run time (the default).
    Convergence(ConvergenceArgs),
    /// Failures, residuals and truncation on the stiff and extreme scenes (default: every
    /// built-in scene with a [stability] table); writes <OUT>/stability/.
    Stability(EnsembleArgs),
    /// Kinetic temperature of the Langevin scenes against h and C_eta, and every scheme's
    /// invariant-measure bias with its order against h and run time (default: every built-in
    /// scene with an [equipartition] table); writes <OUT>/equipartition/.
    Equipartition(EnsembleArgs),
    /// Weak errors E[f(X_N)] - E[f(X_T)] of the scene's observables, weak orders and
    /// Richardson-Romberg extrapolation (default: the pendulum scene); writes
    /// <OUT>/<scene>/weak.json, weak.csv, weak.md and plots.
    Weak(WeakArgs),
    /// Merge the shard files of `--shard I/N` runs into the unsharded report.
    Merge(MergeArgs),
    /// One path of each scene as <OUT>/trace/<scene>.svg and .csv (default: every built-in
    /// scene).
    Trace(TraceArgs),
    /// Paths of a scene with one scheme as trajectory files, written as they are simulated:
    /// extended XYZ (VMD, OVITO), VTK (ParaView) or CSV; writes <OUT>/simulate/<scene>/.
    Simulate(SimulateArgs),
    /// The built-in scenes and the schemes.
    List,
    /// Multilevel Monte Carlo of E[f(X_T)] (Giles): convergence test, rates, complexity
    /// table, savings against standard Monte Carlo (default: the pendulum's E[cos phi_T]);
    /// writes <OUT>/mlmc/<scene>/. An interrupted run saves the blocks of samples it finished
    /// (exit code 130) and --resume carries on from them to the numbers of an uninterrupted
    /// run.
    Mlmc(MlmcArgs),
    /// Merge the shard files of `mlmc --plan FILE --shard I/N` runs into the plan's report.
    MlmcMerge(MlmcMergeArgs),
    /// E[f(X_T)] to an accuracy eps by whichever of standard Monte Carlo, randomized QMC,
    /// MLMC and multilevel QMC a short pilot predicts cheapest (default: the pendulum's
    /// E[cos phi_T]); writes <OUT>/expect/<scene>/report.json, report.md and report.csv.
    Expect(ExpectArgs),
    /// Compare the numbers of two reports or shards (JSON), leaving out what differs between
    /// runs (timings, thread counts): exit code 0 if they are equal, 1 with the first
    /// difference.
    Compare(CompareArgs),
}

/// Which scenes to run.
#[derive(Debug, Clone, Args)]
pub struct SceneArgs {
    /// Built-in scenes, comma-separated (`list` shows them).
    #[arg(long, value_name = "NAMES", value_delimiter = ',',
          value_parser = OneOf(BUILT_IN.map(|(name, _)| name).to_vec()))]
    pub scene: Vec<String>,
    /// A scene file (TOML); may be repeated.
    #[arg(long = "scene-file", value_name = "PATH")]
    pub scene_file: Vec<PathBuf>,
}

/// Where results go.
#[derive(Debug, Clone, Args)]
pub struct OutArgs {
    /// Output folder; one subfolder per scene or study.
    #[arg(
        long,
        value_name = "DIR",
        env = "SDAE_STUDY_OUT",
        default_value = "target/study"
    )]
    pub out: PathBuf,
}

/// Options of every Monte Carlo study.
#[derive(Debug, Clone, Args)]
pub struct EnsembleArgs {
    #[command(flatten)]
    pub scenes: SceneArgs,
    /// Monte Carlo paths (default: the scene's).
    #[arg(long, value_name = "N")]
    pub paths: Option<usize>,
    /// Seed of the path streams (default: the scene's, 2026 unless it says otherwise).
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
    /// Worker threads, 1 to 1024 (default: the available cores); more than the paths or than
    /// 4 per available core are not started (the run's first line gives the count); the
    /// numbers do not depend on it.
    #[arg(long, value_name = "K", value_parser = thread_count)]
    pub threads: Option<usize>,
    /// A small run for CI: fewer paths, the scene's coarsest levels and a reference 2^4 times
    /// finer than the finest level.
    #[arg(long)]
    pub quick: bool,
    #[command(flatten)]
    pub checkpoint: CheckpointArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Options of a study that saves checkpoints.
#[derive(Debug, Clone, Args)]
pub struct CheckpointArgs {
    /// Carry on from what an interrupted run of the same command saved (its finished paths,
    /// or for mlmc its finished blocks of samples).
    #[arg(long, conflicts_with = "fresh")]
    pub resume: bool,
    /// Start afresh over the checkpoint of an interrupted run, discarding what it saved
    /// (without --resume or --fresh such a checkpoint is refused).
    #[arg(long)]
    pub fresh: bool,
    /// Save what is finished every SECONDS while the study runs (at most a year, 31536000).
    /// Each save is synced to disk, so a save waits too for 9 times as long as the last one
    /// took: saving takes at most about a tenth of the run. 0 saves after every block of
    /// paths or samples when the disk keeps up, else as often as that allows.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, value_parser = seconds)]
    pub checkpoint_every: f64,
}

/// Options of the convergence study.
#[derive(Debug, Clone, Args)]
pub struct ConvergenceArgs {
    #[command(flatten)]
    pub ensemble: EnsembleArgs,
    /// Schemes to compare, comma-separated (default: all that apply).
    #[arg(long, value_name = "NAMES", value_delimiter = ',', value_parser = scheme_parser())]
    pub schemes: Vec<SchemeKind>,
    /// Scheme of the reference (default: half-explicit-practical).
    #[arg(long = "reference-scheme", value_name = "NAME", value_parser = scheme_parser())]
    pub reference_scheme: Option<SchemeKind>,
    /// Step counts N = 2^A .. 2^B (default: the scene's).
    #[arg(long, value_name = "A..B", value_parser = parse_levels)]
    pub levels: Option<(u32, u32)>,
    /// Reference with 2^R steps (default: the scene's).
    #[arg(long = "ref-level", value_name = "R")]
    pub ref_level: Option<u32>,
    /// Final time (default: the scene's).
    #[arg(long = "t-end", alias = "T", value_name = "T")]
    pub t_end: Option<f64>,
    /// Errors are L^p norms over paths (default 2).
    #[arg(long, value_name = "P")]
    pub p: Option<f64>,
    /// Run only paths i with i % N == I and write <OUT>/<scene>/shard-I-of-N.json; `auto`
    /// takes I and N from a Slurm job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT).
    #[arg(long, value_name = "I/N|auto", value_parser = ShardArg::parse)]
    pub shard: Option<ShardArg>,
}

/// Options of the weak-error study.
#[derive(Debug, Clone, Args)]
pub struct WeakArgs {
    #[command(flatten)]
    pub ensemble: EnsembleArgs,
    /// Run only paths i with i % N == I and write <OUT>/<scene>/weak-shard-I-of-N.json
    /// (`merge` makes the unsharded weak report of them); `auto` takes I and N from a Slurm job
    /// array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT).
    #[arg(long, value_name = "I/N|auto", value_parser = ShardArg::parse)]
    pub shard: Option<ShardArg>,
    /// Randomized quasi-Monte Carlo paths (scrambled Sobol' points, Brownian bridge): R
    /// randomizations of n = paths / R points, path p being point p % n of randomization p / n;
    /// each randomization's values are averaged into one sample and the intervals rest on the R
    /// samples. --paths must then be R n with n a power of two; without --paths, the scene's
    /// paths are rounded down to such a number.
    #[arg(long)]
    pub qmc: bool,
    /// With --qmc: randomizations R (at least 2; their spread gives the intervals).
    #[arg(long, value_name = "R", default_value_t = WEAK_RANDOMIZATIONS, requires = "qmc")]
    pub randomizations: usize,
}

/// Options of `merge`.
#[derive(Debug, Clone, Args)]
pub struct MergeArgs {
    /// Folders holding shard-*.json and weak-shard-*.json files (searched one level deep).
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Options of `compare`.
#[derive(Debug, Clone, Args)]
pub struct CompareArgs {
    /// The first report.
    #[arg(value_name = "A")]
    pub first: PathBuf,
    /// The second report.
    #[arg(value_name = "B")]
    pub second: PathBuf,
}

/// Options of `trace`.
#[derive(Debug, Clone, Args)]
pub struct TraceArgs {
    #[command(flatten)]
    pub scenes: SceneArgs,
    /// Seed of the path stream.
    #[arg(long, value_name = "S", default_value_t = 2026)]
    pub seed: u64,
    #[command(flatten)]
    pub out: OutArgs,
}

fn scheme_parser() -> impl TypedValueParser<Value = SchemeKind> {
    OneOf(SchemeKind::ALL.map(SchemeKind::name).to_vec())
        .map(|name| SchemeKind::from_name(&name).expect("one of the possible values"))
}

/// A value that must be one of these names. A refused value is shown with its control
/// characters escaped ([`escaped`]), where clap would print it raw (a newline in a scene's
/// name would break the message's line), with the possible values and the nearest one, or the
/// first one it begins (`euler` for `euler-maruyama`).
#[derive(Debug, Clone)]
struct OneOf(Vec<&'static str>);

impl TypedValueParser for OneOf {
    type Value = String;

    fn parse_ref(
        &self, cmd: &clap::Command, arg: Option<&clap::Arg>, value: &std::ffi::OsStr,
    ) -> Result<String, clap::Error> {
        if let Some(name) = value.to_str().filter(|v| self.0.contains(v)) {
            return Ok(name.to_string());
        }
        let flag = arg.map_or_else(|| "the value".to_string(), |a| format!("'{a}'"));
        let value = value.to_string_lossy();
        let begun = |n: &&&str| !value.is_empty() && n.starts_with(&*value);
        let tip = sdae_study::observable::nearest(&value, &self.0)
            .or_else(|| self.0.iter().find(begun).copied())
            .map_or(String::new(), |n| {
                format!("\n\n  tip: a similar value exists: '{n}'")
            });
        let message = format!(
            "invalid value '{}' for {flag}\n  [possible values: {}]{tip}",
            escaped(&value),
            self.0.join(", ")
        );
        let mut cmd = cmd.clone();
        Err(clap::Error::raw(clap::error::ErrorKind::InvalidValue, message).format(&mut cmd))
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(
            self.0.iter().map(|n| clap::builder::PossibleValue::new(*n)),
        ))
    }
}

fn thread_count(value: &str) -> Result<usize, String> {
    match value.parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) if n > MAX_THREADS => Err(format!("must be at most {MAX_THREADS}")),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}

/// Whether the user typed `flag` on the command line (`--flag V` or `--flag=V`).
pub fn typed(flag: &str) -> bool {
    std::env::args_os().skip(1).any(|arg| {
        arg.to_str().is_some_and(|arg| {
            arg.strip_prefix(flag)
                .is_some_and(|rest| rest.is_empty() || rest.starts_with('='))
        })
    })
}

/// The value the user typed for `flag` (`--flag V` or `--flag=V`; the last one if repeated),
/// `None` if the flag was not typed with a value.
pub fn typed_value(flag: &str) -> Option<String> {
    let args: Vec<String> = std::env::args_os()
        .skip(1)
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    args.iter().enumerate().rev().find_map(|(k, arg)| {
        if arg == flag {
            args.get(k + 1).cloned()
        } else {
            arg.strip_prefix(flag)
                .and_then(|rest| rest.strip_prefix('='))
                .map(str::to_string)
        }
    })
}

/// The longest checkpoint interval, in seconds: a year. Longer than any batch job runs (an
/// interval longer than the run saves only when it is stopped), and far below the
/// 1.8e19 seconds a [`std::time::Duration`] holds.
pub const MAX_CHECKPOINT_SECONDS: f64 = 365.0 * 24.0 * 3600.0;

/// A checkpoint interval: finite, >= 0 and at most [`MAX_CHECKPOINT_SECONDS`].
fn seconds(value: &str) -> Result<f64, String> {
    match value.parse::<f64>() {
        Ok(s) if s.is_finite() && (0.0..=MAX_CHECKPOINT_SECONDS).contains(&s) => Ok(s),
        Ok(s) if s.is_finite() && s > MAX_CHECKPOINT_SECONDS => Err(format!(
            "must be at most {MAX_CHECKPOINT_SECONDS} seconds (a year); {s:e} is {:.1e} years",
            s / MAX_CHECKPOINT_SECONDS
        )),
        Ok(_) => Err("must be finite and >= 0".into()),
        Err(e) => Err(e.to_string()),
    }
}

fn parse_levels(value: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected A..B with A <= B (say 3..8), got '{value}'");
    let (a, b) = value.split_once("..").ok_or_else(bad)?;
    let (a, b) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a <= b { Ok((a, b)) } else { Err(bad()) }
}

impl EnsembleArgs {
    /// The paths, seed, threads and quick given on the command line.
    pub fn options(&self) -> EnsembleOptions {
        EnsembleOptions {
            paths: self.paths,
            seed: self.seed,
            threads: self.threads,
            quick: self.quick,
        }
    }

    /// Applies the paths, seed and threads given on the command line
    /// ([`EnsembleOptions::apply`]).
    pub fn apply(&self, s: ConvergenceSettings) -> ConvergenceSettings {
        self.options().apply(s)
    }
}

impl SceneArgs {
    /// The scenes named (built-in ones first, then files), or the built-in scenes that
    /// `default` selects when none is named; every one read and its system built
    /// ([`Scene::check_system`]) before any study runs, so that a bad value in the last scene
    /// stops the command before the first one runs.
    pub fn load(&self, default: fn(&Scene) -> bool) -> Result<Vec<Scene>, sdae_study::StudyError> {
        let scenes = self.read(default)?;
        for (k, scene) in scenes.iter().enumerate() {
            scene.check_system().map_err(|e| match self.file_of(k) {
                Some(file) => e.in_scene_file(&escaped(&file.display().to_string())),
                None => e,
            })?;
        }
        Ok(scenes)
    }

    /// The scene file the `k`-th scene [`SceneArgs::load`] returns was read from, `None` for a
    /// built-in scene.
    pub fn file_of(&self, k: usize) -> Option<&std::path::Path> {
        k.checked_sub(self.scene.len())
            .and_then(|i| self.scene_file.get(i))
            .map(PathBuf::as_path)
    }

    /// The scenes, read and checked as files, their systems not built yet.
    fn read(&self, default: fn(&Scene) -> bool) -> Result<Vec<Scene>, sdae_study::StudyError> {
        let mut scenes = Vec::new();
        for name in &self.scene {
            scenes.push(Scene::built_in(name)?);
        }
        for file in &self.scene_file {
            scenes.push(Scene::from_file(file)?);
        }
        if scenes.is_empty() {
            for (name, _) in BUILT_IN {
                let scene = Scene::built_in(name)?;
                if default(&scene) {
                    scenes.push(scene);
                }
            }
        }
        Ok(scenes)
    }
}

impl WeakArgs {
    /// The weak study's options: with --qmc, its randomizations.
    pub fn options(&self) -> WeakOptions {
        WeakOptions {
            ensemble: self.ensemble.options(),
            randomizations: self.qmc.then_some(self.randomizations),
        }
    }
}

impl ConvergenceArgs {
    /// The convergence settings of `scene` with the command line's options
    /// ([`ConvergenceOptions::settings`]).
    pub fn settings(&self, scene: &Scene) -> ConvergenceSettings {
        ConvergenceOptions {
            ensemble: self.ensemble.options(),
            schemes: self.schemes.clone(),
            reference_scheme: self.reference_scheme,
            levels: self.levels,
            ref_level: self.ref_level,
            t_end: self.t_end,
            p: self.p,
        }
        .settings(scene)
    }
}

/// Options of `expect`.
#[derive(Debug, Clone, Args)]
pub struct ExpectArgs {
    #[command(flatten)]
    pub scenes: SceneArgs,
    // Its levels: the pilot's convergence test adds levels up to 0..=L only while the bias
    // needs them.
    #[command(flatten)]
    pub estimate: EstimateArgs,
    /// Root mean square accuracy eps (default: the smallest of the scene's [mlmc] eps).
    #[arg(long, value_name = "EPS", allow_negative_numbers = true)]
    pub eps: Option<f64>,
    /// Run this estimator whatever the prediction: mlmc, mlqmc, standard or rqmc (default: the
    /// cheapest predicted).
    #[arg(long, value_name = "NAME", value_parser = method)]
    pub method: Option<Method>,
    /// What the cheapest is judged by: `work` (steps; the same choice on every machine and
    /// thread count) or `seconds` (steps at the measured seconds per step of each kind of path).
    #[arg(long = "pick-by", value_name = "MEASURE", default_value = "work", value_parser = measure)]
    pub pick_by: CostMeasure,
    /// Randomizations R of the QMC methods (at least 2).
    #[arg(long, value_name = "R", default_value_t = MLQMC_RANDOMIZATIONS)]
    pub randomizations: u32,
    /// Points n_0 of each randomization when an MLQMC level is first run, the QMC pilot's
    /// largest (a power of two).
    #[arg(long = "initial-points", value_name = "N", default_value_t = MLQMC_INITIAL_POINTS)]
    pub initial_points: u64,
    #[command(flatten)]
    pub out: OutArgs,
}

/// An estimator's name on the command line.
fn method(value: &str) -> Result<Method, String> {
    value.parse()
}

/// A cost measure's name on the command line.
fn measure(value: &str) -> Result<CostMeasure, String> {
    value.parse()
}

/// Options of `simulate`.
#[derive(Debug, Clone, Args)]
pub struct SimulateArgs {
    /// The scene: one built-in scene (--scene) or one scene file (--scene-file); default: the
    /// pendulum.
    #[command(flatten)]
    pub scenes: SceneArgs,
    /// The scheme.
    #[arg(long, value_name = "NAME", default_value = "half-explicit-practical",
          value_parser = scheme_parser())]
    pub scheme: SchemeKind,
    /// Paths P.
    #[arg(long, value_name = "P", default_value_t = 1, value_parser = at_least_one)]
    pub paths: usize,
    /// Steps N over the scene's T (default: 2^B, B the scene's finest study level).
    #[arg(long, value_name = "N", value_parser = at_least_one)]
    pub steps: Option<usize>,
    /// Record t_0, every K-th step and t_N (default: N / 256, at least 1; 1 keeps every step).
    #[arg(long, value_name = "K", value_parser = at_least_one)]
    pub every: Option<usize>,
    /// Seed of the path streams: path i draws from the stream (seed, i), as in every study.
    #[arg(long, value_name = "S", default_value_t = 2026)]
    pub seed: u64,
    /// Worker threads, 1 to 1024 (default: the available cores); the numbers do not depend
    /// on it.
    #[arg(long, value_name = "K", value_parser = thread_count)]
    pub threads: Option<usize>,
    /// File format: xyz (extended XYZ, one file per path: VMD, OVITO, ASE), vtk (an XML grid
    /// of polylines per recorded time and a .pvd collection: ParaView; chains of beads in 3-D
    /// only) or csv (path, step, time, r). Default: vtk for fibers, xyz for the rest.
    #[arg(long, value_name = "FORMAT", value_parser = format_parser())]
    pub format: Option<TrajectoryFormat>,
    /// Files go to <OUT>/simulate/<scene>/.
    #[command(flatten)]
    pub out: OutArgs,
}

fn format_parser() -> impl TypedValueParser<Value = TrajectoryFormat> {
    PossibleValuesParser::new(TrajectoryFormat::ALL.map(TrajectoryFormat::name))
        .map(|name| TrajectoryFormat::from_name(&name).expect("one of the possible values"))
}

fn at_least_one(value: &str) -> Result<usize, String> {
    match value.parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn levels_and_threads_are_checked() {
        assert_eq!(parse_levels("3..8"), Ok((3, 8)));
        assert!(parse_levels("8..3").is_err());
        assert!(parse_levels("3-8").is_err());
        assert_eq!(thread_count("2"), Ok(2));
        assert!(thread_count("0").is_err());
        assert_eq!(thread_count("1024"), Ok(1024));
        assert!(thread_count("1025").is_err());
    }

    #[test]
    fn checkpoint_intervals_are_bounded_by_a_year() {
        assert_eq!(seconds("0"), Ok(0.0));
        assert_eq!(seconds("31536000"), Ok(MAX_CHECKPOINT_SECONDS));
        let refused = seconds("2e19").unwrap_err();
        assert!(refused.contains("at most 31536000 seconds"), "{refused}");
        assert!(seconds("31536001").is_err());
        assert!(seconds("inf").is_err());
        assert!(seconds("-1").is_err());
        // Every accepted value converts to a Duration without panicking.
        let _ = std::time::Duration::from_secs_f64(MAX_CHECKPOINT_SECONDS);
    }
}

/// The levels of a multilevel run and its convergence test (`mlmc`, `expect`).
#[derive(Debug, Clone, Args)]
pub struct LevelArgs {
    /// Antithetic fine paths in the pairs (for multiplicative noise).
    #[arg(long)]
    pub antithetic: bool,
    /// Level 0 on 2^K steps (default: the scene's, 2).
    #[arg(long, value_name = "K")]
    pub coarsest: Option<u32>,
    /// The finest level a multilevel run may add (default: the scene's, 12).
    #[arg(long = "max-level", value_name = "L")]
    pub max_level: Option<u32>,
    /// The convergence test runs levels 0..=L (default: the scene's, 6).
    #[arg(long = "test-levels", value_name = "L")]
    pub test_levels: Option<u32>,
    /// Samples per level of the convergence test (default: the scene's, 4096).
    #[arg(long = "test-samples", value_name = "N")]
    pub test_samples: Option<u64>,
}

impl LevelArgs {
    /// MLMC options with these levels, the others at their defaults.
    pub fn options(&self) -> MlmcOptions {
        MlmcOptions {
            antithetic: self.antithetic,
            coarsest: self.coarsest,
            max_level: self.max_level,
            test_levels: self.test_levels,
            test_samples: self.test_samples,
            ..MlmcOptions::default()
        }
    }
}

/// What a multilevel estimate (`mlmc`, `expect`) is of and how its samples are drawn: the
/// observable, the scheme, the levels, the final time, the seed and the threads.
#[derive(Debug, Clone, Args)]
pub struct EstimateArgs {
    /// Observable f of E[f(X_T)]: an observable of the scene's system (docs/scenes.md names
    /// them), or for a system written as expressions an expression of its coordinates and
    /// velocities (default: the scene's, else cos_angle).
    #[arg(long, value_name = "NAME")]
    pub observable: Option<String>,
    /// Scheme on the paths, on both paths of each pair of a multilevel run (default: the
    /// scene's, half-explicit-practical).
    #[arg(long, value_name = "NAME")]
    pub scheme: Option<String>,
    #[command(flatten)]
    pub levels: LevelArgs,
    /// Final time (default: the scene's).
    #[arg(long = "t-end", alias = "T", value_name = "T")]
    pub t_end: Option<f64>,
    /// Seed of the sample streams.
    #[arg(long, value_name = "S", default_value_t = 2026)]
    pub seed: u64,
    /// Worker threads, 1 to 1024 (default: the available cores); the samples do not depend
    /// on it.
    #[arg(long, value_name = "K", value_parser = thread_count)]
    pub threads: Option<usize>,
}

impl EstimateArgs {
    /// MLMC options with this observable, scheme, levels, final time, seed and threads, the
    /// others at their defaults.
    pub fn options(&self) -> MlmcOptions {
        MlmcOptions {
            observable: self.observable.clone(),
            scheme: self.scheme.clone(),
            t_end: self.t_end,
            seed: self.seed,
            threads: self.threads,
            ..self.levels.options()
        }
    }
}

/// Options of `mlmc`.
#[derive(Debug, Clone, Args)]
pub struct MlmcArgs {
    #[command(flatten)]
    pub scenes: SceneArgs,
    #[command(flatten)]
    pub estimate: EstimateArgs,
    /// Accuracies eps of the complexity table, comma-separated (default: the scene's).
    #[arg(
        long,
        value_name = "EPS",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub eps: Vec<f64>,
    /// A run of seconds: two test levels fewer, 1024 test samples, the two largest eps.
    #[arg(long)]
    pub quick: bool,
    /// Leave out the direct standard Monte Carlo run at the largest eps.
    #[arg(long = "no-standard")]
    pub no_standard: bool,
    /// Also run randomized quasi-Monte Carlo paths (scrambled Sobol' points, Brownian
    /// bridge): multilevel QMC at every eps beside MLMC, and single-level QMC beside the
    /// direct standard run (docs/expectations.md). Not with --plan or --shard: multilevel QMC
    /// is not sharded, it runs on one machine.
    #[arg(long, conflicts_with_all = ["plan", "shard"])]
    pub qmc: bool,
    /// `mlqmc`: multilevel QMC alone at every eps (no MLMC, no convergence test), written to
    /// <OUT>/mlmc/<scene>/mlqmc.json and mlqmc.md; `mlmc` (the default): the study.
    #[arg(long, value_name = "NAME", default_value = "mlmc", value_parser = ["mlmc", "mlqmc"],
          conflicts_with_all = ["plan", "shard", "write_plan", "resume"])]
    pub method: String,
    /// With --qmc or --method mlqmc: randomizations R per level (at least 2; their spread
    /// gives the interval).
    #[arg(
        long,
        value_name = "R",
        default_value_t = MLQMC_RANDOMIZATIONS,
        conflicts_with = "plan"
    )]
    pub randomizations: u32,
    /// With --qmc or --method mlqmc: points n_0 of each randomization when a level is first
    /// run (a power of two).
    #[arg(
        long = "initial-points",
        value_name = "N",
        default_value_t = MLQMC_INITIAL_POINTS,
        conflicts_with = "plan"
    )]
    pub initial_points: u64,
    /// After the study, write the plan (levels and N_l) for the smallest eps, from the
    /// convergence test, to this file (the pilot of a cluster run, docs/cluster.md). Not with
    /// --quick, whose short convergence test cannot fix a plan. If the test's levels do not
    /// bring the bias estimate below eps / sqrt(2), no plan is written (exit code 1, the
    /// report written): test more levels (--test-levels).
    #[arg(long = "write-plan", value_name = "FILE", conflicts_with = "plan")]
    pub write_plan: Option<PathBuf>,
    /// Run this plan (from --write-plan) instead of the study; with --shard, only a shard.
    #[arg(long, value_name = "FILE")]
    pub plan: Option<PathBuf>,
    /// With --plan: run the blocks b with b % N == I and write
    /// <OUT>/mlmc/<scene>/mlmc-shard-I-of-N.json; `auto` reads a Slurm job array. Only a plan
    /// is sharded (not --qmc).
    #[arg(long, value_name = "I/N|auto", value_parser = ShardArg::parse, requires = "plan")]
    pub shard: Option<ShardArg>,
    #[command(flatten)]
    pub checkpoint: CheckpointArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Options of `mlmc-merge`.
#[derive(Debug, Clone, Args)]
pub struct MlmcMergeArgs {
    /// Folders holding mlmc-shard-*.json files (searched one level deep).
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    /// The scene of the shards, if not built in (a scene file).
    #[arg(long = "scene-file", value_name = "PATH")]
    pub scene_file: Option<PathBuf>,
    #[command(flatten)]
    pub out: OutArgs,
}
