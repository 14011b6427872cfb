//! A figure as data (panels of labelled lines with error bars) and the one function that draws
//! it in the style of [`super::style`]: every plot of every study is a [`Figure`] drawn by
//! [`render`], so the style is written once.

use std::ops::Range;
use std::path::Path;

use plotters::prelude::*;

use super::style::{self, Canvas, DrawResult, Entry, LineStyle};
use crate::error::StudyError;

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

/// How an axis maps values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Logarithmic (base 10): only values in [`MIN_DRAWN`]..=[`MAX_DRAWN`] are drawn.
    Log,
}

/// An axis: its name, scale, range (`None`: covering every point, padded; `Some`: points
/// beyond it are drawn at its edge) and how its numbers are labelled (`None`: by the scale).
#[derive(Debug, Clone)]
pub struct Axis {
    /// The axis's name.
    pub label: String,
    /// Its scale.
    pub scale: Scale,
    /// A fixed range, in the values' own units.
    pub range: Option<Range<f64>>,
    /// The tick label of a value (in the values' own units).
    pub format: Option<fn(f64) -> String>,
}

impl Axis {
    /// A logarithmic axis named `label`.
    pub fn log(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            scale: Scale::Log,
            range: None,
            format: None,
        }
    }

    /// A linear axis named `label`.
    pub fn linear(label: impl Into<String>) -> Self {
        Self {
            scale: Scale::Linear,
            ..Self::log(label)
        }
    }

    /// The axis with the fixed range `range`.
    pub fn within(self, range: Range<f64>) -> Self {
        Self {
            range: Some(range),
            ..self
        }
    }

    /// The axis with tick labels written by `format`.
    pub fn formatted(self, format: fn(f64) -> String) -> Self {
        Self {
            format: Some(format),
            ..self
        }
    }

    /// Where `v` goes on the axis (log10 for a logarithmic one), `None` if it cannot be drawn.
    fn map(&self, v: f64) -> Option<f64> {
        match self.scale {
            Scale::Linear => v.is_finite().then_some(v),
            Scale::Log => drawable(v).then(|| v.log10()),
        }
    }

    /// The value at the mapped position `u`.
    fn unmap(&self, u: f64) -> f64 {
        match self.scale {
            Scale::Linear => u,
            Scale::Log => 10f64.powf(u),
        }
    }
}

/// One point of a line, with its error bars (in the values' own units) if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// A horizontal bar from .0 to .1 (say, the range of repeated timings).
    pub x_bar: Option<(f64, f64)>,
    /// A vertical bar from .0 to .1 (say, a 95% confidence interval).
    pub y_bar: Option<(f64, f64)>,
}

impl Point {
    /// The point (x, y) without bars.
    pub fn at(x: f64, y: f64) -> Self {
        Self {
            x,
            y,
            x_bar: None,
            y_bar: None,
        }
    }
}

/// A labelled line: its points, a guide drawn thin in its colour (a fitted slope), and whether
/// it is drawn thin (a derived line, say an extrapolation) or without markers (a long path).
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Its label in the legend (empty: no legend entry).
    pub label: String,
    /// Its points.
    pub points: Vec<Point>,
    /// A thin guide line in its colour, without markers.
    pub guide: Vec<(f64, f64)>,
    /// Drawn one pixel wide.
    pub thin: bool,
    /// Drawn without markers.
    pub no_markers: bool,
}

impl Series {
    /// A line labelled `label` through `points`.
    pub fn new(label: impl Into<String>, points: Vec<Point>) -> Self {
        Self {
            label: label.into(),
            points,
            ..Self::default()
        }
    }
}

/// One panel: a title, its axes, its lines and grey reference lines (say, ratio = 1).
#[derive(Debug, Clone)]
pub struct Panel {
    /// Its title.
    pub title: String,
    /// The x axis.
    pub x: Axis,
    /// The y axis.
    pub y: Axis,
    /// Its lines.
    pub series: Vec<Series>,
    /// Grey reference lines.
    pub guides: Vec<Vec<(f64, f64)>>,
}

