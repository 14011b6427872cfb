//! The weak study's files: `weak.json` (everything), `weak.csv` (one row per observable, scheme
//! or extrapolation, and step size), `weak.md` (orders, the fastest scheme to each weak error,
//! all levels) and the plots `weak_error_vs_h.svg` and `weak_error_vs_time.svg`; and the
//! summary on the terminal.

use std::fmt::Write as _;
use std::path::Path;

use super::{Basis, ObservableReport, WeakLevel, WeakOrder, WeakReport, WeakScheme};
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use crate::output::{decades, left_out, readable};
use crate::plots::figure::{Axis as FigureAxis, Figure, Panel, Point, Series, render};
use sdae_stats::Interval;

/// "order [low, high]", then the levels left out of the fit and why (unresolved,
/// pre-asymptotic), and the bend of a slope still moving at the finest levels; or "-".
pub fn describe_order(order: Option<&WeakOrder>, row: &WeakScheme) -> String {
    let Some(o) = order else {
        return "-".into();
    };
    let notes = order_notes(o, row);
    let s = order_text(o);
    if notes.is_empty() {
        s
    } else {
        format!("{s}; {}", notes.join("; "))
    }
}

/// "order [low, high]", or "-" where the levels do not tell it.
fn order_text(o: &WeakOrder) -> String {
    o.order.map_or("-".into(), |i| {
        format!("{:.2} [{:.2}, {:.2}]", i.estimate, i.ci_low, i.ci_high)
    })
}

/// What an order leaves out and why: "unresolved at N = ...", "pre-asymptotic N = ...", "still
/// bending by ... per level".
fn order_notes(o: &WeakOrder, row: &WeakScheme) -> Vec<String> {
    let mut s = Vec::new();
    let n = |levels: &[usize]| -> String {
        let n: Vec<String> = levels
            .iter()
            .filter_map(|&j| row.levels.get(j).map(|l| l.n_steps.to_string()))
            .collect();
        n.join(", ")
    };
    if !o.unresolved.is_empty() {
        s.push(format!("unresolved at N = {}", n(&o.unresolved)));
    }
    if !o.pre_asymptotic.is_empty() {
        s.push(format!("pre-asymptotic N = {}", n(&o.pre_asymptotic)));
    }
    if let Some(b) = o.bending {
        s.push(format!("still bending by {b:.2} per level"));
    }
    match (o.order, o.after_crossing) {
        (None, _) if o.unsettled => s.push("the local slopes do not settle yet".into()),
        (None, _) if o.unshown => s.push(format!(
            "the resolved levels N = {} cannot show the asymptote (fewer than three, or their \
             local slopes' change is unknown to within {})",
            n(&o.fitted),
            sdae_stats::weak_order::MAX_UNSHOWN_CHANGE
        )),
        (None, _) => s.push("too few levels after the error's change of sign".into()),
        (Some(_), Some(x)) => s.push(format!("{x:.2} off after the error's change of sign")),
        _ => {}
    }
    s
}

/// The levels a row lost, or "".
fn describe_lost(row: &WeakScheme) -> String {
    let lost: Vec<String> = row.lost.iter().map(|l| l.describe()).collect();
    lost.join("; ")
}

fn cell(i: &Interval) -> String {
    format!("{:.2e} [{:.1e}, {:.1e}]", i.estimate, i.ci_low, i.ci_high)
}

fn basis_text(o: &ObservableReport) -> String {
    match (o.basis, &o.reference_bias) {
        (Basis::Exact(x), _) => format!("the exact value {}", readable(x)),
        (Basis::Reference, None) => "the reference on the same paths".into(),
        (Basis::Reference, Some(b)) => format!(
            "the reference on the same paths, extrapolated from its two finest levels for weak order {} (E[f_R - f_(R-1)] = {}); its bias is bounded by B = {:.1e} at T and {:.1e} over the grid, added to every interval",
            b.order,
            cell(&b.difference),
            b.bound,
            b.grid_bound
        ),
    }
}

