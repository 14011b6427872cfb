//! The files of an MLMC report: JSON (the whole report), CSV (the convergence test, one row
//! per level, then the complexity table, one row per eps), a Markdown summary laid out as
//! Giles's `mlmc_test` prints it, and the SVG plots.

use std::fmt::Write as _;
use std::path::Path;

use super::cells::{LevelColumn, bias_cell, csv_interval, interval, level_table, ratio, with_bias};
use super::quasi_report;
use super::rows::StandardRun;
use super::study::MlmcReport;
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use crate::output::readable;
use sdae_mlmc::fit::Rates;
use sdae_stats::Interval;

/// "estimate [low, high]", or "-".
pub fn describe(i: Option<&Interval>) -> String {
    i.map_or("-".into(), |i| {
        format!("{:.3} [{:.3}, {:.3}]", i.estimate, i.ci_low, i.ci_high)
    })
}

/// The convergence test (`table,level,...`) and the complexity table (`complexity,eps,...`).
pub fn csv(report: &MlmcReport) -> String {
    let mut s = String::from(
        "level,steps,samples,failed_fine,failed_coarse,mean_dp,var_dp,mean_p,var_p,kurtosis,consistency,work_per_sample,seconds_per_sample\n",
    );
    for l in &report.test {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{},{:e}",
            l.level,
            l.steps,
            l.samples,
            l.failed_fine,
            l.failed_coarse,
            l.mean_y,
            l.var_y,
            l.mean_p,
            l.var_p,
            l.kurtosis,
            l.consistency,
            l.work_per_sample,
            l.seconds_per_sample
        );
    }
    s.push_str("\neps,estimate,ci_low,ci_high,low_with_bias,high_with_bias,bias,bias_alpha,converged,levels,samples,failed,mlmc_work,standard_work,savings,mlmc_cost,standard_cost,seconds\n");
    for row in &report.complexity {
        let r = &row.run;
        let joined = |v: Vec<u64>| v.iter().map(u64::to_string).collect::<Vec<_>>().join(" ");
        let _ = writeln!(
            s,
            "{:e},{},{:e},{:e},{:e},{:e},{},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e}",
            r.eps,
            csv_interval(&r.estimate),
            r.with_bias.ci_low,
            r.with_bias.ci_high,
            r.bias,
            r.bias_alpha,
            r.converged,
            row.samples.len(),
            joined(row.samples.clone()),
            joined(r.levels.iter().map(|l| l.failed).collect()),
            row.mlmc_work,
            row.standard_work,
            row.savings,
            row.mlmc_cost,
            row.standard_cost,
            r.seconds
        );
    }
    if let Some(qmc) = &report.qmc {
        s += &quasi_report::csv(qmc);
    }
    s
}

/// The Markdown summary.
pub fn markdown(report: &MlmcReport) -> String {
    let mut s = heading(report);
    s += &test_section(report);
    s += &complexity_section(report);
    if let Some(qmc) = &report.qmc {
        s += &quasi_report::section(qmc);
    }
    s += &warnings(report);
    s.push_str("\n![variance and mean per level](levels.svg)\n\n![N_l per eps](samples.svg)\n\n![eps^2 cost against eps](cost.svg)\n");
    if report.qmc.is_some() {
        s.push_str("\n![MLQMC: n_l and variance per randomization per level](mlqmc.svg)\n");
    }
    s
}

/// The title and one paragraph of the run's settings.
fn heading(report: &MlmcReport) -> String {
    let st = &report.settings;
    let mut s = format!(
        "# MLMC: {} ({}, E[{}(X_T)])\n\n",
        report.scene, report.scheme, report.observable
    );
    let _ = writeln!(
        s,
        "T = {}, level 0 on 2^{} steps, refinement factor 2, {}antithetic, seed {}, {} threads.\n",
        readable(st.t_end),
        st.spec.coarsest,
        if st.spec.antithetic { "" } else { "not " },
        st.seed,
        st.threads
    );
    s
}

