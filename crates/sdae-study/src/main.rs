//! `sdae-study`: the convergence study of the stochastic pendulum (run by `cargo xtask study`).

use std::path::PathBuf;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_study::stats::OrderFit;
use sdae_study::{PendulumStudy, StudyReport, pendulum_study};

const USAGE: &str = "\
sdae-study: strong errors of the half-explicit drift-truncated Euler scheme on the stochastic
pendulum (seed Section 5.1), against a fine-step reference on the same Brownian paths.

Options:
  --paths N        Monte Carlo paths (default 10000)
  --levels A..B    step counts N = 2^A .. 2^B (default 3..10)
  --ref-level R    reference with 2^R steps (default 15)
  --T T            final time (default 1)
  --c-eta C        truncation constant C_eta (default 0.25, the theory value)
  --seed S         seed of the path streams (default 2026)
  --p P            errors are L^p norms over paths (default 2)
  --threads K      worker threads (default: available cores)
  --out DIR        output folder (default target/study)
  --quick          a small run for CI: 200 paths, levels 3..7, reference 11
  --help           this text
";

fn parse<T: std::str::FromStr>(flag: &str, value: Option<String>) -> Result<T, String> {
    let value = value.ok_or_else(|| format!("{flag} needs a value"))?;
    value
        .parse()
        .map_err(|_| format!("{flag}: cannot read '{value}'"))
}

fn parse_args() -> Result<Option<(PendulumStudy, PathBuf)>, String> {
    let mut study = PendulumStudy {
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        ..PendulumStudy::default()
    };
    let mut out = PathBuf::from("target/study");
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        match flag.as_str() {
            "--help" | "-h" => return Ok(None),
            "--quick" => {
                study.paths = 200;
                study.coarsest = 3;
                study.finest = 7;
                study.reference = 11;
            }
            "--paths" => study.paths = parse(&flag, args.next())?,
            "--ref-level" => study.reference = parse(&flag, args.next())?,
            "--T" => study.t_end = parse(&flag, args.next())?,
            "--c-eta" => study.c_eta = parse(&flag, args.next())?,
            "--seed" => study.seed = parse(&flag, args.next())?,
            "--p" => study.p = parse(&flag, args.next())?,
            "--threads" => study.threads = parse(&flag, args.next())?,
            "--out" => out = PathBuf::from(parse::<String>(&flag, args.next())?),
            "--levels" => {
                let value: String = parse(&flag, args.next())?;
                let (a, b) = value
                    .split_once("..")
                    .ok_or_else(|| format!("--levels: expected A..B, got '{value}'"))?;
                study.coarsest = parse("--levels", Some(a.to_string()))?;
                study.finest = parse("--levels", Some(b.to_string()))?;
            }
            other => return Err(format!("unknown option '{other}'")),
        }
    }
    study.validate()?;
    Ok(Some((study, out)))
}

fn csv(report: &StudyReport) -> String {
    let mut s = String::from(
        "n_steps,h,error_r,error_r_low,error_r_high,error_v,error_v_low,error_v_high,error_mu,error_mu_low,error_mu_high,seconds_per_path,truncated_fraction,newton_iterations_per_step,homotopy_steps,failures\n",
    );
    for l in &report.levels {
        let e = &l.error;
        let cells: Vec<String> = [e.r, e.v, e.mu]
            .iter()
            .flat_map(|i| [i.estimate, i.ci_low, i.ci_high])
            .map(|x| format!("{x:e}"))
            .collect();
        s += &format!(
            "{},{},{},{:e},{},{},{},{}\n",
            l.n_steps,
            l.h,
            cells.join(","),
            l.seconds_per_path,
            l.truncated_fraction,
            l.newton_iterations_per_step,
            l.homotopy_steps,
            l.failures
        );
    }
    s
}

fn describe(name: &str, fit: &OrderFit) -> String {
    let o = &fit.order;
    let flagged = if fit.pre_asymptotic.is_empty() {
        String::new()
    } else {
        format!(
            " ({} coarse level(s) pre-asymptotic, not fitted)",
            fit.pre_asymptotic.len()
        )
    };
    format!(
        "{name} {:.2} [{:.2}, {:.2}]{flagged}",
        o.estimate, o.ci_low, o.ci_high
    )
}

