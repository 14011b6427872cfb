//! The bias sections of the equipartition report: Markdown tables and `bias.svg` (|bias|
//! against run time per scheme, one panel per scene and time average).

use std::fmt::Write as _;
use std::path::Path;

use super::bias::{BiasStudy, ReferenceKind};
use super::interval_cell;
use crate::error::StudyError;
use crate::plots::figure::{Axis as FigureAxis, Figure, Panel, Point, Series, render};
use sdae_stats::Interval;

/// An interval as "estimate [low, high]" in scientific notation, or "-".
fn cell(x: Option<Interval>) -> String {
    x.map_or("-".into(), |i| {
        format!(
            "{:+.2e} [{:+.2e}, {:+.2e}]",
            i.estimate, i.ci_low, i.ci_high
        )
    })
}

/// The Markdown section of one bias study.
pub fn markdown(study: &BiasStudy) -> String {
    let source = match study.reference_kind {
        ReferenceKind::ClosedForm => "closed form",
        ReferenceKind::FinestGBaoab => "g-baoab at its smallest step (no closed form known)",
    };
    let mut s = format!(
        "\n### Invariant-measure bias of {}\n\nReference {:.6} ({source}). Order: slope of \
         log |D(h)| against log h, D(h) = E[X_h - X_(h/2)] on the same Brownian paths, over \
         the differences whose 95% interval excludes 0, with a 95% paired-bootstrap interval. \
         Time: mean seconds per path of the cheapest step size whose bias interval lies within \
         the target (below resolution: no interval is narrow enough to tell; more paths are \
         needed).\n\n| scheme | order [95% CI] | fitted on h | s/path to 1e-2 | s/path to 1e-3 |\n|---|---|---|---|---|\n",
        study.quantity, study.reference
    );
    for scheme in &study.schemes {
        let order = scheme.order.map_or("not resolved".into(), |o| {
            format!("{:.2} [{:.2}, {:.2}]", o.estimate, o.ci_low, o.ci_high)
        });
        let fitted: Vec<String> = scheme.fitted.iter().map(|h| format!("{h:.2e}")).collect();
        let time = |k: usize| {
            scheme
                .time_to
                .get(k)
                .map_or("-".into(), |t| match (t.h, t.seconds) {
                    (Some(h), Some(sec)) => format!("{sec:.2e} (h = {h:.1e})"),
                    _ if t.resolved => "not reached".into(),
                    _ => "below resolution".into(),
                })
        };
        let _ = writeln!(
            s,
            "| {} | {order} | {} | {} | {} |",
            scheme.scheme,
            fitted.join(", "),
            time(0),
            time(1)
        );
    }
    s += "\n| scheme | h | value [95% CI] | bias [95% CI] | D(h) [95% CI] | s/path | paths |\n|---|---|---|---|---|---|---|\n";
    for scheme in &study.schemes {
        for l in &scheme.levels {
            let value = interval_cell(l.value, 5);
            let _ = writeln!(
                s,
                "| {} | {:.2e} | {value} | {} | {} | {:.2e} | {} |",
                scheme.scheme,
                l.h,
                cell(l.bias),
                cell(l.difference),
                l.seconds,
                l.paths
            );
        }
    }
    s
}

/// `bias.svg`: one panel per bias study (a scene's time average, with the scene's name),
/// |bias| against seconds per path, one line per scheme (levels with a bias estimate of 0 are
/// left out of the log scale).
pub fn plot<'a>(
    studies: impl Iterator<Item = (&'a str, &'a BiasStudy)>, path: &Path,
) -> Result<(), StudyError> {
    let panels = studies.map(|(scene, b)| panel(scene, b)).collect();
    let mut figure = Figure::row("invariant-measure bias against run time", panels);
    figure.panel_size = (500, 440);
    render(&figure, path).map(|_| ())
}

/// One panel: |bias| against s/path for every scheme.
fn panel(scene: &str, study: &BiasStudy) -> Panel {
    let series = study
        .schemes
        .iter()
        .map(|scheme| {
            let points = scheme
                .levels
                .iter()
                .filter_map(|l| Some(Point::at(l.seconds, l.bias?.estimate.abs())));
            Series::new(scheme.scheme.clone(), points.collect())
        })
        .collect();
    Panel {
        title: format!("{scene}: {}", study.quantity),
        x: FigureAxis::log("seconds per path"),
        y: FigureAxis::log("|bias|"),
        series,
        guides: Vec::new(),
    }
}
