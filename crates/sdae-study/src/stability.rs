//! The stability study: every scheme on stiff and extreme scenes over a range of step sizes,
//! counting the paths that finish and the failures by kind, with the largest constraint
//! residuals, the share of truncated steps, the error against a reference where one exists,
//! and the run time.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;
use serde::Serialize;

use sdae_reference::CurvedSystem;

use crate::convergence::{
    ConvergenceReport, ConvergenceSettings, LevelReport, build_report, run_convergence_on,
};
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use crate::integrator::StudyScheme;
use crate::lockstep::Limits;
use crate::parallel::Control;
use crate::plots::{COLOURS, draw_legend, log_range};
use crate::scene::{Prepared, Scene};

/// The stability settings of a scene (`None` if it has no `[stability]` table); `quick` keeps
/// at most 20 paths, the three coarsest levels and a reference 4 levels above them.
pub fn stability_settings(scene: &Scene, quick: bool) -> Option<ConvergenceSettings> {
    let spec = scene.stability.as_ref()?;
    let [mut coarsest, mut finest] = spec.levels;
    let mut paths = spec.paths;
    let mut reference = spec.reference;
    if quick {
        paths = paths.min(20);
        finest = finest.min(coarsest + 2);
        reference = reference.map(|r| r.min(finest + 4));
        coarsest = coarsest.min(finest);
    }
    Some(ConvergenceSettings {
        paths,
        coarsest,
        finest,
        reference,
        limits: Limits {
            blow_up: spec.blow_up,
            drift_tolerance: Some(spec.drift_tolerance),
        },
        ..ConvergenceSettings::for_scene(scene)
    })
}

/// One scene of the stability study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StabilityScene {
    /// The stiff or extreme case it stands for.
    pub case: String,
    /// Its results (errors only where a reference exists).
    pub report: ConvergenceReport,
}

/// The stability study of one scene with `settings` (from [`stability_settings`], perhaps
/// adjusted): the scene's system as `prepared` (from a scene file through a
/// [`SceneRunner`](crate::scene::SceneRunner), or built in code with
/// [`Scene::prepare_custom`]), the built-in schemes of the settings and the user's `extra`
/// schemes; `progress` is called with the number of finished paths.
pub fn run_stability_on<S>(
    scene: &Scene, prepared: &Prepared<S>, extra: &[StudyScheme<S>],
    settings: &ConvergenceSettings, progress: &(dyn Fn(usize) + Sync),
) -> Result<StabilityScene, StudyError>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let control = Control {
        progress: Some(progress),
        ..Control::default()
    };
    let run = run_convergence_on(scene, prepared, extra, settings, (0, 1), control)?;
    let case = scene.stability.as_ref().map_or_else(
        || format!("{} (no [stability] table)", scene.name),
        |s| s.case.clone(),
    );
    Ok(StabilityScene {
        case,
        report: build_report(run),
    })
}

/// The stability study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StabilityReport {
    /// One entry per scene.
    pub scenes: Vec<StabilityScene>,
}

