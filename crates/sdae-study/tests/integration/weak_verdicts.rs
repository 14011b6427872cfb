//! What the weak study concludes, on cases whose answers are known: the weak orders of the
//! default pendulum (1 for the half-explicit and Euler-type schemes, 2 for BAOAB and g-BAOAB,
//! which are more accurate than the plain half-explicit reference the study once used), the
//! orders on a particle on a circle whose E[cos(angle turned)] has a closed form (every order
//! given is true, and a scheme without one is said why), and a scheme that loses its coarsest
//! level keeps its finer ones.
//!
//! The runs use the seeds and path counts of the study's defaults; the intervals they check are
//! the study's own 95% intervals (Monte Carlo error from a bootstrap over whole paths, plus the
//! model error the levels show, `sdae_stats::weak_order`).

use crate::weak_run;

use sdae_study::convergence::ConvergenceSettings;
use sdae_study::integrator::SchemeKind;
use sdae_study::scene::Scene;
use sdae_study::weak::report::markdown;
use sdae_study::weak::{Basis, WeakReport, WeakScheme, circle_cos_turn, weak_settings};
use weak_run::Weak;

fn row<'a>(report: &'a WeakReport, name: &str) -> &'a WeakScheme {
    report.observables[0]
        .schemes
        .iter()
        .find(|r| r.name == name)
        .unwrap_or_else(|| panic!("no row {name}"))
}

/// The true weak order of a built-in scheme on smooth observables.
fn true_order(kind: SchemeKind) -> f64 {
    f64::from(kind.weak_order())
}

#[test]
fn the_default_pendulum_gets_each_schemes_true_order() {
    let scene = Scene::built_in("pendulum").unwrap();
    let defaults = weak_settings(&scene, false).unwrap();
    assert_eq!(defaults.reference_scheme, SchemeKind::BaoabRattle);
    assert!(defaults.paired_reference);
    let first_order = [
        SchemeKind::HalfExplicitPractical,
        SchemeKind::EulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
    ];
    let second_order = [SchemeKind::BaoabRattle, SchemeKind::GBaoab];
    let settings = ConvergenceSettings {
        schemes: first_order.iter().chain(&second_order).copied().collect(),
        observables: vec!["cos_angle".into()],
        threads: 2,
        ..defaults
    };
    let report = scene.run(Weak {
        settings: &settings,
        extra: None,
    });
    let report = report.unwrap();
    let cos = &report.observables[0];
    assert_eq!(cos.basis, Basis::Reference);
    let bias = cos.reference_bias.as_ref().expect("a paired reference");
    assert_eq!(bias.order, 2);
    // The reference is better than every scheme it judges: its bias bound lies below the
    // smallest error any plain row resolved.
    let smallest = cos
        .schemes
        .iter()
        .filter(|r| !r.extrapolated)
        .flat_map(|r| r.levels.iter().filter(|l| l.resolved))
        .map(|l| l.error.estimate.abs())
        .fold(f64::INFINITY, f64::min);
    assert!(bias.bound < 0.1 * smallest, "{bias:?} against {smallest:e}");
    let order = |name: &str| {
        let r = row(&report, name);
        let fit = r
            .order
            .as_ref()
            .unwrap_or_else(|| panic!("{name}: no order"));
        fit.order.unwrap_or_else(|| panic!("{name}: {fit:?}"))
    };
    let practical = order("half-explicit-practical");
    assert!(practical.contains(1.0), "{practical:?}");
    for kind in second_order {
        let o = order(kind.name());
        assert!(o.ci_low > 1.6, "{}: {o:?}", kind.name());
        assert!(o.contains(true_order(kind)), "{}: {o:?}", kind.name());
    }
    // Richardson-Romberg rows of the first-order schemes: second order, or their levels named.
    for kind in first_order {
        let r = row(&report, &format!("{} + richardson", kind.name()));
        let fit = r.order.as_ref().unwrap();
        match fit.order {
            Some(o) => assert!(o.estimate > 1.6, "{}: {fit:?}", r.name),
            None => assert!(!fit.pre_asymptotic.is_empty(), "{}: {fit:?}", r.name),
        }
    }
    let md = markdown(&report);
    assert!(
        md.contains("reference baoab-rattle with 2048 steps (and 1024"),
        "{md}"
    );
    assert!(md.contains("its bias is bounded by B ="), "{md}");
}

/// A unit mass on a circle of radius 1.5 with friction 0.7 and noise 0.9, no gravity, started
/// at speed 1.2: E[cos(phi_T - phi_0)] in closed form ([`circle_cos_turn`]).
const CIRCLE: &str = r#"
name = "test-circle"
T = 1.0
outputs = ["position", "velocity"]
[system.pendulum]
dim = 2
length = 1.5
gravity = 0.0
noise = 0.9
friction = 0.7
[initial]
position = [0.0, -1.5]
velocity = [1.2, 0.0]
[scheme]
practical_c_eta = 1.0
[weak]
observables = ["cos_turn"]
paths = 20000
"#;

