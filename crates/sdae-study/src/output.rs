//! The files of a convergence report: JSON (the whole report), CSV (one row per scheme and step
//! size), a Markdown summary (settings, tables, orders, which scheme reaches an error fastest,
//! plots) and the SVG plots.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use crate::convergence::{ConvergenceReport, Errors, LevelReport, ReferenceReport};
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use crate::parallel::Skipped;
use sdae_stats::Interval;
use sdae_stats::{INDICATIVE_BELOW, OrderFit};

fn fmt_interval(i: Option<Interval>) -> [String; 3] {
    match i {
        Some(i) => [i.estimate, i.ci_low, i.ci_high].map(|x| format!("{x:e}")),
        None => [String::new(), String::new(), String::new()],
    }
}

/// One row per scheme and step size.
pub fn csv(report: &ConvergenceReport) -> String {
    let mut s = String::from(
        "scheme,n_steps,h,error_r,error_r_low,error_r_high,error_v,error_v_low,error_v_high,error_mu,error_mu_low,error_mu_high,seconds_per_path,steps_per_second,failures,truncated_fraction,newton_iterations_per_step,homotopy_steps,rounding_certified_steps,max_position_residual,max_velocity_residual\n",
    );
    for scheme in &report.schemes {
        for l in &scheme.levels {
            let e = &l.error;
            let cells: Vec<String> = [e.r, e.v, e.mu]
                .into_iter()
                .flat_map(fmt_interval)
                .collect();
            let _ = writeln!(
                s,
                "{},{},{:e},{},{:e},{:e},{},{},{},{},{},{:e},{:e}",
                scheme.name,
                l.n_steps,
                l.h,
                cells.join(","),
                l.seconds_per_path,
                l.steps_per_second,
                l.failures,
                l.truncated_fraction,
                l.newton_iterations_per_step,
                l.homotopy_steps,
                l.rounding_certified_steps,
                l.max_position_residual,
                l.max_velocity_residual
            );
        }
    }
    s
}

