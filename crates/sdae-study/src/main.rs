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

const USAGE: &str = "\
sdae-study: strong errors of the half-explicit drift-truncated Euler scheme and of solvers of
the inherent SDE, against a fine-step reference on the same Brownian paths, with run time.

Usage: sdae-study [options]           convergence study (default: the pendulum scene)
       sdae-study merge DIR... [--out DIR]
                                      merge shard files into the unsharded report
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
  --quick              a small run for CI: 200 paths, levels 3..7, reference 2^11
  --shard I/N          run only paths i with i % N == I, write DIR/<scene>/shard-I-of-N.json
  --help               this text

Each scene folder gets report.json, report.csv, report.md, error_vs_h.svg, error_vs_time.svg.
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
    fn settings(&self, scene: &Scene) -> ConvergenceSettings {
        let mut s = ConvergenceSettings::for_scene(scene);
        if let Some((a, b)) = self.levels {
            s.coarsest = a;
            s.finest = b;
        }
        if let Some(x) = &self.schemes {
            s.schemes = x.clone();
        }
        s.reference_scheme = self.reference_scheme.unwrap_or(s.reference_scheme);
        s.paths = self.paths.unwrap_or(s.paths);
        s.reference = self.reference.unwrap_or(s.reference);
        s.t_end = self.t_end.unwrap_or(s.t_end);
        s.seed = self.seed.unwrap_or(s.seed);
        s.p = self.p.unwrap_or(s.p);
        s.threads = self.threads.unwrap_or(s.threads);
        s
    }
}

/// What the command line asks for.
enum Command {
    Help,
    List,
    Run {
        scenes: Vec<Scene>,
        overrides: Overrides,
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
    let merge = match args.peek().map(String::as_str) {
        Some("merge") => {
            args.next();
            true
        }
        Some("list") => return Ok(Command::List),
        _ => false,
    };
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
            "--quick" => {
                o.paths = Some(200);
                o.levels = Some((3, 7));
                o.reference = Some(11);
            }
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
    if names.is_empty() && files.is_empty() {
        names.push("pendulum".into());
    }
    let mut scenes = Vec::new();
    for name in &names {
        scenes.push(Scene::built_in(name).map_err(|e| e.to_string())?);
    }
    for file in &files {
        scenes.push(Scene::from_file(file).map_err(|e| e.to_string())?);
    }
    for scene in &scenes {
        o.settings(scene)
            .validate()
            .map_err(|e| format!("scene {}: {e}", scene.name))?;
    }
    Ok(Command::Run {
        scenes,
        overrides: o,
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

fn run_scene(
    scene: &Scene,
    settings: &ConvergenceSettings,
    out: &Path,
    shard: Option<(usize, usize)>,
) -> Result<(), String> {
    let (index, count) = shard.unwrap_or((0, 1));
    eprintln!(
        "{}: {} paths (shard {index}/{count}), N = 2^{}..2^{}, reference 2^{} ({}), T = {}, {} threads",
        scene.name,
        settings.paths,
        settings.coarsest,
        settings.finest,
        settings.reference,
        settings.reference_scheme.name(),
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
            scenes,
            overrides,
            out,
            shard,
        } => scenes
            .iter()
            .try_for_each(|scene| run_scene(scene, &overrides.settings(scene), &out, shard)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("sdae-study: {message}");
            ExitCode::FAILURE
        }
    }
}