/// A figure: a title, panels in rows of `columns`, each `panel_size` pixels, and the legend's
/// second lines by label.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Its title.
    pub title: String,
    /// Its panels.
    pub panels: Vec<Panel>,
    /// Panels per row.
    pub columns: usize,
    /// The size of a panel in pixels.
    pub panel_size: (u32, u32),
    /// Second lines of legend entries: (label, text).
    pub details: Vec<(String, String)>,
}

impl Figure {
    /// A figure titled `title` with `panels` side by side, 480 x 480 pixels each.
    pub fn row(title: impl Into<String>, panels: Vec<Panel>) -> Self {
        Self {
            title: title.into(),
            columns: panels.len().max(1),
            panels,
            panel_size: (480, 480),
            details: Vec::new(),
        }
    }

    /// Whether a line labelled `label` has a point its panel's axes can draw.
    fn draws(&self, label: &str) -> bool {
        self.panels.iter().any(|p| {
            p.series
                .iter()
                .filter(|s| s.label == label)
                .flat_map(|s| &s.points)
                .any(|q| p.x.map(q.x).is_some() && p.y.map(q.y).is_some())
        })
    }

    /// Every label of a line, in order of first appearance.
    pub fn labels(&self) -> Vec<&str> {
        let mut labels: Vec<&str> = Vec::new();
        for s in self.panels.iter().flat_map(|p| &p.series) {
            if !s.label.is_empty() && !labels.contains(&s.label.as_str()) {
                labels.push(&s.label);
            }
        }
        labels
    }
}

/// The tick label of a logarithmic axis at `v`: plain between 0.01 and 1000, else 1e-3 style.
pub fn log_tick(v: f64) -> String {
    let e = v.log10();
    if (e - e.round()).abs() < 1e-6 {
        let e = e.round() as i32;
        return if (-2..3).contains(&e) {
            format!("{}", 10f64.powi(e))
        } else {
            format!("1e{e}")
        };
    }
    if (1e-2..1e3).contains(&v.abs()) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

/// The padded range (in mapped units) of the values `us` (mapped), or of `fixed`.
fn mapped_range(axis: &Axis, us: &[f64]) -> Range<f64> {
    if let Some(r) = &axis.range
        && let (Some(a), Some(b)) = (axis.map(r.start), axis.map(r.end))
    {
        return a..b;
    }
    let (lo, hi) = us
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &u| {
            (a.min(u), b.max(u))
        });
    if lo > hi {
        return match axis.scale {
            Scale::Log => -3.0..0.0,
            Scale::Linear => 0.0..1.0,
        };
    }
    let pad = match axis.scale {
        Scale::Log => 1.5f64.log10(),
        Scale::Linear => ((hi - lo) * 0.06).max(1e-9 * hi.abs().max(1.0)),
    };
    lo - pad..hi + pad
}

/// Maps `v` onto `axis` within `range`: values beyond a fixed range are drawn at its edge.
fn place(axis: &Axis, range: &Range<f64>, v: f64) -> Option<f64> {
    let u = axis.map(v)?;
    if axis.range.is_some() {
        Some(u.clamp(range.start, range.end))
    } else {
        Some(u)
    }
}

/// Draws `figure` into the SVG file `path`; gives back the number of points left out because
/// an axis cannot draw them (zero or negative on a logarithmic axis, not finite).
pub fn render(figure: &Figure, path: &Path) -> Result<usize, StudyError> {
    let err = |e: &dyn std::fmt::Display| StudyError::write(path, e);
    let labels = figure.labels();
    let styles = style::assign(&labels);
    // The legend names the lines that have a point to draw.
    let entries: Vec<Entry<'_>> = labels
        .iter()
        .zip(&styles)
        .filter(|(label, _)| figure.draws(label))
        .map(|(label, style)| Entry {
            label,
            style: *style,
            detail: figure
                .details
                .iter()
                .find(|(l, _)| l == label)
                .map(|(_, d)| d.as_str()),
            markers: figure
                .panels
                .iter()
                .flat_map(|p| &p.series)
                .any(|s| s.label == *label && !s.no_markers),
        })
        .collect();
    let (legend_w, legend_h) = style::legend_size(&entries);
    let columns = figure.columns.clamp(1, figure.panels.len().max(1));
    let rows = figure.panels.len().div_ceil(columns).max(1);
    let (pw, ph) = figure.panel_size;
    let body_w = pw * columns as u32;
    let height = (ph * rows as u32 + 40).max(legend_h as u32 + 50);
    let canvas = SVGBackend::new(path, (body_w + legend_w as u32, height)).into_drawing_area();
    canvas.fill(&WHITE).map_err(|e| err(&e))?;
    let body = canvas
        .titled(&figure.title, ("sans-serif", 20))
        .map_err(|e| err(&e))?;
    let (panels, legend) = body.split_horizontally(body_w);
    let mut left_out = 0;
    for (area, panel) in panels
        .split_evenly((rows, columns))
        .iter()
        .zip(&figure.panels)
    {
        left_out += draw_panel(&canvas, area, panel, &labels, &styles).map_err(|e| err(&e))?;
    }
    style::draw_legend(&legend, &entries).map_err(|e| err(&e))?;
    canvas.present().map_err(|e| err(&e))?;
    Ok(left_out)
}