#[test]
fn on_a_circle_every_order_given_is_true_and_the_reference_is_the_closed_form() {
    let scene = Scene::from_toml(CIRCLE).unwrap();
    let settings = ConvergenceSettings {
        threads: 2,
        ..weak_settings(&scene, false).unwrap()
    };
    let report = scene
        .run(Weak {
            settings: &settings,
            extra: None,
        })
        .unwrap();
    let cos = &report.observables[0];
    // The extrapolated reference against the closed form: within its 95% interval and its
    // bias bound.
    let exact = circle_cos_turn(1.2 / 1.5, 0.7, 0.9 / 1.5, 1.0);
    let reference = cos.reference_value.unwrap();
    let bound = cos.reference_bias.as_ref().unwrap().bound;
    assert!(
        reference.ci_low - bound <= exact && exact <= reference.ci_high + bound,
        "{reference:?} +- {bound:e} against {exact}"
    );
    // Every order given covers the true one. A scheme gets none only where the report says
    // why: its local slopes do not settle over these levels (the theory's C_eta truncates most
    // steps at coarse h, so its error falls faster and faster as the truncation turns off),
    // too few levels follow a change of sign of its error (named pre-asymptotic), or it is
    // more accurate than the paths resolve at all but one level (g-BAOAB, whose geodesic
    // drift is exact on a circle).
    for kind in SchemeKind::ALL {
        let r = row(&report, kind.name());
        assert!(r.lost.is_empty(), "{}: {:?}", r.name, r.lost);
        let Some(fit) = &r.order else {
            let unresolved = r.levels.iter().filter(|l| !l.resolved).count();
            assert!(
                unresolved + 1 >= r.levels.len(),
                "{}: {:?}",
                r.name,
                r.levels
            );
            continue;
        };
        match fit.order {
            Some(o) => assert!(o.contains(true_order(kind)), "{}: {fit:?}", r.name),
            None => assert!(
                fit.unsettled || !fit.pre_asymptotic.is_empty(),
                "{}: {fit:?}",
                r.name
            ),
        }
    }
    for kind in [
        SchemeKind::HalfExplicitPractical,
        SchemeKind::EulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
        SchemeKind::BaoabRattle,
    ] {
        let fit = row(&report, kind.name()).order.as_ref();
        assert!(fit.is_some_and(|f| f.order.is_some()), "{}", kind.name());
    }
}

#[test]
fn a_scheme_that_loses_its_coarsest_level_keeps_the_finer_ones() {
    // On a pendulum of length 0.8 a step of T / 4 is longer than the radius: the half-explicit
    // schemes fail there on some paths, and their finer levels are still compared.
    let scene = Scene::from_toml(
        &include_str!("fixtures/pendulum.toml")
            .replace("length = 1.0", "length = 0.8")
            .replace("position = [0.0, -1.0]", "position = [0.0, -0.8]"),
    )
    .unwrap();
    let settings = ConvergenceSettings {
        paths: 2000,
        coarsest: 2,
        finest: 6,
        reference: Some(10),
        threads: 2,
        observables: vec!["cos_angle".into(), "kinetic_energy".into()],
        schemes: vec![SchemeKind::HalfExplicitUntruncated, SchemeKind::BaoabRattle],
        reference_scheme: SchemeKind::BaoabRattle,
        paired_reference: true,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report = scene
        .run(Weak {
            settings: &settings,
            extra: None,
        })
        .unwrap();
    let untruncated = row(&report, "half-explicit-untruncated");
    let lost: Vec<usize> = untruncated.lost.iter().map(|l| l.n_steps).collect();
    assert!(lost.contains(&4), "{:?}", untruncated.lost);
    assert!(untruncated.lost.iter().all(|l| !l.failures.is_empty()));
    let kept: Vec<usize> = untruncated.levels.iter().map(|l| l.n_steps).collect();
    assert!(kept.contains(&64), "{kept:?}");
    assert!(kept.iter().all(|n| !lost.contains(n)));
    // Its extrapolated row loses the pairs with a lost level, not the others.
    let extrapolated = row(&report, "half-explicit-untruncated + richardson");
    assert!(extrapolated.lost.iter().any(|l| l.n_steps == 8));
    assert!(!extrapolated.levels.is_empty());
    assert!(report.uncompared().is_empty(), "{:?}", report.uncompared());
    let md = markdown(&report);
    assert!(md.contains("N = 4 ("), "{md}");
}
