//! SVG plots of a convergence study: strong error against step size (with the fitted slopes)
//! and against run time per path (the median of repeated timings, with their range), one panel
//! per component (r, v, mu), one line per scheme, on log-log axes with 95% error bars; and the
//! one style of every study's plots ([`style`], drawn by [`figure::render`]).

pub mod figure;
pub mod style;

pub use figure::{MAX_DRAWN, MIN_DRAWN, drawable};

use std::io::Write as _;
use std::path::Path;

use crate::convergence::{ConvergenceReport, Errors, LevelReport, Orders, SchemeReport};
use crate::error::StudyError;
use figure::{Axis as FigureAxis, Figure, Panel, Point, Series};
use sdae_stats::Interval;
use sdae_stats::OrderFit;

/// A component: its name, how to pick its error from a level and its fit from the orders.
#[derive(Clone, Copy)]
struct Component {
    name: &'static str,
    pick: fn(&Errors) -> Option<Interval>,
    fit: fn(&Orders) -> Option<&OrderFit>,
}

const COMPONENTS: [Component; 3] = [
    Component {
        name: "r",
        pick: |e| e.r,
        fit: |o| o.r.as_ref(),
    },
    Component {
        name: "v",
        pick: |e| e.v,
        fit: |o| o.v.as_ref(),
    },
    Component {
        name: "mu",
        pick: |e| e.mu,
        fit: |o| o.mu.as_ref(),
    },
];

/// Padded logarithmic range covering the values that can be drawn ([`drawable`]): always
/// finite, positive and within a factor 1.5 of [`MIN_DRAWN`]..[`MAX_DRAWN`].
pub fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|&v| drawable(v))
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
    /// A level's point on this axis: its step size, or the median of its repeated timings
    /// with their range (the mean where no spread was recorded).
    fn of(self, l: &LevelReport) -> (f64, Option<(f64, f64)>) {
        match self {
            Axis::StepSize => (l.h, None),
            Axis::RunTime if l.seconds.max > 0.0 => {
                (l.seconds.median, Some((l.seconds.min, l.seconds.max)))
            }
            Axis::RunTime => (l.seconds_per_path, None),
        }
    }
    fn label(self) -> &'static str {
        match self {
            Axis::StepSize => "step size h",
            Axis::RunTime => "seconds per path (median, range of the blocks' timings)",
        }
    }
}

/// Every point of a scheme for a component with an error: x with its bar (the range of the
/// timings), the error with its 95% interval.
fn all_points(s: &SchemeReport, pick: fn(&Errors) -> Option<Interval>, axis: Axis) -> Vec<Point> {
    s.levels
        .iter()
        .filter_map(|l| {
            let (x, x_bar) = axis.of(l);
            pick(&l.error).map(|e| Point {
                x,
                y: e.estimate,
                x_bar,
                y_bar: Some((e.ci_low, e.ci_high)),
            })
        })
        .collect()
}

/// The fitted line c h^order over the fitted levels, through their geometric centre.
fn fitted_line(
    scheme: &SchemeReport, pick: fn(&Errors) -> Option<Interval>, fit: &OrderFit,
) -> Vec<(f64, f64)> {
    let points: Vec<(f64, f64)> = fit
        .fitted
        .iter()
        .filter_map(|&j| scheme.levels.get(j))
        .filter_map(|l| pick(&l.error).map(|e| (l.h, e.estimate)))
        .filter(|(h, e)| drawable(*h) && drawable(*e))
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
        .filter(|(_, e)| drawable(*e))
        .collect()
}

/// A scheme's line for `component` against `axis`: its errors with their 95% intervals,
/// against h its fitted slope, against run time the range of the timings.
fn scheme_series(scheme: &SchemeReport, component: Component, axis: Axis) -> Series {
    let points = all_points(scheme, component.pick, axis);
    let guide = match (axis, (component.fit)(&scheme.observed_order)) {
        (Axis::StepSize, Some(fit)) => fitted_line(scheme, component.pick, fit),
        _ => Vec::new(),
    };
    Series {
        guide,
        ..Series::new(scheme.name.clone(), points)
    }
}

/// The fitted orders of a scheme, "order r 1.01, v 1.32, mu 1.09", for the legend.
fn orders_text(scheme: &SchemeReport, components: &[Component]) -> Option<String> {
    let orders: Vec<String> = components
        .iter()
        .filter_map(|c| {
            let fit = (c.fit)(&scheme.observed_order)?;
            fit.order
                .estimate
                .is_finite()
                .then(|| format!("{} {:.2}", c.name, fit.order.estimate))
        })
        .collect();
    (!orders.is_empty()).then(|| format!("order {}", orders.join(", ")))
}

/// The figure of `report` against `axis`: one panel per component with an error.
fn figure(report: &ConvergenceReport, title: &str, axis: Axis) -> Figure {
    let components: Vec<Component> = COMPONENTS
        .into_iter()
        .filter(|c| {
            report
                .schemes
                .iter()
                .any(|s| s.levels.iter().any(|l| (c.pick)(&l.error).is_some()))
        })
        .collect();
    let panels = components
        .iter()
        .map(|&c| Panel {
            title: format!("error of {}", c.name),
            x: FigureAxis::log(axis.label()),
            y: FigureAxis::log(format!("L^{} norm of the sup error", report.p)),
            series: report
                .schemes
                .iter()
                .map(|s| scheme_series(s, c, axis))
                .collect(),
            guides: Vec::new(),
        })
        .collect();
    let mut figure = Figure::row(title, panels);
    if let Axis::StepSize = axis {
        figure.details = report
            .schemes
            .iter()
            .filter_map(|s| Some((s.name.clone(), orders_text(s, &components)?)))
            .collect();
    }
    figure
}

fn draw(
    report: &ConvergenceReport, path: &Path, title: &str, axis: Axis,
) -> Result<(), StudyError> {
    let left_out = figure::render(&figure(report, title, axis), path)?;
    if left_out > 0 {
        // A closed standard error ends the note, not the plot.
        let _ = writeln!(
            &mut std::io::stderr(),
            "note: {}: {left_out} error(s) left out of the plot: zero, not finite, or beyond \
             {MIN_DRAWN:e}..{MAX_DRAWN:e} (the report has them)",
            path.display()
        );
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ranges_are_finite_and_bounded_whatever_the_values() {
        let range = log_range([1e308, 1e-310, 0.0, f64::INFINITY, f64::NAN, 1.0].into_iter());
        assert_eq!(range, 1.0 / 1.5..1.5);
        let range = log_range([1e300, 1e-300].into_iter());
        assert!(range.start > 0.0 && range.end.is_finite(), "{range:?}");
        assert_eq!(log_range([f64::MAX, 5e-324].into_iter()), 1e-3..1.0);
        assert!(!drawable(1e-310) && !drawable(1e308) && !drawable(0.0));
        assert!(drawable(1e-300) && drawable(1e300));
    }
}