/// Draws `panel` into `area` (its lines onto `canvas`, the whole figure, in its pixels);
/// gives back the number of points left out.
fn draw_panel(
    canvas: &Canvas<'_>, area: &Canvas<'_>, panel: &Panel, labels: &[&str], styles: &[LineStyle],
) -> DrawResult<usize> {
    let (xs, ys) = panel_ranges(panel);
    let ticks = |axis: &Axis, r: &Range<f64>| match axis.scale {
        Scale::Log if r.end - r.start >= 2.0 => (r.end - r.start).ceil() as usize + 1,
        _ => 6,
    };
    let (x_axis, y_axis) = (&panel.x, &panel.y);
    let x_format = move |u: &f64| tick(x_axis, *u);
    let y_format = move |u: &f64| tick(y_axis, *u);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(62)
        .build_cartesian_2d(xs.clone(), ys.clone())?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_labels(ticks(x_axis, &xs))
        .y_labels(ticks(y_axis, &ys))
        .x_desc(&x_axis.label)
        .y_desc(&y_axis.label)
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .draw()?;
    let to_pixel = |x: f64, y: f64| {
        let (px, py) = (place(x_axis, &xs, x)?, place(y_axis, &ys, y)?);
        Some(chart.backend_coord(&(px, py)))
    };
    for guide in &panel.guides {
        let points: Vec<(i32, i32)> = guide.iter().filter_map(|&(x, y)| to_pixel(x, y)).collect();
        style::draw_line(canvas, &points, style::GUIDE.to_rgba(), 1, Some((5.0, 4.0)))?;
    }
    let mut left_out = 0;
    for series in &panel.series {
        let style = labels
            .iter()
            .position(|l| *l == series.label)
            .map_or(unlabelled(), |k| styles[k]);
        left_out += draw_series(canvas, series, style, &to_pixel)?;
    }
    let (px, py) = chart.plotting_area().get_pixel_range();
    canvas.draw(&Rectangle::new(
        [(px.start, py.start), (px.end - 1, py.end - 1)],
        style::FRAME.stroke_width(1),
    ))?;
    Ok(left_out)
}

/// The style of a line without a label (a single path): the first colour, no dash.
fn unlabelled() -> LineStyle {
    style::assign(&["path"])[0]
}

/// The tick label at the mapped position `u` of `axis`.
fn tick(axis: &Axis, u: f64) -> String {
    let v = axis.unmap(u);
    match (axis.format, axis.scale) {
        (Some(f), _) => f(v),
        (None, Scale::Log) => log_tick(v),
        (None, Scale::Linear) => {
            let s = format!("{v:.3}");
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        }
    }
}

/// The mapped ranges of a panel's axes, covering every point and bar that can be drawn.
fn panel_ranges(panel: &Panel) -> (Range<f64>, Range<f64>) {
    let points = || panel.series.iter().flat_map(|s| &s.points);
    let (mut us, mut vs) = (Vec::new(), Vec::new());
    for p in points() {
        let (Some(_), Some(_)) = (panel.x.map(p.x), panel.y.map(p.y)) else {
            continue;
        };
        let xb = p.x_bar.map_or([p.x; 2], |(a, b)| [a, b]);
        let yb = p.y_bar.map_or([p.y; 2], |(a, b)| [a, b]);
        us.extend([p.x, xb[0], xb[1]].iter().filter_map(|&v| panel.x.map(v)));
        vs.extend([p.y, yb[0], yb[1]].iter().filter_map(|&v| panel.y.map(v)));
    }
    for &(x, y) in panel.series.iter().flat_map(|s| &s.guide) {
        us.extend(panel.x.map(x));
        vs.extend(panel.y.map(y));
    }
    (mapped_range(&panel.x, &us), mapped_range(&panel.y, &vs))
}

