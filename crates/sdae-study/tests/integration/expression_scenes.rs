//! Built-in systems written again as expressions (`[system.expressions]`): the seed's pendulum
//! (`pendulum-expressions`) and a chain molecule of 4 atoms with an angle potential
//! (`chain-expressions`) give the built-in scenes' strong errors (r, v, mu) and weak errors to
//! three digits, scheme by scheme and level by level, on the same Brownian paths. The
//! differences are by definition: the theory variant of the half-explicit scheme needs the
//! theory's C_g bound that only a built-in constraint has (skipped for the expressions), and
//! the local variant measures the motion on each constraint's own length scale, which the bead
//! chain knows (its segment length) and a constraint written as expressions does not (it takes
//! the seed's functional, the sphere's own for the unit pendulum).
//!
//! The Langevin scenes written as expressions (`torus`, `water`) have the equipartition value
//! (n - m) kT / 2 and BAOAB as their weak reference; their particles place their coordinates in
//! trajectory files.

use sdae_stats::Interval;
use sdae_study::convergence::{
    ConvergenceReport, ConvergenceSettings, build_report, run_convergence,
};
use sdae_study::integrator::SchemeKind;
use sdae_study::parallel::Control;
use sdae_study::scene::{Prepared, Scene, SceneRunner, SystemSpec};
use sdae_study::trajectory::Particles;
use sdae_study::weak::{WeakReport, build_weak_report, weak_reference, weak_settings};
use sdae_systems::{AngleParams, ChainMoleculeParams, Masses};

/// The smallest study that shows the errors of every scheme at three levels.
fn strong(scene: &Scene) -> ConvergenceReport {
    let settings = ConvergenceSettings {
        paths: 64,
        coarsest: 3,
        finest: 5,
        reference: Some(9),
        threads: 2,
        ..ConvergenceSettings::for_scene(scene)
    };
    build_report(run_convergence(scene, &settings, (0, 1), Control::default()).unwrap())
}

/// The scene's `--quick` weak study, on fewer paths and levels.
fn weak(scene: &Scene) -> WeakReport {
    let settings = ConvergenceSettings {
        paths: 256,
        coarsest: 2,
        finest: 4,
        reference: Some(7),
        threads: 2,
        ..weak_settings(scene, true).unwrap()
    };
    build_weak_report(run_convergence(scene, &settings, (0, 1), Control::default()).unwrap())
        .unwrap()
}

/// Whether two estimates agree to three significant digits (both absent also agrees).
fn agree(a: Option<&Interval>, b: Option<&Interval>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            let (x, y) = (a.estimate, b.estimate);
            x == y || (x - y).abs() <= 5e-4 * x.abs().max(y.abs())
        }
        _ => false,
    }
}

/// Whether the scheme `name` (`g-baoab`, `g-baoab + richardson`) is one of `apart`.
fn is_apart(name: &str, apart: &[&str]) -> bool {
    apart.contains(&name.split(' ').next().unwrap_or(name))
}

/// Asserts that the expression scene's strong errors are the built-in scene's, scheme by scheme
/// (the theory variant only in the built-in report), but the schemes `apart`.
fn same_strong_errors(built_in: &ConvergenceReport, written: &ConvergenceReport, apart: &[&str]) {
    let names = |r: &ConvergenceReport| -> Vec<String> {
        r.schemes.iter().map(|s| s.name.clone()).collect()
    };
    let expected: Vec<String> = names(built_in)
        .into_iter()
        .filter(|n| n != "half-explicit-theory")
        .collect();
    assert_eq!(names(written), expected);
    let mut compared = 0;
    for scheme in written.schemes.iter().filter(|s| !is_apart(&s.name, apart)) {
        let twin = built_in
            .schemes
            .iter()
            .find(|s| s.name == scheme.name)
            .unwrap();
        for (a, b) in twin.levels.iter().zip(&scheme.levels) {
            assert_eq!(a.n_steps, b.n_steps);
            for (what, x, y) in [
                ("r", &a.error.r, &b.error.r),
                ("v", &a.error.v, &b.error.v),
                ("mu", &a.error.mu, &b.error.mu),
            ] {
                assert!(
                    agree(x.as_ref(), y.as_ref()),
                    "{} N = {}: error {what} {x:?} built in, {y:?} as expressions",
                    scheme.name,
                    a.n_steps
                );
                compared += usize::from(x.is_some());
            }
        }
    }
    assert!(
        compared >= 2 * 3 * expected.len(),
        "{compared} errors compared"
    );
}

