//! SVG plots of a study: strong error against step size (with the fitted slopes) and against
//! run time per path, for r, v and mu, on log-log axes.

use std::path::Path;

use plotters::prelude::*;

use crate::pendulum::{Errors, StudyReport};
use crate::stats::{Interval, OrderFit};

const COLOURS: [RGBColor; 3] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
];

/// One plotted component: its name, how to pick its error from a level, and its order fit.
type Component<'a> = (&'static str, fn(&Errors) -> Interval, &'a OrderFit);

/// r, v and mu.
fn components(report: &StudyReport) -> [Component<'_>; 3] {
    let o = &report.observed_order;
    [
        ("r", |e: &Errors| e.r, &o.r),
        ("v", |e: &Errors| e.v, &o.v),
        ("mu", |e: &Errors| e.mu, &o.mu),
    ]
}

/// Padded logarithmic range covering the positive values.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return 1e-3..1.0;
    }
    lo / 1.5..hi * 1.5
}

/// Draws error against `x(level)` for the three components; with `fits`, adds the fitted lines.
fn draw(
    report: &StudyReport,
    path: &Path,
    title: &str,
    x_label: &str,
    x: impl Fn(&crate::pendulum::LevelReport) -> f64,
    fits: bool,
) -> Result<(), String> {
    let root = SVGBackend::new(path, (720, 520)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("plot {}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let xs = log_range(report.levels.iter().map(&x));
    let ys = log_range(report.levels.iter().flat_map(|l| {
        let e = &l.error;
        [
            e.r.ci_low,
            e.r.ci_high,
            e.v.ci_low,
            e.v.ci_high,
            e.mu.ci_low,
            e.mu.ci_high,
        ]
    }));
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(245, 245, 245))
        .x_labels(8)
        .y_labels(8)
        .x_desc(x_label)
        .y_desc(format!(
            "L^{} norm of the sup error over the grid",
            report.settings.p
        ))
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    for (k, (name, pick, fit)) in components(report).into_iter().enumerate() {
        let colour = COLOURS[k];
        let points: Vec<(f64, f64)> = report
            .levels
            .iter()
            .map(|l| (x(l), pick(&l.error).estimate))
            .filter(|(a, b)| *a > 0.0 && *b > 0.0)
            .collect();
        let label = if fits {
            format!("{name}: order {:.2}", fit.order.estimate)
        } else {
            name.to_string()
        };
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(label)
            .legend(move |(a, b)| {
                PathElement::new(vec![(a, b), (a + 18, b)], colour.stroke_width(2))
            });
        chart
            .draw_series(report.levels.iter().map(|l| {
                let i = pick(&l.error);
                ErrorBar::new_vertical(
                    x(l),
                    i.ci_low.max(f64::MIN_POSITIVE),
                    i.estimate,
                    i.ci_high,
                    colour.filled(),
                    6,
                )
            }))
            .map_err(|e| err(&e))?;
        if fits && fit.fitted.len() >= 2 {
            // The fitted line c h^order through the fitted levels' geometric centre.
            let fitted: Vec<(f64, f64)> = fit
                .fitted
                .iter()
                .map(|&i| points_of(report, i, pick))
                .collect();
            let n = fitted.len() as f64;
            let (mx, my) = fitted.iter().fold((0.0, 0.0), |(a, b), (h, e)| {
                (a + h.ln() / n, b + e.ln() / n)
            });
            let line = fitted
                .iter()
                .map(|(h, _)| (*h, (my + fit.order.estimate * (h.ln() - mx)).exp()));
            chart
                .draw_series(LineSeries::new(line, colour.mix(0.5).stroke_width(1)))
                .map_err(|e| err(&e))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}

fn points_of(report: &StudyReport, level: usize, pick: fn(&Errors) -> Interval) -> (f64, f64) {
    let l = &report.levels[level];
    (l.h, pick(&l.error).estimate)
}

/// Writes `<stem>_error_vs_h.svg` and `<stem>_error_vs_time.svg` into `dir`.
pub fn write_plots(report: &StudyReport, dir: &Path, stem: &str) -> Result<(), String> {
    draw(
        report,
        &dir.join(format!("{stem}_error_vs_h.svg")),
        &format!("{}: strong error against step size", report.scene),
        "step size h",
        |l| l.h,
        true,
    )?;
    draw(
        report,
        &dir.join(format!("{stem}_error_vs_time.svg")),
        &format!("{}: strong error against run time", report.scene),
        "seconds per path",
        |l| l.seconds_per_path,
        false,
    )
}
