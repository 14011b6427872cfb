//! The `expect` subcommand: E[f(X_T)] of a scene's observable to an accuracy eps by whichever
//! of standard Monte Carlo, randomized QMC, MLMC and multilevel QMC a short pilot predicts
//! cheapest (docs/expectations.md).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use sdae_mlmc::expectation::{CostMeasure, Method};
use sdae_mlmc::{MlmcError, RunControl};
use sdae_study::mlmc::expect_report::{summary, write_expect_report};
use sdae_study::mlmc::{ExpectRequest, MlmcSettings, QmcSettings, scene_expectation_with};
use sdae_study::options::{MLQMC_INITIAL_POINTS, MLQMC_RANDOMIZATIONS, MlmcOptions};
use sdae_study::scene::Scene;

use crate::Failure;
use crate::args::{LevelArgs, OutArgs, SceneArgs};
use crate::runs::writable_out;

/// Options of `expect`.
#[derive(Debug, Clone, Args)]
pub struct ExpectArgs {
    #[command(flatten)]
    pub scenes: SceneArgs,
    /// Observable f of E[f(X_T)], a built-in observable of the scene's system (default: the
    /// scene's, else cos_angle).
    #[arg(long, value_name = "NAME")]
    pub observable: Option<String>,
    /// Scheme on the paths (default: the scene's, half-explicit-practical).
    #[arg(long, value_name = "NAME")]
    pub scheme: Option<String>,
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
    // The pilot's convergence test adds levels up to 0..=L only while the bias needs them.
    #[command(flatten)]
    pub levels: LevelArgs,
    /// Randomizations R of the QMC methods (at least 2).
    #[arg(long, value_name = "R", default_value_t = MLQMC_RANDOMIZATIONS)]
    pub randomizations: u32,
    /// Points n_0 of each randomization when an MLQMC level is first run, the QMC pilot's
    /// largest (a power of two).
    #[arg(long = "initial-points", value_name = "N", default_value_t = MLQMC_INITIAL_POINTS)]
    pub initial_points: u64,
    /// Final time (default: the scene's).
    #[arg(long = "t-end", alias = "T", value_name = "T")]
    pub t_end: Option<f64>,
    /// Seed of the sample streams.
    #[arg(long, value_name = "S", default_value_t = 2026)]
    pub seed: u64,
    /// Worker threads, 1 to 1024 (default: the available cores).
    #[arg(long, value_name = "K")]
    pub threads: Option<usize>,
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

impl ExpectArgs {
    /// The MLMC settings of `scene` with the command line's changes, checked.
    fn settings(&self, scene: &Scene) -> Result<MlmcSettings, Failure> {
        let settings = MlmcOptions {
            observable: self.observable.clone(),
            scheme: self.scheme.clone(),
            eps: self.eps.into_iter().collect(),
            t_end: self.t_end,
            seed: self.seed,
            threads: self.threads,
            quick: false,
            standard_run: false,
            qmc: Some(QmcSettings {
                randomizations: self.randomizations,
                initial_points: self.initial_points,
            }),
            ..self.levels.options()
        }
        .settings(scene);
        settings
            .validate_for(scene)
            .map_err(|e| Failure::from(e).within(&format!("scene {}", scene.name)))?;
        Ok(settings)
    }
}

/// The smallest accuracy of `settings` (the one typed, or the scene's smallest).
fn smallest_eps(settings: &MlmcSettings) -> f64 {
    settings
        .spec
        .eps
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
}

/// A spinner counting samples on stderr.
pub fn spinner(scene: &str) -> ProgressBar {
    let template = format!("  {{spinner}} {scene}: {{pos}} samples, {{elapsed}} elapsed");
    ProgressBar::new_spinner().with_style(
        ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    )
}

/// Runs `request` on `scene` with a spinner and the stop flag: its expectation.
pub fn run_expectation(
    scene: &Scene, settings: &MlmcSettings, request: &ExpectRequest, stop: &AtomicBool,
) -> Result<sdae_study::mlmc::SceneExpectation, Failure> {
    let bar = spinner(&scene.name);
    let progress = |n: u64| bar.inc(n);
    let mut control = RunControl::new(settings.threads)?;
    control.progress = Some(&progress);
    control.stop = Some(stop);
    let found = scene_expectation_with(scene, settings, request, &control);
    bar.finish_and_clear();
    found.map_err(|e| match e {
        MlmcError::Interrupted => {
            Failure::Unsaved(format!("{}: interrupted: nothing was saved", scene.name))
        }
        e => Failure::from(e).within(&format!("scene {}", scene.name)),
    })
}

/// E[f(X_T)] of one scene (the pendulum by default) to eps: writes
/// <OUT>/expect/<scene>/report.json, report.md and report.csv and prints a summary.
pub fn expect(args: &ExpectArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.name == "pendulum")?;
    let [scene] = &scenes[..] else {
        return Err(Failure::Usage(format!(
            "expect runs one scene at a time; {} were named",
            scenes.len()
        )));
    };
    let settings = args.settings(scene)?;
    let dir: PathBuf = args.out.out.join("expect").join(&scene.name);
    writable_out(&dir)?;
    let request = ExpectRequest {
        eps: smallest_eps(&settings),
        by: args.pick_by,
        method: args.method,
    };
    note!(
        "{}: E[{}] with {} to eps = {:e}, {} threads",
        scene.name,
        settings.spec.observable,
        settings.spec.scheme,
        request.eps,
        settings.threads
    );
    let found = run_expectation(scene, &settings, &request, stop)?;
    write_expect_report(&found, &dir)?;
    for line in summary(&found) {
        say!("{line}");
    }
    say!("wrote {}", dir.join("report.md").display());
    Ok(())
}
