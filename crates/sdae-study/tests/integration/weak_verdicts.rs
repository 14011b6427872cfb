//! What the weak study concludes, on cases whose answers are known: the weak orders of the
//! default pendulum (1 for the half-explicit and Euler-type schemes, 2 for BAOAB and g-BAOAB,
//! which are more accurate than the plain half-explicit reference the study once used), the
//! orders on a particle on a circle whose E[cos(angle turned)] has a closed form (every order
//! given is true, and a scheme without one is said why), and a scheme that loses its coarsest
//! level keeps its finer ones.
//!
//! The thorough variants (run with `--ignored`) use the seeds, path counts and levels of the
//! study's defaults, the default ones fewer paths and levels; the intervals they check are the
//! study's own 95% intervals (Monte Carlo error from a bootstrap over whole paths, plus the
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

/// The default pendulum's weak study with `first_order` schemes and BAOAB and g-BAOAB, on the
/// study's defaults (`thorough`) or on 10000 paths and levels 2..6 against a reference at 2^10
/// steps (four levels above the finest, as the defaults have): the reference is better than
/// every scheme it judges, the half-explicit scheme's order interval contains 1 and the
/// splitting schemes' contain 2 and exclude 1 (thoroughly: lie above 1.6).
fn pendulum_orders(first_order: &[SchemeKind], thorough: bool) -> WeakReport {
    let scene = Scene::built_in("pendulum").unwrap();
    let defaults = weak_settings(&scene, false).unwrap();
    assert_eq!(defaults.reference_scheme, SchemeKind::BaoabRattle);
    assert!(defaults.paired_reference);
    let second_order = [SchemeKind::BaoabRattle, SchemeKind::GBaoab];
    let mut settings = ConvergenceSettings {
        schemes: first_order.iter().chain(&second_order).copied().collect(),
        observables: vec!["cos_angle".into()],
        threads: 2,
        ..defaults
    };
    if !thorough {
        settings.paths = 10_000;
        settings.finest = 6;
        settings.reference = Some(10);
    }
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
        // Their errors fall fast below the Monte Carlo error: where only three levels are
        // resolved and their two local slopes differ beyond what one order allows (g-BAOAB on
        // the study's paths: 2.28 [1.93, 2.80], then 1.72 [1.17, 2.62]), the levels cannot
        // show the asymptote and the order is withheld with that reason.
        if row(&report, kind.name())
            .order
            .as_ref()
            .is_some_and(|f| f.unshown && f.order.is_none())
        {
            continue;
        }
        let o = order(kind.name());
        let lowest = if thorough { 1.6 } else { 1.0 };
        assert!(o.ci_low > lowest, "{}: {o:?}", kind.name());
        assert!(o.contains(true_order(kind)), "{}: {o:?}", kind.name());
    }
    report
}

#[test]
fn the_pendulum_gets_the_true_orders_of_half_explicit_and_splitting_schemes() {
    pendulum_orders(&[SchemeKind::HalfExplicitPractical], false);
}

