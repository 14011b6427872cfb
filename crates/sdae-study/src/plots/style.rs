//! The one style of every plot the studies write: each line's colour, marker and dash, chosen
//! from its label, and the legend in a column of its own to the right of the panels.
//!
//! Each built-in scheme has a colour and a marker no other scheme has, the same in every plot.
//! The schemes of one family share a hue and a dash: the half-explicit variants blue and
//! violet, solid, with filled markers; the reference solvers of the inherent SDE
//! (Euler-Maruyama and its relatives) red and orange, dashed, with hollow markers; the
//! splitting schemes (BAOAB, g-BAOAB) green, dotted, with stars. So eleven schemes stay apart
//! in colour, and in grey print the dash and the marker carry the distinction. A label that
//! extends a scheme's name (`euler-maruyama + richardson`) gets that scheme's colour with
//! another marker; every other label (a user's scheme, the lines of an MLMC plot) gets a colour
//! of a qualitative palette and a marker, never a (colour, marker) pair another line has.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::integrator::SchemeKind;

/// What a figure draws on.
pub type Canvas<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// What drawing on a canvas gives back.
pub type DrawResult<T> = Result<T, DrawingAreaErrorKind<std::io::Error>>;

/// A family of lines that share a hue and a dash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// The half-explicit drift-truncated Euler scheme and its variants: solid lines.
    HalfExplicit,
    /// Schemes on the inherent SDE (the Euler-Maruyama family): dashed lines.
    InherentSde,
    /// The splitting schemes (BAOAB, g-BAOAB): dotted lines.
    Splitting,
    /// Anything else: solid lines in a qualitative palette.
    Other,
}

impl Family {
    /// The family of a built-in scheme.
    pub fn of(kind: SchemeKind) -> Self {
        match kind {
            SchemeKind::HalfExplicitTheory
            | SchemeKind::HalfExplicitPractical
            | SchemeKind::HalfExplicitUntruncated
            | SchemeKind::HalfExplicitRescaled
            | SchemeKind::HalfExplicitLocal => Family::HalfExplicit,
            SchemeKind::EulerMaruyama
            | SchemeKind::TruncatedEulerMaruyama
            | SchemeKind::ProjectedEulerMaruyama
            | SchemeKind::StochasticHeun => Family::InherentSde,
            SchemeKind::BaoabRattle | SchemeKind::GBaoab => Family::Splitting,
        }
    }

    /// The family's colours, dark to light.
    fn colours(self) -> &'static [RGBColor] {
        match self {
            Family::HalfExplicit => &HALF_EXPLICIT,
            Family::InherentSde => &INHERENT_SDE,
            Family::Splitting => &SPLITTING,
            Family::Other => &QUALITATIVE,
        }
    }

    /// The family's dash: (drawn, gap) in pixels, `None` for a solid line.
    pub fn dash(self) -> Option<(f64, f64)> {
        match self {
            Family::HalfExplicit | Family::Other => None,
            Family::InherentSde => Some((7.0, 4.0)),
            Family::Splitting => Some((2.0, 3.0)),
        }
    }
}

const HALF_EXPLICIT: [RGBColor; 5] = [
    RGBColor(11, 60, 140),
    RGBColor(47, 127, 209),
    RGBColor(114, 179, 232),
    RGBColor(94, 60, 153),
    RGBColor(154, 127, 209),
];

const INHERENT_SDE: [RGBColor; 4] = [
    RGBColor(178, 24, 43),
    RGBColor(232, 89, 12),
    RGBColor(240, 160, 50),
    RGBColor(140, 74, 31),
];

const SPLITTING: [RGBColor; 2] = [RGBColor(27, 120, 55), RGBColor(110, 190, 110)];

/// A qualitative palette (Okabe and Ito's, its yellow left out) for lines of no scheme family.
const QUALITATIVE: [RGBColor; 7] = [
    RGBColor(0, 0, 0),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 158, 115),
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(204, 121, 167),
];