/// A Markdown summary: settings, the table with intervals, the fitted orders and the plots.
fn markdown(report: &StudyReport) -> String {
    let st = &report.settings;
    let mut s = format!(
        "# {} study\n\n{} paths, N = 2^{}..2^{}, reference 2^{} steps on the same Brownian paths, T = {}, C_eta = {}, seed {}, errors: L^{} over paths of the sup over the grid.\n\n",
        report.scene,
        st.paths,
        st.coarsest,
        st.finest,
        st.reference,
        st.t_end,
        st.c_eta,
        st.seed,
        st.p
    );
    s += "| N | h | error r [95% CI] | error v [95% CI] | error mu [95% CI] | us/path | eta < 1 | Newton it./step | homotopy | failures |\n|---|---|---|---|---|---|---|---|---|---|\n";
    let cell = |i: &sdae_study::stats::Interval| {
        format!("{:.3e} [{:.2e}, {:.2e}]", i.estimate, i.ci_low, i.ci_high)
    };
    for l in &report.levels {
        s += &format!(
            "| {} | {:.3e} | {} | {} | {} | {:.1} | {:.1}% | {:.2} | {} | {} |\n",
            l.n_steps,
            l.h,
            cell(&l.error.r),
            cell(&l.error.v),
            cell(&l.error.mu),
            l.seconds_per_path * 1e6,
            100.0 * l.truncated_fraction,
            l.newton_iterations_per_step,
            l.homotopy_steps,
            l.failures
        );
    }
    let o = &report.observed_order;
    s += "\nObserved orders (95% intervals):\n\n";
    for (name, fit) in [("r", &o.r), ("v", &o.v), ("mu", &o.mu)] {
        s += &format!("- {}\n", describe(name, fit));
    }
    s += &format!(
        "\nReference failures: {}\n\n![error against h]({scene}_error_vs_h.svg)\n![error against run time]({scene}_error_vs_time.svg)\n",
        report.reference_failures,
        scene = report.scene
    );
    s
}

fn write_outputs(report: &StudyReport, out: &PathBuf) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let json = serde_json::to_string_pretty(report).map_err(std::io::Error::other)?;
    std::fs::write(out.join("pendulum.json"), json + "\n")?;
    std::fs::write(out.join("pendulum.csv"), csv(report))?;
    std::fs::write(out.join("pendulum.md"), markdown(report))?;
    sdae_study::plots::write_plots(report, out, "pendulum").map_err(std::io::Error::other)
}

fn main() -> ExitCode {
    let (study, out) = match parse_args() {
        Ok(Some(parsed)) => parsed,
        Ok(None) => {
            print!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(message) => {
            eprintln!("sdae-study: {message}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    eprintln!(
        "pendulum study: {} paths, N = 2^{}..2^{}, reference 2^{}, T = {}, C_eta = {}, {} threads",
        study.paths,
        study.coarsest,
        study.finest,
        study.reference,
        study.t_end,
        study.c_eta,
        study.threads
    );
    // Drawn on stderr when it is a terminal; hidden otherwise (CI logs stay clean).
    let bar = ProgressBar::new(study.paths as u64).with_style(
        ProgressStyle::with_template("  {bar:40} {pos}/{len} paths, {elapsed} elapsed, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let report = pendulum_study(study, |done| bar.set_position(done as u64));
    bar.finish_and_clear();
    println!(
        "{:>7} {:>10} {:>11} {:>11} {:>11} {:>11} {:>7} {:>7} {:>5}",
        "N", "h", "err r", "err v", "err mu", "s/path", "eta<1", "newton", "fail"
    );
    for l in &report.levels {
        println!(
            "{:>7} {:>10.3e} {:>11.3e} {:>11.3e} {:>11.3e} {:>11.3e} {:>6.1}% {:>7.2} {:>5}",
            l.n_steps,
            l.h,
            l.error.r.estimate,
            l.error.v.estimate,
            l.error.mu.estimate,
            l.seconds_per_path,
            100.0 * l.truncated_fraction,
            l.newton_iterations_per_step,
            l.failures
        );
    }
    let o = &report.observed_order;
    println!("observed order with 95% interval (least squares in log-log):");
    for (name, fit) in [("  r ", &o.r), ("  v ", &o.v), ("  mu", &o.mu)] {
        println!("{}", describe(name, fit));
    }
    if report.reference_failures > 0 {
        println!(
            "reference failures (paths left out): {}",
            report.reference_failures
        );
    }
    match write_outputs(&report, &out) {
        Ok(()) => {
            println!(
                "wrote {0}/pendulum.json, .csv, .md, _error_vs_h.svg and _error_vs_time.svg",
                out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("sdae-study: cannot write results to {}: {e}", out.display());
            ExitCode::FAILURE
        }
    }
}
