//! `sdae-study`: the convergence study of the stochastic pendulum (run by `cargo xtask study`).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

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
        "n_steps,h,error_r,stderr_r,error_v,stderr_v,error_mu,stderr_mu,seconds_per_path,truncated_fraction,newton_iterations_per_step,homotopy_steps,failures\n",
    );
    for l in &report.levels {
        s += &format!(
            "{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{},{},{},{}\n",
            l.n_steps,
            l.h,
            l.error_r,
            l.stderr_r,
            l.error_v,
            l.stderr_v,
            l.error_mu,
            l.stderr_mu,
            l.seconds_per_path,
            l.truncated_fraction,
            l.newton_iterations_per_step,
            l.homotopy_steps,
            l.failures
        );
    }
    s
}

fn write_outputs(report: &StudyReport, out: &PathBuf) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let json = serde_json::to_string_pretty(report).map_err(std::io::Error::other)?;
    std::fs::write(out.join("pendulum.json"), json + "\n")?;
    std::fs::write(out.join("pendulum.csv"), csv(report))
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
    let total = study.paths;
    let report = pendulum_study(study, |done| {
        if done % (total / 50).max(1) == 0 || done == total {
            eprint!("\r  {done}/{total} paths");
            let _ = std::io::stderr().flush();
        }
    });
    eprintln!();
    println!(
        "{:>7} {:>10} {:>11} {:>11} {:>11} {:>11} {:>7} {:>7} {:>5}",
        "N", "h", "err r", "err v", "err mu", "s/path", "eta<1", "newton", "fail"
    );
    for l in &report.levels {
        println!(
            "{:>7} {:>10.3e} {:>11.3e} {:>11.3e} {:>11.3e} {:>11.3e} {:>6.1}% {:>7.2} {:>5}",
            l.n_steps,
            l.h,
            l.error_r,
            l.error_v,
            l.error_mu,
            l.seconds_per_path,
            100.0 * l.truncated_fraction,
            l.newton_iterations_per_step,
            l.failures
        );
    }
    let [pr, pv, pm] = report.observed_order;
    println!("observed order (least squares over all levels): r {pr:.2}, v {pv:.2}, mu {pm:.2}");
    if report.reference_failures > 0 {
        println!(
            "reference failures (paths left out): {}",
            report.reference_failures
        );
    }
    match write_outputs(&report, &out) {
        Ok(()) => {
            println!(
                "wrote {0}/pendulum.json and {0}/pendulum.csv",
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
