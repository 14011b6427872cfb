//! The `mlmc` and `mlmc-merge` subcommands: multilevel Monte Carlo of a scene's E[f(X_T)].

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use sdae_cli::checkpoint::RunLock;
use sdae_cli::folders::check_writable;
use sdae_cli::mlmc_checkpoint::{Journal, MlmcCheckpoint, MlmcRun, SavedBlocks};
use sdae_mlmc::{MlmcError, Plan, RunControl};
use sdae_study::StudyError;
use sdae_study::files::{read_json, write_atomically, write_json};
use sdae_study::mlmc::QmcSettings;
use sdae_study::mlmc::plan_runs::{PlanRun, merged_report, plan_for_eps, run_scene_plan};
use sdae_study::mlmc::report::{REPORT_FILES, print_summary, write_report};
use sdae_study::mlmc::shard::{MlmcShard, merge, plan_markdown};
use sdae_study::mlmc::study::{MlmcReport, MlmcSettings, run_mlmc};
use sdae_study::mlmc::{caused_by_input, study_error};
use sdae_study::options::MlmcOptions;

use sdae_study::scene::{Scene, escaped};

use crate::args::{MlmcArgs, MlmcMergeArgs};
use crate::expect_cli::{run_expectation, spinner};
use crate::failure::Failure;
use crate::runs::{Resumable, Resumption, prepare, refused, writable_out};
use crate::stopping;
use sdae_mlmc::expectation::{CostMeasure, Method};
use sdae_study::mlmc::ExpectRequest;
use sdae_study::mlmc::expect_report::{markdown as expect_markdown, summary};

impl From<MlmcError> for Failure {
    fn from(e: MlmcError) -> Failure {
        if let Some(study) = study_error(&e) {
            return Failure::from_study(study.clone());
        }
        match e {
            MlmcError::Interrupted => Failure::Unsaved("interrupted: nothing was saved".into()),
            // Named by the flag the user typed, else by its scene-file key, as the other
            // studies' settings are.
            MlmcError::Setting { key, value, rule } => {
                Failure::from_study(StudyError::Setting { key, value, rule })
            }
            e if caused_by_input(&e) => Failure::Usage(e.to_string()),
            e => Failure::Failed(e.to_string()),
        }
    }
}

impl MlmcArgs {
    /// The settings of `scene` with the command line's changes ([`MlmcOptions::settings`]).
    fn settings(&self, scene: &Scene) -> MlmcSettings {
        MlmcOptions {
            eps: self.eps.clone(),
            quick: self.quick,
            standard_run: !self.no_standard,
            qmc: (self.qmc || self.mlqmc_alone()).then_some(QmcSettings {
                randomizations: self.randomizations,
                initial_points: self.initial_points,
            }),
            ..self.estimate.options()
        }
        .settings(scene)
    }

    /// Whether `--method mlqmc` asks for multilevel QMC alone.
    fn mlqmc_alone(&self) -> bool {
        self.method == "mlqmc"
    }

    /// Refuses the QMC design's flags without --qmc or --method mlqmc, which use them.
    fn check_quasi_flags(&self) -> Result<(), Failure> {
        if self.qmc || self.mlqmc_alone() {
            return Ok(());
        }
        match ["--randomizations", "--initial-points"]
            .into_iter()
            .find(|f| crate::args::typed(f))
        {
            Some(flag) => Err(Failure::Usage(format!(
                "{flag} sets the design of the quasi-Monte Carlo runs: it needs --qmc or \
                 --method mlqmc"
            ))),
            None => Ok(()),
        }
    }

    /// The settings of `scene` with the command line's changes, checked against the scene: a
    /// bad value from the scene file (not typed) is named with the file.
    fn checked_settings(&self, scene: &Scene) -> Result<MlmcSettings, Failure> {
        let settings = self.settings(scene);
        settings.validate_for(scene).map_err(|e| {
            let e = match (e, self.scenes.file_of(0)) {
                // A value from the scene file (not typed) is named with the file, as the scene
                // file's own checks name it.
                (MlmcError::Setting { key, value, rule }, Some(file))
                    if crate::failure::flag(key).is_none() =>
                {
                    MlmcError::Setting {
                        key,
                        value,
                        rule: format!(
                            "{rule} (scene file {})",
                            escaped(&file.display().to_string())
                        ),
                    }
                }
                (e, _) => e,
            };
            Failure::from(e).within(&format!("scene {}", scene.name))
        })?;
        Ok(settings)
    }

