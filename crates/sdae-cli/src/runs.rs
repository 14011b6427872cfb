//! What each subcommand does: run the studies with progress bars and checkpoints, write the
//! reports, and say where they went.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use sdae_cli::checkpoint::{Checkpoint, Resumed, RunLock, SavedPaths};
use sdae_cli::compare::{first_difference, numbers_of};
use sdae_cli::folders::{check_writable, remove_stale_temporaries};
use sdae_study::StudyError;
use sdae_study::convergence::{
    ConvergenceReport, ConvergenceRun, ConvergenceSettings, build_report, merge_runs,
};
use sdae_study::integrator::SchemeKind;
use sdae_study::output::{print_summary, readable, write_report};
use sdae_study::parallel::Control;
use sdae_study::scene::{BUILT_IN, Scene, escaped};
use sdae_study::scene_load::key_in_table;
use sdae_study::stability::{self, StabilityReport, StabilityScene};
use sdae_study::{equipartition, trace, weak};

use crate::args::{CheckpointArgs, ConvergenceArgs, EnsembleArgs, TraceArgs, WeakArgs};
use crate::failure::Failure;
use crate::shard::ShardArg;
use crate::stopping;

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

/// What the command line says about checkpoints.
#[derive(Debug, Clone, Copy)]
pub struct Resumption {
    /// Carry on from a checkpoint.
    pub resume: bool,
    /// Discard a checkpoint.
    pub fresh: bool,
    /// Save what is finished this often.
    pub every: Duration,
}

impl Resumption {
    /// The command line's checkpoint options.
    pub fn of(args: &CheckpointArgs) -> Self {
        Resumption {
            resume: args.resume,
            fresh: args.fresh,
            // The parser bounds the interval by a year; a value it let through that a Duration
            // cannot hold means "never periodically".
            every: Duration::try_from_secs_f64(args.checkpoint_every).unwrap_or(Duration::MAX),
        }
    }
}

/// Checks that `dir`, the output folder or a folder in it, can be written
/// ([`check_writable`]), else refuses (exit code 2) naming where the folder came from: --out,
/// or the SDAE_STUDY_OUT variable when --out was not typed.
pub fn writable_out(dir: &Path) -> Result<(), Failure> {
    check_writable(dir).map_err(|e| {
        let from = match std::env::var_os("SDAE_STUDY_OUT") {
            Some(_) if !crate::args::typed("--out") => "SDAE_STUDY_OUT",
            _ => "--out",
        };
        refused(e).within(from)
    })
}

/// A library error met before anything ran: a refusal (exit code 2), whatever its kind.
pub fn refused(e: StudyError) -> Failure {
    match Failure::from(e) {
        Failure::Failed(message) => Failure::Usage(message),
        other => other,
    }
}

/// A job made ready to run: its folder checked, its results locked (until it is dropped), and
/// the paths it resumes from.
struct Ready<'a> {
    job: Job<'a>,
    saved: Option<SavedPaths>,
    /// Printed before the job runs (an equipartition variant's name).
    label: Option<String>,
    _lock: RunLock,
}

impl<'a> Job<'a> {
    /// The job of shard `shard` of `scene` under `settings`, its checkpoint at `file` saved as
    /// `how` says.
    fn new(
        scene: &'a Scene, settings: &'a ConvergenceSettings, shard: (usize, usize), file: PathBuf,
        how: Resumption,
    ) -> Self {
        Job {
            scene,
            settings,
            shard,
            checkpoint: Checkpoint::new(file).every(how.every),
        }
    }

    /// Before anything runs: see [`prepare`].
    fn ready(self, how: Resumption, outputs: &[&str]) -> Result<Ready<'a>, Failure> {
        let (saved, lock) = prepare(&self, &self.scene.name, how, outputs)?;
        Ok(Ready {
            job: self,
            saved,
            label: None,
            _lock: lock,
        })
    }

    /// The paths of the job's shard.
    fn selected(&self) -> usize {
        let (index, count) = self.shard;
        (index..self.settings.paths).step_by(count).count()
    }
}

