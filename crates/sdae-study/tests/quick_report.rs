//! The `--quick` pendulum study's report for every scheme, floats rounded to 3 significant
//! digits and timings left out: a change here is a change in the schemes' numbers.

use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::output::describe_fit;
use sdae_study::scene::Scene;
use sdae_study::stats::Interval;

fn interval(i: Option<Interval>) -> String {
    i.map_or("-".into(), |i| {
        format!("{:.2e} [{:.2e}, {:.2e}]", i.estimate, i.ci_low, i.ci_high)
    })
}

#[test]
fn quick_report_snapshot() {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = ConvergenceSettings {
        paths: 200,
        coarsest: 3,
        finest: 7,
        reference: Some(11),
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report = build_report(run_convergence(&scene, &settings, (0, 1), |_| {}).unwrap());
    let mut text = String::new();
    for scheme in &report.schemes {
        text += &format!("{}\n", scheme.name);
        for l in &scheme.levels {
            let e = &l.error;
            text += &format!(
                "  N {:>4}: r {}  v {}  mu {}  truncated {:.3}  newton/step {:.3}  homotopy {}  failures {}\n",
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
    insta::assert_snapshot!("pendulum_quick", text);
}