    /// The shard (i, n) that `--shard` names, its variables read from the environment.
    fn resolved_shard(&self) -> Result<Option<(u64, u64)>, Failure> {
        Ok(self
            .shard
            .map(|s| s.resolve(|name| std::env::var(name).ok()))
            .transpose()
            .map_err(Failure::Usage)?
            .map(|(i, n)| (i as u64, n as u64)))
    }
}

/// A run's control: `threads` workers, the progress callback, the stop flag.
fn control<'a>(
    threads: usize, progress: &'a (dyn Fn(u64) + Sync), stop: &'a AtomicBool,
) -> Result<RunControl<'a>, Failure> {
    let mut c = RunControl::new(threads)?;
    c.progress = Some(progress);
    c.stop = Some(stop);
    Ok(c)
}

/// The files a plan's unsharded run writes.
const PLAN_FILES: [&str; 2] = ["plan-report.json", "plan-report.md"];

/// An MLMC run's checkpoint with the run it belongs to, as [`prepare`] sees it.
struct Saved<'a> {
    checkpoint: &'a MlmcCheckpoint,
    run: &'a MlmcRun,
}

impl Resumable for Saved<'_> {
    type Saved = SavedBlocks;
    fn file(&self) -> &Path {
        self.checkpoint.path()
    }
    fn lock(&self) -> Result<RunLock, StudyError> {
        self.checkpoint.lock()
    }
    fn holds(&self) -> Option<String> {
        Some(format!("{} blocks of samples", self.checkpoint.holds()?))
    }
    fn load(&self) -> Result<Option<SavedBlocks>, StudyError> {
        self.checkpoint.load(self.run)
    }
    fn describe(&self, saved: &SavedBlocks) -> String {
        let torn = saved
            .torn_note()
            .map_or(String::new(), |n| format!(" ({n})"));
        format!("{} blocks of samples{torn}", saved.blocks.len())
    }
    fn remove(&self) -> Result<(), StudyError> {
        self.checkpoint.remove()
    }
}

/// The failure of a run that ended with `error`: when it was stopped, the blocks it finished
/// (with those it resumed from) are saved in the checkpoint first (exit code 130; 131 when
/// there are none or they cannot be saved).
fn stopped(
    error: MlmcError, journal: &Journal<'_>, checkpoint: &MlmcCheckpoint, scene: &str,
) -> Failure {
    if error != MlmcError::Interrupted {
        return Failure::from(error).within(&format!("scene {scene}"));
    }
    let blocks = journal.blocks();
    if blocks == 0 {
        return Failure::Unsaved(format!(
            "{scene}: interrupted before any block of samples finished: nothing saved"
        ));
    }
    match journal.save() {
        Ok(()) => Failure::Interrupted(format!(
            "{scene}: interrupted; {blocks} blocks of samples are saved in {}: run the same \
             command with --resume to carry on",
            checkpoint.path().display()
        )),
        Err(e) => Failure::Unsaved(format!(
            "{scene}: interrupted, and the finished samples could not be saved: {e}"
        )),
    }
}

/// Saves every block of a finished run in the checkpoint before its report is written, so
/// that a stop signal from now on ends the process at once, losing nothing.
fn keep(journal: &Journal<'_>, checkpoint: &MlmcCheckpoint, scene: &str) -> Result<(), Failure> {
    let file = checkpoint.path().display();
    journal.save().map_err(|e| {
        Failure::Failed(format!(
            "{scene}: every block finished, but they could not be saved in {file}: {e}"
        ))
    })?;
    stopping::all_saved(format!(
        "{scene}: stopped after every block finished; all {} blocks of samples are saved in \
         {file}: run the same command with --resume to write the results without running again",
        journal.blocks()
    ));
    Ok(())
}

