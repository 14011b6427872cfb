//! SVG plots of a convergence study: strong error against step size (with the fitted slopes)
//! and against run time per path, one panel per component (r, v, mu), one line per scheme, on
//! log-log axes with 95% error bars.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::convergence::{ConvergenceReport, Errors, LevelReport, Orders, SchemeReport};
use crate::error::StudyError;
use crate::stats::{Interval, OrderFit};

/// One colour per line (in report order).
pub const COLOURS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// A component: its name, how to pick its error from a level and its fit from the orders.
type Component = (
    &'static str,
    fn(&Errors) -> Option<Interval>,
    fn(&Orders) -> Option<&OrderFit>,
);

const COMPONENTS: [Component; 3] = [
    ("r", |e| e.r, |o| o.r.as_ref()),
    ("v", |e| e.v, |o| o.v.as_ref()),
    ("mu", |e| e.mu, |o| o.mu.as_ref()),
];

/// Padded logarithmic range covering the positive finite values.
pub fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
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

/// What the x axis shows.
#[derive(Clone, Copy)]
enum Axis {
    StepSize,
    RunTime,
}

impl Axis {
    fn of(self, l: &LevelReport) -> f64 {
        match self {
            Axis::StepSize => l.h,
            Axis::RunTime => l.seconds_per_path,
        }
    }
    fn label(self) -> &'static str {
        match self {
            Axis::StepSize => "step size h",
            Axis::RunTime => "seconds per path",
        }
    }
}

/// The finished points (x, error) of a scheme for a component.
fn points(
    s: &SchemeReport,
    pick: fn(&Errors) -> Option<Interval>,
    axis: Axis,
) -> Vec<(f64, Interval)> {
    s.levels
        .iter()
        .filter_map(|l| pick(&l.error).map(|e| (axis.of(l), e)))
        .filter(|(x, e)| *x > 0.0 && e.estimate.is_finite() && e.estimate > 0.0)
        .collect()
}

/// The fitted line c h^order over the fitted levels, through their geometric centre.
fn fitted_line(
    scheme: &SchemeReport,
    pick: fn(&Errors) -> Option<Interval>,
    fit: &OrderFit,
) -> Vec<(f64, f64)> {
    let points: Vec<(f64, f64)> = fit
        .fitted
        .iter()
        .filter_map(|&j| scheme.levels.get(j))
        .filter_map(|l| pick(&l.error).map(|e| (l.h, e.estimate)))
        .filter(|(h, e)| *h > 0.0 && *e > 0.0 && e.is_finite())
        .collect();
    if points.len() < 2 || !fit.order.estimate.is_finite() {
        return Vec::new();
    }
    let n = points.len() as f64;
    let (mx, my) = points.iter().fold((0.0, 0.0), |(a, b), (h, e)| {
        (a + h.ln() / n, b + e.ln() / n)
    });
    points
        .iter()
        .map(|(h, _)| (*h, (my + fit.order.estimate * (h.ln() - mx)).exp()))
        .collect()
}

fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    report: &ConvergenceReport,
    (name, pick, order): Component,
    axis: Axis,
) -> Result<(), StudyError> {
    let err = |e: &dyn std::fmt::Display| StudyError::write(name, e);
    let all: Vec<(f64, Interval)> = report
        .schemes
        .iter()
        .flat_map(|s| points(s, pick, axis))
        .collect();
    let xs = log_range(all.iter().map(|p| p.0));
    let ys = log_range(
        all.iter()
            .flat_map(|p| [p.1.ci_low, p.1.ci_high, p.1.estimate]),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(format!("error of {name}"), ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(245, 245, 245))
        .x_labels(6)
        .y_labels(8)
        .x_desc(axis.label())
        .y_desc(format!("L^{} norm of the sup error", report.p))
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    for (k, scheme) in report.schemes.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let pts = points(scheme, pick, axis);
        if pts.is_empty() {
            continue;
        }
        let fit = order(&scheme.observed_order);
        let label = match (axis, fit) {
            (Axis::StepSize, Some(f)) if f.order.estimate.is_finite() => {
                format!("{} ({:.2})", scheme.name, f.order.estimate)
            }
            _ => scheme.name.to_string(),
        };
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|(x, e)| (*x, e.estimate)),
                colour.stroke_width(2),
            ))
            .map_err(|e| err(&e))?
            .label(label)
            .legend(move |(a, b)| {
                PathElement::new(vec![(a, b), (a + 18, b)], colour.stroke_width(2))
            });
        chart
            .draw_series(pts.iter().map(|(x, i)| {
                ErrorBar::new_vertical(
                    *x,
                    i.ci_low.max(f64::MIN_POSITIVE),
                    i.estimate,
                    i.ci_high,
                    colour.filled(),
                    5,
                )
            }))
            .map_err(|e| err(&e))?;
        if let (Axis::StepSize, Some(fit)) = (axis, fit) {
            chart
                .draw_series(LineSeries::new(
                    fitted_line(scheme, pick, fit),
                    colour.mix(0.45).stroke_width(1),
                ))
                .map_err(|e| err(&e))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 11))
        .position(match axis {
            Axis::StepSize => SeriesLabelPosition::LowerRight,
            Axis::RunTime => SeriesLabelPosition::UpperRight,
        })
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}

fn draw(
    report: &ConvergenceReport,
    path: &Path,
    title: &str,
    axis: Axis,
) -> Result<(), StudyError> {
    let components: Vec<Component> = COMPONENTS
        .into_iter()
        .filter(|(_, pick, _)| {
            report
                .schemes
                .iter()
                .any(|s| s.levels.iter().any(|l| pick(&l.error).is_some()))
        })
        .collect();
    let width = 480 * components.len().max(1) as u32;
    let root = SVGBackend::new(path, (width, 480)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| StudyError::write(path, e);
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(title, ("sans-serif", 20))
        .map_err(|e| err(&e))?;
    let panels = root.split_evenly((1, components.len().max(1)));
    for (area, component) in panels.iter().zip(components) {
        panel(area, report, component, axis)?;
    }
    root.present().map_err(|e| err(&e))
}

/// Writes `error_vs_h.svg` and `error_vs_time.svg` into `dir`.
pub fn write_plots(report: &ConvergenceReport, dir: &Path) -> Result<(), StudyError> {
    let stem = &report.scene;
    draw(
        report,
        &dir.join("error_vs_h.svg"),
        &format!("{stem}: strong error against step size (fitted order)"),
        Axis::StepSize,
    )?;
    draw(
        report,
        &dir.join("error_vs_time.svg"),
        &format!("{stem}: strong error against run time"),
        Axis::RunTime,
    )
}
