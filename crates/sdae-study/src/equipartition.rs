//! The equipartition study: on Langevin scenes at equilibrium, E[v^T M v / 2] must equal
//! (n - m) kT / 2 on the constraint manifold. Measured (time average after a burn-in, mean over
//! independent paths with a 95% interval) for every scheme and step size, and for the
//! half-explicit scheme over a range of C_eta, so that a user can read off which settings give
//! the right temperature and where truncation biases it (design notes, Section 6).

mod bias;
mod bias_report;

use std::fmt::Write as _;
use std::ops::Range;
use std::path::Path;

use serde::Serialize;

use sdae_reference::CurvedSystem;

pub use bias::{
    BIAS_TARGETS, BiasLevel, BiasScheme, BiasStudy, ReferenceKind, TimeToBias, bias_study,
};

use crate::convergence::{
    ConvergenceReport, ConvergenceRun, ConvergenceSettings, build_report, run_convergence_on,
};
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use crate::integrator::{SchemeKind, StudyScheme};
use crate::parallel::Control;
use crate::plots::figure::{Axis as FigureAxis, Figure, Panel, Point, Series, render};
use crate::scene::{Prepared, Scene};
use sdae_stats::Interval;

/// One configuration of the comparison: a scheme, and C_eta for the half-explicit runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// Label in the report.
    pub label: String,
    /// The scene to run (its practical C_eta set for this variant).
    pub scene: Scene,
    /// Its settings.
    pub settings: ConvergenceSettings,
}

/// The variants of a scene's equipartition study (`None` without an `[equipartition]` table):
/// every scheme but the practical and rescaled half-explicit ones at the scene's C_eta, then
/// those two at each C_eta of the table. `quick` keeps at most 40 paths and the two
/// finest levels.
pub fn variants(scene: &Scene, quick: bool) -> Option<Vec<Variant>> {
    let spec = scene.equipartition.as_ref()?;
    let [mut coarsest, finest] = spec.levels;
    let mut paths = spec.paths;
    if quick {
        paths = paths.min(40);
        coarsest = coarsest.max(finest.saturating_sub(1));
    }
    let base = ConvergenceSettings {
        paths,
        coarsest,
        finest,
        reference: None,
        t_end: spec.t_end,
        kinetic_after: Some(spec.burn_in),
        time_averaged: spec.configurational.clone(),
        ..ConvergenceSettings::for_scene(scene)
    };
    let per_c_eta = [
        SchemeKind::HalfExplicitPractical,
        SchemeKind::HalfExplicitRescaled,
    ];
    let others: Vec<SchemeKind> = SchemeKind::ALL
        .into_iter()
        .filter(|k| !per_c_eta.contains(k))
        .collect();
    let mut variants = vec![Variant {
        label: "all schemes".into(),
        scene: scene.clone(),
        settings: ConvergenceSettings {
            schemes: others,
            ..base.clone()
        },
    }];
    for &c in &spec.c_eta {
        let mut scene = scene.clone();
        scene.scheme.practical_c_eta = c;
        variants.push(Variant {
            label: format!("half-explicit C_eta = {c}"),
            scene,
            settings: ConvergenceSettings {
                schemes: per_c_eta.to_vec(),
                ..base.clone()
            },
        });
    }
    Some(variants)
}

/// The equipartition study of one scene: its `variants` (from [`variants`], perhaps with the
/// settings adjusted) with the scene's system as `prepared` (from a scene file through a
/// [`SceneRunner`](crate::scene::SceneRunner), or built in code with
/// [`Scene::prepare_custom`]; it must have a kinetic target), the user's `extra` schemes run
/// with the first variant; `progress` is called with the variant's label and the number of
/// finished paths. `None` when the system has no equipartition value.
pub fn run_equipartition_on<S>(
    prepared: &Prepared<S>, variants: &[Variant], extra: &[StudyScheme<S>],
    progress: &(dyn Fn(&str, usize) + Sync),
) -> Result<Option<EquipartitionScene>, StudyError>
where
    S: CurvedSystem + Clone + Send + Sync + 'static,
{
    let mut runs = Vec::new();
    for (i, variant) in variants.iter().enumerate() {
        let mut prepared = prepared.clone();
        prepared.constants.practical_c_eta = variant.scene.scheme.practical_c_eta;
        let extra = if i == 0 { extra } else { &[] };
        let run = run_convergence_on(
            &variant.scene,
            &prepared,
            extra,
            &variant.settings,
            (0, 1),
            Control {
                progress: Some(&|done| progress(&variant.label, done)),
                ..Control::default()
            },
        )?;
        runs.push(run);
    }
    Ok(collect(&runs))
}