/// A number as people read it: plain for moderate magnitudes, in exponent form otherwise
/// (`1e300`, not 301 digits; `2.5e-7`).
pub fn readable(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() || (1e-4..1e6).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A Markdown paragraph per scheme left out, with the reason.
pub fn left_out(skipped: &[Skipped]) -> String {
    skipped
        .iter()
        .map(|x| format!("\nLeft out: {}: {}.\n", x.name, x.reason))
        .collect()
}

/// "order [low, high]", the pre-asymptotic levels left out, the fitted levels where the
/// error curve still bends beyond the Monte Carlo error, and "indicative" when the intervals
/// come from too few paths to hold their 95%.
pub fn describe_fit(fit: &OrderFit) -> String {
    let o = &fit.order;
    let mut flags = Vec::new();
    if fit.indicative {
        flags.push(format!(
            "indicative: {:.0} effective paths",
            fit.effective_paths
        ));
    }
    if !fit.pre_asymptotic.is_empty() {
        flags.push(format!(
            "{} coarse level(s) pre-asymptotic",
            fit.pre_asymptotic.len()
        ));
    }
    if !fit.curvature.is_empty() {
        flags.push(format!("curved at {} level(s)", fit.curvature.len()));
    }
    let flagged = if flags.is_empty() {
        String::new()
    } else {
        format!(" ({})", flags.join("; "))
    };
    format!(
        "{:.2} [{:.2}, {:.2}]{flagged}",
        o.estimate, o.ci_low, o.ci_high
    )
}

fn cell(i: Option<Interval>) -> String {
    match i {
        Some(i) if i.estimate.is_finite() => {
            format!("{:.2e} [{:.1e}, {:.1e}]", i.estimate, i.ci_low, i.ci_high)
        }
        Some(_) => "n/a".into(),
        None => "-".into(),
    }
}

type Pick = fn(&Errors) -> Option<Interval>;

const PICKS: [(&str, Pick); 3] = [("r", |e| e.r), ("v", |e| e.v), ("mu", |e| e.mu)];

/// For each component and each decade of error that some scheme reaches: the scheme that
/// reaches it with the least run time per path (over the levels measured, no interpolation).
fn fastest(report: &ConvergenceReport) -> String {
    let mut s = String::new();
    for (name, pick) in PICKS {
        let reached = |target: f64| {
            report
                .schemes
                .iter()
                .filter_map(|scheme| {
                    scheme
                        .levels
                        .iter()
                        .filter(|l| pick(&l.error).is_some_and(|e| e.estimate <= target))
                        .map(|l| (l.seconds_per_path, l))
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .map(|(t, l)| (t, scheme.name.as_str(), l.n_steps))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
        };
        let errors = report
            .schemes
            .iter()
            .flat_map(|sc| sc.levels.iter().filter_map(|l| pick(&l.error)))
            .map(|e| e.estimate);
        for decade in decades(errors) {
            if let Some((t, scheme, n)) = reached(decade) {
                let _ = writeln!(
                    s,
                    "| {name} | {decade:.0e} | {scheme} | {n} | {:.1} |",
                    t * 1e6
                );
            }
        }
    }
    if s.is_empty() {
        return s;
    }
    format!(
        "## Fastest to a given error\n\nFor each error level, the scheme that reached it with the least run time per path (over the step sizes measured).\n\n| component | error <= | scheme | N | us/path |\n|---|---|---|---|---|\n{s}"
    )
}

/// The powers of ten between the smallest and the largest of `values` (finite and positive
/// ones; none without any), from the largest down: the error levels of a "fastest to a given
/// error" table, each reached by some value.
pub fn decades(values: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let values: Vec<f64> = values
        .into_iter()
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    let (Some(lo), Some(hi)) = (
        values.iter().copied().reduce(f64::min),
        values.iter().copied().reduce(f64::max),
    ) else {
        return Vec::new();
    };
    let mut decade = 10f64.powf(hi.log10().floor());
    let mut out = Vec::new();
    while decade >= lo {
        out.push(decade);
        decade /= 10.0;
    }
    out
}

/// The share of truncated steps as a table cell, marked "stable but biased" above
/// [`TRUNCATION_DOMINATED`](sdae_model::TRUNCATION_DOMINATED).
pub fn truncated_cell(fraction: f64) -> String {
    if fraction > sdae_model::TRUNCATION_DOMINATED {
        format!("{:.1}% (stable but biased)", 100.0 * fraction)
    } else {
        format!("{:.1}%", 100.0 * fraction)
    }
}

fn level_row(scheme: &str, l: &LevelReport) -> String {
    let e = &l.error;
    let marked = |i: Option<Interval>, name: &str| {
        let mark = if e.indicative.contains(&name) {
            "*"
        } else {
            ""
        };
        format!("{}{mark}", cell(i))
    };
    format!(
        "| {scheme} | {} | {:.2e} | {} | {} | {} | {:.1} | {} | {} | {:.2} | {:.1e} |\n",
        l.n_steps,
        l.h,
        marked(e.r, "r"),
        marked(e.v, "v"),
        marked(e.mu, "mu"),
        l.seconds_per_path * 1e6,
        l.failures,
        truncated_cell(l.truncated_fraction),
        l.newton_iterations_per_step,
        l.max_position_residual,
    )
}

/// The Markdown summary.
pub fn markdown(report: &ConvergenceReport) -> String {
    let mut s = heading(report);
    s += &orders_section(report);
    s += "\n";
    s += &fastest(report);
    s += &levels_section(report);
    s += &footnotes(report);
    s += "\n![error against h](error_vs_h.svg)\n\n![error against run time](error_vs_time.svg)\n";
    s
}

/// The title, the scene's description and one paragraph of the study's settings.
fn heading(report: &ConvergenceReport) -> String {
    let st = &report.settings;
    let reference = match &report.reference {
        Some(r) => format!(
            "reference: {} with {} steps on the same Brownian paths",
            r.scheme, r.n_steps
        ),
        None => "no reference".into(),
    };
    format!(
        "# Convergence study: {}\n\n{}\n\n{} paths, N = 2^{}..2^{}, {reference}, T = {}, seed {}; errors are the L^{} norm over paths of the sup over the grid, with 95% confidence intervals.\n\n",
        report.scene,
        report.scene_definition.description,
        report.paths,
        st.coarsest,
        st.finest,
        readable(report.t_end),
        report.seed,
        report.p,
    )
}

/// The observed orders per scheme and the levels left out of the fits as truncation-dominated.
fn orders_section(report: &ConvergenceReport) -> String {
    let mut s = String::from("## Observed orders (95% intervals)\n\n");
    if any_indicative(report) {
        let _ = write!(
            s,
            "Intervals marked indicative rest on fewer than {INDICATIVE_BELOW} effective paths (errors too heavy-tailed for the paths run, or a degenerate bootstrap): their coverage falls short of 95%.\n\n"
        );
    }
    s += "| scheme | r | v | mu |\n|---|---|---|---|\n";
    for scheme in &report.schemes {
        let o = &scheme.observed_order;
        let f = |fit: &Option<OrderFit>| fit.as_ref().map_or("-".into(), describe_fit);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            scheme.name,
            f(&o.r),
            f(&o.v),
            f(&o.mu)
        );
    }
    for scheme in &report.schemes {
        if !scheme.unresolved.is_empty() {
            let levels: Vec<String> = scheme
                .unresolved
                .iter()
                .map(|u| {
                    format!(
                        "{} at N = {} (error {:e})",
                        u.output, scheme.levels[u.level].n_steps, u.error
                    )
                })
                .collect();
            let _ = writeln!(
                s,
                "\nNot fitted, unresolved (the error underflowed to zero or a subnormal float, or \
                 lies within 64 roundings of the state it measures: the arithmetic is measured, \
                 not the scheme): {}: {}.",
                scheme.name,
                levels.join("; ")
            );
        }
        if !scheme.not_fitted_truncated.is_empty() {
            let levels: Vec<String> = scheme
                .not_fitted_truncated
                .iter()
                .map(|&j| scheme.levels[j].n_steps.to_string())
                .collect();
            let _ = writeln!(
                s,
                "\nNot fitted, truncation-dominated (stable but biased): {} at N = {}.",
                scheme.name,
                levels.join(", ")
            );
        }
    }
    s
}

/// The table of every scheme and level.
fn levels_section(report: &ConvergenceReport) -> String {
    let mut s = String::from(
        "\n## All levels\n\n| scheme | N | h | error r | error v | error mu | us/path | failures | truncated | Newton it./step | max abs g |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for scheme in &report.schemes {
        for l in &scheme.levels {
            s += &level_row(&scheme.name, l);
        }
    }
    s
}

/// The notes below the levels: indicative errors, the reference's failures and run time, the
/// schemes left out.
fn footnotes(report: &ConvergenceReport) -> String {
    let mut s = String::new();
    if report
        .schemes
        .iter()
        .any(|scheme| scheme.levels.iter().any(|l| !l.error.indicative.is_empty()))
    {
        let _ = writeln!(
            s,
            "\n\\* indicative: the error rests on fewer than {INDICATIVE_BELOW} effective paths (a few heavy paths make up the mean of d^p); its interval's coverage falls short of 95%."
        );
    }
    if let Some(r) = &report.reference {
        s += &r.summary(report.paths);
    }
    s += &left_out(&report.skipped);
    s
}

/// Whether some order fit of the report is indicative only.
fn any_indicative(report: &ConvergenceReport) -> bool {
    report.schemes.iter().any(|scheme| {
        let o = &scheme.observed_order;
        [&o.r, &o.v, &o.mu]
            .into_iter()
            .flatten()
            .any(|fit| fit.indicative)
    })
}

/// A short table on the terminal: per scheme, its orders and its finest level.
/// A closed standard output (`| head`) ends the printing, not the caller.
pub fn print_summary(report: &ConvergenceReport) {
    let _ = write_summary(report, &mut std::io::stdout().lock());
}

/// The summary [`print_summary`] prints, written to `out`.
pub fn write_summary(
    report: &ConvergenceReport, out: &mut impl std::io::Write,
) -> std::io::Result<()> {
    write_scheme_lines(report, out)?;
    let unresolved: usize = report.schemes.iter().map(|s| s.unresolved.len()).sum();
    if unresolved > 0 {
        // On standard error, as every note; a closed stream ends the note only.
        let _ = writeln!(
            &mut std::io::stderr(),
            "note: {unresolved} error(s) underflowed or lie at the rounding level of their state \
             and are not fitted (unresolved: see report.md)"
        );
    }
    if any_indicative(report) {
        writeln!(
            out,
            "* indicative: fewer than {INDICATIVE_BELOW} effective paths (errors too heavy-tailed for the paths run, or a degenerate bootstrap); the interval's coverage falls short of 95%"
        )?;
    }
    write_biased(report, out)?;
    if let Some(r) = &report.reference {
        write_reference_line(r, report.paths, out)?;
    }
    for skipped in &report.skipped {
        writeln!(out, "left out {}: {}", skipped.name, skipped.reason)?;
    }
    Ok(())
}

/// An order's cell of the summary: its estimate and interval, starred where indicative, or
/// `-` without a fit.
fn order_cell(fit: &Option<OrderFit>) -> String {
    fit.as_ref().map_or("-".into(), |f| {
        format!(
            "{:.2} [{:.2}, {:.2}]{}",
            f.order.estimate,
            f.order.ci_low,
            f.order.ci_high,
            if f.indicative { "*" } else { "" }
        )
    })
}

/// The summary's header line and one line per scheme: its orders, run time per path at the
/// finest level and failures.
fn write_scheme_lines(
    report: &ConvergenceReport, out: &mut impl std::io::Write,
) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<28} {:>22} {:>22} {:>22} {:>10} {:>6}",
        "scheme", "order r", "order v", "order mu", "us/path", "fail"
    )?;
    for scheme in &report.schemes {
        let o = &scheme.observed_order;
        let finest = scheme.levels.last();
        writeln!(
            out,
            "{:<28} {:>22} {:>22} {:>22} {:>10.1} {:>6}",
            scheme.name,
            order_cell(&o.r),
            order_cell(&o.v),
            order_cell(&o.mu),
            finest.map_or(0.0, |l| l.seconds_per_path * 1e6),
            scheme.levels.iter().map(|l| l.failures).sum::<usize>()
        )?;
    }
    Ok(())
}