/// The convergence test: one row per level, then the fitted rates and the unresolved levels.
fn test_section(report: &MlmcReport) -> String {
    let st = &report.settings;
    let mut s = String::from("## Convergence test\n\n");
    let _ = writeln!(
        s,
        "{} samples per level; Y_l = P_l - P_l-1 (Y_0 = P_0).\n",
        st.spec.test_samples
    );
    use LevelColumn::*;
    let columns = [
        Level, Steps, MeanY, VarY, MeanP, VarP, Kurtosis, Check, Work, Seconds, Failed,
    ];
    s += &level_table(&columns, &report.test);
    s.push('\n');
    for line in rates_lines(&report.rates) {
        let _ = writeln!(s, "{line}");
    }
    s
}

/// The levels of a list, "1, 2".
fn listed(levels: &[u32]) -> String {
    levels
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The fitted rates and the levels left out of them, one sentence a line (the Markdown
/// report and the terminal).
pub fn rates_lines(r: &Rates) -> Vec<String> {
    let mut lines = vec![format!(
        "Rates over levels l >= {} (95% intervals): alpha = {}, beta = {}, gamma = {} from the \
         work per sample in steps (measured seconds per sample: {}).",
        r.from_level,
        describe(r.alpha.as_ref()),
        describe(r.beta.as_ref()),
        describe(r.gamma.as_ref()),
        describe(r.gamma_seconds.as_ref())
    )];
    for (rate, levels) in [
        ("alpha", &r.alpha_pre_asymptotic),
        ("beta", &r.beta_pre_asymptotic),
    ] {
        if !levels.is_empty() {
            lines.push(format!(
                "Pre-asymptotic levels left out of {rate}: {} (their local slope departs from the \
                 finer levels' beyond the Monte Carlo error and by more than {}).",
                listed(levels),
                sdae_stats::PRE_ASYMPTOTIC_TOLERANCE
            ));
        }
    }
    if !r.unresolved.is_empty() {
        lines.push(format!(
            "Unresolved levels left out of alpha (|mean Y_l| below two standard errors): {}.",
            listed(&r.unresolved)
        ));
    }
    for out in &r.left_out {
        lines.push(format!(
            "Level {} left out of every rate: {}.",
            out.level, out.reason
        ));
    }
    lines
}

/// The complexity table, one row per eps, and the direct standard Monte Carlo run if any.
fn complexity_section(report: &MlmcReport) -> String {
    let mut s = String::from(
        "\n## Complexity\n\n| eps | E[f(X_T)] [95% + bias] | bias est. (alpha) | L | N_l | MLMC work (steps) | standard MC work (steps) | savings | MLMC cost (s) | standard MC cost (s) | run (s) |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for row in &report.complexity {
        let e = &row.run;
        let n: Vec<String> = row.samples.iter().map(u64::to_string).collect();
        let _ = writeln!(
            s,
            "| {:.0e} | {} | {} | {} | {} | {:.3e} | {:.3e} | {:.1} | {:.3e} | {:.3e} | {:.3} |",
            e.eps,
            interval(&e.with_bias),
            bias_cell(e.bias, e.bias_alpha, e.converged),
            row.samples.len() - 1,
            n.join(" "),
            row.mlmc_work,
            row.standard_work,
            row.savings,
            row.mlmc_cost,
            row.standard_cost,
            e.seconds
        );
    }
    s.push_str(
        "\nWork in steps from the work per sample (the savings); costs in seconds from the \
         convergence test's measured seconds per sample, beside it. Standard Monte Carlo needs \
         2 V[P_L] / eps^2 paths on the finest level L of the MLMC run. The bias estimate raises \
         each of the last means by its standard error and takes alpha at the low end of its \
         interval over the asymptotic levels. Every interval for E[f(X_T)] is the 95% sampling \
         interval of E[P_L] widened by that bias estimate on each side (95% + bias).\n",
    );
    if let Some(d) = &report.standard {
        let _ = writeln!(s, "\n{}", standard_line(d));
    }
    s
}

/// What the direct standard Monte Carlo run did, with its cap.
pub fn standard_line(d: &StandardRun) -> String {
    let capped = d.eps > d.target_eps;
    let (accuracy, scaled) = if capped {
        (
            format!(
                "at eps = {:.0e} it would need {:.3e} steps (predicted {:.1} s), above the cap, so \
                 it ran at eps = {:.2e}",
                d.target_eps, d.target_work, d.predicted_seconds, d.eps
            ),
            format!(
                "; scaled by (eps_run / eps)^2 to eps = {:.0e}: {:.3} s",
                d.target_eps,
                d.seconds * (d.eps / d.target_eps).powi(2)
            ),
        )
    } else {
        (format!("at eps = {:.0e}", d.eps), String::new())
    };
    format!(
        "Direct standard Monte Carlo (cap: the MLMC part's work, {:.3e} steps, predicted {:.1} s): \
         {accuracy} on level {} ({} paths, {} failed): {} in {:.3} s{scaled}, \
         against {:.3} s for MLMC (seconds of all threads together, which bound the wall-clock \
         time): {}.",
        d.cap_work,
        d.cap_seconds,
        d.level,
        d.samples,
        d.failed,
        with_bias(&d.with_bias, d.bias),
        d.seconds,
        d.mlmc_seconds,
        ratio(d.speedup)
    )
}

/// The run's warnings as a list, or nothing without any.
fn warnings(report: &MlmcReport) -> String {
    let mut s = String::new();
    if !report.warnings.is_empty() {
        s.push_str("\n## Warnings\n\n");
        for w in &report.warnings {
            let _ = writeln!(s, "- {w}");
        }
    }
    s
}

/// Prints the rates and the complexity table on the terminal.
/// A closed standard output (`| head`) ends the printing, not the caller.
pub fn print_summary(report: &MlmcReport) {
    let _ = write_summary(report, &mut std::io::stdout().lock());
}

/// The summary [`print_summary`] prints, written to `out`.
pub fn write_summary(report: &MlmcReport, out: &mut impl std::io::Write) -> std::io::Result<()> {
    writeln!(
        out,
        "{} ({}, E[{}]):",
        report.scene, report.scheme, report.observable
    )?;
    for line in rates_lines(&report.rates) {
        writeln!(out, "  {line}")?;
    }
    for row in &report.complexity {
        let e = &row.run;
        writeln!(
            out,
            "  eps {:.0e}: {} (95% + bias), bias est. {:.2e} (alpha {:.2}), L = {}, \
             N_l = {:?}, work {:.3e} steps, savings {:.1}x, {:.3} s",
            e.eps,
            interval(&e.with_bias),
            e.bias,
            e.bias_alpha,
            row.samples.len() - 1,
            row.samples,
            row.mlmc_work,
            row.savings,
            e.seconds
        )?;
    }
    if let Some(d) = &report.standard {
        writeln!(out, "  {}", standard_line(d))?;
    }
    if let Some(qmc) = &report.qmc {
        for line in quasi_report::summary_lines(qmc) {
            writeln!(out, "  {line}")?;
        }
    }
    for w in &report.warnings {
        writeln!(out, "  warning: {w}")?;
    }
    Ok(())
}

/// The files [`write_report`] writes for every study (with `--qmc` also `mlqmc.svg`).
pub const REPORT_FILES: [&str; 6] = [
    "report.json",
    "report.csv",
    "report.md",
    "levels.svg",
    "samples.svg",
    "cost.svg",
];

/// Writes the [`REPORT_FILES`] (and with `--qmc` `mlqmc.svg`) into `dir`.
pub fn write_report(report: &MlmcReport, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), report)?;
    write_atomically(&dir.join("report.csv"), &csv(report))?;
    write_atomically(&dir.join("report.md"), &markdown(report))?;
    super::plots::write_plots(report, dir)
}

#[cfg(test)]
mod tests {
    use sdae_mlmc::fit::LeftOut;
    use sdae_stats::Interval;

    use super::*;

    #[test]
    fn the_rates_name_the_levels_left_out_and_why() {
        let rate = |x: f64| Interval {
            estimate: x,
            ci_low: x - 0.1,
            ci_high: x + 0.1,
        };
        let rates = Rates {
            alpha: Some(rate(1.0)),
            beta: Some(rate(2.0)),
            gamma: Some(rate(1.0)),
            gamma_seconds: None,
            from_level: 1,
            unresolved: vec![],
            alpha_pre_asymptotic: vec![],
            beta_pre_asymptotic: vec![1, 2],
            left_out: vec![LeftOut {
                level: 3,
                reason: "3 fine paths failed".into(),
            }],
        };
        let lines = rates_lines(&rates).join("\n");
        assert!(lines.contains("left out of beta: 1, 2"), "{lines}");
        assert!(!lines.contains("left out of alpha"), "{lines}");
        assert!(
            lines.contains("Level 3 left out of every rate: 3 fine paths failed."),
            "{lines}"
        );
    }
}
