//! The weak report of a scene, as the tests of the weak study run it.

use sdae_study::StudyError;
use sdae_study::convergence::{ConvergenceRun, ConvergenceSettings};
use sdae_study::observable::{Observable, built_in_all};
use sdae_study::parallel::Control;
use sdae_study::scene::{Prepared, Scene, SceneRunner};
use sdae_study::weak::{WeakReport, build_weak_report, run_weak_on};

/// The weak report of a scene's own observables plus a user's closure `extra`, with `settings`.
pub struct Weak<'a> {
    pub settings: &'a ConvergenceSettings,
    pub extra: Option<Observable>,
}

impl SceneRunner for Weak<'_> {
    type Output = WeakReport;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> WeakReport
    where
        S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
    {
        let mut observables = built_in_all(scene, &prepared, &self.settings.observables).unwrap();
        observables.extend(self.extra);
        let run = run_whole(scene, &prepared, &observables, self.settings).unwrap();
        build_weak_report(run).unwrap()
    }
}

/// The weak study of a scene's `observables` with `settings` over all its paths (one shard,
/// no schemes beyond the settings', never stopped), as the tests run it.
pub fn run_whole<S>(
    scene: &Scene, prepared: &Prepared<S>, observables: &[Observable],
    settings: &ConvergenceSettings,
) -> Result<ConvergenceRun, StudyError>
where
    S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
{
    run_weak_on(
        scene,
        prepared,
        &[],
        observables,
        settings,
        (0, 1),
        Control::default(),
    )
}
