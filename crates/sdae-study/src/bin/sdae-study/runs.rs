//! What each subcommand does: run the studies with progress bars and checkpoints, write the
//! reports, and say where they went.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_study::checkpoint::{Checkpoint, Resumed};
use sdae_study::convergence::{
    ConvergenceReport, ConvergenceRun, ConvergenceSettings, build_report, merge_shards,
};
use sdae_study::files::{read_json, write_json};
use sdae_study::integrator::SchemeKind;
use sdae_study::output::{print_summary, readable, write_report};
use sdae_study::parallel::Control;
use sdae_study::scene::{BUILT_IN, Scene};
use sdae_study::stability::{self, StabilityReport, StabilityScene, stability_settings};
use sdae_study::{equipartition, trace, weak};

use crate::Failure;
use crate::args::{ConvergenceArgs, EnsembleArgs, TraceArgs};

/// A progress bar of `len` items on stderr, drawn when stderr is a terminal (CI logs stay
/// clean).
fn bar(len: usize, what: &str) -> ProgressBar {
    let template = format!("  {{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} elapsed, ETA {{eta}}");
    ProgressBar::new(len as u64).with_style(
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    )
}

/// One study run of a scene that an interruption does not lose.
struct Job<'a> {
    scene: &'a Scene,
    settings: &'a ConvergenceSettings,
    shard: (usize, usize),
    checkpoint: Checkpoint,
}

impl Job<'_> {
    /// Runs the job with a progress bar, from the saved paths with `resume`; an interruption
    /// saves the finished paths and comes back as [`Failure::Interrupted`].
    fn run(&self, resume: bool, stop: &AtomicBool) -> Result<ConvergenceRun, Failure> {
        let (scene, st, (index, count)) = (self.scene, self.settings, self.shard);
        let saved = if resume {
            self.checkpoint.load(scene, st, self.shard)?
        } else {
            if self.checkpoint.path().exists() {
                eprintln!(
                    "note: starting afresh; {} held the paths of an interrupted run (--resume \
                     carries on from them)",
                    self.checkpoint.path().display()
                );
            }
            None
        };
        let reference = st.reference.map_or("no reference".into(), |r| {
            format!("reference 2^{r} ({})", st.reference_scheme.name())
        });
        eprintln!(
            "{}: {} paths (shard {index}/{count}), N = 2^{}..2^{}, {reference}, T = {}, {} threads",
            scene.name,
            st.paths,
            st.coarsest,
            st.finest,
            readable(st.t_end),
            st.threads
        );
        let selected = (index..st.paths).step_by(count).count();
        let bar = bar(selected, "paths");
        bar.set_position(saved.as_ref().map_or(0, |s| s.records.len()) as u64);
        let control = Control {
            progress: Some(&|_| bar.inc(1)),
            stop: Some(stop),
            done: &[],
        };
        let resumed = self.checkpoint.run(scene, st, self.shard, saved, control)?;
        bar.finish_and_clear();
        match resumed {
            Resumed::Finished(run) => Ok(*run),
            Resumed::Interrupted { saved, selected } => Err(Failure::Interrupted(format!(
                "{}: interrupted; {saved} of {selected} paths are saved in {}: run the same \
                 command with --resume to carry on",
                scene.name,
                self.checkpoint.path().display()
            ))),
        }
    }
}

/// Validates each scene's settings before anything runs, so that a bad value stops the
/// command at once.
fn checked(scenes: &[Scene], settings: &[ConvergenceSettings]) -> Result<(), Failure> {
    for (scene, s) in scenes.iter().zip(settings) {
        // Whatever the library calls it, a setting it refuses is a usage error.
        s.validate().map_err(|e| {
            let failure = match Failure::from(e) {
                Failure::Failed(message) => Failure::Usage(message),
                other => other,
            };
            failure.within(&format!("scene {}", scene.name))
        })?;
    }
    Ok(())
}