/// One row: a scheme (with its C_eta where it has one) at one step size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EquipartitionRow {
    /// The scheme, with C_eta for the half-explicit family.
    pub scheme: String,
    /// Step size.
    pub h: f64,
    /// Mean kinetic energy with its 95% interval (over the paths that finished).
    pub kinetic_energy: Option<Interval>,
    /// Its ratio to the equipartition value (the temperature ratio T_measured / T).
    pub temperature_ratio: Option<Interval>,
    /// Whether the interval of the ratio excludes 1 (`None` with fewer than 2 finished paths).
    pub biased: Option<bool>,
    /// Share of truncated steps.
    pub truncated_fraction: f64,
    /// Mean over the paths of the clock lag sum_k (1 - eta_k) h. A time-changed scheme
    /// (`half-explicit-rescaled`) has covered only T minus this lag of its own time, and its
    /// kinetic energy is averaged over that clock (weights eta_k h, burn-in on sum_k eta_k h).
    pub clock_lag: f64,
    /// Paths that failed.
    pub failures: usize,
    /// Paths counted.
    pub paths: usize,
}

/// The equipartition study of one scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EquipartitionScene {
    /// The scene.
    pub scene: String,
    /// The equipartition value (n - m) kT / 2.
    pub target: f64,
    /// The time after which the kinetic energy is averaged.
    pub burn_in: f64,
    /// T.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// One row per scheme and step size.
    pub rows: Vec<EquipartitionRow>,
    /// The bias of the scene's configurational average (`[equipartition] configurational`)
    /// per scheme, step size and run time, with the fitted order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub configurational: Option<BiasStudy>,
    /// The bias of the kinetic energy against (n - m) kT / 2, likewise.
    pub kinetic: Option<BiasStudy>,
}

impl EquipartitionScene {
    /// Paths that failed and paths counted, summed over the rows.
    pub fn failed_paths(&self) -> (usize, usize) {
        self.rows
            .iter()
            .fold((0, 0), |(f, p), r| (f + r.failures, p + r.paths))
    }

    /// The rows that lost every path (nothing to compare with the set temperature), one line
    /// each: the scheme, h and the failures.
    pub fn lost(&self) -> Vec<String> {
        self.rows
            .iter()
            .filter(|r| r.failures >= r.paths)
            .map(|r| {
                format!(
                    "scene {}: {} at h = {:e} lost all {} paths ({} failed)",
                    self.scene, r.scheme, r.h, r.paths, r.failures
                )
            })
            .collect()
    }
}

/// A scheme of a run, labelled with its C_eta where the variants differ in it.
fn label(scene: &Scene, name: &str) -> String {
    let c = &scene.scheme;
    match SchemeKind::from_name(name) {
        Some(SchemeKind::HalfExplicitPractical) => {
            format!("half-explicit C_eta = {}", c.practical_c_eta)
        }
        Some(SchemeKind::HalfExplicitRescaled) => {
            format!("half-explicit-rescaled C_eta = {}", c.practical_c_eta)
        }
        _ => name.to_string(),
    }
}