/// A run's checkpoint as [`prepare`] sees it: the paths of a convergence-type study, or the
/// blocks of samples of an MLMC run.
pub trait Resumable {
    /// What the checkpoint holds, read back.
    type Saved;
    /// The checkpoint file.
    fn file(&self) -> &Path;
    /// Takes the lock of the checkpoint.
    fn lock(&self) -> Result<RunLock, StudyError>;
    /// What the checkpoint file holds ("8 of 30 paths"), if its header can be read.
    fn holds(&self) -> Option<String>;
    /// What the checkpoint holds for this run, checked; `None` when there is no checkpoint.
    fn load(&self) -> Result<Option<Self::Saved>, StudyError>;
    /// What `saved` holds ("8 of 30 paths").
    fn describe(&self, saved: &Self::Saved) -> String;
    /// Removes the checkpoint file.
    fn remove(&self) -> Result<(), StudyError>;
}

impl Resumable for Job<'_> {
    type Saved = SavedPaths;
    fn file(&self) -> &Path {
        self.checkpoint.path()
    }
    fn lock(&self) -> Result<RunLock, StudyError> {
        self.checkpoint.lock()
    }
    fn holds(&self) -> Option<String> {
        let (n, m) = self.checkpoint.holds()?;
        Some(format!("{n} of {m} paths"))
    }
    fn load(&self) -> Result<Option<SavedPaths>, StudyError> {
        self.checkpoint.load(self.scene, self.settings, self.shard)
    }
    fn describe(&self, saved: &SavedPaths) -> String {
        let torn = saved
            .torn_note()
            .map_or(String::new(), |n| format!(" ({n})"));
        format!("{} of {} paths{torn}", saved.records.len(), self.selected())
    }
    fn remove(&self) -> Result<(), StudyError> {
        self.checkpoint.remove()
    }
}

/// Before a run of scene `name` starts: checks that its checkpoint's folder is writable, takes
/// the lock of the checkpoint (held until the lock returned is dropped), removes the temporary
/// files of `outputs` (and of the checkpoint) that killed runs left, and reads the checkpoint
/// with --resume. A checkpoint found without --resume is refused, or discarded with --fresh.
pub fn prepare<R: Resumable>(
    checkpoint: &R, name: &str, how: Resumption, outputs: &[&str],
) -> Result<(Option<R::Saved>, RunLock), Failure> {
    let path = checkpoint.file().to_path_buf();
    let dir = path.parent().unwrap_or(Path::new("."));
    writable_out(dir)?;
    let lock = checkpoint.lock().map_err(refused)?;
    stopping::hold(lock.path().to_path_buf());
    if let Some(pid) = lock.took_over {
        note!(
            "note: {} was left by process {pid}, which is gone: taken over",
            lock.path().display()
        );
    }
    let own = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let names: Vec<&str> = outputs.iter().copied().chain([own]).collect();
    let removed = remove_stale_temporaries(dir, &names);
    if removed > 0 {
        note!(
            "note: removed {removed} temporary file(s) in {} left by a killed run",
            dir.display()
        );
    }
    let saved = if how.resume {
        let saved = checkpoint
            .load()
            .map_err(|e| refused(e).within(&format!("scene {name}")))?;
        match &saved {
            Some(s) => note!(
                "{name}: resuming from {} saved in {}",
                checkpoint.describe(s),
                path.display()
            ),
            None => note!(
                "{name}: nothing to resume ({} does not exist): starting from the beginning",
                path.display()
            ),
        }
        saved
    } else if path.exists() {
        let what = checkpoint.holds().map_or_else(
            || "a file that is not a checkpoint".into(),
            |held| format!("{held} of an interrupted run"),
        );
        if !how.fresh {
            return Err(Failure::Usage(format!(
                "scene {name}: {} holds {what}: --resume carries on from them, --fresh \
                 discards them",
                path.display()
            )));
        }
        note!("note: --fresh: discarding {} ({what})", path.display());
        checkpoint.remove().map_err(refused)?;
        None
    } else {
        None
    };
    Ok((saved, lock))
}