/// After a finished run's results were written (`written`): removes the checkpoint; if they
/// could not be written, saves every block in it instead, so that --resume writes the results
/// without running again.
fn deliver(
    written: Result<(), StudyError>, journal: &Journal<'_>, checkpoint: &MlmcCheckpoint,
) -> Result<(), Failure> {
    let Err(e) = written else {
        stopping::running();
        return Ok(checkpoint.remove()?);
    };
    Err(Failure::Failed(match journal.save() {
        Ok(()) => format!(
            "{e}; the samples are saved in {}: --resume writes the results without running \
             again",
            checkpoint.path().display()
        ),
        Err(saving) => format!("{e}; nor could the samples be saved: {saving}"),
    }))
}

/// The checkpoint and result files of a run: the study's, a whole plan's or a shard's.
struct RunFiles {
    /// The checkpoint's file name.
    checkpoint: String,
    /// A shard's result file, `None` for a study or a whole plan.
    shard: Option<String>,
    /// Whether a plan is run.
    plan: bool,
}

impl RunFiles {
    /// The files of a study (`plan` false) or of a plan's run, whole or shard (i, n).
    fn of(plan: bool, shard: Option<(u64, u64)>) -> Self {
        let (checkpoint, shard) = match (plan, shard) {
            (false, _) => ("mlmc-checkpoint.bin".to_string(), None),
            (true, None) => ("mlmc-plan-checkpoint.bin".to_string(), None),
            (true, Some((i, n))) => (
                format!("mlmc-plan-checkpoint-{i}-of-{n}.bin"),
                Some(format!("mlmc-shard-{i}-of-{n}.json")),
            ),
        };
        Self {
            checkpoint,
            shard,
            plan,
        }
    }

    /// The files the run writes (a run refuses to start over another run's).
    fn outputs(&self) -> Vec<&str> {
        match (self.plan, &self.shard) {
            (false, _) => REPORT_FILES.to_vec(),
            (true, None) => PLAN_FILES.to_vec(),
            (true, Some(f)) => vec![f],
        }
    }
}

/// The MLMC study of one scene (the pendulum by default), a plan's run or one of its shards,
/// saved in a checkpoint while it runs and when it is stopped, and resumed from it with
/// --resume.
pub fn mlmc(args: &MlmcArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let scenes = args.scenes.load(|s| s.name == "pendulum")?;
    let [scene] = &scenes[..] else {
        return Err(Failure::Usage(format!(
            "mlmc runs one scene at a time; {} were named",
            scenes.len()
        )));
    };
    args.check_quasi_flags()?;
    let settings = args.checked_settings(scene)?;
    if args.mlqmc_alone() {
        return mlqmc_alone(args, scene, &settings, stop);
    }
    let plan = args
        .plan
        .as_deref()
        .map(|f| read_plan(f, &settings))
        .transpose()?;
    if let Some(file) = &args.write_plan {
        check_plan_file(file, args.quick)?;
    }
    let shard = args.resolved_shard()?;
    let dir = args.out.out.join("mlmc").join(&scene.name);
    let files = RunFiles::of(plan.is_some(), shard);
    let outputs = files.outputs();
    let how = Resumption::of(&args.checkpoint);
    let checkpoint = MlmcCheckpoint::new(dir.join(&files.checkpoint)).every(how.every);
    let run = MlmcRun {
        scene: scene.clone(),
        settings: settings.clone(),
        plan,
        shard,
    };
    let saved = Saved {
        checkpoint: &checkpoint,
        run: &run,
    };
    let (saved, _lock) = prepare(&saved, &scene.name, how, &outputs)?;
    let journal = checkpoint.journal(&run, saved);
    let bar = spinner(&scene.name);
    let progress = |n: u64| bar.inc(n);
    let mut control = control(settings.threads, &progress, stop)?;
    control.store = Some(&journal);
    if let Some(plan) = &run.plan {
        let done = run_scene_plan(scene, &settings, &control, plan.clone(), shard);
        bar.finish_and_clear();
        let done = done.map_err(|e| stopped(e, &journal, &checkpoint, &scene.name))?;
        keep(&journal, &checkpoint, &scene.name)?;
        let written = match done {
            PlanRun::Shard(s) => write_shard(&s, &dir),
            PlanRun::Whole(r) => write_plan_report(&r, &dir),
        };
        return deliver(written, &journal, &checkpoint);
    }
    note_study(scene, &settings);
    let report = run_mlmc(scene, &settings, &control);
    bar.finish_and_clear();
    let report = report.map_err(|e| stopped(e, &journal, &checkpoint, &scene.name))?;
    keep(&journal, &checkpoint, &scene.name)?;
    deliver(write_report(&report, &dir), &journal, &checkpoint)?;
    print_summary(&report);
    say!("wrote {}", dir.join("report.md").display());
    if let Some(file) = &args.write_plan {
        write_plan_file(file, scene, &settings, &report)?;
    }
    Ok(())
}