/// Collects the rows and the biases of the variants' runs of one scene (`None` without a
/// kinetic target: not a Langevin system).
pub fn collect(runs: &[ConvergenceRun]) -> Option<EquipartitionScene> {
    let reports: Vec<ConvergenceReport> = runs.iter().cloned().map(build_report).collect();
    let first = reports.first()?;
    let target = first.kinetic_target?;
    let spec = first.scene_definition.equipartition.as_ref()?;
    let mut rows = Vec::new();
    for report in &reports {
        for scheme in &report.schemes {
            for l in &scheme.levels {
                let ratio = l.kinetic_energy.map(|k| Interval {
                    estimate: k.estimate / target,
                    ci_low: k.ci_low / target,
                    ci_high: k.ci_high / target,
                });
                rows.push(EquipartitionRow {
                    scheme: label(&report.scene_definition, &scheme.name),
                    h: l.h,
                    kinetic_energy: l.kinetic_energy,
                    temperature_ratio: ratio,
                    biased: ratio
                        .filter(|r| r.ci_low.is_finite() && r.ci_high.is_finite())
                        .map(|r| !(r.ci_low <= 1.0 && 1.0 <= r.ci_high)),
                    truncated_fraction: l.truncated_fraction,
                    clock_lag: l.clock_lag,
                    failures: l.failures,
                    paths: l.paths,
                });
            }
        }
    }
    let by_label = |run: &ConvergenceRun, name: &str| label(&run.scene, name);
    let configurational = spec.configurational.as_deref().and_then(|name| {
        let exact = first.scene_definition.system.exact_average(name);
        bias_study(runs, name, |t| t.time_average, exact, by_label)
    });
    let kinetic = bias_study(
        runs,
        "kinetic_energy",
        |t| t.kinetic_energy,
        Some(target),
        by_label,
    );
    Some(EquipartitionScene {
        scene: first.scene.clone(),
        target,
        burn_in: spec.burn_in,
        t_end: spec.t_end,
        rows,
        configurational,
        kinetic,
    })
}

/// An interval as "estimate [low, high]" to `digits` decimals, or "-".
fn interval_cell(x: Option<Interval>, digits: usize) -> String {
    x.map_or("-".into(), |i| {
        let (e, low, high) = (i.estimate, i.ci_low, i.ci_high);
        format!("{e:.digits$} [{low:.digits$}, {high:.digits$}]")
    })
}

/// The Markdown summary.
pub fn markdown(scenes: &[EquipartitionScene]) -> String {
    let mut s = String::from(
        "# Equipartition study\n\nAt equilibrium, E[v^T M v / 2] = (n - m) kT / 2 on the constraint manifold. \
         Each row: the kinetic energy averaged over t >= burn-in and over independent paths, with a 95% interval, \
         and its ratio to the equipartition value (the measured temperature over the set one). \
         \"biased\" marks rows whose interval excludes 1 (n/a: fewer than 2 paths finished). \
         A time-changed scheme (half-explicit-rescaled: a truncated step of size h is in law an untruncated step of size eta h) \
         is averaged over its own clock sum_k eta_k h, with weights eta_k h and the burn-in on that clock; \
         \"clock lag\" is T minus that clock (mean over paths), and a row without an estimate has not reached the burn-in on it.\n",
    );
    for sc in scenes {
        let _ = write!(
            s,
            "\n## {}\n\nTarget (n - m) kT / 2 = {:.4}, T = {}, averaged over t >= {}.\n\n| scheme | h | kinetic energy [95% CI] | T ratio [95% CI] | biased | truncated | clock lag | failures |\n|---|---|---|---|---|---|---|---|\n",
            sc.scene, sc.target, sc.t_end, sc.burn_in
        );
        for r in &sc.rows {
            let k = interval_cell(r.kinetic_energy, 4);
            let t = interval_cell(r.temperature_ratio, 3);
            let _ = writeln!(
                s,
                "| {} | {:.1e} | {k} | {t} | {} | {} | {:.3} | {}/{} |",
                r.scheme,
                r.h,
                match r.biased {
                    Some(true) => "yes",
                    Some(false) => "no",
                    None => "n/a",
                },
                crate::output::truncated_cell(r.truncated_fraction),
                r.clock_lag,
                r.failures,
                r.paths
            );
        }
    }
    s += "\n![temperature ratio against h](equipartition.svg)\n";
    for sc in scenes {
        if sc.configurational.is_some() || sc.kinetic.is_some() {
            let _ = write!(s, "\n## {}: invariant-measure bias\n", sc.scene);
        }
        for study in sc.configurational.iter().chain(&sc.kinetic) {
            s += &bias_report::markdown(study);
        }
    }
    s += "\n![bias against run time](bias.svg)\n";
    s
}