fn failures(l: &LevelReport) -> String {
    if l.failures_by_kind.is_empty() {
        return "-".into();
    }
    l.failures_by_kind
        .iter()
        .map(|(k, n)| format!("{} {n}", k.name()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The largest h at which every path of the scheme finished at every h up to it, if any.
fn largest_stable_h(levels: &[LevelReport]) -> Option<f64> {
    let mut stable = None;
    for l in levels.iter().rev() {
        if l.failures > 0 {
            break;
        }
        stable = Some(l.h);
    }
    stable
}

/// The Markdown summary: an overview (largest stable h per scheme and scene) and per scene a
/// table of every scheme and step size.
pub fn markdown(report: &StabilityReport) -> String {
    let mut s = String::from("# Stability study\n\n");
    s += &overview(report);
    for sc in &report.scenes {
        s += &scene_section(sc);
    }
    s += "\n![share of paths that finish](stability.svg)\n";
    s
}

/// The overview: per scene and scheme, the largest h up to which every path finished.
fn overview(report: &StabilityReport) -> String {
    let mut s = String::from(
        "Largest step size h up to which every path finished (failures: no root, spurious root, \
          no convergence, singular, non-finite, blow-up, constraint drift beyond tolerance):\n\n",
    );
    let schemes: Vec<&str> = report
        .scenes
        .iter()
        .flat_map(|sc| sc.report.schemes.iter().map(|s| s.name.as_str()))
        .fold(Vec::new(), |mut v, n| {
            if !v.contains(&n) {
                v.push(n);
            }
            v
        });
    s += "| scene | case |";
    for name in &schemes {
        let _ = write!(s, " {name} |");
    }
    s += "\n|---|---|";
    s += &"---|".repeat(schemes.len());
    s += "\n";
    for sc in &report.scenes {
        let case = sc.case.replace('|', "\\|");
        let _ = write!(s, "| {} | {case} |", sc.report.scene);
        for name in &schemes {
            let cell = match sc.report.schemes.iter().find(|x| x.name == *name) {
                None => "n/a".into(),
                Some(x) => {
                    largest_stable_h(&x.levels).map_or("none".into(), |h| format!("{h:.1e}"))
                }
            };
            let _ = write!(s, " {cell} |");
        }
        s += "\n";
    }
    s
}

/// A scene's heading, its settings and the table of every scheme and step size.
fn scene_section(sc: &StabilityScene) -> String {
    let mut s = String::new();
    let r = &sc.report;
    let tol = r.settings.limits.drift_tolerance.unwrap_or(f64::INFINITY);
    let _ = write!(
        s,
        "\n## {}\n\n{}. {} paths, T = {}, drift tolerance {tol:e}, blow-up bound {:e}{}.\n\n",
        r.scene,
        sc.case,
        r.paths,
        crate::output::readable(r.t_end),
        r.settings.limits.blow_up,
        r.reference
            .as_ref()
            .map_or(", no reference".into(), |x| format!(
                ", reference {} with {} steps",
                x.scheme, x.n_steps
            ))
    );
    s += "| scheme | h | finished | failures | max abs g | max abs Dg v | truncated | error r | us/path |\n|---|---|---|---|---|---|---|---|---|\n";
    for scheme in &r.schemes {
        for l in &scheme.levels {
            let error = l
                .error
                .r
                .filter(|e| e.estimate.is_finite())
                .map_or("-".into(), |e| format!("{:.2e}", e.estimate));
            let _ = writeln!(
                s,
                "| {} | {:.1e} | {:.0}% | {} | {:.1e} | {:.1e} | {} | {error} | {:.0} |",
                scheme.name,
                l.h,
                100.0 * l.finished_fraction,
                failures(l),
                l.max_position_residual,
                l.max_velocity_residual,
                crate::output::truncated_cell(l.truncated_fraction),
                l.seconds_per_path * 1e6,
            );
        }
    }
    s += &crate::output::left_out(&r.skipped);
    s
}

/// `stability.svg`: per scene, the share of paths that finish against h, one line per scheme.
pub fn plot(report: &StabilityReport, path: &Path) -> Result<(), StudyError> {
    let count = report.scenes.len().max(1);
    let cols = count.min(3);
    let rows = count.div_ceil(cols);
    let root =
        SVGBackend::new(path, (420 * cols as u32, 340 * rows as u32 + 40)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| StudyError::write(path, e);
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled("share of paths that finish", ("sans-serif", 20))
        .map_err(|e| err(&e))?;
    for (area, sc) in root.split_evenly((rows, cols)).iter().zip(&report.scenes) {
        let r = &sc.report;
        let xs = log_range(r.schemes.iter().flat_map(|s| s.levels.iter().map(|l| l.h)));
        let mut chart = ChartBuilder::on(area)
            .caption(&r.scene, ("sans-serif", 15))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(40)
            .build_cartesian_2d(xs.log_scale(), -0.05..1.05)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .light_line_style(RGBColor(245, 245, 245))
            .x_desc("h")
            .x_labels(5)
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| err(&e))?;
        for (k, scheme) in r.schemes.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            // Offset the lines slightly so that coinciding schemes stay visible.
            let offset = 0.012 * (k as f64 - 3.0);
            chart
                .draw_series(LineSeries::new(
                    scheme
                        .levels
                        .iter()
                        .map(|l| (l.h, l.finished_fraction + offset)),
                    colour.stroke_width(2),
                ))
                .map_err(|e| err(&e))?
                .label(scheme.name.as_str())
                .legend(move |(a, b)| {
                    PathElement::new(vec![(a, b), (a + 14, b)], colour.stroke_width(2))
                });
        }
        draw_legend(&mut chart, 10, SeriesLabelPosition::LowerLeft).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// Writes `report.json`, `report.md` and `stability.svg` into `dir`.
pub fn write_report(report: &StabilityReport, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), report)?;
    write_atomically(&dir.join("report.md"), &markdown(report))?;
    plot(report, &dir.join("stability.svg"))
}