/// Draws a line: its guide, its path, its bars and its markers; gives back the number of its
/// points left out.
fn draw_series(
    canvas: &Canvas<'_>, series: &Series, style: LineStyle,
    to_pixel: &dyn Fn(f64, f64) -> Option<(i32, i32)>,
) -> DrawResult<usize> {
    let guide: Vec<(i32, i32)> = series
        .guide
        .iter()
        .filter_map(|&(x, y)| to_pixel(x, y))
        .collect();
    style::draw_line(canvas, &guide, style.colour.mix(0.55), 1, None)?;
    let drawn: Vec<(&Point, (i32, i32))> = series
        .points
        .iter()
        .filter_map(|p| Some((p, to_pixel(p.x, p.y)?)))
        .collect();
    let width = if series.thin { 1 } else { 2 };
    let path: Vec<(i32, i32)> = drawn.iter().map(|d| d.1).collect();
    style::draw_line(
        canvas,
        &path,
        style.colour.to_rgba(),
        width,
        style.family.dash(),
    )?;
    for (p, (x, y)) in &drawn {
        // A bar's end that cannot be drawn (say, an interval reaching below 0 on a log axis)
        // is drawn at the point.
        if let Some((a, b)) = p.y_bar {
            let end = |v: f64| to_pixel(p.x, v).map_or(*y, |q| q.1);
            bar(canvas, [(*x, end(a)), (*x, end(b))], style.colour, true)?;
        }
        if let Some((a, b)) = p.x_bar {
            let end = |v: f64| to_pixel(v, p.y).map_or(*x, |q| q.0);
            bar(canvas, [(end(a), *y), (end(b), *y)], style.colour, false)?;
        }
    }
    if !series.no_markers {
        for (_, at) in &drawn {
            style::draw_marker(canvas, style.marker, style.colour, *at)?;
        }
    }
    Ok(series.points.len() - drawn.len())
}

/// An error bar from `ends[0]` to `ends[1]` with caps: vertical (an interval) at 80% of the
/// line's colour, horizontal (a range of timings, often long) at 35% so that it does not hide
/// the lines.
fn bar(
    canvas: &Canvas<'_>, ends: [(i32, i32); 2], colour: RGBColor, vertical: bool,
) -> DrawResult<()> {
    if ends[0] == ends[1] {
        return Ok(());
    }
    let line = colour
        .mix(if vertical { 0.8 } else { 0.35 })
        .stroke_width(1);
    canvas.draw(&PathElement::new(ends.to_vec(), line))?;
    for (x, y) in ends {
        let cap = if vertical {
            vec![(x - 4, y), (x + 4, y)]
        } else {
            vec![(x, y - 4), (x, y + 4)]
        };
        canvas.draw(&PathElement::new(cap, line))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_read_as_numbers() {
        assert_eq!(log_tick(1e-3), "1e-3");
        assert_eq!(log_tick(0.1), "0.1");
        assert_eq!(log_tick(100.0), "100");
        assert_eq!(log_tick(1.05), "1.05");
        assert_eq!(log_tick(3.2e-5), "3.2e-5");
    }

    #[test]
    fn fixed_ranges_draw_far_values_at_their_edge_and_log_axes_leave_out_zero() {
        let axis = Axis::log("y").within(0.1..10.0);
        let range = -1.0..1.0;
        assert_eq!(place(&axis, &range, 1e5), Some(1.0));
        assert_eq!(place(&axis, &range, 0.0), None);
        assert_eq!(Axis::linear("x").map(f64::NAN), None);
        assert_eq!(mapped_range(&Axis::log("y"), &[]), -3.0..0.0);
    }
}
