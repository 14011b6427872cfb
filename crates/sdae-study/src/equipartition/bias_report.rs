//! The bias sections of the equipartition report: Markdown tables and `bias.svg` (|bias|
//! against run time per scheme, one panel per scene and time average).

use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::EquipartitionScene;
use super::bias::{BiasStudy, ReferenceKind};
use crate::error::StudyError;
use crate::plots::{COLOURS, DrawResult, draw_legend, log_range};
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
            let value = l.value.map_or("-".into(), |v| {
                format!("{:.5} [{:.5}, {:.5}]", v.estimate, v.ci_low, v.ci_high)
            });
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

/// `bias.svg`: per scene and time average, |bias| against seconds per path, one line per
/// scheme (levels with a bias estimate of 0 are left out of the log scale).
pub fn plot(scenes: &[EquipartitionScene], path: &Path) -> Result<(), StudyError> {
    let panels: Vec<(&str, &BiasStudy)> = scenes
        .iter()
        .flat_map(|sc| {
            sc.configurational
                .iter()
                .chain(&sc.kinetic)
                .map(move |b| (sc.scene.as_str(), b))
        })
        .collect();
    let count = panels.len().max(1);
    let root = SVGBackend::new(path, (520 * count as u32, 440)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| StudyError::write(path, e);
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "invariant-measure bias against run time",
            ("sans-serif", 20),
        )
        .map_err(|e| err(&e))?;
    for (area, (scene, study)) in root.split_evenly((1, count)).iter().zip(&panels) {
        panel(area, scene, study).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// One panel: |bias| against s/path for every scheme.
fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>, scene: &str, study: &BiasStudy,
) -> DrawResult<()> {
    let points = |k: usize| -> Vec<(f64, f64)> {
        study.schemes[k]
            .levels
            .iter()
            .filter_map(|l| Some((l.seconds, l.bias?.estimate.abs())))
            .filter(|(t, b)| *t > 0.0 && *b > 0.0 && b.is_finite())
            .collect()
    };
    let all: Vec<(f64, f64)> = (0..study.schemes.len()).flat_map(points).collect();
    let xs = log_range(all.iter().map(|p| p.0));
    let ys = log_range(all.iter().map(|p| p.1));
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{scene}: {}", study.quantity), ("sans-serif", 15))
        .margin(10)
        .x_label_area_size(32)
        .y_label_area_size(52)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(245, 245, 245))
        .x_desc("seconds per path")
        .y_desc("|bias|")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    for (k, scheme) in study.schemes.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(points(k), colour.stroke_width(2)))?
            .label(scheme.scheme.as_str())
            .legend(move |(a, b)| {
                PathElement::new(vec![(a, b), (a + 14, b)], colour.stroke_width(2))
            });
        chart.draw_series(
            points(k)
                .into_iter()
                .map(|p| Circle::new(p, 3, colour.filled())),
        )?;
    }
    draw_legend(&mut chart, 9, SeriesLabelPosition::LowerLeft)
}
