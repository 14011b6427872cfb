//! Simulated paths ([`sdae_study::simulate`]): path 0 is the one-path trace of the same seed bit
//! for bit, a path's numbers do not depend on the number of paths or the threads, a failed path
//! holds NaN after its last completed step, and bad settings are refused naming them.

use std::sync::atomic::{AtomicUsize, Ordering};

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
    // 70 paths are blocks of 64 and 6 on one thread, 128 paths two full blocks on two: paths
    // 64..70 sit in blocks of different widths.
    let scene = Scene::built_in("spherical-pendulum").unwrap();
    let few = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 70, 64, 11)
        .unwrap()
        .every(16)
        .unwrap();
    let many = SimulateSettings { paths: 128, ..few }.threads(2).unwrap();
    let (a, b) = (
        simulate(&scene, &few, NEVER).unwrap(),
        simulate(&scene, &many, NEVER).unwrap(),
    );
    let (n, m, times) = (a.n, a.m, a.times.len());
    assert_eq!(a.positions, b.positions[..70 * times * n]);
    assert_eq!(a.velocities, b.velocities[..70 * times * n]);
    assert_eq!(a.multipliers, b.multipliers[..70 * times * m]);
    assert_eq!(a.diagnostics, b.diagnostics[..70]);
}

#[test]
fn a_stop_ends_the_run_with_an_error_before_and_inside_a_block() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 4, 1 << 12, 1).unwrap();
    let stopped = simulate(&scene, &settings, &|| true).unwrap_err();
    assert!(matches!(stopped, StudyError::Stopped), "{stopped}");
    // True from the third look on: the block has started and stops at a later check.
    let looks = AtomicUsize::new(0);
    let later = || looks.fetch_add(1, Ordering::Relaxed) >= 2;
    let stopped = simulate(&scene, &settings, &later).unwrap_err();
    assert!(matches!(stopped, StudyError::Stopped), "{stopped}");
    assert_eq!(looks.load(Ordering::Relaxed), 3);
}

#[test]
fn states_that_would_not_fit_in_memory_are_refused_naming_paths() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = SimulateSettings::new(SchemeKind::EulerMaruyama, 1 << 40, 1 << 20, 1).unwrap();
    let refused = simulate(&scene, &settings, NEVER).unwrap_err().to_string();
    assert!(
        refused.starts_with("paths = 1099511627776: the recorded states need"),
        "{refused}"
    );
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
    assert!(
        settings
            .threads(1025)
            .unwrap_err()
            .to_string()
            .starts_with("threads")
    );
    // Settings built field by field are checked by the run.
    let scene = Scene::built_in("pendulum").unwrap();
    let zero_every = SimulateSettings {
        every: 0,
        ..settings
    };
    let refused = simulate(&scene, &zero_every, NEVER)
        .unwrap_err()
        .to_string();
    assert!(refused.starts_with("every = 0"), "{refused}");
}

#[test]
fn a_failed_path_holds_nan_after_its_last_completed_step() {
    // Untruncated steps of 1/16 on the noisy pendulum: the kappa system of some paths has no
    // root connected to 0. Recorded every step, and every third (steps 0, 3, .., 15, 16).
    let scene = Scene::built_in("noisy-pendulum").unwrap();
    for every in [1, 3] {
        let settings = SimulateSettings::new(SchemeKind::HalfExplicitUntruncated, 64, 16, 1)
            .unwrap()
            .every(every)
            .unwrap();
        let recorded = settings.recorded_steps();
        let paths = simulate(&scene, &settings, NEVER).unwrap();
        let failed = paths.failures.iter().filter(|f| f.is_some()).count();
        assert!(failed > 0 && failed < 64, "{failed} failed");
        let (n, times) = (paths.n, recorded.len());
        for (p, failure) in paths.failures.iter().enumerate() {
            let done = if failure.is_some() {
                paths.diagnostics[p].steps
            } else {
                16
            };
            for (j, &k) in recorded.iter().enumerate() {
                let state = &paths.positions[(p * times + j) * n..][..n];
                let kept = k <= done;
                assert!(
                    state.iter().all(|x| x.is_finite() == kept),
                    "path {p} step {k}"
                );
                assert!(
                    state.iter().all(|x| x.is_nan() != kept),
                    "path {p} step {k}"
                );
            }
        }
    }
}