/// The colour of the frame around each panel's plotting area (used for nothing else).
pub const FRAME: RGBColor = RGBColor(77, 77, 77);

/// The colour of the legend's box (used for nothing else).
pub const LEGEND_FRAME: RGBColor = RGBColor(170, 170, 170);

/// The colour of reference lines (ratio = 1, ...) and of the legend's second lines.
pub const GUIDE: RGBColor = RGBColor(110, 110, 110);

/// A marker's outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Shape {
    /// A circle.
    Circle,
    /// A square.
    Square,
    /// A triangle pointing up.
    TriangleUp,
    /// A diamond.
    Diamond,
    /// A triangle pointing down.
    TriangleDown,
    /// A five-pointed star.
    Star,
    /// A plus sign.
    Plus,
    /// A hexagon.
    Hexagon,
}

/// A marker: an outline, filled or hollow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Marker {
    /// The outline.
    pub shape: Shape,
    /// Filled (or drawn as an outline).
    pub filled: bool,
}

const fn filled(shape: Shape) -> Marker {
    Marker {
        shape,
        filled: true,
    }
}

const fn hollow(shape: Shape) -> Marker {
    Marker {
        shape,
        filled: false,
    }
}

/// Every marker, in the order lines of no scheme take them.
const MARKERS: [Marker; 16] = [
    filled(Shape::Circle),
    filled(Shape::Square),
    filled(Shape::TriangleUp),
    filled(Shape::Diamond),
    filled(Shape::TriangleDown),
    hollow(Shape::Circle),
    hollow(Shape::Square),
    hollow(Shape::TriangleUp),
    hollow(Shape::Diamond),
    hollow(Shape::TriangleDown),
    filled(Shape::Star),
    hollow(Shape::Star),
    filled(Shape::Plus),
    filled(Shape::Hexagon),
    hollow(Shape::Hexagon),
    hollow(Shape::Plus),
];

/// The markers a variant of a scheme tries first (after its scheme's marker turned over).
const VARIANT_MARKERS: [Marker; 4] = [
    filled(Shape::Plus),
    filled(Shape::Hexagon),
    hollow(Shape::Hexagon),
    hollow(Shape::Plus),
];

/// The colour, marker and dash of one line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineStyle {
    /// Its colour.
    pub colour: RGBColor,
    /// Its marker.
    pub marker: Marker,
    /// Its family (which sets the dash).
    pub family: Family,
}

/// The style of a built-in scheme: its family's colour and marker at its place in the family.
pub fn scheme_style(kind: SchemeKind) -> LineStyle {
    let family = Family::of(kind);
    let place = SchemeKind::ALL
        .iter()
        .filter(|k| Family::of(**k) == family)
        .position(|k| *k == kind)
        .unwrap_or(0);
    let marker = match family {
        Family::HalfExplicit => MARKERS[place],
        Family::InherentSde => MARKERS[5 + place],
        _ => MARKERS[10 + place],
    };
    LineStyle {
        colour: family.colours()[place % family.colours().len()],
        marker,
        family,
    }
}

/// The built-in scheme whose name `label` is, or starts with (the longest such name), and
/// whether it is exactly that name.
fn scheme_of(label: &str) -> Option<(SchemeKind, bool)> {
    SchemeKind::ALL
        .into_iter()
        .filter(|k| label.starts_with(k.name()))
        .max_by_key(|k| k.name().len())
        .map(|k| (k, label == k.name()))
}

/// The family a label that names no scheme belongs to by its first word.
fn family_by_prefix(label: &str) -> Family {
    if label.starts_with("half-explicit") {
        Family::HalfExplicit
    } else {
        Family::Other
    }
}

