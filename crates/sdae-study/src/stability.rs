//! The stability study: every scheme on stiff and extreme scenes over a range of step sizes,
//! counting the paths that finish and the failures by kind, with the largest constraint
//! residuals, the share of truncated steps, the error against a reference where one exists,
//! and the run time.

use std::fmt::Write as _;
use std::path::Path;

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
use crate::plots::figure::{Axis as FigureAxis, Figure, Panel, Point, Series, render};
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

/// `stability.svg`: per scene, the share of paths that finish against h, one line per scheme
/// (each scheme's line nudged by its place in the figure, so that coinciding lines stay apart).
pub fn plot(report: &StabilityReport, path: &Path) -> Result<(), StudyError> {
    let mut names: Vec<&str> = Vec::new();
    for s in report.scenes.iter().flat_map(|sc| &sc.report.schemes) {
        if !names.contains(&s.name.as_str()) {
            names.push(&s.name);
        }
    }
    let nudge = |name: &str| {
        let k = names.iter().position(|n| *n == name).unwrap_or(0);
        0.008 * (k as f64 - 0.5 * (names.len() as f64 - 1.0))
    };
    let panels = report
        .scenes
        .iter()
        .map(|sc| Panel {
            title: sc.report.scene.clone(),
            x: FigureAxis::log("h"),
            y: FigureAxis::linear("share of paths that finish").within(-0.1..1.1),
            series: sc
                .report
                .schemes
                .iter()
                .map(|s| {
                    let points = s.levels.iter();
                    let points =
                        points.map(|l| Point::at(l.h, l.finished_fraction + nudge(&s.name)));
                    Series::new(s.name.clone(), points.collect())
                })
                .collect(),
            guides: Vec::new(),
        })
        .collect::<Vec<_>>();
    let mut figure = Figure::row("share of paths that finish", panels);
    figure.columns = figure.panels.len().clamp(1, 3);
    figure.panel_size = (420, 340);
    render(&figure, path).map(|_| ())
}

/// Writes `report.json`, `report.md` and `stability.svg` into `dir`.
pub fn write_report(report: &StabilityReport, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), report)?;
    write_atomically(&dir.join("report.md"), &markdown(report))?;
    plot(report, &dir.join("stability.svg"))
}