impl Ready<'_> {
    /// Runs the job with a progress bar, from the saved paths; an interruption saves the
    /// finished paths and comes back as [`Failure::Interrupted`] (exit code 130), or as
    /// [`Failure::Unsaved`] (131) when no path finished or they could not be saved.
    fn run(&mut self, stop: &AtomicBool) -> Result<ConvergenceRun, Failure> {
        let job = &self.job;
        let (scene, st, (index, count)) = (job.scene, job.settings, job.shard);
        let reference = st.reference.map_or("no reference".into(), |r| {
            let pair = if st.paired_reference {
                format!(" and 2^{}, extrapolated", r - 1)
            } else {
                String::new()
            };
            format!("reference 2^{r}{pair} ({})", st.reference_scheme.name())
        });
        note!(
            "{}: {} paths (shard {index}/{count}), N = 2^{}..2^{}, {reference}, T = {}, {} threads",
            scene.name,
            st.paths,
            st.coarsest,
            st.finest,
            readable(st.t_end),
            st.threads
        );
        stopping::running();
        let saved = self.saved.take();
        let bar = bar(job.selected(), "paths");
        bar.set_position(saved.as_ref().map_or(0, |s| s.records.len()) as u64);
        let control = Control {
            progress: Some(&|_| bar.inc(1)),
            stop: Some(stop),
            ..Control::default()
        };
        let resumed = job.checkpoint.run(scene, st, job.shard, saved, control);
        bar.finish_and_clear();
        let file = job.checkpoint.path().display();
        match resumed {
            Ok(Resumed::Finished(run)) => {
                self.keep(&run);
                Ok(*run)
            }
            Ok(Resumed::Interrupted { saved: 0, selected }) => Err(Failure::Unsaved(format!(
                "{}: interrupted before any of its {selected} paths finished: nothing saved",
                scene.name
            ))),
            Ok(Resumed::Interrupted { saved, selected }) => Err(Failure::Interrupted(format!(
                "{}: interrupted; {saved} of {selected} paths are saved in {file}: run the same \
                 command with --resume to carry on",
                scene.name
            ))),
            Err(e) if stop.load(Ordering::SeqCst) => Err(Failure::Unsaved(format!(
                "{}: interrupted, and the finished paths could not be saved: {e}",
                scene.name
            ))),
            Err(e @ StudyError::Threads { .. }) => Err(refused(e)),
            Err(e) => Err(Failure::from(e)),
        }
    }
}

impl Ready<'_> {
    /// The finished `run` is in the job's checkpoint ([`Checkpoint::run`] saved it): a stop
    /// signal from now on, while the report is computed and written, ends the process at once,
    /// losing nothing: the same command with --resume writes the report without running again.
    fn keep(&self, run: &ConvergenceRun) {
        let file = self.job.checkpoint.path().display();
        stopping::all_saved(format!(
            "{}: stopped after every path finished; all {} paths are saved in {file}: run the \
             same command with --resume to write the results without running again",
            self.job.scene.name,
            run.records.len(),
        ));
    }
}