/// The styles of a figure's lines, by label: see the module's documentation. Labels are
/// styled in their order, every built-in scheme first, so a scheme looks the same in every
/// plot whichever lines it shares it with.
pub fn assign(labels: &[&str]) -> Vec<LineStyle> {
    let mut styles: Vec<Option<LineStyle>> = labels
        .iter()
        .map(|l| match scheme_of(l) {
            Some((kind, true)) => Some(scheme_style(kind)),
            _ => None,
        })
        .collect();
    for (i, label) in labels.iter().enumerate() {
        if styles[i].is_some() {
            continue;
        }
        let taken: Vec<LineStyle> = styles.iter().flatten().copied().collect();
        styles[i] = Some(match scheme_of(label) {
            Some((kind, _)) => variant_style(scheme_style(kind), &taken),
            None => free_style(family_by_prefix(label), &taken),
        });
    }
    styles.into_iter().flatten().collect()
}

/// A variant of a scheme: its colour with its marker turned over or another marker, else the
/// first free pair of its family.
fn variant_style(of: LineStyle, taken: &[LineStyle]) -> LineStyle {
    let turned = Marker {
        filled: !of.marker.filled,
        ..of.marker
    };
    std::iter::once(turned)
        .chain(VARIANT_MARKERS)
        .map(|marker| LineStyle { marker, ..of })
        .find(|s| is_free(s, taken))
        .unwrap_or_else(|| free_style(of.family, taken))
}

fn is_free(style: &LineStyle, taken: &[LineStyle]) -> bool {
    !taken
        .iter()
        .any(|t| t.colour == style.colour && t.marker == style.marker)
}

/// The free (colour, marker) pair of `family` whose colour and marker the fewest lines have
/// (the first such in the family's order), else (beyond every pair) a pair of the
/// qualitative palette.
fn free_style(family: Family, taken: &[LineStyle]) -> LineStyle {
    let markers: Vec<Marker> = match family {
        Family::Other => MARKERS.to_vec(),
        _ => VARIANT_MARKERS.iter().chain(&MARKERS).copied().collect(),
    };
    let uses = |s: &LineStyle| {
        taken
            .iter()
            .map(|t| usize::from(t.colour == s.colour) + usize::from(t.marker == s.marker))
            .sum::<usize>()
    };
    markers
        .iter()
        .flat_map(|&marker| {
            family.colours().iter().map(move |&colour| LineStyle {
                colour,
                marker,
                family,
            })
        })
        .filter(|s| is_free(s, taken))
        .min_by_key(uses)
        .unwrap_or(LineStyle {
            colour: QUALITATIVE[taken.len() % QUALITATIVE.len()],
            marker: MARKERS[taken.len() % MARKERS.len()],
            family: Family::Other,
        })
}

/// The radius of a marker in pixels.
pub const MARKER_SIZE: i32 = 5;

/// The corners of a marker's outline around (0, 0), `None` for a circle.
fn outline(shape: Shape, s: i32) -> Option<Vec<(i32, i32)>> {
    let polar = |n: usize, radius: &dyn Fn(usize) -> f64, turn: f64| -> Vec<(i32, i32)> {
        (0..n)
            .map(|k| {
                let a = turn + std::f64::consts::TAU * k as f64 / n as f64;
                let r = radius(k);
                ((r * a.sin()).round() as i32, (-r * a.cos()).round() as i32)
            })
            .collect()
    };
    let r = f64::from(s);
    let t = s / 3;
    Some(match shape {
        Shape::Circle => return None,
        Shape::Square => vec![
            (-s + 1, -s + 1),
            (s - 1, -s + 1),
            (s - 1, s - 1),
            (-s + 1, s - 1),
        ],
        Shape::TriangleUp => vec![(0, -s - 1), (s + 1, s), (-s - 1, s)],
        Shape::TriangleDown => vec![(0, s + 1), (-s - 1, -s), (s + 1, -s)],
        Shape::Diamond => vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0)],
        Shape::Star => polar(10, &|k| if k % 2 == 0 { r + 1.5 } else { 0.45 * r }, 0.0),
        Shape::Hexagon => polar(6, &|_| r, std::f64::consts::FRAC_PI_6),
        Shape::Plus => vec![
            (-t, -s),
            (t, -s),
            (t, -t),
            (s, -t),
            (s, t),
            (t, t),
            (t, s),
            (-t, s),
            (-t, t),
            (-s, t),
            (-s, -t),
            (-t, -t),
        ],
    })
}

