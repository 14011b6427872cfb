//! The `--quick` pendulum study's report for every scheme, errors rounded to 2 significant
//! digits (what 200 paths resolve), orders to 2 decimals, timings left out: a change here is a
//! change in the schemes' numbers, while a last-bit change of the step size leaves it alone.

use sdae_stats::Interval;
use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::output::describe_fit;
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

fn interval(i: Option<Interval>) -> String {
    i.map_or("-".into(), |i| {
        format!("{:.1e} [{:.1e}, {:.1e}]", i.estimate, i.ci_low, i.ci_high)
    })
}

/// The report's text; `nudge` moves T, and so every step size, by one unit in the last place.
fn report_text(nudge: bool) -> String {
    let scene = Scene::built_in("pendulum").unwrap();
    let mut settings = ConvergenceSettings {
        paths: 200,
        coarsest: 3,
        finest: 7,
        reference: Some(11),
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    if nudge {
        settings.t_end = settings.t_end.next_up();
    }
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    let mut text = String::new();
    for scheme in &report.schemes {
        text += &format!("{}\n", scheme.name);
        for l in &scheme.levels {
            let e = &l.error;
            text += &format!(
                "  N {:>4}: r {}  v {}  mu {}  truncated {:.2}  newton/step {:.2}  homotopy {}  failures {}\n",
                l.n_steps,
                interval(e.r),
                interval(e.v),
                interval(e.mu),
                l.truncated_fraction,
                l.newton_iterations_per_step,
                l.homotopy_steps,
                l.failures,
            );
        }
        let o = &scheme.observed_order;
        for (name, fit) in [("r", &o.r), ("v", &o.v), ("mu", &o.mu)] {
            let fit = fit.as_ref().unwrap();
            text += &format!(
                "  order {name}: {} fitted {:?}\n",
                describe_fit(fit),
                fit.fitted
            );
        }
    }
    text += &format!(
        "reference failures: {}\n",
        report.reference.unwrap().failures
    );
    text
}

#[test]
fn quick_report_snapshot() {
    let text = report_text(false);
    assert_eq!(
        text,
        report_text(true),
        "a last-bit change of h rewrites it"
    );
    insta::assert_snapshot!("pendulum_quick", text);
}

/// At T = 1e-100 the paths move by about 1e-100 and the errors of r and v, some 1e-114 at every
/// N, are the rounding of that move: they are named unresolved and no order is fitted to them
/// (they were fitted to orders -0.01 [-0.01, -0.01] and 0.00 [0.00, 0.00]).
#[test]
fn errors_at_the_rounding_level_of_the_state_get_no_order() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = ConvergenceSettings {
        paths: 8,
        coarsest: 3,
        finest: 7,
        reference: Some(11),
        threads: 1,
        t_end: 1e-100,
        schemes: vec![
            sdae_study::integrator::SchemeKind::EulerMaruyama,
            sdae_study::integrator::SchemeKind::HalfExplicitPractical,
        ],
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    for scheme in &report.schemes {
        assert!(scheme.observed_order.r.is_none(), "{}", scheme.name);
        assert!(scheme.observed_order.v.is_none(), "{}", scheme.name);
        for output in ["r", "v"] {
            let named = scheme.unresolved.iter().filter(|u| u.output == output);
            assert_eq!(named.count(), scheme.levels.len(), "{}", scheme.name);
        }
    }
}