/// The CSV table: one row per observable, scheme (or extrapolation) and step size compared;
/// `bias_bound` is the reference's bias bound B added to each error interval (0 against an
/// exact value).
pub fn csv(report: &WeakReport) -> String {
    let mut s = String::from(
        "observable,basis,bias_bound,scheme,extrapolated,n_steps,h,value,value_lo,value_hi,error,error_lo,error_hi,resolved,sup_error,sup_error_lo,sup_error_hi,seconds_per_path\n",
    );
    for o in &report.observables {
        let basis = match o.basis {
            Basis::Exact(_) => "exact",
            Basis::Reference => "reference",
        };
        let bound = match (o.basis, &o.reference_bias) {
            (Basis::Reference, Some(b)) => b.bound,
            _ => 0.0,
        };
        for row in &o.schemes {
            for l in &row.levels {
                let sup = l
                    .sup_error
                    .map_or([String::new(), String::new(), String::new()], |i| {
                        [i.estimate, i.ci_low, i.ci_high].map(|x| format!("{x:e}"))
                    });
                let _ = writeln!(
                    s,
                    "{},{basis},{bound:e},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{},{},{:e}",
                    o.name,
                    row.name,
                    row.extrapolated,
                    l.n_steps,
                    l.h,
                    l.value.estimate,
                    l.value.ci_low,
                    l.value.ci_high,
                    l.error.estimate,
                    l.error.ci_low,
                    l.error.ci_high,
                    l.resolved,
                    sup[0],
                    sup[1],
                    sup[2],
                    l.seconds_per_path
                );
            }
        }
    }
    s
}

/// The largest |x| over an error's interval: the error is below it with 95% confidence.
fn upper_bound(e: &Interval) -> f64 {
    e.ci_low.abs().max(e.ci_high.abs())
}

/// Whether level `j` of `row` holds |error| <= `target`: its interval and those of every finer
/// level of the row lie within +-target, and no finer level was lost (a zero crossing of the
/// error, or a level whose finer neighbours are worse, is no accuracy).
fn holds(row: &WeakScheme, j: usize, target: f64) -> bool {
    let n = row.levels[j].n_steps;
    row.levels[j..]
        .iter()
        .all(|l| upper_bound(&l.error) <= target)
        && row.lost.iter().all(|l| l.n_steps < n)
}

