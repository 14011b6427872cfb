//! The `simulate` subcommand: paths of a scene with one scheme, written as trajectory files
//! (extended XYZ, VTK or CSV) as they are simulated, with a progress line.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::{ProgressBar, ProgressStyle};
use sdae_study::StudyError;
use sdae_study::scene::Scene;
use sdae_study::simulate::{SimulateSettings, Streaming, check_streaming, simulate_streaming};
use sdae_study::trace;
use sdae_study::trajectory::{
    MAX_OPEN_FILES, Particles, TrajectoryFormat, TrajectoryWriter, check_room,
};

use crate::args::SimulateArgs;
use crate::failure::Failure;
use crate::runs::{refused, writable_out};

/// Recorded times of a run, at most, where --every is not given.
const DEFAULT_RECORDS: usize = 256;

/// What a run writes: the settings, the format, the folder and the paths in flight.
struct Plan {
    scene: Scene,
    settings: SimulateSettings,
    format: TrajectoryFormat,
    dir: PathBuf,
    batch: usize,
}

impl SimulateArgs {
    /// The scene, settings, format and folder of the run, every refusal made before anything
    /// runs: a second scene, a format the system cannot have, an output folder that cannot be
    /// written, paths beyond the memory or files beyond the free disk.
    fn plan(&self) -> Result<Plan, Failure> {
        if self.scenes.scene.len() + self.scenes.scene_file.len() > 1 {
            return Err(Failure::Usage(
                "simulate runs one scene: give one --scene or one --scene-file".into(),
            ));
        }
        let scene = self
            .scenes
            .load(|s| s.name == "pendulum")?
            .pop()
            .ok_or_else(|| Failure::Usage("no scene to simulate".into()))?;
        let steps = match self.steps {
            Some(steps) => steps,
            None => trace::steps(&scene).map_err(refused)?,
        };
        let every = self.every.unwrap_or((steps / DEFAULT_RECORDS).max(1));
        let threads = self.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        });
        let settings = SimulateSettings::new(self.scheme, self.paths, steps, self.seed)
            .and_then(|s| s.every(every))
            .and_then(|s| s.threads(threads))
            .map_err(flagged)?;
        let format = self
            .format
            .unwrap_or_else(|| TrajectoryFormat::default_for(&scene));
        let particles = Particles::of(&scene).map_err(refused)?;
        particles.check(format, &scene).map_err(flagged)?;
        let dir = self.out.out.join("simulate").join(&scene.name);
        writable_out(&dir)?;
        // VTK writes a file per time holding every path: all of them at once. XYZ keeps a file
        // per path open: at most that many paths at a time; CSV too, or a block of paths per
        // thread if more.
        let batch = match format {
            TrajectoryFormat::Vtk => settings.paths,
            TrajectoryFormat::Xyz => MAX_OPEN_FILES,
            TrajectoryFormat::Csv => MAX_OPEN_FILES.max(64 * settings.threads),
        };
        check_streaming(&scene, &settings, batch).map_err(flagged)?;
        check_room(format, &particles, &settings, &dir).map_err(flagged)?;
        Ok(Plan {
            scene,
            settings,
            format,
            dir,
            batch,
        })
    }
}

/// A library refusal of a setting, named by its flag and the value typed (`--paths 10`),
/// with the flags of the numbers it is made of.
fn flagged(e: StudyError) -> Failure {
    match e {
        StudyError::Setting { key, value, rule } => {
            let flag = match key {
                "paths" => "--paths",
                "steps" => "--steps",
                "every" => "--every",
                "threads" => "--threads",
                "format" => "--format",
                _ => return refused(StudyError::Setting { key, value, rule }),
            };
            Failure::Usage(format!("{flag} {value}: {rule}"))
        }
        other => refused(other),
    }
}

/// Runs `simulate`: the paths streamed into the writer, a progress line on stderr (when it is
/// a terminal). Stopped by a signal, the files keep the frames written before it (exit code
/// 130).
pub fn simulate(args: &SimulateArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let plan = args.plan()?;
    let settings = &plan.settings;
    let mut writer =
        TrajectoryWriter::create(plan.format, &plan.scene, settings.scheme.name(), &plan.dir)
            .map_err(refused)?;
    let bar = progress(settings);
    let streaming = Streaming {
        batch: plan.batch,
        stop: &|| stop.load(Ordering::Relaxed),
        progress: &|done| bar.inc(done),
    };
    let run = simulate_streaming(&plan.scene, settings, &streaming, &mut |frame| {
        writer.write_frame(frame)
    });
    bar.finish_and_clear();
    match run {
        Ok(paths) => {
            let files = writer.finish()?;
            report(&plan, &files, &paths.failures);
            Ok(())
        }
        Err(StudyError::Stopped) => {
            let files = writer.finish()?;
            Err(Failure::Interrupted(format!(
                "interrupted: {} holds the {} files of the frames written before the stop",
                plan.dir.display(),
                files.len()
            )))
        }
        Err(e) => Err(Failure::from(e)),
    }
}

/// A progress bar of the run's P N path steps on stderr, drawn when stderr is a terminal.
fn progress(settings: &SimulateSettings) -> ProgressBar {
    let total = settings.paths as u64 * settings.steps as u64;
    let template = format!(
        "  {{bar:40}} {{percent}}% of {} paths x {} steps, {{elapsed}} elapsed, ETA {{eta}}",
        settings.paths, settings.steps
    );
    ProgressBar::new(total).with_style(
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    )
}

/// Says what was written and how to open it; notes the paths that stopped early.
fn report(plan: &Plan, files: &[PathBuf], failures: &[Option<String>]) {
    let settings = &plan.settings;
    say!(
        "{}: {} paths of {} steps with {}, {} recorded times each: wrote {} {} files to {}",
        plan.scene.name,
        settings.paths,
        settings.steps,
        settings.scheme.name(),
        settings.records(),
        files.len(),
        plan.format.name(),
        plan.dir.display()
    );
    let open = |file: &Path| file.display().to_string();
    match (plan.format, files.first()) {
        (TrajectoryFormat::Vtk, Some(pvd)) => say!("open {} in ParaView", open(pvd)),
        (TrajectoryFormat::Xyz, Some(first)) => say!("open {} in VMD or OVITO", open(first)),
        _ => {}
    }
    let failed: Vec<(usize, &String)> = failures
        .iter()
        .enumerate()
        .filter_map(|(p, f)| f.as_ref().map(|f| (p, f)))
        .collect();
    if let Some((p, why)) = failed.first() {
        note!(
            "{} of {} paths stopped early and have no frames after it (path {p}: {why})",
            failed.len(),
            settings.paths
        );
    }
}
