//! Small studies and scratch folders shared by the tests.

use std::path::{Path, PathBuf};

use sdae_study::convergence::{ConvergenceRun, ConvergenceSettings, run_convergence};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

/// The built-in pendulum with a small, fast setting.
pub fn small(paths: usize) -> (Scene, ConvergenceSettings) {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = ConvergenceSettings {
        paths,
        coarsest: 2,
        finest: 4,
        reference: Some(8),
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    (scene, settings)
}

/// Runs shard `index` of `count`.
pub fn run(
    scene: &Scene, settings: &ConvergenceSettings, index: usize, count: usize,
) -> ConvergenceRun {
    run_convergence(scene, settings, (index, count), Control::default()).unwrap()
}

/// The scratch folder `name` in the target's temporary folder, emptied (not created).
pub fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}