/// One line per scheme that is stable but biased at some levels, naming those levels.
fn write_biased(report: &ConvergenceReport, out: &mut impl std::io::Write) -> std::io::Result<()> {
    for scheme in &report.schemes {
        let biased: Vec<String> = scheme
            .levels
            .iter()
            .filter(|l| l.stable_but_biased)
            .map(|l| l.n_steps.to_string())
            .collect();
        if !biased.is_empty() {
            writeln!(
                out,
                "stable but biased: {} is truncated on more than {:.0}% of the steps at N = {}",
                scheme.name,
                100.0 * sdae_model::TRUNCATION_DOMINATED,
                biased.join(", ")
            )?;
        }
    }
    Ok(())
}

/// The reference's line of the summary, and the paths it failed on (of `paths`) if any.
fn write_reference_line(
    r: &ReferenceReport, paths: usize, out: &mut impl std::io::Write,
) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<28} {:>22} {:>22} {:>22} {:>10.1} {:>6}",
        format!("ref {}", r.scheme),
        "-",
        "-",
        "-",
        r.seconds_per_path * 1e6,
        r.failures
    )?;
    if r.failures > 0 {
        writeln!(
            out,
            "the reference failed on {} of {} paths ({}): they are left out of every error",
            r.failures,
            paths,
            r.failures_by_kind
                .iter()
                .map(|(kind, n)| format!("{kind} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
    }
    Ok(())
}

/// Writes `report.json`, `report.csv`, `report.md`, `error_vs_h.svg` and `error_vs_time.svg`
/// into `dir` (one folder per scene).
pub fn write_report(report: &ConvergenceReport, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), report)?;
    write_atomically(&dir.join("report.csv"), &csv(report))?;
    write_atomically(&dir.join("report.md"), &markdown(report))?;
    crate::plots::write_plots(report, dir)
}

