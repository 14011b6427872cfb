//! The `--quick` stability report of the built-in stiff and extreme scenes: finished paths and
//! failures by kind per scheme and step size, with rounded figures (timings left out).

use sdae_study::convergence::{build_report, run_convergence};
use sdae_study::scene::{BUILT_IN, Scene};
use sdae_study::stability::stability_settings;

/// The order of magnitude of a residual; rounding-level values collapse to one class.
fn magnitude(x: f64) -> String {
    if x < 1e-12 {
        "<1e-12".into()
    } else {
        format!("1e{}", x.log10().floor())
    }
}

#[test]
fn quick_stability_report_snapshot() {
    let mut text = String::new();
    for (name, _) in BUILT_IN {
        let scene = Scene::built_in(name).unwrap();
        let Some(mut settings) = stability_settings(&scene, true) else {
            continue;
        };
        settings.threads = 2;
        let report = build_report(run_convergence(&scene, &settings, (0, 1), |_| {}).unwrap());
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
                    "  {:<26} N {:>5}: finished {:>3}/{}  [{}]  |g| {}  |Dg v| {}  truncated {:.2}  error r {error}\n",
                    scheme.name,
                    l.n_steps,
                    l.paths - l.failures,
                    l.paths,
                    failures.join(", "),
                    magnitude(l.max_position_residual),
                    magnitude(l.max_velocity_residual),
                    l.truncated_fraction,
                );
            }
        }
    }
    insta::assert_snapshot!("stability_quick", text);
}
