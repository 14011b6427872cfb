//! The weak study: observables recorded on the paths of the convergence study without moving its
//! numbers, named errors for bad observables, a user's closure as a built-in one, and the weak
//! errors of every scheme on the rotor against the closed form of E[cos(angle turned)].

use crate::weak_run;

use sdae_study::StudyError;
use sdae_study::convergence::{ConvergenceRun, ConvergenceSettings, build_report, run_convergence};
use sdae_study::observable::Observable;
use sdae_study::parallel::Control;
use sdae_study::scene::{Scene, SystemSpec};
use sdae_study::weak::{Basis, circle_cos_turn, weak_settings};
use statrs::distribution::{ContinuousCDF, Normal};
use weak_run::Weak;

fn small(scene: &Scene, observables: &[&str]) -> ConvergenceSettings {
    ConvergenceSettings {
        paths: 64,
        coarsest: 2,
        finest: 5,
        reference: Some(8),
        threads: 2,
        observables: observables.iter().map(|s| s.to_string()).collect(),
        ..ConvergenceSettings::for_scene(scene)
    }
}

fn run(scene: &Scene, settings: &ConvergenceSettings) -> ConvergenceRun {
    run_convergence(scene, settings, (0, 1), Control::default()).unwrap()
}

#[test]
fn observing_leaves_the_strong_numbers_alone() {
    let scene = Scene::built_in("pendulum").unwrap();
    let plain = run(&scene, &small(&scene, &[]));
    let observed = run(&scene, &small(&scene, &["height", "cos_angle"]));
    for (a, b) in plain.records.iter().zip(&observed.records) {
        assert!(a.reference_observed.is_empty());
        assert_eq!(b.reference_observed.len(), 2 * 4);
        for (x, y) in a.tracks.iter().zip(&b.tracks) {
            assert!(x.observed.is_empty());
            assert_eq!(y.observed.len(), 2 * 4, "2 observables at 4 grid points");
            assert_eq!(x.distances, y.distances);
            assert_eq!(x.steps, y.steps);
        }
    }
    let (p, o) = (build_report(plain), build_report(observed));
    for (x, y) in p.schemes.iter().zip(&o.schemes) {
        assert_eq!(x.observed_order, y.observed_order);
        for (a, b) in x.levels.iter().zip(&y.levels) {
            assert_eq!(a.error, b.error);
        }
    }
}

#[test]
fn observed_values_belong_to_the_states_compared() {
    // |height_N(t_k) - height_ref(t_k)| <= |r_N(t_k) - r_ref(t_k)| <= the sup distance over the
    // grid, at every grid point of every track; cos_angle = -height on the unit pendulum.
    let scene = Scene::built_in("pendulum").unwrap();
    let observed = run(&scene, &small(&scene, &["height", "cos_angle"]));
    for record in &observed.records {
        for track in &record.tracks {
            let sup = track.distances.unwrap()[0];
            for (k, values) in track.observed.chunks_exact(2).enumerate() {
                let reference = &record.reference_observed[2 * k..2 * k + 2];
                assert!((values[0] - reference[0]).abs() <= sup + 1e-12);
                assert_eq!(values[1], -values[0]);
            }
        }
    }
}

/// A valid pendulum scene without a [weak] table, whose only output is the position.
fn pendulum_positions() -> String {
    include_str!("fixtures/pendulum.toml").replace(
        "outputs = [\"position\", \"velocity\", \"multiplier\"]",
        "outputs = [\"position\"]",
    )
}

