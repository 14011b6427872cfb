//! The randomized QMC part of an MLMC report ([`QmcReport`]): its Markdown section, its
//! terminal lines and its CSV table.

use std::fmt::Write as _;

use super::cells::{bias_cell, csv_interval, interval, ratio, with_bias};
use super::quasi::{QmcReport, QuasiStandardRun};
use sdae_stats::Interval;

/// "c [low, high]", "c (no interval from two eps)", or "-" (fewer than two eps).
fn exponent(c: Option<&Interval>) -> String {
    match c {
        Some(c) if c.ci_low.is_finite() && c.ci_high.is_finite() => {
            format!("{:.2} [{:.2}, {:.2}]", c.estimate, c.ci_low, c.ci_high)
        }
        Some(c) => format!("{:.2} (no interval from two eps)", c.estimate),
        None => "- (fewer than two eps)".into(),
    }
}

/// The n_l of a run's levels, space-separated.
fn points(row: &super::quasi::QuasiRow) -> String {
    let n: Vec<String> = row
        .run
        .levels
        .iter()
        .map(|q| q.points.to_string())
        .collect();
    n.join(" ")
}

/// The Markdown section: one row per eps, the cost exponents and the single-level run.
pub fn section(qmc: &QmcReport) -> String {
    let mut s = format!(
        "\n## Multilevel quasi-Monte Carlo\n\nR = {} randomizations (scrambled Sobol' points, Brownian bridge), n_0 = {} points per level.\n\n| eps | E[f(X_T)] [95% t over R + bias] | sum V_l | bias est. (alpha) | L | n_l | MLQMC work (steps) | MLMC work (steps) | savings | run (s) | MLMC run (s) |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        qmc.settings.randomizations, qmc.settings.initial_points
    );
    for row in &qmc.runs {
        let e = &row.run;
        let _ = writeln!(
            s,
            "| {:.0e} | {} | {:.2e} | {} | {} | {} | {:.3e} | {:.3e} | {:.1} | {:.3} | {:.3} |",
            e.eps,
            interval(&e.with_bias),
            e.variance,
            bias_cell(e.bias, e.bias_alpha, e.converged),
            e.levels.len() - 1,
            points(row),
            e.work,
            row.mlmc_work,
            row.savings,
            e.seconds,
            row.mlmc_seconds
        );
    }
    let _ = writeln!(
        s,
        "\nCost exponent c of work ~ eps^-c: MLQMC {}, MLMC {}. Per level, the variance of the \
         mean over R randomizations is V_l; the algorithm doubles n_l on the level with the \
         largest V_l / (C_l n_l) until sum V_l <= eps^2 / 2.",
        exponent(qmc.cost_exponent.as_ref()),
        exponent(qmc.mlmc_cost_exponent.as_ref())
    );
    s += &levels_table(qmc);
    let _ = writeln!(s, "\n{}", coordinates_line(qmc));
    if let Some(d) = &qmc.standard {
        let _ = writeln!(s, "\n{}", standard_line(d));
    }
    s
}

/// The levels of the run at the smallest eps: n_l, the mean of Y_l, V_l (the variance of its
/// mean over the R randomizations) and R V_l (the variance per randomization).
fn levels_table(qmc: &QmcReport) -> String {
    let Some(row) = qmc
        .runs
        .iter()
        .min_by(|a, b| a.run.eps.total_cmp(&b.run.eps))
    else {
        return String::new();
    };
    let mut s = format!(
        "\nLevels of the run at eps = {:.0e}:\n\n| l | n_l | mean Y_l | V_l | R V_l (per randomization) | work (steps) | failed |\n|---|---|---|---|---|---|---|\n",
        row.run.eps
    );
    for q in &row.run.levels {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4e} | {:.3e} | {:.3e} | {:.3e} | {} |",
            q.level, q.points, q.mean, q.variance, q.variance_per_randomization, q.work, q.failed
        );
    }
    s
}