#[cfg(test)]
mod tests {
    use super::{decades, describe_fit, readable};
    use sdae_stats::Interval;
    use sdae_stats::OrderFit;

    #[test]
    fn decades_run_from_the_largest_value_down_to_the_smallest() {
        let d = decades([0.03, 2e-4, f64::NAN, -1.0, 0.0, f64::INFINITY]);
        assert_eq!(d.len(), 2, "{d:?}");
        for (got, want) in d.iter().zip([1e-2, 1e-3]) {
            assert!((got / want - 1.0).abs() < 1e-12, "{d:?}");
        }
        assert!(decades([f64::NAN, 0.0]).is_empty());
        assert_eq!(decades([5.0, 0.5]), vec![1.0]);
        assert!(decades([5.0]).is_empty());
    }

    #[test]
    fn indicative_fits_say_so() {
        let order = Interval {
            estimate: 1.0,
            ci_low: 0.9,
            ci_high: 1.2,
        };
        let mut fit = OrderFit {
            order,
            fitted: vec![0, 1, 2],
            pre_asymptotic: Vec::new(),
            local_slopes: Vec::new(),
            curvature: Vec::new(),
            effective_paths: 150.0,
            indicative: false,
        };
        assert_eq!(describe_fit(&fit), "1.00 [0.90, 1.20]");
        fit.indicative = true;
        fit.effective_paths = 6.4;
        assert_eq!(
            describe_fit(&fit),
            "1.00 [0.90, 1.20] (indicative: 6 effective paths)"
        );
        let json = serde_json::to_string(&fit).unwrap();
        assert!(json.contains("\"indicative\":true"), "{json}");
    }

    #[test]
    fn numbers_read_as_people_write_them() {
        assert_eq!(readable(1e300), "1e300");
        assert_eq!(readable(2.5e-7), "2.5e-7");
        assert_eq!(readable(1.0), "1");
        assert_eq!(readable(256.0), "256");
        assert_eq!(readable(0.0), "0");
    }
}