/// `mlmc --method mlqmc`: multilevel QMC alone at every eps of `settings` (as `expect
/// --method mlqmc` runs it), written to <OUT>/mlmc/<scene>/mlqmc.json (the list of
/// expectations) and mlqmc.md, with a summary of each.
fn mlqmc_alone(
    args: &MlmcArgs, scene: &Scene, settings: &MlmcSettings, stop: &AtomicBool,
) -> Result<(), Failure> {
    let dir = args.out.out.join("mlmc").join(&scene.name);
    writable_out(&dir)?;
    let mut eps = settings.spec.eps.clone();
    eps.sort_by(|a, b| b.total_cmp(a));
    let mut runs = Vec::with_capacity(eps.len());
    let mut markdown = String::new();
    for eps in eps {
        let request = ExpectRequest {
            eps,
            by: CostMeasure::Work,
            method: Some(Method::Mlqmc),
        };
        let found = run_expectation(scene, settings, &request, stop)?;
        for line in summary(&found) {
            say!("{line}");
        }
        markdown.push_str(&expect_markdown(&found));
        markdown.push('\n');
        runs.push(found);
    }
    write_json(&dir.join("mlqmc.json"), &runs)?;
    write_atomically(&dir.join("mlqmc.md"), &markdown)?;
    say!("wrote {}", dir.join("mlqmc.md").display());
    Ok(())
}

/// Says on stderr what the study of `scene` runs: the observable, scheme, levels, eps and
/// threads.
fn note_study(scene: &Scene, settings: &MlmcSettings) {
    let s = &settings.spec;
    note!(
        "{}: MLMC of E[{}] with {}, level 0 on 2^{} steps, {}eps {:?}, {} threads",
        scene.name,
        s.observable,
        s.scheme,
        s.coarsest,
        if s.antithetic { "antithetic, " } else { "" },
        s.eps,
        settings.threads
    );
}

/// Writes to `file` the plan for the smallest eps of `settings` from the study's `report`,
/// and says where. The study has run: a plan its convergence test cannot fix (levels too few
/// for the bias of that eps), or a file that cannot be written, is a failure (exit code 1)
/// naming --write-plan, not a refusal.
fn write_plan_file(
    file: &Path, scene: &Scene, settings: &MlmcSettings, report: &MlmcReport,
) -> Result<(), Failure> {
    let eps = settings
        .spec
        .eps
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let failed = |e: String| {
        Failure::Failed(format!(
            "--write-plan {}: no plan written (the study's report is): {e}",
            escaped(&file.display().to_string())
        ))
    };
    let plan = plan_for_eps(scene, settings, report, eps).map_err(|e| {
        let flag = match e {
            MlmcError::Levels { .. } => " (--test-levels)",
            _ => "",
        };
        failed(format!(
            "eps = {eps:e}, the smallest of the study's: {e}{flag}"
        ))
    })?;
    write_json(file, &plan).map_err(|e| failed(e.to_string()))?;
    say!(
        "wrote {} (eps {eps:.0e}, N_l {:?}); run it with --plan, sharded with --shard",
        file.display(),
        plan.samples
    );
    Ok(())
}

/// The plan in `file`, checked against `settings` before anything runs: a file that cannot be
/// read or is not a plan, and a plan the run cannot hold or finish, are refused naming the file
/// (exit code 2).
fn read_plan(file: &Path, settings: &MlmcSettings) -> Result<Plan, Failure> {
    let plan: Plan = read_json(file).map_err(refused)?;
    settings
        .validate_plan(&plan)
        .map_err(|e| Failure::from(e).within(&format!("plan {}", file.display())))?;
    Ok(plan)
}