/// The level of the rows `rows` that holds |error| <= `target` ([`holds`]) with the least run
/// time per path: (seconds, scheme, N).
fn fastest_to<'a>(
    rows: impl Iterator<Item = &'a WeakScheme>, target: f64,
) -> Option<(f64, &'a str, usize)> {
    rows.flat_map(|row| {
        (0..row.levels.len())
            .filter(move |&j| holds(row, j, target))
            .map(move |j| {
                let l = &row.levels[j];
                (l.seconds_per_path, row.name.as_str(), l.n_steps)
            })
    })
    .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// For each observable and each decade of weak error some row reaches: the fastest scheme
/// without extrapolation and the fastest row with it (plain or extrapolated).
fn fastest(report: &WeakReport) -> String {
    let mut s = String::new();
    for o in &report.observables {
        let bounds = o
            .schemes
            .iter()
            .flat_map(|r| r.levels.iter().map(|l| upper_bound(&l.error)));
        for decade in decades(bounds) {
            let plain = fastest_to(o.schemes.iter().filter(|r| !r.extrapolated), decade);
            let any = fastest_to(o.schemes.iter(), decade);
            let show = |x: Option<(f64, &str, usize)>| {
                x.map_or("- | - | -".into(), |(t, name, n)| {
                    format!("{name} | {n} | {:.1}", t * 1e6)
                })
            };
            if plain.is_some() || any.is_some() {
                let _ = writeln!(
                    s,
                    "| {} | {decade:.0e} | {} | {} |",
                    o.name,
                    show(plain),
                    show(any)
                );
            }
        }
    }
    if s.is_empty() {
        return s;
    }
    format!(
        "## Fastest to a given weak error\n\nFor each weak error level, the row that reached it with the least run time per path, without and with Richardson-Romberg extrapolation (a level counts when the whole 95% interval of its final-time error, the reference's bias bound included, lies within +-error, and so do those of every finer level of the same row, none of which was lost).\n\n| observable | error <= | scheme | N | us/path | with extrapolation | N | us/path |\n|---|---|---|---|---|---|---|---|\n{s}"
    )
}

fn level_row(observable: &str, row: &WeakScheme, l: &WeakLevel) -> String {
    format!(
        "| {observable} | {} | {} | {:.2e} | {} | {} | {} | {} | {:.1} |\n",
        row.name,
        l.n_steps,
        l.h,
        cell(&l.value),
        cell(&l.error),
        if l.resolved { "yes" } else { "no" },
        l.sup_error.as_ref().map_or("-".into(), cell),
        l.seconds_per_path * 1e6,
    )
}

/// The Markdown summary.
pub fn markdown(report: &WeakReport) -> String {
    let st = &report.settings;
    let r = &report.reference;
    let grid: Vec<String> = report.grid.iter().map(|t| readable(*t)).collect();
    let mut s = format!(
        "# Weak-error study: {}\n\n{}\n\n{} paths, N = 2^{}..2^{}, reference {} with {} steps{} on the same Brownian paths, T = {}, seed {}. Weak errors E[f(X_N)] - E[f(X_T)] with 95% intervals: at T against the exact value where the scene gives one, otherwise against the reference from the per-path differences f(X_N) - f(X_ref), the interval widened by the bound on the reference's own bias; the largest error over the grid always against the reference, over the grid of the coarsest level, t = {}. A level is resolved when |error| is above the half-width of its interval and a normal float (an error that underflowed to zero or a subnormal, the paths agreeing to the last bit, measures the arithmetic: unresolved). Orders are fitted over the resolved levels after the last change of sign of the error, less the coarse levels whose local slope departs from the finer levels' (pre-asymptotic, named); where the local slope still changes between the finest levels, the order's interval holds that bend. Intervals are 95% bootstrap intervals over whole paths. Levels where paths failed or gave values that are not finite are lost (named, left out). Each scheme is followed by its Richardson-Romberg extrapolation 2 E[f(X_(h/2))] - E[f(X_h)] (labelled with the finer N; its run time is both levels').\n\n",
        report.scene,
        report.scene_definition.description,
        report.paths,
        st.coarsest,
        st.finest,
        r.scheme,
        r.n_steps,
        if st.paired_reference {
            format!(
                " (and {} for its extrapolation and bias bound)",
                r.n_steps / 2
            )
        } else {
            String::new()
        },
        readable(report.t_end),
        report.seed,
        grid.join(", "),
    );
    if let Some(qmc) = &report.qmc {
        s += &qmc.describe();
        s += "\n\n";
    }
    for o in &report.observables {
        s += &observable_section(o);
    }
    s += &fastest(report);
    s += "\n## All levels\n\n| observable | scheme | N | h | E[f(X_N)] | error at T | resolved | largest error over the grid | us/path |\n|---|---|---|---|---|---|---|---|---|\n";
    for o in &report.observables {
        for row in &o.schemes {
            for l in &row.levels {
                s += &level_row(&o.name, row, l);
            }
        }
    }
    s += &r.summary(report.paths);
    s += &left_out(&report.skipped);
    s += "\n![weak error against h](weak_error_vs_h.svg)\n\n![weak error against run time](weak_error_vs_time.svg)\n";
    s
}

fn observable_section(o: &ObservableReport) -> String {
    let mut s = format!(
        "## {}\n\nErrors at T against {}; E[f(X_ref)] = {}.\n\n| scheme | weak order at T | weak order of the largest error over the grid | paths | levels lost |\n|---|---|---|---|---|\n",
        o.name,
        basis_text(o),
        o.reference_value.as_ref().map_or("-".into(), cell),
    );
    for row in &o.schemes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            row.name,
            describe_order(row.order.as_ref(), row),
            describe_order(row.sup_order.as_ref(), row),
            row.paths,
            describe_lost(row)
        );
    }
    s += "\n";
    s
}

/// A short table on the terminal: per observable and scheme, its weak orders, its finest level's
/// error and run time.
/// A closed standard output (`| head`) ends the printing, not the caller.
pub fn print_summary(report: &WeakReport) {
    let _ = write_summary(report, &mut std::io::stdout().lock());
}

