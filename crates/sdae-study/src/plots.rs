//! SVG plots of a convergence study: strong error against step size (with the fitted slopes)
//! and against run time per path, one panel per component (r, v, mu), one line per scheme, on
//! log-log axes with 95% error bars.

use std::io::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::convergence::{ConvergenceReport, Errors, LevelReport, Orders, SchemeReport};
use crate::error::StudyError;
use sdae_stats::Interval;
use sdae_stats::OrderFit;

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

/// What drawing into an SVG chart gives back.
pub type DrawResult<T> = Result<T, DrawingAreaErrorKind<std::io::Error>>;

/// A chart with logarithmic x and y axes drawn into an SVG file.
pub type LogChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// Draws the legend of `chart` at `position`: its labels in `font_size` on a light, framed box.
pub fn draw_legend<'a, 'b: 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, CT>, font_size: u32, position: SeriesLabelPosition,
) -> DrawResult<()> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", font_size))
        .position(position)
        .draw()
}

/// The smallest value a logarithmic axis draws. Smaller ones (subnormal, or within a few
/// hundred decades of it) are left out of the plots with a note: an axis must stay a finite,
/// bounded range for the plotting library to place its ticks.
pub const MIN_DRAWN: f64 = 1e-300;

/// The largest value a logarithmic axis draws (see [`MIN_DRAWN`]).
pub const MAX_DRAWN: f64 = 1e300;

/// Whether a logarithmic axis can draw `v`: finite and within [`MIN_DRAWN`]..=[`MAX_DRAWN`].
pub fn drawable(v: f64) -> bool {
    (MIN_DRAWN..=MAX_DRAWN).contains(&v)
}

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

/// Every point (x, error) of a scheme for a component with an error.
fn all_points(
    s: &SchemeReport, pick: fn(&Errors) -> Option<Interval>, axis: Axis,
) -> Vec<(f64, Interval)> {
    s.levels
        .iter()
        .filter_map(|l| pick(&l.error).map(|e| (axis.of(l), e)))
        .collect()
}

/// The points (x, error) of a scheme for a component that can be drawn ([`drawable`]).
fn points(
    s: &SchemeReport, pick: fn(&Errors) -> Option<Interval>, axis: Axis,
) -> Vec<(f64, Interval)> {
    all_points(s, pick, axis)
        .into_iter()
        .filter(|(x, e)| drawable(*x) && drawable(e.estimate))
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

/// One panel: the error of `component` against `axis`, one line per scheme with its error bars
/// (and its fitted slope against h), and the legend.
fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>, report: &ConvergenceReport, component: Component,
    axis: Axis,
) -> Result<(), StudyError> {
    let err = |e: &dyn std::fmt::Display| StudyError::write(component.name, e);
    let mut chart = panel_chart(area, report, component, axis).map_err(|e| err(&e))?;
    for (k, scheme) in report.schemes.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        draw_scheme(&mut chart, scheme, component, axis, colour).map_err(|e| err(&e))?;
    }
    let position = match axis {
        Axis::StepSize => SeriesLabelPosition::LowerRight,
        Axis::RunTime => SeriesLabelPosition::UpperRight,
    };
    draw_legend(&mut chart, 11, position).map_err(|e| err(&e))
}

/// A panel's log-log chart with its mesh, its axes covering every scheme's points.
fn panel_chart<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>, report: &ConvergenceReport, component: Component,
    axis: Axis,
) -> DrawResult<LogChart<'a, 'b>> {
    let all: Vec<(f64, Interval)> = report
        .schemes
        .iter()
        .flat_map(|s| points(s, component.pick, axis))
        .collect();
    let xs = log_range(all.iter().map(|p| p.0));
    let ys = log_range(
        all.iter()
            .flat_map(|p| [p.1.ci_low, p.1.ci_high, p.1.estimate]),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(format!("error of {}", component.name), ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(245, 245, 245))
        .x_labels(6)
        .y_labels(8)
        .x_desc(axis.label())
        .y_desc(format!("L^{} norm of the sup error", report.p))
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()?;
    Ok(chart)
}

/// A scheme's line in `colour` (labelled with its fitted order against h), its 95% error bars
/// and, against h, its fitted slope; nothing if it has no point.
fn draw_scheme(
    chart: &mut LogChart<'_, '_>, scheme: &SchemeReport, component: Component, axis: Axis,
    colour: RGBColor,
) -> DrawResult<()> {
    let pts = points(scheme, component.pick, axis);
    if pts.is_empty() {
        return Ok(());
    }
    let fit = (component.fit)(&scheme.observed_order);
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
        ))?
        .label(label)
        .legend(move |(a, b)| PathElement::new(vec![(a, b), (a + 18, b)], colour.stroke_width(2)));
    chart.draw_series(pts.iter().map(|(x, i)| {
        ErrorBar::new_vertical(
            *x,
            i.ci_low.clamp(MIN_DRAWN, i.estimate),
            i.estimate,
            i.ci_high.clamp(i.estimate, MAX_DRAWN),
            colour.filled(),
            5,
        )
    }))?;
    if let (Axis::StepSize, Some(fit)) = (axis, fit) {
        chart.draw_series(LineSeries::new(
            fitted_line(scheme, component.pick, fit),
            colour.mix(0.45).stroke_width(1),
        ))?;
    }
    Ok(())
}

fn draw(
    report: &ConvergenceReport, path: &Path, title: &str, axis: Axis,
) -> Result<(), StudyError> {
    let components: Vec<Component> = COMPONENTS
        .into_iter()
        .filter(|c| {
            report
                .schemes
                .iter()
                .any(|s| s.levels.iter().any(|l| (c.pick)(&l.error).is_some()))
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
    let mut left_out = 0;
    for (area, component) in panels.iter().zip(components) {
        panel(area, report, component, axis)?;
        left_out += report
            .schemes
            .iter()
            .flat_map(|s| all_points(s, component.pick, axis))
            .filter(|(x, e)| !(drawable(*x) && drawable(e.estimate)))
            .count();
    }
    if left_out > 0 {
        // A closed standard error ends the note, not the plot.
        let _ = writeln!(
            &mut std::io::stderr(),
            "note: {}: {left_out} error(s) left out of the plot: zero, not finite, or beyond \
             {MIN_DRAWN:e}..{MAX_DRAWN:e} (the report has them)",
            path.display()
        );
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