/// Asserts that the expression scene's weak errors are the built-in scene's, observable by
/// observable, scheme by scheme, level by level, but the schemes `apart`.
fn same_weak_errors(built_in: &WeakReport, written: &WeakReport, apart: &[&str]) {
    assert_eq!(built_in.observables.len(), written.observables.len());
    for (a, b) in built_in.observables.iter().zip(&written.observables) {
        assert_eq!(a.name, b.name);
        assert!(agree(
            a.reference_value.as_ref(),
            b.reference_value.as_ref()
        ));
        for scheme in b.schemes.iter().filter(|s| !is_apart(&s.name, apart)) {
            let twin = a
                .schemes
                .iter()
                .find(|s| s.name == scheme.name && s.extrapolated == scheme.extrapolated)
                .unwrap_or_else(|| panic!("{} only as expressions", scheme.name));
            assert_eq!(twin.levels.len(), scheme.levels.len(), "{}", scheme.name);
            for (x, y) in twin.levels.iter().zip(&scheme.levels) {
                assert!(
                    agree(Some(&x.error), Some(&y.error)),
                    "{} {} N = {}: weak error {:?} built in, {:?} as expressions",
                    a.name,
                    scheme.name,
                    x.n_steps,
                    x.error,
                    y.error
                );
            }
        }
    }
}

#[test]
fn the_pendulum_written_as_expressions_has_the_built_in_errors() {
    let built_in = Scene::built_in("pendulum").unwrap();
    let written = Scene::built_in("pendulum-expressions").unwrap();
    same_strong_errors(&strong(&built_in), &strong(&written), &[]);
    same_weak_errors(&weak(&built_in), &weak(&written), &[]);
}

#[test]
fn a_chain_molecule_written_as_expressions_has_the_built_in_errors() {
    let written = Scene::built_in("chain-expressions").unwrap();
    let SystemSpec::Expressions(spec) = &written.system else {
        panic!("chain-expressions is written as expressions");
    };
    // The same molecule, built in, from the same zigzag.
    let built_in = Scene {
        name: "chain".into(),
        system: SystemSpec::ChainMolecule(ChainMoleculeParams {
            atoms: 4,
            bond_length: spec.parameters["L"],
            masses: Masses::Uniform(1.0),
            friction: 1.0,
            temperature: 1.0,
            angle: AngleParams {
                stiffness: spec.parameters["k"],
                equilibrium: spec.parameters["theta0"],
            },
            torsion: Default::default(),
        }),
        ..written.clone()
    };
    let apart = ["half-explicit-local"];
    same_strong_errors(&strong(&built_in), &strong(&written), &apart);
    same_weak_errors(&weak(&built_in), &weak(&written), &apart);
}

/// The equipartition value (n - m) kT / 2 of a scene's system (`None`: not a Langevin system).
fn kinetic_target(scene: &Scene) -> Option<f64> {
    struct Target;
    impl SceneRunner for Target {
        type Output = Option<f64>;
        fn run<S>(self, _: &Scene, prepared: Prepared<S>) -> Option<f64> {
            prepared.kinetic_target
        }
    }
    scene.run(Target).unwrap()
}

#[test]
fn langevin_expression_systems_have_the_equipartition_value_and_a_baoab_reference() {
    // n - m = 3 - 1 on the torus, 9 - 2 for the water molecule, at kT = 1.
    for (name, target) in [("torus", Some(1.0)), ("water", Some(3.5))] {
        let scene = Scene::built_in(name).unwrap();
        assert_eq!(kinetic_target(&scene), target, "{name}");
        assert_eq!(weak_reference(&scene), SchemeKind::BaoabRattle, "{name}");
    }
    // Additive noise without friction: no temperature.
    let double = Scene::built_in("double-pendulum").unwrap();
    assert_eq!(kinetic_target(&double), None);
}

#[test]
fn particles_of_an_expression_system_place_its_coordinates() {
    let water = Particles::of(&Scene::built_in("water").unwrap()).unwrap();
    assert_eq!((water.count, water.dim, water.chain), (3, 3, false));
    let double = Particles::of(&Scene::built_in("double-pendulum").unwrap()).unwrap();
    assert_eq!((double.count, double.dim), (2, 2));
    // Named coordinates are not particles: no trajectory file can place them.
    let mut named = Scene::built_in("double-pendulum").unwrap();
    let SystemSpec::Expressions(spec) = &mut named.system else {
        panic!("double-pendulum is written as expressions");
    };
    spec.coordinates = Some(["x1", "y1", "x2", "y2"].map(String::from).to_vec());
    (spec.particles, spec.dimension) = (None, None);
    let e = Particles::of(&named).unwrap_err().to_string();
    assert!(
        e.contains("system.expressions names its coordinates"),
        "{e}"
    );
}

/// The torus scene with each `from` replaced by its `to` in its file, read as a scene file is.
fn torus_with_all(changes: &[(&str, &str)]) -> Result<Scene, sdae_study::StudyError> {
    let mut text = include_str!("../../scenes/torus.toml").to_string();
    for (from, to) in changes {
        assert!(text.contains(from), "'{from}' not in the torus scene");
        text = text.replacen(from, to, 1);
    }
    Scene::from_toml(&text)
}