/// How many coordinates of a path were quasi-random, level by level.
pub fn coordinates_line(qmc: &QmcReport) -> String {
    let padded: Vec<String> = qmc
        .coordinates
        .iter()
        .filter(|c| c.quasi < c.coordinates)
        .map(|c| format!("level {}: {} of {}", c.level, c.quasi, c.coordinates))
        .collect();
    match (qmc.coordinates.last(), padded.is_empty()) {
        (None, _) => "Coordinates per path: not known for this sampler.".into(),
        (Some(c), true) => format!(
            "Every coordinate of every path is quasi-random (up to {} per path on level {}).",
            c.coordinates, c.level
        ),
        (Some(_), false) => format!(
            "Quasi-random coordinates per path where a path takes more than the Sobol' \
             dimensions (the rest are pseudo-random padding): {}.",
            padded.join(", ")
        ),
    }
}

/// What the direct single-level randomized QMC run did.
pub fn standard_line(d: &QuasiStandardRun) -> String {
    format!(
        "Direct single-level randomized QMC on level {} ({} randomizations of {} points, {} \
         failed): {} at eps = {:.2e} (asked {:.0e}) in {:.3e} steps, {:.3} s; \
         standard Monte Carlo needs {:.3e} steps for that accuracy: {}.",
        d.level.level,
        d.level.randomizations.len(),
        d.level.points,
        d.level.failed,
        with_bias(&d.with_bias, d.bias),
        d.eps,
        d.target_eps,
        d.work,
        d.seconds,
        d.standard_work,
        ratio(d.savings)
    )
}

/// The lines the terminal summary prints.
pub fn summary_lines(qmc: &QmcReport) -> Vec<String> {
    let mut out: Vec<String> = qmc
        .runs
        .iter()
        .map(|row| {
            let e = &row.run;
            format!(
                "MLQMC eps {:.0e}: {}, L = {}, n_l = [{}] x R = {}, work {:.3e} \
                 steps (MLMC's over it: {:.1}x), {:.3} s",
                e.eps,
                with_bias(&e.with_bias, e.bias),
                e.levels.len() - 1,
                points(row),
                e.randomizations,
                e.work,
                row.savings,
                e.seconds
            )
        })
        .collect();
    out.push(format!(
        "cost exponent: MLQMC {}, MLMC {}",
        exponent(qmc.cost_exponent.as_ref()),
        exponent(qmc.mlmc_cost_exponent.as_ref())
    ));
    out.push(coordinates_line(qmc));
    out.extend(qmc.standard.as_ref().map(standard_line));
    out
}

/// The CSV table of the MLQMC runs, one row per eps (after a blank line).
pub fn csv(qmc: &QmcReport) -> String {
    let mut s = String::from(
        "\nmlqmc_eps,estimate,ci_low,ci_high,low_with_bias,high_with_bias,variance,bias,bias_alpha,converged,levels,points,randomizations,failed,work,mlmc_work,savings,seconds\n",
    );
    for row in &qmc.runs {
        let e = &row.run;
        let failed: Vec<String> = e.levels.iter().map(|q| q.failed.to_string()).collect();
        let _ = writeln!(
            s,
            "{:e},{},{:e},{:e},{:e},{},{},{},{},{},{:e},{:e},{:e},{:e}",
            e.eps,
            csv_interval(&e.estimate),
            e.variance,
            e.bias,
            e.bias_alpha,
            e.converged,
            e.levels.len(),
            points(row),
            e.randomizations,
            failed.join(" "),
            e.work,
            row.mlmc_work,
            row.savings,
            e.seconds
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mlmc::quasi::PathCoordinates;
    use crate::mlmc::run_settings::QmcSettings;

    /// Levels whose paths take more coordinates than the Sobol' dimensions are named with how
    /// many were quasi-random.
    #[test]
    fn padded_levels_are_named_with_their_quasi_random_count() {
        let level = |level, coordinates: u64| PathCoordinates {
            level,
            coordinates,
            quasi: coordinates.min(21_201),
        };
        let mut qmc = QmcReport {
            settings: QmcSettings::default(),
            coordinates: vec![level(0, 15_360), level(1, 30_720)],
            runs: Vec::new(),
            cost_exponent: None,
            mlmc_cost_exponent: None,
            standard: None,
        };
        let line = coordinates_line(&qmc);
        assert!(line.contains("level 1: 21201 of 30720"), "{line}");
        assert!(!line.contains("level 0"), "{line}");
        qmc.coordinates.pop();
        assert!(coordinates_line(&qmc).starts_with("Every coordinate"));
        qmc.coordinates.clear();
        assert!(coordinates_line(&qmc).contains("not known"));
    }
}