/// The thorough variant, on the study's defaults (40000 paths, levels 2..7, a reference at
/// 2^11 steps) with the Euler-type schemes and their Richardson-Romberg rows (about a minute in
/// the test profile): `cargo test -p sdae-study --test integration -- --ignored`.
#[test]
#[ignore]
fn the_default_pendulum_gets_each_schemes_true_order() {
    let first_order = [
        SchemeKind::HalfExplicitPractical,
        SchemeKind::EulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
    ];
    let report = pendulum_orders(&first_order, true);
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

/// The weak study of every built-in scheme on the circle, on the scene's 20000 paths and the
/// default levels 2..7 against 2^11 steps (`thorough`), or on 5000 paths and levels 2..6
/// against 2^10 steps, where BAOAB resolves too few levels for an order and so is not required
/// to have one.
fn circle_orders(thorough: bool) {
    let scene = Scene::from_toml(CIRCLE).unwrap();
    let mut settings = ConvergenceSettings {
        threads: 2,
        ..weak_settings(&scene, false).unwrap()
    };
    if !thorough {
        settings.paths = 5000;
        settings.finest = 6;
        settings.reference = Some(10);
    }
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
    for r in &cos.schemes {
        assert!(r.lost.is_empty(), "{}: {:?}", r.name, r.lost);
    }
    every_order_is_true_or_withheld(&report);
    let mut with_orders = vec![
        SchemeKind::HalfExplicitPractical,
        SchemeKind::EulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
    ];
    if thorough {
        with_orders.push(SchemeKind::BaoabRattle);
    }
    for kind in with_orders {
        let fit = row(&report, kind.name()).order.as_ref();
        let withheld = kind == SchemeKind::BaoabRattle && fit.is_some_and(|f| f.unshown);
        assert!(
            withheld || fit.is_some_and(|f| f.order.is_some()),
            "{}: {fit:?}",
            kind.name()
        );
    }
}

/// Every order given covers the true one. A scheme gets none only where the report says why:
/// its local slopes do not settle over these levels (the theory's C_eta truncates most steps at
/// coarse h, so its error falls faster and faster as the truncation turns off), too few levels
/// follow a change of sign of its error (named pre-asymptotic), its resolved levels cannot show
/// the asymptote, or it is more accurate than the paths resolve at all but one level (g-BAOAB,
/// whose geodesic drift is exact on a circle), or the errors of its two finest resolved levels
/// differ in sign (stochastic Heun on fewer paths, whose error crosses zero near N = 16).
fn every_order_is_true_or_withheld(report: &WeakReport) {
    for kind in SchemeKind::ALL {
        let r = row(report, kind.name());
        let Some(fit) = &r.order else {
            let resolved: Vec<f64> = r
                .levels
                .iter()
                .filter(|l| l.resolved)
                .map(|l| l.error.estimate)
                .collect();
            let crossed = resolved
                .windows(2)
                .last()
                .is_some_and(|pair| pair[0].signum() != pair[1].signum());
            assert!(resolved.len() <= 1 || crossed, "{}: {:?}", r.name, r.levels);
            continue;
        };
        match fit.order {
            Some(o) => assert!(o.contains(true_order(kind)), "{}: {fit:?}", r.name),
            None => assert!(
                fit.unsettled || fit.unshown || !fit.pre_asymptotic.is_empty(),
                "{}: {fit:?}",
                r.name
            ),
        }
    }
}

#[test]
fn on_a_circle_every_order_given_is_true_and_the_reference_is_the_closed_form() {
    circle_orders(false);
}

/// The thorough variant (about a minute in the test profile):
/// `cargo test -p sdae-study --test integration -- --ignored`.
#[test]
#[ignore]
fn on_a_circle_every_order_given_is_true_thoroughly() {
    circle_orders(true);
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

/// A second circle (radius 0.8, friction 1.5, noise 1.1, speed 1.4, T = 1) whose mean kinetic
/// energy has a closed form (E[|v_T|^2 / 2] = (u_0^2 e^(-2 gamma T) + sigma^2 (1 - e^(-2 gamma
/// T)) / (2 gamma)) / 2, the constraint force being normal to v), on the weak study's default
/// sizes (10000 paths, levels 2..7 against 2^11 steps): every order printed covers the true one
/// or is withheld with its reason, and the extrapolated reference covers the closed form.
#[test]
fn on_a_second_circle_the_kinetic_energy_orders_are_true_or_withheld() {
    let scene = Scene::from_toml(
        &CIRCLE
            .replace("length = 1.5", "length = 0.8")
            .replace("position = [0.0, -1.5]", "position = [0.0, -0.8]")
            .replace("friction = 0.7", "friction = 1.5")
            .replace("noise = 0.9", "noise = 1.1")
            .replace("velocity = [1.2, 0.0]", "velocity = [1.4, 0.0]")
            .replace("[\"cos_turn\"]", "[\"kinetic_energy\"]")
            .replace("paths = 20000\n", ""),
    )
    .unwrap();
    let settings = ConvergenceSettings {
        threads: 2,
        ..weak_settings(&scene, false).unwrap()
    };
    assert_eq!((settings.paths, settings.finest), (10_000, 7));
    let report = scene
        .run(Weak {
            settings: &settings,
            extra: None,
        })
        .unwrap();
    let energy = &report.observables[0];
    let decay = (-2.0 * 1.5f64).exp();
    let exact = 0.5 * (1.4f64.powi(2) * decay + 1.1f64.powi(2) * (1.0 - decay) / 3.0);
    let reference = energy.reference_value.unwrap();
    let bound = energy.reference_bias.as_ref().unwrap().bound;
    assert!(
        reference.ci_low - bound <= exact && exact <= reference.ci_high + bound,
        "{reference:?} +- {bound:e} against {exact}"
    );
    every_order_is_true_or_withheld(&report);
}