/// The summary [`print_summary`] prints, written to `out`.
pub fn write_summary(report: &WeakReport, out: &mut impl std::io::Write) -> std::io::Result<()> {
    if let Some(qmc) = &report.qmc {
        writeln!(
            out,
            "randomized QMC: {} randomizations of {} points; intervals rest on {} samples",
            qmc.randomizations, qmc.points, qmc.samples
        )?;
    }
    for o in &report.observables {
        let against = match (o.basis, &o.reference_bias) {
            (Basis::Exact(_), _) => "the exact value".to_string(),
            (Basis::Reference, None) => "the reference".to_string(),
            (Basis::Reference, Some(b)) => format!(
                "the extrapolated reference, bias bound {:.1e} in every interval",
                b.bound
            ),
        };
        writeln!(out, "{} (errors at T against {against})", o.name)?;
        writeln!(
            out,
            "  {:<40} {:>22} {:>22} {:>24} {:>10}",
            "scheme", "weak order", "order of sup", "finest error", "us/path"
        )?;
        for row in &o.schemes {
            let f = |w: Option<&WeakOrder>| w.map_or("-".into(), order_text);
            let finest = row.levels.last();
            writeln!(
                out,
                "  {:<40} {:>22} {:>22} {:>24} {:>10.1}",
                row.name,
                f(row.order.as_ref()),
                f(row.sup_order.as_ref()),
                finest.map_or("-".into(), |l| cell(&l.error)),
                finest.map_or(0.0, |l| l.seconds_per_path * 1e6)
            )?;
            let mut notes = row
                .order
                .as_ref()
                .map_or_else(Vec::new, |o| order_notes(o, row));
            if !row.lost.is_empty() {
                notes.push(format!("lost {}", describe_lost(row)));
            }
            if !notes.is_empty() {
                writeln!(out, "      {}", notes.join("; "))?;
            }
        }
    }
    let r = &report.reference;
    if r.failures > 0 {
        writeln!(
            out,
            "the reference failed on {} of {} paths: they are left out of every error",
            r.failures, report.paths
        )?;
    }
    for skipped in &report.skipped {
        writeln!(out, "left out {}: {}", skipped.name, skipped.reason)?;
    }
    Ok(())
}

/// What the x axis shows.
#[derive(Clone, Copy)]
enum Axis {
    StepSize,
    RunTime,
}

impl Axis {
    /// A level's value on this axis.
    fn of(self, l: &WeakLevel) -> f64 {
        match self {
            Axis::StepSize => l.h,
            Axis::RunTime => l.seconds_per_path,
        }
    }
}

/// One panel per observable: |final-time error| of every row on log-log axes, with 95% error
/// bars; extrapolated rows thin, in the colour of their scheme.
fn draw(report: &WeakReport, path: &Path, axis: Axis) -> Result<(), StudyError> {
    let title = match axis {
        Axis::StepSize => format!("{}: weak error at T against step size", report.scene),
        Axis::RunTime => format!("{}: weak error at T against run time", report.scene),
    };
    let panels = report
        .observables
        .iter()
        .map(|o| observable_panel(o, axis))
        .collect();
    render(&Figure::row(title, panels), path).map(|_| ())
}

/// An observable's panel: every row's |error| against `axis` with its error bars.
fn observable_panel(o: &ObservableReport, axis: Axis) -> Panel {
    Panel {
        title: o.name.clone(),
        x: FigureAxis::log(match axis {
            Axis::StepSize => "h",
            Axis::RunTime => "seconds per path",
        }),
        y: FigureAxis::log("|weak error| at T"),
        series: o.schemes.iter().map(|row| row_series(row, axis)).collect(),
        guides: Vec::new(),
    }
}

/// A row's |error| against `axis`, its 95% interval folded onto |error| (from |error| less
/// the half-width to the largest |bound|); thin if extrapolated.
fn row_series(row: &WeakScheme, axis: Axis) -> Series {
    let points = row
        .levels
        .iter()
        .map(|l| {
            let y = l.error.estimate.abs();
            Point {
                y_bar: Some((
                    y - 0.5 * (l.error.ci_high - l.error.ci_low),
                    upper_bound(&l.error),
                )),
                ..Point::at(axis.of(l), y)
            }
        })
        .collect();
    Series {
        thin: row.extrapolated,
        ..Series::new(row.name.clone(), points)
    }
}

/// Writes `weak.json`, `weak.csv`, `weak.md`, `weak_error_vs_h.svg` and
/// `weak_error_vs_time.svg` into `dir`.
pub fn write_report(report: &WeakReport, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("weak.json"), report)?;
    write_atomically(&dir.join("weak.csv"), &csv(report))?;
    write_atomically(&dir.join("weak.md"), &markdown(report))?;
    draw(report, &dir.join("weak_error_vs_h.svg"), Axis::StepSize)?;
    draw(report, &dir.join("weak_error_vs_time.svg"), Axis::RunTime)
}
