//! `sdae-study`: the convergence study of the stochastic pendulum (run by `cargo xtask study`).

use std::path::PathBuf;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_study::stats::OrderFit;
use sdae_study::{PendulumStudy, Shard, StudyReport, build_report, merge_shards, run_paths};

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
  --shard I/N      run only paths i with i % N == I and write DIR/shard-I-of-N.json
  --help           this text

sdae-study merge DIR... [--out DIR]
  merges the shard files found in the folders into exactly the report an unsharded run
  gives (timings aside); any batch system can run the shards
";

fn parse<T: std::str::FromStr>(flag: &str, value: Option<String>) -> Result<T, String> {
    let value = value.ok_or_else(|| format!("{flag} needs a value"))?;
    value
        .parse()
        .map_err(|_| format!("{flag}: cannot read '{value}'"))
}

/// What the command line asks for.
enum Command {
    Help,
    /// Run the study (or one shard of it) and write to `out`.
    Run {
        study: PendulumStudy,
        out: PathBuf,
        shard: Option<(usize, usize)>,
    },
    /// Merge the shard files found in `dirs` into one report in `out`.
    Merge {
        dirs: Vec<PathBuf>,
        out: PathBuf,
    },
}

fn parse_shard(value: &str) -> Result<(usize, usize), String> {
    let bad = || format!("--shard: expected i/n with 0 <= i < n, got '{value}'");
    let (i, n) = value.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (i.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
    if i < n { Ok((i, n)) } else { Err(bad()) }
}

fn parse_args() -> Result<Command, String> {
    let mut study = PendulumStudy {
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        ..PendulumStudy::default()
    };
    let mut out = PathBuf::from("target/study");
    let mut shard = None;
    let mut merge: Option<Vec<PathBuf>> = None;
    let mut args = std::env::args().skip(1).peekable();
    if args.peek().map(String::as_str) == Some("merge") {
        args.next();
        merge = Some(Vec::new());
    }
    while let Some(flag) = args.next() {
        match flag.as_str() {
            "--help" | "-h" => return Ok(Command::Help),
            "--out" => out = PathBuf::from(parse::<String>(&flag, args.next())?),
            dir if merge.is_some() && !dir.starts_with("--") => {
                if let Some(dirs) = merge.as_mut() {
                    dirs.push(PathBuf::from(dir));
                }
            }
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
            "--shard" => shard = Some(parse_shard(&parse::<String>(&flag, args.next())?)?),
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
    if let Some(dirs) = merge {
        if dirs.is_empty() {
            return Err("merge needs at least one folder of shard files".into());
        }
        return Ok(Command::Merge { dirs, out });
    }
    study.validate()?;
    Ok(Command::Run { study, out, shard })
}

/// Reads every `shard-*.json` in the folders.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<Shard>, String> {
    let mut shards = Vec::new();
    for dir in dirs {
        let entries =
            std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        for entry in entries.flatten() {
            let path = entry.path();
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if name.starts_with("shard-") && name.ends_with(".json") {
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
                let shard: Shard = serde_json::from_str(&text)
                    .map_err(|e| format!("{} is not a shard file: {e}", path.display()))?;
                shards.push(shard);
            }
        }
    }
    Ok(shards)
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

fn print_report(report: &StudyReport) {
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
}

fn finish(report: &StudyReport, out: &PathBuf) -> ExitCode {
    print_report(report);
    match write_outputs(report, out) {
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

fn main() -> ExitCode {
    let (study, out, shard) = match parse_args() {
        Ok(Command::Run { study, out, shard }) => (study, out, shard),
        Ok(Command::Help) => {
            print!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Ok(Command::Merge { dirs, out }) => {
            return match read_shards(&dirs).and_then(merge_shards) {
                Ok(report) => finish(&report, &out),
                Err(message) => {
                    eprintln!("sdae-study merge: {message}");
                    ExitCode::FAILURE
                }
            };
        }
        Err(message) => {
            eprintln!("sdae-study: {message}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let (index, count) = shard.unwrap_or((0, 1));
    eprintln!(
        "pendulum study: {} paths (shard {index}/{count}), N = 2^{}..2^{}, reference 2^{}, T = {}, C_eta = {}, {} threads",
        study.paths,
        study.coarsest,
        study.finest,
        study.reference,
        study.t_end,
        study.c_eta,
        study.threads
    );
    // Drawn on stderr when it is a terminal; hidden otherwise (CI logs stay clean).
    let mine = (index..study.paths).step_by(count).count();
    let bar = ProgressBar::new(mine as u64).with_style(
        ProgressStyle::with_template("  {bar:40} {pos}/{len} paths, {elapsed} elapsed, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let records = run_paths(&study, index, count, |done| bar.set_position(done as u64));
    bar.finish_and_clear();
    if shard.is_none() {
        return finish(&build_report(&study, records), &out);
    }
    let file = out.join(format!("shard-{index}-of-{count}.json"));
    let shard = Shard {
        settings: study,
        index,
        count,
        records,
    };
    let written = std::fs::create_dir_all(&out)
        .and_then(|()| serde_json::to_string(&shard).map_err(std::io::Error::other))
        .and_then(|json| std::fs::write(&file, json));
    match written {
        Ok(()) => {
            println!(
                "wrote {} ({mine} paths); merge all shards with `cargo xtask study merge DIR...`",
                file.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("sdae-study: cannot write {}: {e}", file.display());
            ExitCode::FAILURE
        }
    }
}