/// Draws `marker` in `colour` centred at the pixel `at` of `canvas`.
pub fn draw_marker(
    canvas: &Canvas<'_>, marker: Marker, colour: RGBColor, at: (i32, i32),
) -> DrawResult<()> {
    let (x, y) = at;
    match outline(marker.shape, MARKER_SIZE) {
        None if marker.filled => canvas.draw(&Circle::new(at, MARKER_SIZE, colour.filled())),
        None => canvas.draw(&Circle::new(
            at,
            MARKER_SIZE,
            ShapeStyle::from(colour).stroke_width(2),
        )),
        Some(corners) => {
            let points: Vec<(i32, i32)> = corners.iter().map(|(a, b)| (x + a, y + b)).collect();
            if marker.filled {
                canvas.draw(&Polygon::new(points, colour.filled()))
            } else {
                let closed: Vec<(i32, i32)> = points.iter().chain(&points[..1]).copied().collect();
                canvas.draw(&PathElement::new(closed, colour.stroke_width(2)))
            }
        }
    }
}

/// Draws the polyline `points` (pixels) in `colour`, `width` wide, dashed as `dash` says.
pub fn draw_line(
    canvas: &Canvas<'_>, points: &[(i32, i32)], colour: RGBAColor, width: u32,
    dash: Option<(f64, f64)>,
) -> DrawResult<()> {
    let style = colour.stroke_width(width);
    let Some((on, off)) = dash else {
        return canvas.draw(&PathElement::new(points.to_vec(), style));
    };
    // Walks the line, drawing `on` pixels and skipping `off`, carrying the phase over corners.
    let mut phase = 0.0;
    for w in points.windows(2) {
        let (a, b) = (
            (f64::from(w[0].0), f64::from(w[0].1)),
            (f64::from(w[1].0), f64::from(w[1].1)),
        );
        let length = (b.0 - a.0).hypot(b.1 - a.1);
        let at = |s: f64| {
            let u = if length > 0.0 { s / length } else { 0.0 };
            (
                (a.0 + u * (b.0 - a.0)).round() as i32,
                (a.1 + u * (b.1 - a.1)).round() as i32,
            )
        };
        let mut s = 0.0;
        while s < length {
            let in_dash = phase < on;
            let step = if in_dash {
                on - phase
            } else {
                on + off - phase
            };
            let end = (s + step).min(length);
            if in_dash && end > s {
                canvas.draw(&PathElement::new(vec![at(s), at(end)], style))?;
            }
            phase = (phase + end - s) % (on + off);
            s = end;
        }
    }
    Ok(())
}

/// The font size of legend labels, in plotters' units (the SVG's font size is this / 1.24).
pub const LEGEND_FONT: f64 = 14.0;

/// The font size of a legend entry's second line.
pub const DETAIL_FONT: f64 = 12.0;

/// The pixels of height one legend entry takes, with a second line if it has one.
fn entry_height(detail: bool) -> i32 {
    if detail { 34 } else { 20 }
}

/// An upper bound on the drawn width of `text` in a sans-serif font of `size` (plotters' units).
pub fn text_width(text: &str, size: f64) -> i32 {
    (0.62 * size / 1.24 * text.chars().count() as f64).ceil() as i32
}

/// One legend entry: its line's label and style, and a second line of text if any.
pub struct Entry<'a> {
    /// The label.
    pub label: &'a str,
    /// The line's style.
    pub style: LineStyle,
    /// A second line (say, the fitted orders), in smaller grey type.
    pub detail: Option<&'a str>,
    /// Whether the line is drawn with markers.
    pub markers: bool,
}

const SAMPLE: i32 = 36;