#[test]
fn bad_observables_are_named_errors() {
    let pendulum = pendulum_positions();
    let unknown = Scene::from_toml(&format!(
        "{pendulum}[weak]\nobservables = [\"cos_angel\"]\n"
    ));
    match unknown {
        Err(e @ StudyError::UnknownObservable { .. }) => {
            let message = e.to_string();
            assert!(message.contains("'cos_angel'"), "{message}");
            assert!(message.contains("did you mean 'cos_angle'"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let needs = Scene::from_toml(&format!("{pendulum}[weak]\nobservables = [\"energy\"]\n"));
    match needs {
        Err(StudyError::ObservableNeedsOutput {
            observable, output, ..
        }) => assert_eq!((observable.as_str(), output), ("energy", "velocity")),
        other => panic!("{other:?}"),
    }
    let exact = Scene::from_toml(&format!(
        "{pendulum}[weak]\nobservables = [\"height\"]\nexact = {{ cos_angle = 1.0 }}\n"
    ));
    assert!(
        matches!(exact, Err(StudyError::Invalid { .. })),
        "{exact:?}"
    );
}

#[test]
fn a_users_closure_measures_what_the_built_in_one_does() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = small(&scene, &["height"]);
    let mine = Observable::new("my_height", |r, _v| r[1]);
    let report = scene
        .run(Weak {
            settings: &settings,
            extra: Some(mine),
        })
        .unwrap();
    let [built_in, closure] = &report.observables[..] else {
        panic!("two observables");
    };
    assert_eq!(closure.name, "my_height");
    assert_eq!(built_in.schemes, closure.schemes);
    assert_eq!(built_in.basis, Basis::Reference);
}

#[test]
fn the_rotor_scene_gives_the_closed_form() {
    let scene = Scene::built_in("rotor").unwrap();
    let SystemSpec::Pendulum(p) = &scene.system else {
        panic!("the rotor is a pendulum without gravity");
    };
    assert_eq!(p.gravity, 0.0);
    let velocity = scene.initial.velocity.as_ref().unwrap();
    let omega0 = velocity[0].hypot(velocity[1]) / p.length;
    let closed = circle_cos_turn(omega0, p.friction, p.noise / p.length, scene.t_end);
    let given = scene.weak.as_ref().unwrap().exact["cos_turn"];
    assert!((given - closed).abs() < 1e-15, "{given} against {closed}");
}

/// Every scheme's weak error on the rotor agrees with the closed form: at the finest level,
/// |E_hat[f(X_N)] - exact| is within the Monte Carlo half-width (Bonferroni over the schemes:
/// a 1 - 0.05 / schemes two-sided normal quantile) plus a bound on the scheme's bias at that h.
/// The bias bound: for a weak order-1 scheme e(h) = c h + O(h^2), so e(h) = e(2h) - e(h) + O(h^2)
/// = E[f(X_(2h)) - f(X_h)] + O(h^2), measured on the coupled paths (the per-path differences
/// have the small variance of the strong error, not that of f), up to O(h^2) terms below the
/// Monte Carlo error at these step sizes.
#[test]
fn rotor_weak_errors_agree_with_the_closed_form() {
    let scene = Scene::built_in("rotor").unwrap();
    let settings = ConvergenceSettings {
        paths: 4000,
        threads: 2,
        observables: vec!["cos_turn".into()],
        ..weak_settings(&scene, true).unwrap()
    };
    let report = scene
        .run(Weak {
            settings: &settings,
            extra: None,
        })
        .unwrap();
    let cos_turn = &report.observables[0];
    let exact = match cos_turn.basis {
        Basis::Exact(x) => x,
        Basis::Reference => panic!("the rotor gives its exact value"),
    };
    let plain: Vec<_> = cos_turn
        .schemes
        .iter()
        .filter(|r| !r.extrapolated)
        .collect();
    // Bonferroni over the schemes: the two-sided 1 - 0.05 / schemes normal quantile.
    let normal = Normal::new(0.0, 1.0).unwrap();
    let z = normal.inverse_cdf(1.0 - 0.025 / plain.len() as f64);
    for row in plain {
        let (finest, coarser) = (
            &row.levels[row.levels.len() - 1],
            &row.levels[row.levels.len() - 2],
        );
        let half = 0.5 * (finest.value.ci_high - finest.value.ci_low);
        let mc = half * z / 1.96;
        // E[f(X_2h)] - E[f(X_h)]: the difference of the two errors, means over the same paths,
        // is the mean of the coupled per-path differences.
        let step = (coarser.error.estimate - finest.error.estimate).abs();
        let distance = (finest.value.estimate - exact).abs();
        println!(
            "{}: N = {}, E = {:.5}, exact {exact:.5}, |diff| {distance:.2e} <= {mc:.2e} + {step:.2e}",
            row.name, finest.n_steps, finest.value.estimate
        );
        assert!(
            distance <= mc + step,
            "{}: |{} - {exact}| = {distance:e} > {mc:e} + {step:e}",
            row.name,
            finest.value.estimate
        );
    }
}