/// The convergence study of each scene, or one shard of it.
pub fn convergence(args: &ConvergenceArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let e = &args.ensemble;
    let scenes = e.scenes.load(|s| s.name == "pendulum")?;
    let settings: Vec<_> = scenes.iter().map(|s| args.settings(s)).collect();
    checked(&scenes, &settings)?;
    let shard = args
        .shard
        .map(|s| s.resolve(|name| std::env::var(name).ok()))
        .transpose()
        .map_err(Failure::Usage)?;
    let (index, count) = shard.unwrap_or((0, 1));
    let mut uncompared = Vec::new();
    for (scene, settings) in scenes.iter().zip(&settings) {
        let dir = e.out.out.join(&scene.name);
        let job = Job {
            scene,
            settings,
            shard: (index, count),
            checkpoint: Checkpoint::new(dir.join(format!("checkpoint-{index}-of-{count}.json"))),
        };
        let run = job.run(e.resume, stop)?;
        if shard.is_some() {
            let file = dir.join(format!("shard-{index}-of-{count}.json"));
            write_json(&file, &run)?;
            job.checkpoint.remove()?;
            println!(
                "wrote {} ({} paths); merge all shards with `cargo xtask study merge DIR...`",
                file.display(),
                run.records.len()
            );
            continue;
        }
        let report = build_report(run);
        print_summary(&report);
        write_report(&report, &dir)?;
        job.checkpoint.remove()?;
        println!(
            "wrote {0}/report.json, report.csv, report.md, error_vs_h.svg, error_vs_time.svg",
            dir.display()
        );
        uncompared.extend(uncompared_in(&report));
    }
    nothing_uncompared(uncompared)
}

/// What of `report` could not be compared with the reference, prefixed by the scene.
fn uncompared_in(report: &ConvergenceReport) -> Vec<String> {
    report
        .uncompared()
        .into_iter()
        .map(|line| format!("scene {}: {line}", report.scene))
        .collect()
}

/// Exit code 1 (through [`Failure::Failed`]) when something could not be compared with the
/// reference: the message names the failure kinds and counts.
fn nothing_uncompared(uncompared: Vec<String>) -> Result<(), Failure> {
    if uncompared.is_empty() {
        Ok(())
    } else {
        Err(Failure::Failed(format!(
            "nothing to compare for\n  {}",
            uncompared.join("\n  ")
        )))
    }
}

/// Every `shard-*.json` in the folders and their subfolders (one level deep).
fn shard_files(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, Failure> {
    let mut files = Vec::new();
    let mut visit = |dir: &Path, deeper: bool| -> Result<Vec<PathBuf>, Failure> {
        let entries = std::fs::read_dir(dir)
            .map_err(|e| Failure::Failed(format!("cannot read {}: {e}", dir.display())))?;
        let mut subdirs = Vec::new();
        for path in entries.flatten().map(|entry| entry.path()) {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if path.is_dir() && deeper {
                subdirs.push(path);
            } else if name.starts_with("shard-") && name.ends_with(".json") {
                files.push(path);
            }
        }
        Ok(subdirs)
    };
    for dir in dirs {
        for sub in visit(dir, true)? {
            visit(&sub, false)?;
        }
    }
    if files.is_empty() {
        return Err(Failure::Failed("no shard-*.json files found".into()));
    }
    files.sort();
    Ok(files)
}

/// Merges the shard files under `dirs`, one report per scene.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), Failure> {
    let mut by_scene: BTreeMap<String, Vec<ConvergenceRun>> = BTreeMap::new();
    for file in shard_files(dirs)? {
        let shard: ConvergenceRun = read_json(&file).map_err(|e| Failure::Failed(e.to_string()))?;
        by_scene
            .entry(shard.scene.name.clone())
            .or_default()
            .push(shard);
    }
    let mut uncompared = Vec::new();
    for (name, shards) in by_scene {
        let context = format!("scene {name}");
        let report = merge_shards(shards).map_err(|e| Failure::from(e).within(&context))?;
        print_summary(&report);
        let dir = out.join(&name);
        write_report(&report, &dir)?;
        println!("wrote {}/report.{{json,csv,md}} and plots", dir.display());
        uncompared.extend(uncompared_in(&report));
    }
    nothing_uncompared(uncompared)
}