/// The size (width, height) in pixels of the legend of `entries`, its margins included.
pub fn legend_size(entries: &[Entry<'_>]) -> (i32, i32) {
    if entries.is_empty() {
        return (0, 0);
    }
    let width = entries
        .iter()
        .map(|e| {
            let detail = e.detail.map_or(0, |d| text_width(d, DETAIL_FONT));
            text_width(e.label, LEGEND_FONT).max(detail)
        })
        .max()
        .unwrap_or(0);
    let height: i32 = entries
        .iter()
        .map(|e| entry_height(e.detail.is_some()))
        .sum();
    (width + SAMPLE + 40, height + 36)
}

/// A left-aligned, vertically centred font of `size` in `colour`.
fn font(size: f64, colour: RGBColor) -> TextStyle<'static> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    ("sans-serif", size)
        .into_font()
        .color(&colour)
        .pos(Pos::new(HPos::Left, VPos::Center))
}

/// Draws the legend of `entries` in its own column `area` (never over a panel): a framed box
/// at the top, one entry per line with a sample of the line and its marker.
pub fn draw_legend(area: &Canvas<'_>, entries: &[Entry<'_>]) -> DrawResult<()> {
    if entries.is_empty() {
        return Ok(());
    }
    let (x0, y0) = (8, 8);
    let (w, h) = legend_size(entries);
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + w - 16, y0 + h - 16)],
        LEGEND_FRAME.stroke_width(1),
    ))?;
    let mut y = y0 + 20;
    for e in entries {
        let sample = [(x0 + 10, y), (x0 + 10 + SAMPLE, y)];
        draw_line(
            area,
            &sample,
            e.style.colour.to_rgba(),
            2,
            e.style.family.dash(),
        )?;
        if e.markers {
            draw_marker(
                area,
                e.style.marker,
                e.style.colour,
                (x0 + 10 + SAMPLE / 2, y),
            )?;
        }
        area.draw_text(e.label, &font(LEGEND_FONT, BLACK), (x0 + 18 + SAMPLE, y))?;
        if let Some(d) = e.detail {
            area.draw_text(d, &font(DETAIL_FONT, GUIDE), (x0 + 18 + SAMPLE, y + 14))?;
        }
        y += entry_height(e.detail.is_some());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scheme_has_its_own_colour_and_marker_and_its_familys_dash() {
        let styles: Vec<LineStyle> = SchemeKind::ALL.into_iter().map(scheme_style).collect();
        for (i, a) in styles.iter().enumerate() {
            for b in &styles[i + 1..] {
                assert_ne!(a.colour, b.colour);
                assert_ne!(a.marker, b.marker);
            }
        }
        let names: Vec<&str> = SchemeKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(assign(&names), styles);
        assert_eq!(Family::of(SchemeKind::GBaoab).dash(), Some((2.0, 3.0)));
    }

    #[test]
    fn variants_and_other_lines_never_repeat_a_pair() {
        let labels = [
            "euler-maruyama + richardson",
            "half-explicit C_eta = 0.5",
            "half-explicit C_eta = 1",
            "half-explicit-rescaled C_eta = 1",
            "half-explicit-rescaled C_eta = 2",
            "my-scheme",
            "P_l",
            "P_l - P_l-1",
        ];
        let mut all: Vec<&str> = SchemeKind::ALL.iter().map(|k| k.name()).collect();
        all.extend(labels);
        let styles = assign(&all);
        for (i, a) in styles.iter().enumerate() {
            for b in &styles[i + 1..] {
                assert!(a.colour != b.colour || a.marker != b.marker, "{a:?} {b:?}");
            }
        }
        let em = scheme_style(SchemeKind::EulerMaruyama);
        assert_eq!(styles[11].colour, em.colour);
        assert_eq!(styles[11].marker.shape, em.marker.shape);
        assert_eq!(styles[12].family, Family::HalfExplicit);
        // Far more lines than pairs still get a style each.
        let many: Vec<String> = (0..200).map(|k| format!("line {k}")).collect();
        let many: Vec<&str> = many.iter().map(String::as_str).collect();
        assert_eq!(assign(&many).len(), 200);
    }
}
