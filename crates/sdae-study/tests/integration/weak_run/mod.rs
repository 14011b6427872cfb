//! The weak report of a scene, as the tests of the weak study run it.

use sdae_study::convergence::ConvergenceSettings;
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
        let run = run_weak_on(
            scene,
            &prepared,
            &[],
            &observables,
            self.settings,
            (0, 1),
            Control::default(),
        )
        .unwrap();
        build_weak_report(run).unwrap()
    }
}