/// The stability study of the scenes with a [stability] table (or those named).
pub fn stability(args: &EnsembleArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.stability.is_some())?;
    let settings = scenes
        .iter()
        .map(|scene| {
            stability_settings(scene, args.quick)
                .map(|s| args.apply(s))
                .ok_or_else(|| {
                    Failure::Usage(format!("scene {} has no [stability] table", scene.name))
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    checked(&scenes, &settings)?;
    let dir = args.out.out.join("stability");
    let mut report = StabilityReport { scenes: Vec::new() };
    let mut checkpoints = Vec::new();
    for (scene, settings) in scenes.iter().zip(&settings) {
        let job = Job {
            scene,
            settings,
            shard: (0, 1),
            checkpoint: Checkpoint::new(dir.join(format!("{}.checkpoint.json", scene.name))),
        };
        let run = job.run(args.resume, stop)?;
        checkpoints.push(job.checkpoint);
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
    stability::write_report(&report, &dir)?;
    checkpoints.iter().try_for_each(Checkpoint::remove)?;
    let table = stability::markdown(&report);
    let head: Vec<&str> = table.lines().take(4 + report.scenes.len()).collect();
    println!("{}", head.join("\n"));
    println!(
        "wrote {0}/report.json, report.md, stability.svg",
        dir.display()
    );
    Ok(())
}

/// The equipartition study of the scenes with an [equipartition] table (or those named).
pub fn equipartition(args: &EnsembleArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.equipartition.is_some())?;
    let mut all = Vec::new();
    for scene in &scenes {
        let variants = equipartition::variants(scene, args.quick).ok_or_else(|| {
            Failure::Usage(format!("scene {} has no [equipartition] table", scene.name))
        })?;
        let settings: Vec<_> = variants
            .iter()
            .map(|v| args.apply(v.settings.clone()))
            .collect();
        let variant_scenes: Vec<_> = variants.iter().map(|v| v.scene.clone()).collect();
        checked(&variant_scenes, &settings)?;
        all.push((scene, variants, settings));
    }
    let dir = args.out.out.join("equipartition");
    let (mut results, mut checkpoints) = (Vec::new(), Vec::new());
    for (scene, variants, settings) in &all {
        let mut reports = Vec::new();
        for (k, (variant, settings)) in variants.iter().zip(settings).enumerate() {
            eprintln!("{}: {}", scene.name, variant.label);
            let job = Job {
                scene: &variant.scene,
                settings,
                shard: (0, 1),
                checkpoint: Checkpoint::new(
                    dir.join(format!("{}-{k}.checkpoint.json", scene.name)),
                ),
            };
            reports.push(build_report(job.run(args.resume, stop)?));
            checkpoints.push(job.checkpoint);
        }
        results.push(equipartition::collect(&reports).ok_or_else(|| {
            Failure::Usage(format!(
                "scene {} has no equipartition value (not a Langevin system)",
                scene.name
            ))
        })?);
    }
    equipartition::write_report(&results, &dir)?;
    checkpoints.iter().try_for_each(Checkpoint::remove)?;
    for scene in &results {
        let biased = scene.rows.iter().filter(|r| r.biased == Some(true)).count();
        println!(
            "{}: {biased} of {} settings biased (95% interval excludes the set temperature)",
            scene.scene,
            scene.rows.len()
        );
    }
    println!(
        "wrote {0}/report.json, report.md, equipartition.svg",
        dir.display()
    );
    Ok(())
}

/// The weak-error study of each scene named (default: the pendulum), from its [weak] table.
pub fn weak(args: &EnsembleArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.name == "pendulum")?;
    let settings = scenes
        .iter()
        .map(|scene| {
            weak::weak_settings(scene, args.quick)
                .map(|s| args.apply(s))
                .ok_or_else(|| Failure::Usage(format!("scene {} has no [weak] table", scene.name)))
        })
        .collect::<Result<Vec<_>, _>>()?;
    checked(&scenes, &settings)?;
    let mut uncompared = Vec::new();
    for (scene, settings) in scenes.iter().zip(&settings) {
        let dir = args.out.out.join(&scene.name);
        let job = Job {
            scene,
            settings,
            shard: (0, 1),
            checkpoint: Checkpoint::new(dir.join("weak-checkpoint.json")),
        };
        let report = weak::build_weak_report(job.run(args.resume, stop)?)?;
        weak::report::print_summary(&report);
        weak::report::write_report(&report, &dir)?;
        job.checkpoint.remove()?;
        println!(
            "wrote {0}/weak.json, weak.csv, weak.md, weak_error_vs_h.svg, weak_error_vs_time.svg",
            dir.display()
        );
        uncompared.extend(
            report
                .uncompared()
                .into_iter()
                .map(|line| format!("scene {}: {line}", report.scene)),
        );
    }
    nothing_uncompared(uncompared)
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

/// One path of each scene as a picture and a CSV file.
pub fn trace(args: &TraceArgs) -> Result<(), Failure> {
    let scenes = args.scenes.load(|_| true)?;
    let dir = args.out.out.join("trace");
    let bar = bar(scenes.len(), "scenes");
    for scene in &scenes {
        let steps = trace_steps(scene);
        let trace = trace::trace(scene, steps, args.seed)?;
        if let Some(failure) = &trace.failure {
            bar.suspend(|| eprintln!("{}: the path stopped early: {failure}", scene.name));
        }
        let file = dir.join(format!("{}.csv", scene.name));
        sdae_study::files::write_atomically(&file, &trace::csv(&trace))?;
        let title = format!(
            "{}: one path, {steps} steps over T = {}",
            scene.name,
            readable(scene.t_end)
        );
        trace::plot(&trace, &title, &dir.join(format!("{}.svg", scene.name)))?;
        bar.suspend(|| {
            println!(
                "wrote {0}/{1}.svg and {0}/{1}.csv",
                dir.display(),
                scene.name
            )
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(())
}

/// The built-in scenes and the schemes.
pub fn list() {
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