/// `equipartition.svg`: per scene, the temperature ratio against h, one line per scheme and
/// C_eta, with 95% error bars and the line ratio = 1.
pub fn plot(scenes: &[EquipartitionScene], path: &Path) -> Result<(), StudyError> {
    let panels: Vec<Panel> = scenes.iter().map(scene_panel).collect();
    let mut figure = Figure::row("measured over set temperature", panels);
    figure.panel_size = (520, 460);
    render(&figure, path).map(|_| ())
}

/// The y range of a scene's panel: every finite interval bound and 0.9..1.1, padded, on a log
/// scale (so above 0), its top capped at 1e3 (ratios run from well below 1 to thousands).
fn ratio_range(sc: &EquipartitionScene) -> Range<f64> {
    let ys: Vec<f64> = sc
        .rows
        .iter()
        .filter_map(|r| r.temperature_ratio)
        .flat_map(|i| [i.ci_low, i.ci_high])
        .filter(|x| x.is_finite())
        .chain([0.9, 1.1])
        .collect();
    let lo = ys
        .iter()
        .copied()
        .filter(|y| *y > 0.0)
        .fold(f64::INFINITY, f64::min)
        / 1.2;
    let hi = ys.iter().copied().fold(0.0, f64::max).min(1e3) * 1.2;
    lo..hi
}

/// A scene's panel: the line ratio = 1, one line per variant with its 95% error bars where its
/// interval is finite and positive (two or more paths finished), kept within the y range.
fn scene_panel(sc: &EquipartitionScene) -> Panel {
    let mut labels: Vec<&str> = sc.rows.iter().map(|r| r.scheme.as_str()).collect();
    labels.dedup();
    let (h0, h1) = sc.rows.iter().fold((f64::INFINITY, 0.0_f64), |(a, b), r| {
        (a.min(r.h), b.max(r.h))
    });
    let series = labels
        .iter()
        .map(|name| {
            let points = sc
                .rows
                .iter()
                .filter(|r| r.scheme == *name)
                .filter_map(|r| r.temperature_ratio.map(|t| (r.h, t)))
                .filter(|(_, t)| t.estimate.is_finite() && t.estimate > 0.0)
                .map(|(h, t)| Point {
                    y_bar: (t.ci_low.is_finite() && t.ci_high.is_finite() && t.ci_low > 0.0)
                        .then_some((t.ci_low, t.ci_high)),
                    ..Point::at(h, t.estimate)
                })
                .collect();
            Series::new(*name, points)
        })
        .collect();
    Panel {
        title: sc.scene.clone(),
        x: FigureAxis::log("h"),
        y: FigureAxis::log("T measured / T").within(ratio_range(sc)),
        series,
        guides: vec![vec![(h0 / 1.5, 1.0), (h1 * 1.5, 1.0)]],
    }
}

/// Writes `report.json`, `report.md`, `equipartition.svg` and `bias.svg` into `dir`.
pub fn write_report(scenes: &[EquipartitionScene], dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), scenes)?;
    write_atomically(&dir.join("report.md"), &markdown(scenes))?;
    plot(scenes, &dir.join("equipartition.svg"))?;
    let studies = scenes.iter().flat_map(|sc| {
        sc.configurational
            .iter()
            .chain(&sc.kinetic)
            .map(|b| (sc.scene.as_str(), b))
    });
    bias_report::plot(studies, &dir.join("bias.svg"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interval_cell_has_the_decimals_asked_for_and_a_missing_one_is_a_dash() {
        let i = Interval {
            estimate: 1.23456,
            ci_low: -0.5,
            ci_high: 2.0,
        };
        assert_eq!(interval_cell(Some(i), 3), "1.235 [-0.500, 2.000]");
        assert_eq!(interval_cell(Some(i), 5), "1.23456 [-0.50000, 2.00000]");
        assert_eq!(interval_cell(None, 4), "-");
    }
}
