//! `sdae-study`: convergence studies of the schemes on built-in or user scenes (run by
//! `cargo xtask study`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_study::convergence::{
    ConvergenceRun, ConvergenceSettings, build_report, merge_shards, run_convergence,
};
use sdae_study::integrator::SchemeKind;
use sdae_study::output::{print_summary, write_report};
use sdae_study::scene::{BUILT_IN, Scene};
use sdae_study::stability::{self, StabilityReport, StabilityScene, stability_settings};
use sdae_study::{equipartition, trace};

const USAGE: &str = "\
sdae-study: strong errors of the half-explicit drift-truncated Euler scheme and of solvers of
the inherent SDE, against a fine-step reference on the same Brownian paths, with run time.

Usage: sdae-study [options]           convergence study (default: the pendulum scene)
       sdae-study stability [options] stability study of the stiff and extreme scenes
       sdae-study equipartition [options]
                                      kinetic temperature of the Langevin scenes against h
                                      and C_eta
       sdae-study merge DIR... [--out DIR]
                                      merge shard files into the unsharded report
       sdae-study trace [--scene NAMES] [--scene-file PATH] [--seed S] [--out DIR]
                                      one path of each scene as DIR/trace/<scene>.svg and .csv
       sdae-study list                built-in scenes and schemes

