//! The `--quick` stability report of the built-in stiff and extreme scenes: finished paths and
//! failures by kind per scheme and step size, residuals and errors as classes (timings left
//! out). Long and stiff paths are chaotic, so the figures are rounded to what the test asserts:
//! a last-bit change of the step size leaves the text alone.

use sdae_study::convergence::{build_report, run_convergence};
use sdae_study::parallel::Control;
use sdae_study::scene::{BUILT_IN, Scene};
use sdae_study::stability::stability_settings;

/// The class of a residual on a level where every path finished: kept to rounding, small, or
/// drifted off the manifold. Where paths failed, the largest residual is that of a failing
/// step, which a last-bit change moves anywhere: "-".
fn residual(x: f64, failures: usize) -> &'static str {
    match x {
        _ if failures > 0 => "-",
        x if x < 1e-12 => "<1e-12",
        x if x < 1e-6 => "<1e-6",
        _ => "drifted",
    }
}

/// The report's text; `nudge` moves T, and so every step size, by one unit in the last place.
fn report_text(nudge: bool) -> String {
    let mut text = String::new();
    for (name, _) in BUILT_IN {
        let scene = Scene::built_in(name).unwrap();
        let Some(mut settings) = stability_settings(&scene, true) else {
            continue;
        };
        settings.threads = 2;
        if nudge {
            settings.t_end = settings.t_end.next_up();
        }
        let report =
            build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
        text += &format!("{name} ({} paths)\n", report.paths);
        for scheme in &report.schemes {
            for l in &scheme.levels {
                let failures: Vec<String> = l
                    .failures_by_kind
                    .iter()
                    .map(|(k, n)| format!("{} {n}", k.name()))
                    .collect();
                let error = l
                    .error
                    .r
                    .filter(|e| e.estimate.is_finite())
                    .map_or("-".into(), |e| format!("{:.1e}", e.estimate));
                text += &format!(
                    "  {:<26} N {:>5}: finished {:>3}/{}  [{}]  |g| {}  |Dg v| {}  truncated {:.1}  error r {error}\n",
                    scheme.name,
                    l.n_steps,
                    l.paths - l.failures,
                    l.paths,
                    failures.join(", "),
                    residual(l.max_position_residual, l.failures),
                    residual(l.max_velocity_residual, l.failures),
                    l.truncated_fraction,
                );
            }
        }
    }
    text
}

#[test]
fn quick_stability_report_snapshot() {
    let text = report_text(false);
    assert_eq!(
        text,
        report_text(true),
        "a last-bit change of h rewrites it"
    );
    insta::assert_snapshot!("stability_quick", text);
}