/// After the finished runs of `jobs` were written (`written`, the report first): removes
/// their checkpoints; if they could not be written, the checkpoints (which hold every path of
/// a finished run) stay, so that --resume writes the results without running again.
fn deliver(jobs: &[Ready<'_>], written: Result<(), StudyError>) -> Result<(), Failure> {
    let Err(e) = written else {
        // The results are written: a signal from now on need not end the process (and the
        // checkpoint it would name is going).
        stopping::running();
        return jobs
            .iter()
            .try_for_each(|r| r.job.checkpoint.remove())
            .map_err(Failure::from);
    };
    let files: Vec<String> = jobs
        .iter()
        .map(|r| r.job.checkpoint.path().display().to_string())
        .collect();
    Err(Failure::Failed(format!(
        "{e}; the finished paths are saved in {}: --resume writes the results without running \
         again",
        files.join(", ")
    )))
}

/// Refuses two scenes of one name in one command: their results would overwrite each other.
fn distinct(scenes: &[Scene]) -> Result<(), Failure> {
    let mut names = std::collections::BTreeSet::new();
    match scenes.iter().find(|s| !names.insert(&s.name)) {
        Some(twice) => Err(Failure::Usage(format!(
            "two scenes are named {0}: their results would overwrite each other (give one \
             another name in its scene file)",
            twice.name
        ))),
        None => Ok(()),
    }
}

/// The files a convergence report puts in its scene's folder.
const REPORT_FILES: [&str; 5] = [
    "report.json",
    "report.csv",
    "report.md",
    "error_vs_h.svg",
    "error_vs_time.svg",
];

/// Validates each scene's settings before anything runs, so that a bad value stops the
/// command at once. A setting the user did not type is named by its key in the scene table
/// `table` the study reads (`weak.paths` for the weak study), with the scene file it came from
/// (`file(k)` for the k-th scene), as a scene file's own values are.
fn checked<'p>(
    scenes: &[Scene], settings: &[ConvergenceSettings], table: &str,
    file: impl Fn(usize) -> Option<&'p Path>,
) -> Result<(), Failure> {
    for (k, (scene, s)) in scenes.iter().zip(settings).enumerate() {
        // Whatever the library calls it, a setting it refuses is a usage error.
        let named = |e: StudyError| match e {
            StudyError::Setting { key, value, rule } if crate::failure::flag(key).is_none() => {
                let rule = match file(k) {
                    Some(f) => format!("{rule} (scene file {})", escaped(&f.display().to_string())),
                    None => rule,
                };
                StudyError::Setting {
                    key: key_in_table(table, key),
                    value,
                    rule,
                }
            }
            e => e,
        };
        s.validate_for(scene)
            .map_err(|e| refused(named(e)).within(&format!("scene {}", scene.name)))?;
    }
    Ok(())
}

/// The convergence study of each scene, or one shard of it.
pub fn convergence(args: &ConvergenceArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let study = SceneStudy {
        prefix: "",
        outputs: &REPORT_FILES,
        table: "study",
    };
    let settings = |scene: &Scene| Ok(args.settings(scene));
    let report = |run: ConvergenceRun, dir: &Path| {
        let report = build_report(run);
        print_summary(&report);
        write_report(&report, dir)?;
        say!(
            "wrote {0}/report.json, report.csv, report.md, error_vs_h.svg, error_vs_time.svg",
            dir.display()
        );
        Ok(uncompared_in(&report))
    };
    run_scenes(&args.ensemble, args.shard, study, stop, settings, report)
}

/// The files of a study that writes one report per scene (the convergence or the weak-error
/// study).
struct SceneStudy<'a> {
    /// What its shard and checkpoint files' names start with.
    prefix: &'a str,
    /// The files its report puts in a scene's folder.
    outputs: &'a [&'a str],
    /// The scene table its settings come from (`study`, `weak`).
    table: &'a str,
}

/// The scenes named (default: the pendulum) and their settings from `settings_of`, checked
/// against the scene table `table`.
fn scenes_and_settings(
    e: &EnsembleArgs, table: &str,
    settings_of: impl Fn(&Scene) -> Result<ConvergenceSettings, Failure>,
) -> Result<(Vec<Scene>, Vec<ConvergenceSettings>), Failure> {
    let scenes = e.scenes.load(|s| s.name == "pendulum")?;
    let settings = scenes
        .iter()
        .map(settings_of)
        .collect::<Result<Vec<_>, _>>()?;
    distinct(&scenes)?;
    checked(&scenes, &settings, table, |k| e.scenes.file_of(k))?;
    Ok((scenes, settings))
}

