//! Simulated paths ([`sdae_study::simulate`]): path 0 is the one-path trace of the same seed bit
//! for bit, a path's numbers do not depend on the number of paths or the threads, a failed path
//! holds NaN after its last completed step, and bad settings are refused naming them.

use sdae_study::StudyError;
use sdae_study::integrator::SchemeKind;
use sdae_study::scene::Scene;
use sdae_study::simulate::{SimulateSettings, simulate};
use sdae_study::trace::{steps, trace};

const NEVER: &(dyn Fn() -> bool + Sync) = &|| false;

#[test]
fn path_zero_is_the_trace_of_the_same_seed_bit_for_bit() {
    let scene = Scene::built_in("pendulum").unwrap();
    let n = steps(&scene).unwrap();
    let traced = trace(&scene, n, 5).unwrap();
    assert!(traced.failure.is_none());
    let every = n / (traced.states.len() - 1);
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 1, n, 5)
        .unwrap()
        .every(every)
        .unwrap();
    let paths = simulate(&scene, &settings, NEVER).unwrap();
    assert_eq!(paths.times.len(), traced.states.len());
    for (j, (t, r)) in traced.states.iter().enumerate() {
        assert_eq!(paths.times[j], *t, "time {j}");
        assert_eq!(&paths.positions[j * 2..][..2], &r[..], "state {j}");
    }
}

#[test]
fn a_path_does_not_depend_on_the_number_of_paths_nor_the_threads() {
    let scene = Scene::built_in("spherical-pendulum").unwrap();
    let few = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 3, 64, 11)
        .unwrap()
        .every(16)
        .unwrap();
    let many = SimulateSettings { paths: 70, ..few }.threads(2).unwrap();
    let (a, b) = (
        simulate(&scene, &few, NEVER).unwrap(),
        simulate(&scene, &many, NEVER).unwrap(),
    );
    let len = a.positions.len();
    assert_eq!(a.positions, b.positions[..len]);
    assert_eq!(a.velocities, b.velocities[..len]);
    assert_eq!(a.multipliers, b.multipliers[..a.multipliers.len()]);
    assert_eq!(b.diagnostics.len(), 70);
}

#[test]
fn a_stop_ends_the_run_with_an_error() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 4, 1 << 12, 1).unwrap();
    let stopped = simulate(&scene, &settings, &|| true).unwrap_err();
    assert!(matches!(stopped, StudyError::Stopped), "{stopped}");
}

#[test]
fn bad_settings_are_refused_naming_them() {
    for (settings, name) in [
        (
            SimulateSettings::new(SchemeKind::EulerMaruyama, 0, 10, 1),
            "paths",
        ),
        (
            SimulateSettings::new(SchemeKind::EulerMaruyama, 1, 0, 1),
            "steps",
        ),
    ] {
        let refused = settings.unwrap_err().to_string();
        assert!(refused.starts_with(name), "{refused}");
    }
    let settings = SimulateSettings::new(SchemeKind::EulerMaruyama, 1, 10, 1).unwrap();
    assert!(
        settings
            .every(0)
            .unwrap_err()
            .to_string()
            .starts_with("every")
    );
    assert!(
        settings
            .threads(0)
            .unwrap_err()
            .to_string()
            .starts_with("threads")
    );
}

#[test]
fn a_failed_path_holds_nan_after_its_last_completed_step() {
    // Untruncated steps of 1/16 on the noisy pendulum: the kappa system of some paths has no
    // root connected to 0.
    let scene = Scene::built_in("noisy-pendulum").unwrap();
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitUntruncated, 64, 16, 1).unwrap();
    let paths = simulate(&scene, &settings, NEVER).unwrap();
    let failed = paths.failures.iter().filter(|f| f.is_some()).count();
    assert!(failed > 0 && failed < 64, "{failed} failed");
    let (n, times) = (paths.n, paths.times.len());
    for (p, failure) in paths.failures.iter().enumerate() {
        let done = if failure.is_some() {
            paths.diagnostics[p].steps
        } else {
            16
        };
        let states = &paths.positions[p * times * n..(p + 1) * times * n];
        let (kept, lost) = states.split_at((done + 1) * n);
        assert!(kept.iter().all(|x| x.is_finite()), "path {p}");
        assert!(lost.iter().all(|x| x.is_nan()), "path {p}");
    }
}
