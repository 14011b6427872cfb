//! The report of an expectation (`sdae-study expect`, `sdae.expectation`): which estimator
//! ran and why (the predicted cost of every one), the estimate with its interval and bias
//! estimate, and the time; as JSON, Markdown, CSV and a short summary.

use std::fmt::Write as _;
use std::path::Path;

use super::expectation::SceneExpectation;
use crate::error::StudyError;
use crate::files::{write_atomically, write_json};
use sdae_mlmc::expectation::{CostMeasure, Expectation};

/// The files [`write_expect_report`] writes.
pub const EXPECT_FILES: [&str; 3] = ["report.json", "report.md", "report.csv"];

/// Why each estimator other than the one that ran lost: its predicted cost against the
/// winner's, or why it was not offered.
pub fn reasons(found: &Expectation) -> Vec<String> {
    let Some(winner) = found.prediction(found.method) else {
        return Vec::new();
    };
    let by = found.by;
    found
        .predicted
        .iter()
        .filter(|p| p.method != found.method)
        .map(|p| {
            if !(p.offered && p.cost(by).is_finite()) {
                return format!("{}: {}", p.method, p.note);
            }
            let ratio = p.cost(by) / winner.cost(by);
            let unit = match by {
                CostMeasure::Work => format!("{:.3e} steps", p.work),
                CostMeasure::Seconds => format!("{:.3} s", p.seconds),
            };
            format!(
                "{}: predicted {unit}, {ratio:.1}x the {}'s {by}",
                p.method, found.method
            )
        })
        .collect()
}

/// Which estimator ran and how it was chosen, in words.
fn how(found: &Expectation) -> String {
    if found.asked {
        format!("{} ({}), as asked", found.method.words(), found.method)
    } else {
        format!(
            "{} ({}), the cheapest predicted by {}",
            found.method.words(),
            found.method,
            found.by
        )
    }
}

/// The lines `sdae-study expect` prints: the estimate, the estimator and why, the time.
pub fn summary(e: &SceneExpectation) -> Vec<String> {
    let f = &e.found;
    let w = &f.with_bias;
    let mut lines = vec![
        format!(
            "{}: E[{}(X_T)] = {:.6} [{:.6}, {:.6}] (95% + bias {:.2e}), eps = {:e}, {}",
            e.scene, e.observable, w.estimate, w.ci_low, w.ci_high, f.bias, f.eps, e.scheme
        ),
        format!(
            "  by {} on levels 0..={}{}",
            how(f),
            f.level,
            if f.converged {
                ""
            } else {
                " (the bias estimate still exceeds eps / sqrt(2) at the finest level allowed)"
            }
        ),
    ];
    lines.extend(reasons(f).into_iter().map(|r| format!("  {r}")));
    lines.push(format!(
        "  {:.2} s wall, {:.2} s of all threads; pilot {:.3e} steps, run {:.3e} steps",
        e.wall_seconds, f.seconds, f.test_work, f.work
    ));
    lines
}

/// The table of predicted costs.
fn predictions_table(f: &Expectation, out: &mut String) {
    let winner = f.prediction(f.method).map(|p| p.cost(f.by));
    out.push_str(
        "| estimator | predicted work (steps) | predicted seconds | against the one that ran | \
         finest level | samples per level | rests on |\n|---|---|---|---|---|---|---|\n",
    );
    for p in &f.predicted {
        let against = match winner {
            Some(w) if p.offered && p.cost(f.by).is_finite() => {
                format!("{:.2}x", p.cost(f.by) / w)
            }
            _ => "-".into(),
        };
        let (work, seconds) = if p.offered && p.work.is_finite() {
            (format!("{:.3e}", p.work), format!("{:.3}", p.seconds))
        } else {
            ("-".into(), "-".into())
        };
        let mark = if p.method == f.method { " (ran)" } else { "" };
        let _ = writeln!(
            out,
            "| {}{mark} | {work} | {seconds} | {against} | {} | {:?} | {} |",
            p.method, p.level, p.samples, p.note
        );
    }
}