/// Runs `study` on each scene named (default: the pendulum) with its settings from
/// `settings_of` (checked first), or shard `shard` of it: a shard's paths are written as
/// `<prefix>shard-I-of-N.json` for `merge`; an unsharded run goes to
/// `report(run, scene's folder)`, which writes the report and returns what could not be
/// compared. A report that cannot be written leaves the paths in the checkpoint.
fn run_scenes(
    e: &EnsembleArgs, shard: Option<ShardArg>, study: SceneStudy<'_>, stop: &AtomicBool,
    settings_of: impl Fn(&Scene) -> Result<ConvergenceSettings, Failure>,
    mut report: impl FnMut(ConvergenceRun, &Path) -> Result<Vec<String>, StudyError>,
) -> Result<(), Failure> {
    let (scenes, settings) = scenes_and_settings(e, study.table, settings_of)?;
    let shard = shard
        .map(|s| s.resolve(|name| std::env::var(name).ok()))
        .transpose()
        .map_err(Failure::Usage)?;
    let (index, count) = shard.unwrap_or((0, 1));
    let how = Resumption::of(&e.checkpoint);
    let prefix = study.prefix;
    let shard_file = format!("{prefix}shard-{index}-of-{count}.json");
    let outputs: Vec<&str> = match shard {
        Some(_) => vec![&shard_file],
        None => study.outputs.to_vec(),
    };
    let jobs = scenes
        .iter()
        .zip(&settings)
        .map(|(scene, settings)| {
            let dir = e.out.out.join(&scene.name);
            let file = dir.join(format!("{prefix}checkpoint-{index}-of-{count}.bin"));
            Job::new(scene, settings, (index, count), file, how).ready(how, &outputs)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut uncompared = Vec::new();
    for mut ready in jobs {
        let run = ready.run(stop)?;
        let dir = e.out.out.join(&ready.job.scene.name);
        if shard.is_some() {
            let file = dir.join(&shard_file);
            deliver(
                std::slice::from_ref(&ready),
                sdae_cli::shards::write_convergence(&run, &file),
            )?;
            say!(
                "wrote {} ({} paths); merge all shards with `cargo xtask study merge DIR...`",
                file.display(),
                run.records.len()
            );
            continue;
        }
        let written = report(run, &dir).map(|lines| uncompared.extend(lines));
        deliver(std::slice::from_ref(&ready), written)?;
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
            .map_err(|e| Failure::Usage(format!("cannot read {}: {e}", dir.display())))?;
        let mut subdirs = Vec::new();
        for path in entries.flatten().map(|entry| entry.path()) {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if path.is_dir() && deeper {
                subdirs.push(path);
            } else if (name.starts_with("shard-") || name.starts_with("weak-shard-"))
                && name.ends_with(".json")
            {
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
        return Err(Failure::Usage(
            "no shard-*.json or weak-shard-*.json files found".into(),
        ));
    }
    files.sort();
    Ok(files)
}

/// Merges the shard files under `dirs`, one report per scene and study: the convergence report
/// of `shard-*.json` files, the weak-error report of `weak-shard-*.json` files (shards that
/// measure observables).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), Failure> {
    writable_out(out)?;
    let mut by_study: BTreeMap<(String, bool), Vec<ConvergenceRun>> = BTreeMap::new();
    for file in shard_files(dirs)? {
        let shard = sdae_cli::shards::read_convergence(&file).map_err(refused)?;
        // An absurd setting in a shard file (say its paths) is refused before merging.
        shard
            .settings
            .validate()
            .map_err(|e| Failure::Usage(format!("shard file {}: {e}", file.display())))?;
        let weak = !shard.settings.observables.is_empty();
        by_study
            .entry((shard.scene.name.clone(), weak))
            .or_default()
            .push(shard);
    }
    // Every scene's folder is checked before any is merged: a refusal writes nothing.
    for (name, _) in by_study.keys() {
        writable_out(&out.join(name))?;
    }
    let mut uncompared = Vec::new();
    for ((name, weak), shards) in by_study {
        let context = format!("scene {name}");
        let run = merge_runs(shards).map_err(|e| refused(e).within(&context))?;
        let dir = out.join(&name);
        if weak {
            let report = weak::build_weak_report(run).map_err(|e| refused(e).within(&context))?;
            write_weak(&report, &dir)?;
            uncompared.extend(weak_uncompared(&report));
            continue;
        }
        let report = build_report(run);
        print_summary(&report);
        write_report(&report, &dir)?;
        say!("wrote {}/report.{{json,csv,md}} and plots", dir.display());
        uncompared.extend(uncompared_in(&report));
    }
    nothing_uncompared(uncompared)
}

/// The files the stability and equipartition studies put in their folder.
const STUDY_FILES: [&str; 5] = [
    "report.json",
    "report.md",
    "stability.svg",
    "equipartition.svg",
    "bias.svg",
];

/// Runs `jobs` one after the other; each finished run is saved in its checkpoint (the study's
/// report needs them all, and an interruption of a later one must not lose them).
fn run_all(jobs: &mut [Ready<'_>], stop: &AtomicBool) -> Result<Vec<ConvergenceRun>, Failure> {
    let mut runs = Vec::new();
    for ready in jobs.iter_mut() {
        if let Some(label) = ready.label.take() {
            note!("{label}");
        }
        runs.push(ready.run(stop)?);
    }
    // Every run is saved ([`Ready::keep`]); a stop signal while the report is computed ends
    // the process with the message of the last.
    Ok(runs)
}

/// The stability study of the scenes with a [stability] table (or those named).
pub fn stability(args: &EnsembleArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.stability.is_some())?;
    distinct(&scenes)?;
    let settings = scenes
        .iter()
        .map(|scene| args.options().stability_settings(scene).map_err(refused))
        .collect::<Result<Vec<_>, _>>()?;
    checked(&scenes, &settings, "stability", |k| args.scenes.file_of(k))?;
    let dir = args.out.out.join("stability");
    let how = Resumption::of(&args.checkpoint);
    let mut jobs = scenes
        .iter()
        .zip(&settings)
        .map(|(scene, settings)| {
            let file = dir.join(format!("{}.checkpoint.bin", scene.name));
            Job::new(scene, settings, (0, 1), file, how).ready(how, &STUDY_FILES)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let runs = run_all(&mut jobs, stop)?;
    let mut report = StabilityReport { scenes: Vec::new() };
    for (scene, run) in scenes.iter().zip(&runs) {
        let case = scene
            .stability
            .as_ref()
            .map(|s| s.case.clone())
            .unwrap_or_default();
        report.scenes.push(StabilityScene {
            case,
            report: build_report(run.clone()),
        });
    }
    deliver(&jobs, stability::write_report(&report, &dir))?;
    let table = stability::markdown(&report);
    let head: Vec<&str> = table.lines().take(4 + report.scenes.len()).collect();
    say!("{}", head.join("\n"));
    say!(
        "wrote {0}/report.json, report.md, stability.svg",
        dir.display()
    );
    Ok(())
}

/// The equipartition study of the scenes with an [equipartition] table (or those named).
pub fn equipartition(args: &EnsembleArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.equipartition.is_some())?;
    distinct(&scenes)?;
    let mut all = Vec::new();
    for (k, scene) in scenes.iter().enumerate() {
        let variants = equipartition::variants(scene, args.quick).ok_or_else(|| {
            Failure::Usage(format!("scene {} has no [equipartition] table", scene.name))
        })?;
        let settings: Vec<_> = variants
            .iter()
            .map(|v| args.apply(v.settings.clone()))
            .collect();
        let variant_scenes: Vec<_> = variants.iter().map(|v| v.scene.clone()).collect();
        let file = args.scenes.file_of(k);
        checked(&variant_scenes, &settings, "equipartition", |_| file)?;
        all.push((scene, variants, settings));
    }
    let dir = args.out.out.join("equipartition");
    let how = Resumption::of(&args.checkpoint);
    let mut jobs = Vec::new();
    for (scene, variants, settings) in &all {
        for (k, (variant, settings)) in variants.iter().zip(settings).enumerate() {
            let file = dir.join(format!("{}-{k}.checkpoint.bin", scene.name));
            let job = Job::new(&variant.scene, settings, (0, 1), file, how);
            let mut ready = job.ready(how, &STUDY_FILES)?;
            ready.label = Some(format!("{}: {}", scene.name, variant.label));
            jobs.push(ready);
        }
    }
    let runs = run_all(&mut jobs, stop)?;
    let mut scene_runs = runs.iter().cloned();
    let mut results = Vec::new();
    for (scene, variants, _) in &all {
        let variant_runs: Vec<_> = scene_runs.by_ref().take(variants.len()).collect();
        results.push(equipartition::collect(&variant_runs).ok_or_else(|| {
            Failure::Usage(format!(
                "scene {} has no equipartition value (not a Langevin system)",
                scene.name
            ))
        })?);
    }
    deliver(&jobs, equipartition::write_report(&results, &dir))?;
    for scene in &results {
        let biased = scene.rows.iter().filter(|r| r.biased == Some(true)).count();
        let (failed, paths) = scene.failed_paths();
        say!(
            "{}: {biased} of {} settings biased (95% interval excludes the set temperature), \
             {failed} of {paths} paths failed",
            scene.scene,
            scene.rows.len()
        );
    }
    say!(
        "wrote {0}/report.json, report.md, equipartition.svg, bias.svg",
        dir.display()
    );
    nothing_uncompared(results.iter().flat_map(|s| s.lost()).collect())
}

/// The files a weak-error report puts in its scene's folder.
const WEAK_FILES: [&str; 5] = [
    "weak.json",
    "weak.csv",
    "weak.md",
    "weak_error_vs_h.svg",
    "weak_error_vs_time.svg",
];

/// The weak-error study of each scene named (default: the pendulum), from its [weak] table, or
/// one shard of it.
pub fn weak(args: &WeakArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let study = SceneStudy {
        prefix: "weak-",
        outputs: &WEAK_FILES,
        table: "weak",
    };
    let options = args.options();
    let settings = |scene: &Scene| options.settings(scene).map_err(refused);
    let report = |run: ConvergenceRun, dir: &Path| {
        let report = weak::build_weak_report(run)?;
        write_weak(&report, dir)?;
        Ok(weak_uncompared(&report))
    };
    run_scenes(&args.ensemble, args.shard, study, stop, settings, report)
}

/// Prints the summary of a weak-error report and writes its files to `dir`.
fn write_weak(report: &weak::WeakReport, dir: &Path) -> Result<(), StudyError> {
    weak::report::print_summary(report);
    weak::report::write_report(report, dir)?;
    say!(
        "wrote {0}/weak.json, weak.csv, weak.md, weak_error_vs_h.svg, weak_error_vs_time.svg",
        dir.display()
    );
    Ok(())
}

/// What of a weak-error report could not be compared, prefixed by the scene.
fn weak_uncompared(report: &weak::WeakReport) -> Vec<String> {
    report
        .uncompared()
        .into_iter()
        .map(|line| format!("scene {}: {line}", report.scene))
        .collect()
}

/// One path of each scene as a picture and a CSV file.
pub fn trace(args: &TraceArgs) -> Result<(), Failure> {
    let scenes = args.scenes.load(|_| true)?;
    let steps = scenes
        .iter()
        .map(trace::steps)
        .collect::<Result<Vec<_>, _>>()?;
    let dir = args.out.out.join("trace");
    let bar = bar(scenes.len(), "scenes");
    for (scene, &steps) in scenes.iter().zip(&steps) {
        let trace = trace::trace(scene, steps, args.seed)?;
        if let Some(failure) = &trace.failure {
            bar.suspend(|| note!("{}: the path stopped early: {failure}", scene.name));
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
            say!(
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

/// Compares the numbers of two reports: equal, or the first difference (exit code 1).
pub fn compare(first: &Path, second: &Path) -> Result<(), Failure> {
    let numbers = |file: &Path| -> Result<serde_json::Value, Failure> {
        let text = std::fs::read_to_string(file)
            .map_err(|e| Failure::Usage(format!("cannot read {}: {e}", file.display())))?;
        numbers_of(&text)
            .map_err(|e| Failure::Usage(format!("{} is not JSON: {e}", file.display())))
    };
    match first_difference(&numbers(first)?, &numbers(second)?) {
        None => {
            say!(
                "{} and {} hold the same numbers",
                first.display(),
                second.display()
            );
            Ok(())
        }
        Some(at) => Err(Failure::Failed(format!(
            "{} and {} differ at {at}",
            first.display(),
            second.display()
        ))),
    }
}

/// The built-in scenes and the schemes.
pub fn list() {
    say!("built-in scenes:");
    for (name, _) in BUILT_IN {
        match Scene::built_in(name) {
            Ok(scene) => say!("  {name:<24} {}", scene.description),
            Err(e) => say!("  {name:<24} (broken: {e})"),
        }
    }
    say!("schemes:");
    for kind in SchemeKind::ALL {
        say!("  {}", kind.name());
    }
}
