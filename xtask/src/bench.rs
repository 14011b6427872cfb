//! `cargo xtask bench`: runs the criterion benchmarks of `sdae-bench` (step, mass, ensemble,
//! fiber, molecule, inherent_ensemble, qmc, expr, expr_system) and summarizes the step and
//! ensemble figures in `target/bench/summary.json`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

use serde_json::{Map, Value, json};

use crate::{TaskError, target_dir, workspace_root};

/// Paths of the `pendulum_ensemble` group (as in crates/sdae-bench/benches/ensemble.rs).
const ENSEMBLE_PATHS: u64 = 512;

/// Bead counts of the `chain_step` group (as in crates/sdae-bench/benches/step.rs).
const CHAIN_SIZES: [u64; 4] = [10, 100, 1000, 10000];

/// Bead counts and paths of the `chain_ensemble` group (as in crates/sdae-bench/benches/step.rs).
const CHAIN_ENSEMBLE_SIZES: [u64; 3] = [10, 100, 1000];
const CHAIN_ENSEMBLE_PATHS: u64 = 8;

/// Bead counts and paths of the `fiber_ensemble` groups (as in crates/sdae-bench/benches/fiber.rs).
const FIBER_ENSEMBLE_SIZES: [u64; 3] = [10, 100, 1000];
const FIBER_ENSEMBLE_PATHS: u64 = 8;

/// The molecules of crates/sdae-bench/benches/molecule.rs (groups `<molecule>_step`,
/// `<molecule>_ensemble`, `<molecule>_ensemble_path_by_path`) and the paths of their ensembles.
const MOLECULES: [&str; 2] = ["molecule", "triatomic"];
const MOLECULE_ENSEMBLE_PATHS: u64 = 64;

/// The benchmarks of `sdae-bench` that run (its `splitting` bench runs with
/// `cargo bench -p sdae-bench --bench splitting`).
const BENCHES: [&str; 9] = [
    "step",
    "mass",
    "ensemble",
    "fiber",
    "molecule",
    "inherent_ensemble",
    "qmc",
    "expr",
    "expr_system",
];

/// Solvers of the `inherent_ensemble` group (as in crates/sdae-bench/benches/inherent_ensemble.rs),
/// each with the same number of paths as `pendulum_ensemble`.
const INHERENT_SOLVERS: [&str; 4] = [
    "euler_maruyama",
    "truncated_euler_maruyama",
    "projected_euler_maruyama",
    "stochastic_heun",
];

/// Criterion options of `--quick`.
const QUICK_OPTIONS: [&str; 4] = ["--warm-up-time", "0.5", "--measurement-time", "1"];

/// What `cargo xtask bench` was asked to do.
#[derive(Debug, Default)]
struct Options {
    quick: bool,
    criterion: Vec<String>,
}

fn parse(args: &[String]) -> Result<Options, TaskError> {
    let mut options = Options::default();
    let mut iter = args.iter();
    while let Some(arg) = iter.next() {
        match arg.as_str() {
            "--quick" => options.quick = true,
            "--" => {
                options.criterion.extend(iter.by_ref().cloned());
            }
            other => {
                return Err(TaskError::Usage(format!(
                    "unknown option `{other}` for `bench` (criterion options go after `--`)"
                )));
            }
        }
    }
    Ok(options)
}

/// Runs the benchmarks, then writes and prints the summary.
pub fn run(args: &[String]) -> Result<(), TaskError> {
    let options = parse(args)?;
    let target = target_dir()?;
    let criterion_home = match std::env::var_os("CRITERION_HOME") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => target.join("criterion"),
    };
    let mut criterion_args: Vec<String> = Vec::new();
    if options.quick {
        criterion_args.extend(QUICK_OPTIONS.iter().map(|s| s.to_string()));
    }
    criterion_args.extend(options.criterion.iter().cloned());
    // Results older than this were not written by this run.
    let started = SystemTime::now();
    run_criterion(&target, &criterion_home, &criterion_args)?;
    let results = Results {
        criterion_home: &criterion_home,
        started,
    };
    let figures = Figures::read(&results)?;
    let out_dir = target.join("bench");
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| TaskError::Failed(format!("cannot create {}: {e}", out_dir.display())))?;
    let out = out_dir.join("summary.json");
    let text = serde_json::to_string_pretty(&figures.summary(options.quick, &criterion_args))
        .map_err(|e| TaskError::Failed(format!("cannot serialize the summary: {e}")))?;
    std::fs::write(&out, text + "\n")
        .map_err(|e| TaskError::Failed(format!("cannot write {}: {e}", out.display())))?;
    figures.print();
    println!("\nsummary written to {}", out.display());
    Ok(())
}

