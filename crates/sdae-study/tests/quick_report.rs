//! The `--quick` pendulum study's report, floats rounded to 3 significant digits and timings
//! left out: a change here is a change in the scheme's numbers.

use sdae_study::{PendulumStudy, pendulum_study};

fn round(x: f64) -> String {
    format!("{x:.2e}")
}

#[test]
fn quick_report_snapshot() {
    let study = PendulumStudy {
        paths: 200,
        coarsest: 3,
        finest: 7,
        reference: 11,
        threads: 2,
        ..PendulumStudy::default()
    };
    let report = pendulum_study(study, |_| {});
    let mut text = String::new();
    for l in &report.levels {
        let e = &l.error;
        let interval = |i: &sdae_study::stats::Interval| {
            format!(
                "{} [{}, {}]",
                round(i.estimate),
                round(i.ci_low),
                round(i.ci_high)
            )
        };
        text += &format!(
            "N {:>4}: r {}  v {}  mu {}  truncated {:.3}  newton/step {:.3}  homotopy {}  failures {}\n",
            l.n_steps,
            interval(&e.r),
            interval(&e.v),
            interval(&e.mu),
            l.truncated_fraction,
            l.newton_iterations_per_step,
            l.homotopy_steps,
            l.failures,
        );
    }
    let o = &report.observed_order;
    for (name, fit) in [("r", &o.r), ("v", &o.v), ("mu", &o.mu)] {
        text += &format!(
            "order {name}: {:.2} [{:.2}, {:.2}] fitted {:?} pre-asymptotic {:?}\n",
            fit.order.estimate, fit.order.ci_low, fit.order.ci_high, fit.fitted, fit.pre_asymptotic
        );
    }
    text += &format!("reference failures: {}\n", report.reference_failures);
    insta::assert_snapshot!("pendulum_quick", text);
}