/// Refuses `--write-plan` before the study runs: with `quick` (a quick run's convergence test,
/// two levels fewer on at most 1024 samples, is a check, too short to fix a plan), and a file
/// that cannot be written: its folder must be (or be made) a writable folder, and the file
/// itself not a folder.
fn check_plan_file(file: &Path, quick: bool) -> Result<(), Failure> {
    let refuse = |why: String| {
        Failure::Usage(format!(
            "--write-plan {}: {why}; nothing was run",
            escaped(&file.display().to_string())
        ))
    };
    if quick {
        return Err(refuse(
            "not with --quick: a plan is fixed by the study's convergence test, and --quick's \
             (two levels fewer, at most 1024 samples per level) is too short for one; run the \
             pilot without --quick (docs/cluster.md)"
                .into(),
        ));
    }
    if file.is_dir() {
        return Err(refuse("is a folder".into()));
    }
    let dir = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    check_writable(dir).map_err(|e| refuse(e.to_string()))
}

/// Writes a shard's file.
fn write_shard(shard: &MlmcShard, dir: &Path) -> Result<(), StudyError> {
    let file = dir.join(format!(
        "mlmc-shard-{}-of-{}.json",
        shard.shard.0, shard.shard.1
    ));
    sdae_cli::shards::write_mlmc(shard, &file)?;
    say!(
        "wrote {}; merge all shards with `cargo xtask study mlmc-merge DIR...`",
        file.display()
    );
    Ok(())
}

/// Writes a plan's report (JSON and Markdown) and says where.
fn write_plan_report(
    report: &sdae_study::mlmc::shard::PlanReport, dir: &Path,
) -> Result<(), StudyError> {
    write_json(&dir.join("plan-report.json"), report)?;
    write_atomically(&dir.join("plan-report.md"), &plan_markdown(report))?;
    let e = &report.estimate;
    say!(
        "{}: {:.6} [{:.6}, {:.6}] (eps {:.0e}, N_l {:?}); wrote {}",
        report.identity.scene,
        e.estimate.estimate,
        e.estimate.ci_low,
        e.estimate.ci_high,
        e.eps,
        report.plan.samples,
        dir.join("plan-report.md").display()
    );
    Ok(())
}

/// The mlmc-shard-*.json files in `dirs` and their subfolders.
fn shard_files(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, Failure> {
    let mut files = Vec::new();
    let is_shard = |p: &Path| {
        p.file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with("mlmc-shard-") && n.ends_with(".json"))
    };
    for dir in dirs {
        let entries = std::fs::read_dir(dir)
            .map_err(|e| Failure::Usage(format!("cannot read {}: {e}", dir.display())))?;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                if let Ok(inner) = std::fs::read_dir(&path) {
                    files.extend(inner.flatten().map(|e| e.path()).filter(|p| is_shard(p)));
                }
            } else if is_shard(&path) {
                files.push(path);
            }
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(Failure::Usage("no mlmc-shard-*.json files found".into()));
    }
    Ok(files)
}

/// Merges the shard files of a plan into its report: exactly the unsharded run's sums.
pub fn mlmc_merge(args: &MlmcMergeArgs) -> Result<(), Failure> {
    writable_out(&args.out.out)?;
    let shards: Vec<MlmcShard> = shard_files(&args.dirs)?
        .iter()
        .map(|f| sdae_cli::shards::read_mlmc(f).map_err(refused))
        .collect::<Result<_, _>>()?;
    let (identity, plan, sums) = merge(&shards)?;
    let scene = match &args.scene_file {
        Some(file) => Scene::from_file(file)?,
        None => Scene::built_in(&identity.scene)?,
    };
    let mut settings = MlmcSettings::for_scene(&scene);
    settings.spec.scheme = identity.scheme.clone();
    settings.spec.observable = identity.observable.clone();
    settings.spec.coarsest = identity.coarsest;
    settings.spec.antithetic = identity.antithetic;
    settings.t_end = identity.t_end;
    settings.seed = identity.seed;
    let dir = args.out.out.join("mlmc").join(&identity.scene);
    writable_out(&dir)?;
    let report = merged_report(&scene, &settings, identity, plan, sums)?;
    Ok(write_plan_report(&report, &dir)?)
}
