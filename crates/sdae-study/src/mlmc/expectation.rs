//! E[f(X_T)] of a scene's observable to a requested accuracy by whichever of standard Monte
//! Carlo, randomized QMC, MLMC and multilevel QMC a short pilot predicts cheapest
//! ([`sdae_mlmc::expectation_quasi`]); its report is `expect_report`.

use std::time::Instant;

use serde::Serialize;

use super::coarsest::{CoarsestMoved, first_level_that_runs};
use super::run_settings::MlmcSettings;
use super::sampler::{SamplerTask, with_sampler};
use crate::scene::Scene;
use sdae_mlmc::expectation::{
    CostMeasure, Expectation, ExpectationSettings, Method, expectation_quasi,
};
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::{LevelSampler, MlmcError, RunControl};

/// What an expectation asks besides the scene's MLMC settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpectRequest {
    /// Root mean square accuracy eps.
    pub eps: f64,
    /// What the cheapest is judged by.
    pub by: CostMeasure,
    /// Run this estimator whatever the prediction (`None`: the cheapest).
    pub method: Option<Method>,
}

impl ExpectRequest {
    /// The cheapest by work at accuracy `eps`.
    pub fn new(eps: f64) -> Self {
        Self {
            eps,
            by: CostMeasure::Work,
            method: None,
        }
    }
}

/// E[f(X_T)] of a scene, with what it was of.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneExpectation {
    /// The scene.
    pub scene: String,
    /// The observable f.
    pub observable: String,
    /// The scheme on the paths.
    pub scheme: String,
    /// Final time T.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// Seed of the sample streams.
    pub seed: u64,
    /// Level 0 on 2^k0 steps.
    pub coarsest: u32,
    /// Antithetic fine paths in MLMC's pairs.
    pub antithetic: bool,
    /// Worker threads.
    pub threads: usize,
    /// The estimate and how it was found.
    #[serde(flatten)]
    pub found: Expectation,
    /// Wall-clock seconds of the pilot and the run.
    #[serde(with = "sdae_stats::json_f64")]
    pub wall_seconds: f64,
    /// Level 0 moved to finer steps because the asked one did not run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarsest_moved: Option<CoarsestMoved>,
}

/// [`scene_expectation_with`] the cheapest estimator by work at accuracy `eps`.
pub fn scene_expectation(
    scene: &Scene, settings: &MlmcSettings, eps: f64, control: &RunControl<'_>,
) -> Result<SceneExpectation, MlmcError> {
    scene_expectation_with(scene, settings, &ExpectRequest::new(eps), control)
}

/// E[f(X_T)] of `scene`'s observable to root mean square accuracy `request.eps`, with the
/// observable, scheme, antithetic pairs, final time, seed, threads, convergence test (levels
/// and samples), N_0, finest level and QMC design (`settings.qmc`, else R = 32 randomizations
/// of n_0 = 32 points) of `settings` (its own list of eps and standard runs are not used). The
/// settings are checked first ([`MlmcSettings::validate_for`]), and level 0 moves to the first
/// step count that runs ([`first_level_that_runs`]).
pub fn scene_expectation_with(
    scene: &Scene, settings: &MlmcSettings, request: &ExpectRequest, control: &RunControl<'_>,
) -> Result<SceneExpectation, MlmcError> {
    let start = Instant::now();
    let mut checked = settings.clone();
    checked.spec.eps = vec![request.eps];
    checked.validate_for(scene)?;
    let (checked, coarsest_moved) = first_level_that_runs(scene, &checked)?;
    let spec = &checked.spec;
    let qmc = checked.qmc.unwrap_or_default();
    let wanted = ExpectationSettings {
        eps: request.eps,
        test_levels: spec.test_levels,
        test_samples: spec.test_samples,
        initial_samples: checked.initial_samples,
        max_level: spec.max_level,
        randomizations: qmc.randomizations,
        initial_points: qmc.initial_points,
        by: request.by,
        method: request.method,
    };
    struct Task<'a, 'b> {
        wanted: ExpectationSettings,
        control: &'a RunControl<'b>,
    }
    impl SamplerTask for Task<'_, '_> {
        type Output = Expectation;
        fn run<L: LevelSampler + QuasiSampler>(
            self, sampler: &L,
        ) -> Result<Expectation, MlmcError> {
            expectation_quasi(sampler, self.control, &self.wanted)
        }
    }
    let found = with_sampler(scene, &checked, Task { wanted, control })?;
    Ok(SceneExpectation {
        scene: scene.name.clone(),
        observable: spec.observable.clone(),
        scheme: spec.scheme.clone(),
        t_end: checked.t_end,
        seed: checked.seed,
        coarsest: spec.coarsest,
        antithetic: spec.antithetic,
        threads: control.threads(),
        found,
        wall_seconds: start.elapsed().as_secs_f64(),
        coarsest_moved,
    })
}