/// The torus scene with `from` replaced by `to` ([`torus_with_all`]).
fn torus_with(from: &str, to: &str) -> Result<Scene, sdae_study::StudyError> {
    torus_with_all(&[(from, to)])
}

#[test]
fn observables_named_in_a_study_are_compiled_as_expressions_of_the_state() {
    // The spec's `height` is y1; y1 named as a text gives the same numbers, and the kinetic
    // energy is |v|^2 / 2 at unit mass.
    let from = "observables = [\"height\", \"cos_tube\", \"kinetic_energy\"]";
    let to = "observables = [\"height\", \"y1\", \"kinetic_energy\", \"v_x1^2 + v_y1^2 + v_z1^2\"]";
    let scene = torus_with(from, to).unwrap();
    let report = weak(&scene);
    let names: Vec<&str> = report.observables.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        ["height", "y1", "kinetic_energy", "v_x1^2 + v_y1^2 + v_z1^2"]
    );
    let [height, y1, kinetic, twice] = &report.observables[..] else {
        unreachable!()
    };
    let estimates = |o: &sdae_study::weak::ObservableReport, scale: f64| {
        let mut all = vec![o.reference_value.as_ref().unwrap().estimate * scale];
        for scheme in &o.schemes {
            all.extend(scheme.levels.iter().map(|l| l.error.estimate * scale));
        }
        all
    };
    assert_eq!(estimates(height, 1.0), estimates(y1, 1.0));
    for (a, b) in estimates(kinetic, 2.0).iter().zip(estimates(twice, 1.0)) {
        assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{a} against {b}");
    }
    // The configurational observable of equipartition and the MLMC observable, as texts.
    let scene = torus_with(
        "configurational = \"cos_tube\"",
        "configurational = \"(sqrt(x1^2 + y1^2) - R) / a\"",
    )
    .unwrap();
    assert_eq!(
        scene.system.exact_average("(sqrt(x1^2 + y1^2) - R) / a"),
        None
    );
    let scene = torus_with(
        "observable = \"cos_tube\"",
        "observable = \"x1 * v_z1 - y1\"",
    );
    let scene = scene.unwrap();
    struct Value;
    impl SceneRunner for Value {
        type Output = f64;
        fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> f64
        where
            S: sdae_model::System + Clone + Send + Sync + 'static,
        {
            let name = &scene.mlmc.as_ref().unwrap().observable;
            let f = sdae_study::observable::built_in(scene, &prepared, name).unwrap();
            f.value(&prepared.position, &prepared.velocity)
        }
    }
    // At (0, -3, 0) with v = (1, 0, 1): 0 * 1 + 3.
    assert_eq!(scene.run(Value).unwrap(), 3.0);
}

#[test]
fn a_study_observable_that_does_not_compile_is_refused_with_the_compilers_message() {
    let from = "observables = [\"height\", \"cos_tube\", \"kinetic_energy\"]";
    let refused = torus_with(from, "observables = [\"height\", \"y1 + * 2\"]").unwrap_err();
    match &refused {
        sdae_study::StudyError::UnknownObservable {
            name,
            refusal: Some(refusal),
            ..
        } => {
            assert_eq!(name, "y1 + * 2");
            assert!(refusal.contains('^'), "{refusal}");
        }
        other => panic!("a typed refusal with the compiler's message: {other:?}"),
    }
    let e = refused.to_string();
    assert!(
        e.starts_with("scene torus: no observable 'y1 + * 2'"),
        "{e}"
    );
    assert!(e.contains("(observables of this system: "), "{e}");
    let lines: Vec<&str> = e.lines().collect();
    let at = lines.iter().position(|l| *l == "y1 + * 2").expect(&e);
    assert_eq!(lines[at + 1].find('^'), Some("y1 + ".len()), "{e}");
    // A slip of a name: the nearest observable, and the compiler's nearest symbol.
    let e = torus_with(from, "observables = [\"heigth\"]")
        .unwrap_err()
        .to_string();
    assert!(e.contains("did you mean 'height'?"), "{e}");
    assert!(e.contains("unknown symbol `heigth`"), "{e}");
    // An expression of the velocities in a scene that does not record them.
    let e = torus_with_all(&[
        (from, "observables = [\"y1 * v_x1\"]"),
        (
            "outputs = [\"position\", \"velocity\", \"multiplier\", \"kinetic-energy\"]",
            "outputs = [\"position\", \"kinetic-energy\"]",
        ),
    ])
    .unwrap_err();
    assert!(
        matches!(&e, sdae_study::StudyError::ObservableNeedsOutput { output, .. } if *output == "velocity"),
        "{e}"
    );
}
