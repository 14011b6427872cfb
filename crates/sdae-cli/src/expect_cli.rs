//! The `expect` subcommand: E[f(X_T)] of a scene's observable to an accuracy eps by whichever
//! of standard Monte Carlo, randomized QMC, MLMC and multilevel QMC a short pilot predicts
//! cheapest (docs/expectations.md).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_mlmc::{MlmcError, RunControl};
use sdae_study::mlmc::expect_report::{summary, write_expect_report};
use sdae_study::mlmc::{ExpectRequest, MlmcSettings, QmcSettings, scene_expectation_with};
use sdae_study::options::MlmcOptions;
use sdae_study::scene::Scene;

use crate::args::ExpectArgs;
use crate::failure::Failure;
use crate::runs::writable_out;

impl ExpectArgs {
    /// The MLMC settings of `scene` with the command line's changes, checked.
    fn settings(&self, scene: &Scene) -> Result<MlmcSettings, Failure> {
        let settings = MlmcOptions {
            eps: self.eps.into_iter().collect(),
            quick: false,
            standard_run: false,
            qmc: Some(QmcSettings {
                randomizations: self.randomizations,
                initial_points: self.initial_points,
            }),
            ..self.estimate.options()
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
