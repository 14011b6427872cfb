//! Scene files: every built-in scene parses and round-trips, and each malformed file gives an
//! error that names the key or value at fault.

use sdae_study::StudyError;
use sdae_study::scene::{BUILT_IN, Scene};

/// A valid pendulum scene, the base of the broken ones below.
const GOOD: &str = include_str!("fixtures/pendulum.toml");

fn error_of(text: &str) -> String {
    match Scene::from_toml(text) {
        Ok(_) => panic!("accepted a malformed scene:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Checks that a scene runs: builds its system and initial state.
fn runs(scene: &Scene) -> Result<(), StudyError> {
    struct Nothing;
    impl sdae_study::scene::SceneRunner for Nothing {
        type Output = ();
        fn run<S>(self, _: &Scene, _: sdae_study::scene::Prepared<S>) {}
    }
    scene.run(Nothing)
}

#[test]
fn built_in_scenes_parse_run_and_round_trip() {
    for (name, _) in BUILT_IN {
        let scene = Scene::built_in(name).unwrap();
        assert_eq!(scene.name, name);
        runs(&scene).unwrap();
        let text = scene.to_toml().unwrap();
        assert_eq!(Scene::from_toml(&text).unwrap(), scene, "{name}");
    }
    assert!(matches!(
        Scene::built_in("nope"),
        Err(StudyError::Unknown(_))
    ));
}

#[test]
fn unknown_keys_are_named() {
    let e = error_of(&GOOD.replace("gravity", "gravty"));
    assert!(e.contains("gravty"), "{e}");
    let e = error_of(&GOOD.replace("T = 1.0", "T = 1.0\ncolour = 3"));
    assert!(e.contains("colour"), "{e}");
    let e = error_of(&GOOD.replace("[system.pendulum]", "[system.pendulm]"));
    assert!(e.contains("pendulm"), "{e}");
    let e = error_of(&GOOD.replace("\"multiplier\"", "\"temperature\""));
    assert!(e.contains("temperature"), "{e}");
}

#[test]
fn missing_values_are_named() {
    let e = error_of(&GOOD.replace("length = 1.0\n", ""));
    assert!(e.contains("length"), "{e}");
    let e = error_of(&GOOD.replace("T = 1.0\n", ""));
    assert!(e.contains("`T`"), "{e}");
    let e = error_of(&GOOD.replace(
        "outputs = [\"position\", \"velocity\", \"multiplier\"]\n",
        "",
    ));
    assert!(e.contains("outputs"), "{e}");
}

#[test]
fn wrong_types_and_bad_values_are_named() {
    let e = error_of(&GOOD.replace("dim = 2", "dim = \"two\""));
    assert!(e.contains("dim"), "{e}");
    let e = error_of(&GOOD.replace("T = 1.0", "T = -1.0"));
    assert!(e.contains("T = -1"), "{e}");
    let e = error_of(&GOOD.replace(
        "outputs = [\"position\", \"velocity\", \"multiplier\"]",
        "outputs = []",
    ));
    assert!(e.contains("outputs"), "{e}");
    let e = error_of(&GOOD.replace("name = \"test\"", "name = \"a b\""));
    assert!(e.contains("name"), "{e}");
}

#[test]
fn bad_systems_and_initial_states_are_refused_when_run() {
    let scene = Scene::from_toml(&GOOD.replace("length = 1.0", "length = -1.0")).unwrap();
    let e = runs(&scene).unwrap_err().to_string();
    assert!(e.contains("system") && e.contains("-1"), "{e}");
    let scene = Scene::from_toml(&GOOD.replace("[0.0, -1.0]", "[0.0, -1.0, 0.0]")).unwrap();
    let e = runs(&scene).unwrap_err().to_string();
    assert!(e.contains("initial.position has 3 entries"), "{e}");
    // Off the circle: refused, unless projection is asked for.
    let off = GOOD.replace("[0.0, -1.0]", "[0.0, -1.1]");
    let e = runs(&Scene::from_toml(&off).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("initial state") && e.contains("project"), "{e}");
    let projected = off.replace("[initial]", "[initial]\nproject = true");
    runs(&Scene::from_toml(&projected).unwrap()).unwrap();
}

#[test]
fn system_parameters_and_shapes_are_checked() {
    let fiber = sdae_study::scene::BUILT_IN
        .iter()
        .find(|(n, _)| *n == "fiber")
        .unwrap()
        .1;
    let e = error_of(&fiber.replace("segment = 0.05263157894736842\n", ""));
    assert!(e.contains("segment"), "{e}");
    let e = error_of(&fiber.replace("turbulence_gain", "turbulence_gian"));
    assert!(e.contains("turbulence_gian"), "{e}");
    let e = error_of(&fiber.replace(
        "shape = { zigzag = 0.3 }",
        "shape = { zigzag = 0.3 }\nposition = [0.0]",
    ));
    assert!(e.contains("either shape or position"), "{e}");
    let e = error_of(&GOOD.replace("position = [0.0, -1.0]", "shape = \"straight\""));
    assert!(e.contains("chains of beads"), "{e}");
    let scene = Scene::from_toml(&fiber.replace("beads = 20", "beads = 1")).unwrap();
    let e = runs(&scene).unwrap_err().to_string();
    assert!(e.contains("beads"), "{e}");
}

#[test]
fn bad_settings_are_named_by_their_scene_key() {
    use sdae_study::convergence::ConvergenceSettings;
    let scene = Scene::built_in("pendulum").unwrap();
    let base = ConvergenceSettings::for_scene(&scene);
    let key = |settings: ConvergenceSettings| match settings.validate() {
        Err(StudyError::Setting { key, .. }) => key,
        other => panic!("{other:?}"),
    };
    let paths = ConvergenceSettings {
        paths: 1,
        ..base.clone()
    };
    assert_eq!(key(paths), "study.paths");
    let levels = ConvergenceSettings {
        coarsest: base.finest + 1,
        ..base.clone()
    };
    assert_eq!(key(levels), "study.levels");
    let threads = ConvergenceSettings {
        threads: 0,
        ..base.clone()
    };
    assert_eq!(key(threads), "threads");
    let t_end = ConvergenceSettings {
        t_end: f64::NAN,
        ..base
    };
    assert_eq!(key(t_end), "T");
}