/// The convergence test and the QMC pilot as tables.
fn pilot_tables(f: &Expectation, out: &mut String) {
    if !f.test.is_empty() {
        out.push_str(
            "\n## Convergence test\n\n| l | samples | mean Y_l | var Y_l | var P_l | seconds \
             per sample |\n|---|---|---|---|---|---|\n",
        );
        for s in &f.test {
            let _ = writeln!(
                out,
                "| {} | {} | {:.3e} | {:.3e} | {:.3e} | {:.3e} |",
                s.level, s.samples, s.mean_y, s.var_y, s.var_p, s.seconds_per_sample
            );
        }
    }
    if !f.quasi_pilot.is_empty() {
        out.push_str(
            "\n## QMC pilot (variances of the means over the randomizations)\n\n| l | points \
             per randomization: V_l, V[mean P_l] | seconds per step |\n|---|---|---|\n",
        );
        for p in &f.quasi_pilot {
            let history: Vec<String> = p
                .history
                .iter()
                .map(|(n, vy, vp)| format!("{n}: {vy:.2e}, {vp:.2e}"))
                .collect();
            let _ = writeln!(
                out,
                "| {} | {} | {:.3e} |",
                p.level,
                history.join("; "),
                p.seconds_per_step
            );
        }
    }
}

/// The report as Markdown.
pub fn markdown(e: &SceneExpectation) -> String {
    let f = &e.found;
    let (w, s) = (&f.with_bias, &f.estimate);
    let mut out = format!(
        "# E[{}(X_T)] of {}\n\n- Scheme {}, T = {}, seed {}, level 0 on 2^{} steps{}, {} \
         threads\n- **Estimate** {:.6} **[{:.6}, {:.6}]** (95% + bias), sampling interval \
         [{:.6}, {:.6}], bias estimate {:.3e}, eps = {:e}\n- Ran {} on levels 0..={}, samples \
         per level {:?}{}\n- Time: {:.2} s wall, {:.2} s of all threads; work {:.3e} steps of \
         pilot and {:.3e} of run\n",
        e.observable,
        e.scene,
        e.scheme,
        e.t_end,
        e.seed,
        e.coarsest,
        if e.antithetic { ", antithetic" } else { "" },
        e.threads,
        w.estimate,
        w.ci_low,
        w.ci_high,
        s.ci_low,
        s.ci_high,
        f.bias,
        f.eps,
        how(f),
        f.level,
        f.samples,
        f.randomizations.map_or(String::new(), |r| format!(
            " (points of each of {r} randomizations)"
        )),
        e.wall_seconds,
        f.seconds,
        f.test_work,
        f.work,
    );
    if let Some(moved) = &e.coarsest_moved {
        let _ = writeln!(out, "- {}", moved.describe());
    }
    if !f.predicted.is_empty() {
        out.push_str("\n## Predicted costs\n\n");
        predictions_table(f, &mut out);
        out.push_str("\n## Why the others lost\n\n");
        for r in reasons(f) {
            let _ = writeln!(out, "- {r}");
        }
    }
    pilot_tables(f, &mut out);
    out
}

/// The report as one CSV row with the predicted work and seconds of every estimator.
pub fn csv(e: &SceneExpectation) -> String {
    let f = &e.found;
    let mut header = String::from(
        "scene,observable,scheme,T,eps,method,asked,by,estimate,ci_low,ci_high,low_with_bias,\
         high_with_bias,bias,level,failed,test_work,work,seconds,wall_seconds",
    );
    let mut row = format!(
        "{},{},{},{:e},{:e},{},{},{},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{:e},{:e},{:e},{:e}",
        e.scene,
        e.observable,
        e.scheme,
        e.t_end,
        f.eps,
        f.method,
        f.asked,
        f.by,
        f.estimate.estimate,
        f.estimate.ci_low,
        f.estimate.ci_high,
        f.with_bias.ci_low,
        f.with_bias.ci_high,
        f.bias,
        f.level,
        f.failed,
        f.test_work,
        f.work,
        f.seconds,
        e.wall_seconds
    );
    for p in &f.predicted {
        let _ = write!(
            header,
            ",predicted_{m}_work,predicted_{m}_seconds",
            m = p.method
        );
        let _ = write!(row, ",{:e},{:e}", p.work, p.seconds);
    }
    format!("{header}\n{row}\n")
}

/// Writes the [`EXPECT_FILES`] into `dir`.
pub fn write_expect_report(e: &SceneExpectation, dir: &Path) -> Result<(), StudyError> {
    write_json(&dir.join("report.json"), e)?;
    write_atomically(&dir.join("report.md"), &markdown(e))?;
    write_atomically(&dir.join("report.csv"), &csv(e))
}
