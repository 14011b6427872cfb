//! The level sampler of a scene's system for a study's settings, and work handed that sampler
//! whatever the system's type.

use super::coupled::CoupledSampler;
use super::run_settings::MlmcSettings;
use crate::integrator::{SchemeKind, StudyScheme};
use crate::scene::{Prepared, Scene};
use sdae_mlmc::MlmcError;
use sdae_mlmc::qmc::QuasiSampler;
use sdae_mlmc::sampler::LevelSampler;

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