/// Runs `cargo bench` on the benchmark packages with `criterion_args`, its results in
/// `criterion_home`.
fn run_criterion(
    target: &Path, criterion_home: &Path, criterion_args: &[String],
) -> Result<(), TaskError> {
    let root = workspace_root()?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(&cargo);
    command
        .current_dir(&root)
        .args(["bench", "-p", "sdae-bench"])
        .args(BENCHES.iter().flat_map(|b| ["--bench", b]))
        .env("CARGO_TARGET_DIR", target)
        .env("CRITERION_HOME", criterion_home);
    if !criterion_args.is_empty() {
        command.arg("--").args(criterion_args);
    }
    let bench_command = format!(
        "{} bench -p sdae-bench {}",
        Path::new(&cargo).display(),
        BENCHES.map(|b| format!("--bench {b}")).join(" ")
    );
    eprintln!(
        "running: {bench_command}{}",
        if criterion_args.is_empty() {
            String::new()
        } else {
            format!(" -- {}", criterion_args.join(" "))
        }
    );
    let status = command.status().map_err(|e| {
        TaskError::Failed(format!(
            "cannot start `{}`: {e}",
            Path::new(&cargo).display()
        ))
    })?;
    if !status.success() {
        return Err(TaskError::Failed(format!(
            "`{bench_command}` failed ({status})"
        )));
    }
    Ok(())
}

/// Where this run's criterion results are, and when it started (older results are not its).
struct Results<'a> {
    criterion_home: &'a Path,
    started: SystemTime,
}

impl Results<'_> {
    /// The mean time in ns of benchmark `group[/id]` ([`read_mean_ns`]).
    fn mean_ns(&self, group: &str, id: Option<&str>) -> Result<f64, TaskError> {
        read_mean_ns(self.criterion_home, group, id, self.started)
    }
}

