//! E[f(X_T)] of a scene's observable to a requested accuracy, by MLMC or standard Monte Carlo,
//! whichever the convergence test predicts cheaper ([`sdae_mlmc::expectation()`]).

use serde::Serialize;

use super::coarsest::{CoarsestMoved, first_level_that_runs};
use super::study::{MlmcSettings, SamplerTask, with_sampler};
use crate::scene::Scene;
use sdae_mlmc::expectation::{Expectation, ExpectationSettings, expectation};
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::{LevelSampler, MlmcError, RunControl};

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
    /// The estimate and how it was found.
    #[serde(flatten)]
    pub found: Expectation,
    /// Level 0 moved to finer steps because the asked one did not run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarsest_moved: Option<CoarsestMoved>,
}

/// E[f(X_T)] of `scene`'s observable to root mean square accuracy `eps`, with the observable,
/// scheme, final time, seed, threads, convergence test (levels and samples), N_0 and finest
/// level of `settings` (its own list of eps and standard and QMC runs are not used). The
/// settings are checked first ([`MlmcSettings::validate_for`]), and level 0 moves to the first
/// step count that runs ([`first_level_that_runs`]).
pub fn scene_expectation(
    scene: &Scene, settings: &MlmcSettings, eps: f64, control: &RunControl<'_>,
) -> Result<SceneExpectation, MlmcError> {
    let mut checked = settings.clone();
    checked.spec.eps = vec![eps];
    checked.validate_for(scene)?;
    let (checked, coarsest_moved) = first_level_that_runs(scene, &checked)?;
    let spec = &checked.spec;
    let wanted = ExpectationSettings {
        eps,
        test_levels: spec.test_levels,
        test_samples: spec.test_samples,
        initial_samples: checked.initial_samples,
        max_level: spec.max_level,
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
            expectation(sampler, self.control, &self.wanted)
        }
    }
    let found = with_sampler(scene, &checked, Task { wanted, control })?;
    Ok(SceneExpectation {
        scene: scene.name.clone(),
        observable: spec.observable.clone(),
        scheme: spec.scheme.clone(),
        t_end: checked.t_end,
        seed: checked.seed,
        found,
        coarsest_moved,
    })
}