Options:
  --scene NAMES        built-in scenes, comma-separated (default: pendulum)
  --scene-file PATH    a scene file (TOML); may be repeated
  --schemes NAMES      schemes to compare, comma-separated (default: all that apply)
  --reference-scheme S scheme of the reference (default: half-explicit-practical)
  --paths N            Monte Carlo paths (default: the scene's)
  --levels A..B        step counts N = 2^A .. 2^B (default: the scene's)
  --ref-level R        reference with 2^R steps (default: the scene's)
  --T T                final time (default: the scene's)
  --seed S             seed of the path streams (default 2026)
  --p P                errors are L^p norms over paths (default 2)
  --threads K          worker threads (default: available cores; results do not depend on it)
  --out DIR            output folder (default target/study); one subfolder per scene
  --quick              a small run for CI: at most 200 paths, the scene's five coarsest levels,
                       a reference 2^4 times finer than the finest (pendulum: levels 3..7,
                       reference 2^11; stability and equipartition: fewer paths and levels)
  --shard I/N          run only paths i with i % N == I, write DIR/<scene>/shard-I-of-N.json
  --help               this text

Each scene folder gets report.json, report.csv, report.md, error_vs_h.svg, error_vs_time.svg.
The stability study (default: every built-in scene with a [stability] table) writes
DIR/stability/report.json, report.md and stability.svg; the equipartition study (default:
every built-in scene with an [equipartition] table) writes DIR/equipartition/report.json,
report.md and equipartition.svg. Of the options above they take --scene, --scene-file,
--paths, --seed, --threads, --out and --quick.
";

fn parse<T: std::str::FromStr>(flag: &str, value: Option<String>) -> Result<T, String> {
    let value = value.ok_or_else(|| format!("{flag} needs a value"))?;
    value
        .parse()
        .map_err(|_| format!("{flag}: cannot read '{value}'"))
}

/// Settings from the command line that override each scene's defaults.
#[derive(Default)]
struct Overrides {
    schemes: Option<Vec<SchemeKind>>,
    reference_scheme: Option<SchemeKind>,
    paths: Option<usize>,
    levels: Option<(u32, u32)>,
    reference: Option<u32>,
    t_end: Option<f64>,
    seed: Option<u64>,
    p: Option<f64>,
    threads: Option<usize>,
}

impl Overrides {
    /// The convergence settings of `scene`: its defaults, or with `quick` at most 200 paths,
    /// its five coarsest levels and a reference 2^4 times finer, then the command line's values.
    fn settings(&self, scene: &Scene, quick: bool) -> ConvergenceSettings {
        let mut s = ConvergenceSettings::for_scene(scene);
        if quick {
            s.paths = s.paths.min(200);
            s.finest = s.finest.min(s.coarsest + 4);
            s.reference = Some(s.finest + 4);
        }
        if let Some((a, b)) = self.levels {
            s.coarsest = a;
            s.finest = b;
        }
        if let Some(x) = &self.schemes {
            s.schemes = x.clone();
        }
        s.reference_scheme = self.reference_scheme.unwrap_or(s.reference_scheme);
        s.paths = self.paths.unwrap_or(s.paths);
        s.reference = self.reference.or(s.reference);
        s.t_end = self.t_end.unwrap_or(s.t_end);
        s.seed = self.seed.unwrap_or(s.seed);
        s.p = self.p.unwrap_or(s.p);
        s.threads = self.threads.unwrap_or(s.threads);
        s
    }
}

/// Which study to run.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Convergence,
    Stability,
    Equipartition,
    Trace,
}

/// What the command line asks for.
enum Command {
    Help,
    List,
    Run {
        mode: Mode,
        scenes: Vec<Scene>,
        overrides: Overrides,
        quick: bool,
        out: PathBuf,
        shard: Option<(usize, usize)>,
    },
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

fn parse_scheme(name: &str) -> Result<SchemeKind, String> {
    SchemeKind::from_name(name).ok_or_else(|| {
        let all: Vec<&str> = SchemeKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown scheme '{name}' (schemes: {})", all.join(", "))
    })
}

fn parse_args(args: Vec<String>) -> Result<Command, String> {
    let mut args = args.into_iter().peekable();
    let (merge, mode) = match args.peek().map(String::as_str) {
        Some("merge") => (true, Mode::Convergence),
        Some("stability") => (false, Mode::Stability),
        Some("equipartition") => (false, Mode::Equipartition),
        Some("trace") => (false, Mode::Trace),
        Some("convergence") => (false, Mode::Convergence),
        Some("list") => return Ok(Command::List),
        _ => (false, Mode::Convergence),
    };
    if args.peek().is_some_and(|a| !a.starts_with('-')) {
        args.next();
    }
    let mut quick = false;
    let mut o = Overrides::default();
    let mut out = PathBuf::from("target/study");
    let (mut shard, mut dirs) = (None, Vec::new());
    let (mut names, mut files): (Vec<String>, Vec<PathBuf>) = (Vec::new(), Vec::new());
    while let Some(flag) = args.next() {
        match flag.as_str() {
            "--help" | "-h" => return Ok(Command::Help),
            "--out" => out = PathBuf::from(parse::<String>(&flag, args.next())?),
            dir if merge && !dir.starts_with("--") => dirs.push(PathBuf::from(dir)),
            "--scene" => {
                let list: String = parse(&flag, args.next())?;
                names.extend(list.split(',').map(str::to_string));
            }
            "--scene-file" => files.push(PathBuf::from(parse::<String>(&flag, args.next())?)),
            "--schemes" => {
                let list: String = parse(&flag, args.next())?;
                o.schemes = Some(
                    list.split(',')
                        .map(parse_scheme)
                        .collect::<Result<_, _>>()?,
                );
            }
            "--reference-scheme" => {
                o.reference_scheme = Some(parse_scheme(&parse::<String>(&flag, args.next())?)?);
            }
            "--quick" => quick = true,
            "--paths" => o.paths = Some(parse(&flag, args.next())?),
            "--ref-level" => o.reference = Some(parse(&flag, args.next())?),
            "--T" => o.t_end = Some(parse(&flag, args.next())?),
            "--seed" => o.seed = Some(parse(&flag, args.next())?),
            "--p" => o.p = Some(parse(&flag, args.next())?),
            "--threads" => o.threads = Some(parse(&flag, args.next())?),
            "--shard" => shard = Some(parse_shard(&parse::<String>(&flag, args.next())?)?),
            "--levels" => {
                let value: String = parse(&flag, args.next())?;
                let (a, b) = value
                    .split_once("..")
                    .ok_or_else(|| format!("--levels: expected A..B, got '{value}'"))?;
                o.levels = Some((
                    parse("--levels", Some(a.to_string()))?,
                    parse("--levels", Some(b.to_string()))?,
                ));
            }
            other => return Err(format!("unknown option '{other}'")),
        }
    }
    if merge {
        if dirs.is_empty() {
            return Err("merge needs at least one folder of shard files".into());
        }
        return Ok(Command::Merge { dirs, out });
    }
    let mut scenes = Vec::new();
    for name in &names {
        scenes.push(Scene::built_in(name).map_err(|e| e.to_string())?);
    }
    for file in &files {
        scenes.push(Scene::from_file(file).map_err(|e| e.to_string())?);
    }
    if scenes.is_empty() {
        scenes = default_scenes(mode)?;
    }
    if mode == Mode::Convergence {
        for scene in &scenes {
            o.settings(scene, quick)
                .validate()
                .map_err(|e| format!("scene {}: {e}", scene.name))?;
        }
    } else if shard.is_some() {
        return Err("--shard applies to convergence studies only".into());
    }
    Ok(Command::Run {
        mode,
        scenes,
        overrides: o,
        quick,
        out,
        shard,
    })
}

/// Reads every `shard-*.json` in the folders and their scene subfolders.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<ConvergenceRun>, String> {
    let mut shards = Vec::new();
    let visit = |dir: &Path, shards: &mut Vec<ConvergenceRun>| -> Result<Vec<PathBuf>, String> {
        let entries =
            std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        let mut subdirs = Vec::new();
        for entry in entries.flatten() {
            let path = entry.path();
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if path.is_dir() {
                subdirs.push(path);
            } else if name.starts_with("shard-") && name.ends_with(".json") {
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
                let shard: ConvergenceRun = serde_json::from_str(&text)
                    .map_err(|e| format!("{} is not a shard file: {e}", path.display()))?;
                shards.push(shard);
            }
        }
        Ok(subdirs)
    };
    for dir in dirs {
        for sub in visit(dir, &mut shards)? {
            visit(&sub, &mut shards)?;
        }
    }
    if shards.is_empty() {
        return Err("no shard-*.json files found".into());
    }
    Ok(shards)
}

fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), String> {
    let mut by_scene: BTreeMap<String, Vec<ConvergenceRun>> = BTreeMap::new();
    for shard in read_shards(dirs)? {
        by_scene
            .entry(shard.scene.name.clone())
            .or_default()
            .push(shard);
    }
    for (name, shards) in by_scene {
        let report = merge_shards(shards).map_err(|e| format!("scene {name}: {e}"))?;
        print_summary(&report);
        let dir = out.join(&name);
        write_report(&report, &dir)?;
        println!("wrote {}/report.{{json,csv,md}} and plots", dir.display());
    }
    Ok(())
}

/// Runs shard `index` of `count` of a study of `scene` with a progress bar.
fn run_with_progress(
    scene: &Scene,
    settings: &ConvergenceSettings,
    (index, count): (usize, usize),
) -> Result<ConvergenceRun, String> {
    eprintln!(
        "{}: {} paths (shard {index}/{count}), N = 2^{}..2^{}, {}, T = {}, {} threads",
        scene.name,
        settings.paths,
        settings.coarsest,
        settings.finest,
        settings
            .reference
            .map_or("no reference".into(), |r| format!(
                "reference 2^{r} ({})",
                settings.reference_scheme.name()
            )),
        settings.t_end,
        settings.threads
    );
    // Drawn on stderr when it is a terminal; hidden otherwise (CI logs stay clean).
    let mine = (index..settings.paths).step_by(count).count();
    let bar = ProgressBar::new(mine as u64).with_style(
        ProgressStyle::with_template("  {bar:40} {pos}/{len} paths, {elapsed} elapsed, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let run = run_convergence(scene, settings, (index, count), |done| {
        bar.set_position(done as u64)
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    Ok(run)
}

fn run_scene(
    scene: &Scene,
    settings: &ConvergenceSettings,
    out: &Path,
    shard: Option<(usize, usize)>,
) -> Result<(), String> {
    let (index, count) = shard.unwrap_or((0, 1));
    let mine = (index..settings.paths).step_by(count).count();
    let run = run_with_progress(scene, settings, (index, count))?;
    let dir = out.join(&scene.name);
    if shard.is_some() {
        let file = dir.join(format!("shard-{index}-of-{count}.json"));
        std::fs::create_dir_all(&dir)
            .and_then(|()| serde_json::to_string(&run).map_err(std::io::Error::other))
            .and_then(|json| std::fs::write(&file, json))
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        println!(
            "wrote {} ({mine} paths); merge all shards with `cargo xtask study merge DIR...`",
            file.display()
        );
        return Ok(());
    }
    let report = build_report(run);
    print_summary(&report);
    write_report(&report, &dir)?;
    println!(
        "wrote {0}/report.json, report.csv, report.md, error_vs_h.svg, error_vs_time.svg",
        dir.display()
    );
    Ok(())
}

/// The built-in scenes a study runs by default.
fn default_scenes(mode: Mode) -> Result<Vec<Scene>, String> {
    let all = BUILT_IN
        .iter()
        .map(|(name, _)| Scene::built_in(name).map_err(|e| e.to_string()))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(match mode {
        Mode::Convergence => all.into_iter().filter(|s| s.name == "pendulum").collect(),
        Mode::Trace => all,
        Mode::Stability => all.into_iter().filter(|s| s.stability.is_some()).collect(),
        Mode::Equipartition => all
            .into_iter()
            .filter(|s| s.equipartition.is_some())
            .collect(),
    })
}

/// Applies the command line's paths, seed and threads to a stability or equipartition run.
fn apply(o: &Overrides, mut s: ConvergenceSettings) -> ConvergenceSettings {
    s.paths = o.paths.unwrap_or(s.paths);
    s.seed = o.seed.unwrap_or(s.seed);
    s.threads = o.threads.unwrap_or(s.threads);
    s
}

fn run_stability(scenes: &[Scene], o: &Overrides, quick: bool, out: &Path) -> Result<(), String> {
    let mut report = StabilityReport { scenes: Vec::new() };
    for scene in scenes {
        let settings = stability_settings(scene, quick)
            .ok_or_else(|| format!("scene {} has no [stability] table", scene.name))?;
        let settings = apply(o, settings);
        settings
            .validate()
            .map_err(|e| format!("scene {}: {e}", scene.name))?;
        let run = run_with_progress(scene, &settings, (0, 1))?;
        let case = scene
            .stability
            .as_ref()
            .map(|s| s.case.clone())
            .unwrap_or_default();
        report.scenes.push(StabilityScene {
            case,
            report: build_report(run),
        });
    }
    let dir = out.join("stability");
    stability::write_report(&report, &dir)?;
    println!(
        "{}",
        stability::markdown(&report)
            .lines()
            .take(4 + report.scenes.len())
            .collect::<Vec<_>>()
            .join("\n")
    );
    println!(
        "wrote {0}/report.json, report.md, stability.svg",
        dir.display()
    );
    Ok(())
}

fn run_equipartition(
    scenes: &[Scene],
    o: &Overrides,
    quick: bool,
    out: &Path,
) -> Result<(), String> {
    let mut results = Vec::new();
    for scene in scenes {
        let variants = equipartition::variants(scene, quick)
            .ok_or_else(|| format!("scene {} has no [equipartition] table", scene.name))?;
        let mut reports = Vec::new();
        for variant in variants {
            let settings = apply(o, variant.settings);
            settings
                .validate()
                .map_err(|e| format!("scene {}: {e}", scene.name))?;
            eprintln!("{}: {}", scene.name, variant.label);
            reports.push(build_report(run_with_progress(
                &variant.scene,
                &settings,
                (0, 1),
            )?));
        }
        let collected = equipartition::collect(&reports).ok_or_else(|| {
            format!(
                "scene {} has no equipartition value (not a Langevin system)",
                scene.name
            )
        })?;
        results.push(collected);
    }
    let dir = out.join("equipartition");
    equipartition::write_report(&results, &dir)?;
    for sc in &results {
        let biased = sc.rows.iter().filter(|r| r.biased == Some(true)).count();
        println!(
            "{}: {biased} of {} settings biased (95% interval excludes the set temperature)",
            sc.scene,
            sc.rows.len()
        );
    }
    println!(
        "wrote {0}/report.json, report.md, equipartition.svg",
        dir.display()
    );
    Ok(())
}

/// The number of steps of a scene's trace: its finest study level (default 2^10).
fn trace_steps(scene: &Scene) -> usize {
    let finest = scene
        .study
        .levels
        .map(|l| l[1])
        .or(scene.stability.as_ref().map(|s| s.levels[1]))
        .or(scene.equipartition.as_ref().map(|e| e.levels[1]))
        .unwrap_or(10);
    1 << finest
}

fn run_trace(scenes: &[Scene], o: &Overrides, out: &Path) -> Result<(), String> {
    let dir = out.join("trace");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot write to {}: {e}", dir.display()))?;
    for scene in scenes {
        let steps = trace_steps(scene);
        let trace =
            trace::trace(scene, steps, o.seed.unwrap_or(2026)).map_err(|e| e.to_string())?;
        if let Some(failure) = &trace.failure {
            eprintln!("{}: the path stopped early: {failure}", scene.name);
        }
        let file = dir.join(format!("{}.csv", scene.name));
        std::fs::write(&file, trace::csv(&trace))
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        let title = format!(
            "{}: one path, {steps} steps over T = {}",
            scene.name, scene.t_end
        );
        trace::plot(&trace, &title, &dir.join(format!("{}.svg", scene.name)))?;
        println!(
            "wrote {0}/{1}.svg and {0}/{1}.csv",
            dir.display(),
            scene.name
        );
    }
    Ok(())
}

fn list() {
    println!("built-in scenes:");
    for (name, _) in BUILT_IN {
        match Scene::built_in(name) {
            Ok(scene) => println!("  {name:<24} {}", scene.description),
            Err(e) => println!("  {name:<24} (broken: {e})"),
        }
    }
    println!("schemes:");
    for kind in SchemeKind::ALL {
        println!("  {}", kind.name());
    }
}

fn main() -> ExitCode {
    let command = match parse_args(std::env::args().skip(1).collect()) {
        Ok(c) => c,
        Err(message) => {
            eprintln!("sdae-study: {message}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let result = match command {
        Command::Help => {
            print!("{USAGE}");
            Ok(())
        }
        Command::List => {
            list();
            Ok(())
        }
        Command::Merge { dirs, out } => merge(&dirs, &out),
        Command::Run {
            mode: Mode::Convergence,
            scenes,
            overrides,
            quick,
            out,
            shard,
        } => scenes
            .iter()
            .try_for_each(|scene| run_scene(scene, &overrides.settings(scene, quick), &out, shard)),
        Command::Run {
            mode: Mode::Stability,
            scenes,
            overrides,
            quick,
            out,
            ..
        } => run_stability(&scenes, &overrides, quick, &out),
        Command::Run {
            mode: Mode::Equipartition,
            scenes,
            overrides,
            quick,
            out,
            ..
        } => run_equipartition(&scenes, &overrides, quick, &out),
        Command::Run {
            mode: Mode::Trace,
            scenes,
            overrides,
            out,
            ..
        } => run_trace(&scenes, &overrides, &out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("sdae-study: {message}");
            ExitCode::FAILURE
        }
    }
}