/// The figures of one run, in ns.
struct Figures {
    /// One path's step of the pendulum.
    pendulum: f64,
    /// (beads, one path's step of the chain).
    chain_step: Vec<(u64, f64)>,
    /// The pendulum ensemble per path-step: with its normals, the step only, the normals only,
    /// the normals one path at a time, the step at one lane, the step with a closure drift.
    ensemble: EnsembleFigures,
    /// (beads, the chain ensemble per bead and path-step).
    chain_ensemble: Vec<(u64, f64)>,
    /// The increments alone of the chain ensemble at K = 1000, per bead and path-step.
    chain_ensemble_normals: f64,
    /// (beads, fiber_step per bead, the fiber ensemble in lanes and path by path, per bead
    /// and path-step).
    fiber: Vec<(u64, f64, f64, f64)>,
    /// (molecule, its scalar step, the ensemble in lanes, the ensemble path by path), per
    /// path-step.
    molecules: Vec<(&'static str, f64, f64, f64)>,
    /// (solver, in lanes, path by path), per path-step.
    inherent: Vec<(&'static str, f64, f64)>,
}

/// The pendulum ensemble's figures, per path-step.
struct EnsembleFigures {
    with_normals: f64,
    step_only: f64,
    normals: f64,
    normals_per_path: f64,
    one_lane: f64,
    closure: f64,
}

impl Figures {
    fn read(results: &Results<'_>) -> Result<Self, TaskError> {
        let mut chain_step = Vec::new();
        for beads in CHAIN_SIZES {
            chain_step.push((
                beads,
                results.mean_ns("chain_step", Some(&beads.to_string()))?,
            ));
        }
        // Criterion's time per iteration of an ensemble step is for every path of the ensemble.
        let ensemble_paths = ENSEMBLE_PATHS as f64;
        let ensemble = |id: &str| -> Result<f64, TaskError> {
            Ok(results.mean_ns("pendulum_ensemble", Some(id))? / ensemble_paths)
        };
        let mut inherent = Vec::new();
        for solver in INHERENT_SOLVERS {
            let per_path_step = |id: &str| -> Result<f64, TaskError> {
                Ok(results.mean_ns("inherent_ensemble", Some(id))? / ensemble_paths)
            };
            let lanes = per_path_step(solver)?;
            let path_by_path = per_path_step(&format!("{solver}_path_by_path"))?;
            inherent.push((solver, lanes, path_by_path));
        }
        // Criterion's time per iteration of `chain_ensemble/K` is one step of every path.
        let mut chain_ensemble = Vec::new();
        for beads in CHAIN_ENSEMBLE_SIZES {
            let ns = results.mean_ns("chain_ensemble", Some(&beads.to_string()))?;
            chain_ensemble.push((beads, ns / (beads * CHAIN_ENSEMBLE_PATHS) as f64));
        }
        // The fiber in lanes with its lane forms and with its forces path by path, per bead
        // and path, against one path of `fiber_step`.
        let mut fiber = Vec::new();
        for beads in FIBER_ENSEMBLE_SIZES {
            let id = beads.to_string();
            let per_bead_path = |group: &str| -> Result<f64, TaskError> {
                Ok(results.mean_ns(group, Some(&id))? / (beads * FIBER_ENSEMBLE_PATHS) as f64)
            };
            let step = results.mean_ns("fiber_step", Some(&id))? / beads as f64;
            let lanes = per_bead_path("fiber_ensemble")?;
            let path_by_path = per_bead_path("fiber_ensemble_path_by_path")?;
            fiber.push((beads, step, lanes, path_by_path));
        }
        let mut molecules = Vec::new();
        for molecule in MOLECULES {
            let step = results.mean_ns(&format!("{molecule}_step"), None)?;
            let per_path = |group: String| -> Result<f64, TaskError> {
                Ok(results.mean_ns(&group, Some("default"))? / MOLECULE_ENSEMBLE_PATHS as f64)
            };
            let lanes = per_path(format!("{molecule}_ensemble"))?;
            let path_by_path = per_path(format!("{molecule}_ensemble_path_by_path"))?;
            molecules.push((molecule, step, lanes, path_by_path));
        }
        Ok(Self {
            pendulum: results.mean_ns("pendulum_step", None)?,
            chain_step,
            ensemble: EnsembleFigures {
                with_normals: ensemble("with_normals")?,
                step_only: ensemble("step_only")?,
                normals: ensemble("normals_only")?,
                normals_per_path: ensemble("normals_one_path_at_a_time")?,
                one_lane: ensemble("step_only_one_lane")?,
                closure: ensemble("step_only_closure_drift")?,
            },
            chain_ensemble,
            // The increments alone of `chain_ensemble/1000` (benches/step.rs), per bead and
            // path.
            chain_ensemble_normals: results.mean_ns("chain_ensemble", Some("normals_only/1000"))?
                / (1000 * CHAIN_ENSEMBLE_PATHS) as f64,
            fiber,
            molecules,
            inherent,
        })
    }

    /// The summary written to `target/bench/summary.json`.
    fn summary(&self, quick: bool, criterion_args: &[String]) -> Value {
        let inherent_summary: Map<String, Value> = self
            .inherent
            .iter()
            .map(|&(solver, lanes, path_by_path)| {
                (
                    solver.to_string(),
                    json!({ "lanes": lanes, "path_by_path": path_by_path }),
                )
            })
            .collect();
        let mut per_bead = Map::new();
        let mut chain_step = Map::new();
        for &(beads, ns) in &self.chain_step {
            per_bead.insert(beads.to_string(), json!(ns / beads as f64));
            chain_step.insert(beads.to_string(), json!(ns));
        }
        let chain_ensemble_per_bead: Map<String, Value> = self
            .chain_ensemble
            .iter()
            .map(|&(beads, ns)| (beads.to_string(), json!(ns)))
            .collect();
        let fiber_summary: Map<String, Value> = self
            .fiber
            .iter()
            .map(|&(beads, step, lanes, path_by_path)| {
                (
                    beads.to_string(),
                    json!({ "fiber_step": step, "lanes": lanes, "path_by_path": path_by_path }),
                )
            })
            .collect();
        let e = &self.ensemble;
        let mut summary = json!({
            "pendulum_step_ns": self.pendulum,
            "chain_step_ns_per_bead": per_bead,
            "chain_step_ns": chain_step,
            "pendulum_ensemble_ns_per_path_step": e.with_normals,
            "pendulum_ensemble_step_only_ns_per_path_step": e.step_only,
            "pendulum_ensemble_one_lane_ns_per_path_step": e.one_lane,
            "pendulum_ensemble_closure_drift_ns_per_path_step": e.closure,
            "pendulum_ensemble_normals_ns_per_path_step": e.normals,
            "pendulum_ensemble_normals_one_path_at_a_time_ns_per_path_step": e.normals_per_path,
            "pendulum_ensemble_speedup": self.pendulum / e.with_normals,
            "chain_ensemble_ns_per_bead_path_step": chain_ensemble_per_bead,
            "chain_ensemble_normals_ns_per_bead_path_step": { "1000": self.chain_ensemble_normals },
            "inherent_ensemble_ns_per_path_step": inherent_summary,
            "fiber_ensemble_ns_per_bead_path_step": fiber_summary,
            "quick": quick,
            "criterion_args": criterion_args,
            "machine": machine(),
        });
        for &(molecule, step, lanes, path_by_path) in &self.molecules {
            summary[format!("{molecule}_ensemble_ns_per_path_step")] = json!({
                format!("{molecule}_step"): step,
                "lanes": lanes,
                "path_by_path": path_by_path,
            });
        }
        summary
    }

    /// The figures as a table on the terminal.
    fn print(&self) {
        let e = &self.ensemble;
        println!();
        println!(
            "{:<20} {:>14} {:>16}",
            "benchmark", "ns/step", "ns/bead/step"
        );
        println!("{:<20} {:>14.1} {:>16}", "pendulum_step", self.pendulum, "");
        for &(beads, ns) in &self.chain_step {
            let name = format!("chain_step/{beads}");
            println!("{name:<20} {ns:>14.1} {:>16.2}", ns / beads as f64);
        }
        println!(
            "{:<20} {:>14.1} {:>16}   ({:.1}x pendulum_step)",
            "pendulum_ensemble",
            e.with_normals,
            "",
            self.pendulum / e.with_normals
        );
        println!(
            "{:<20} {:>14.1} {:>16}   (one lane: {:.1}; closure drift: {:.1})",
            "  step only", e.step_only, "", e.one_lane, e.closure
        );
        println!(
            "{:<20} {:>14.1} {:>16}   (one path at a time: {:.1})",
            "  normals only", e.normals, "", e.normals_per_path
        );
        for &(beads, ns) in &self.chain_ensemble {
            let name = format!("chain_ensemble/{beads}");
            println!("{name:<20} {:>14} {ns:>16.2}   (per bead and path)", "");
        }
        println!(
            "{:<20} {:>14} {:>16.2}   (K = 1000, per bead and path)",
            "  normals only", "", self.chain_ensemble_normals
        );
        for &(beads, step, lanes, path_by_path) in &self.fiber {
            let name = format!("fiber_ensemble/{beads}");
            println!(
                "{name:<20} {:>14} {lanes:>16.2}   (per bead and path; path by path: {path_by_path:.2}; fiber_step: {step:.2})",
                ""
            );
        }
        for &(molecule, step, lanes, path_by_path) in &self.molecules {
            let name = format!("{molecule}_ensemble");
            println!(
                "{name:<20} {lanes:>14.1} {:>16}   (per path; path by path: {path_by_path:.1}; {molecule}_step: {step:.1})",
                ""
            );
        }
        for &(solver, lanes, path_by_path) in &self.inherent {
            println!(
                "{solver:<25} {lanes:>9.1} {:>16}   (path by path: {path_by_path:.1}, {:.1}x)",
                "",
                path_by_path / lanes
            );
        }
    }
}

/// The mean time in ns of benchmark `group[/id]` from criterion's
/// `<criterion home>/<group>[/<id>]/new/estimates.json`, which must be newer than `started`.
fn read_mean_ns(
    criterion_home: &Path, group: &str, id: Option<&str>, started: SystemTime,
) -> Result<f64, TaskError> {
    let mut path = criterion_home.join(group);
    if let Some(id) = id {
        path.push(id);
    }
    path.push("new");
    path.push("estimates.json");
    let name = match id {
        Some(id) => format!("{group}/{id}"),
        None => group.to_string(),
    };
    let fail = |what: String| {
        TaskError::Failed(format!("benchmark `{name}`: {what} ({})", path.display()))
    };
    let modified = std::fs::metadata(&path)
        .and_then(|m| m.modified())
        .map_err(|e| fail(format!("cannot read criterion's estimates: {e}")))?;
    if modified < started {
        return Err(fail(
            "criterion's estimates are older than this run (was the benchmark filtered out?)"
                .into(),
        ));
    }
    let text = std::fs::read_to_string(&path)
        .map_err(|e| fail(format!("cannot read criterion's estimates: {e}")))?;
    let value: Value = serde_json::from_str(&text)
        .map_err(|e| fail(format!("criterion's estimates are not valid JSON: {e}")))?;
    let mean = value
        .get("mean")
        .and_then(|m| m.get("point_estimate"))
        .and_then(Value::as_f64)
        .ok_or_else(|| fail("no number at mean.point_estimate".into()))?;
    if !(mean.is_finite() && mean > 0.0) {
        return Err(fail(format!("mean {mean} ns is not a positive number")));
    }
    Ok(mean)
}

/// Cores, CPU model and compiler of this machine.
fn machine() -> Value {
    let cpus = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find(|line| line.starts_with("model name"))
                .and_then(|line| line.split_once(':'))
                .map(|(_, model)| model.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let rustc_version = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    json!({ "cpus": cpus, "model": model, "rustc": rustc_version })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn parses_quick_and_passthrough() {
        let options = parse(&args(&["--quick", "--", "--sample-size", "10"])).unwrap();
        assert!(options.quick);
        assert_eq!(options.criterion, args(&["--sample-size", "10"]));
    }

    #[test]
    fn rejects_unknown_options() {
        assert!(matches!(
            parse(&args(&["--fast"])),
            Err(TaskError::Usage(_))
        ));
    }

    #[test]
    fn missing_estimates_are_an_error() {
        let dir = std::env::temp_dir().join("xtask-bench-test-missing");
        let error = read_mean_ns(&dir, "nothing", Some("1"), SystemTime::UNIX_EPOCH).unwrap_err();
        assert!(error.to_string().contains("nothing/1"), "{error}");
    }

    #[test]
    fn reads_the_mean_and_rejects_bad_json() {
        let dir = std::env::temp_dir().join(format!("xtask-bench-test-{}", std::process::id()));
        let new = dir.join("g").join("7").join("new");
        std::fs::create_dir_all(&new).unwrap();
        let file = new.join("estimates.json");
        std::fs::write(&file, r#"{"mean": {"point_estimate": 12.5}}"#).unwrap();
        let mean = read_mean_ns(&dir, "g", Some("7"), SystemTime::UNIX_EPOCH).unwrap();
        assert_eq!(mean, 12.5);
        std::fs::write(&file, r#"{"mean": {}}"#).unwrap();
        assert!(read_mean_ns(&dir, "g", Some("7"), SystemTime::UNIX_EPOCH).is_err());
        std::fs::write(&file, "not json").unwrap();
        assert!(read_mean_ns(&dir, "g", Some("7"), SystemTime::UNIX_EPOCH).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes criterion's estimate of 1000 ns for benchmark `group` (and `id`) under `dir`.
    fn write_estimate(dir: &Path, group: &str, id: Option<&str>) {
        let mut new = dir.join(group);
        if let Some(id) = id {
            new.push(id);
        }
        new.push("new");
        std::fs::create_dir_all(&new).unwrap();
        std::fs::write(
            new.join("estimates.json"),
            r#"{"mean": {"point_estimate": 1000.0}}"#,
        )
        .unwrap();
    }

    /// Writes an estimate of 1000 ns under `dir` for every benchmark the summary reads.
    fn write_every_estimate(dir: &Path) {
        let write = |group: &str, id: Option<&str>| write_estimate(dir, group, id);
        write("pendulum_step", None);
        for id in [
            "with_normals",
            "step_only",
            "normals_only",
            "normals_one_path_at_a_time",
            "step_only_one_lane",
            "step_only_closure_drift",
        ] {
            write("pendulum_ensemble", Some(id));
        }
        for solver in INHERENT_SOLVERS {
            write("inherent_ensemble", Some(solver));
            write("inherent_ensemble", Some(&format!("{solver}_path_by_path")));
        }
        for beads in CHAIN_SIZES {
            write("chain_step", Some(&beads.to_string()));
        }
        for beads in CHAIN_ENSEMBLE_SIZES {
            write("chain_ensemble", Some(&beads.to_string()));
        }
        write("chain_ensemble", Some("normals_only/1000"));
        for beads in FIBER_ENSEMBLE_SIZES {
            for group in [
                "fiber_step",
                "fiber_ensemble",
                "fiber_ensemble_path_by_path",
            ] {
                write(group, Some(&beads.to_string()));
            }
        }
        for molecule in MOLECULES {
            write(&format!("{molecule}_step"), None);
            write(&format!("{molecule}_ensemble"), Some("default"));
            write(
                &format!("{molecule}_ensemble_path_by_path"),
                Some("default"),
            );
        }
    }

    #[test]
    fn the_summary_holds_every_figure_per_path_step() {
        let dir = std::env::temp_dir().join(format!("xtask-bench-summary-{}", std::process::id()));
        write_every_estimate(&dir);
        let results = Results {
            criterion_home: &dir,
            started: SystemTime::UNIX_EPOCH,
        };
        let summary = Figures::read(&results).unwrap().summary(true, &[]);
        let at = |path: &[&str]| -> f64 {
            path.iter()
                .fold(&summary, |v, key| &v[*key])
                .as_f64()
                .unwrap_or_else(|| panic!("{path:?} in {summary:#}"))
        };
        let per_path = 1000.0 / ENSEMBLE_PATHS as f64;
        assert_eq!(at(&["pendulum_step_ns"]), 1000.0);
        assert_eq!(at(&["pendulum_ensemble_ns_per_path_step"]), per_path);
        assert_eq!(at(&["pendulum_ensemble_speedup"]), ENSEMBLE_PATHS as f64);
        assert_eq!(at(&["chain_step_ns_per_bead", "100"]), 10.0);
        assert_eq!(
            at(&["chain_ensemble_ns_per_bead_path_step", "10"]),
            1000.0 / (10 * CHAIN_ENSEMBLE_PATHS) as f64
        );
        assert_eq!(
            at(&["fiber_ensemble_ns_per_bead_path_step", "100", "fiber_step"]),
            10.0
        );
        assert_eq!(
            at(&["molecule_ensemble_ns_per_path_step", "lanes"]),
            1000.0 / MOLECULE_ENSEMBLE_PATHS as f64
        );
        assert_eq!(
            at(&[
                "inherent_ensemble_ns_per_path_step",
                INHERENT_SOLVERS[0],
                "path_by_path"
            ]),
            per_path
        );
        assert_eq!(summary["quick"], Value::Bool(true));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
