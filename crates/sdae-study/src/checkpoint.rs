//! Nothing lost on interruption: a run stopped early (Ctrl-C, or SIGTERM from a batch system at
//! its time limit) saves the paths it finished to a checkpoint file, and the same study run
//! again with resumption carries on from them. Each path's numbers come from its own stream,
//! so the resumed run ends with exactly the records, and the report, of an uninterrupted one
//! (timings aside).

use std::path::{Path, PathBuf};

use crate::convergence::{ConvergenceRun, ConvergenceSettings, run_convergence};
use crate::error::StudyError;
use crate::files::{read_json, write_compact_json};
use crate::parallel::Control;
use crate::scene::Scene;

/// How a resumable run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Resumed {
    /// Every selected path finished: the whole run (with the saved paths it resumed from).
    Finished(Box<ConvergenceRun>),
    /// The stop flag was raised: `saved` of the shard's `selected` paths are in the checkpoint.
    Interrupted {
        /// Paths saved so far.
        saved: usize,
        /// Paths of the shard.
        selected: usize,
    },
}

/// The checkpoint file of one run (one scene, one shard of one study).
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    path: PathBuf,
}

impl Checkpoint {
    /// A checkpoint kept at `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Checkpoint { path: path.into() }
    }

    /// Where the finished paths are kept.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The paths saved by an interrupted run of the same scene, settings (the thread count
    /// aside) and shard; `None` when there is no checkpoint file.
    pub fn load(
        &self,
        scene: &Scene,
        settings: &ConvergenceSettings,
        shard: (usize, usize),
    ) -> Result<Option<ConvergenceRun>, StudyError> {
        if !self.path.exists() {
            return Ok(None);
        }
        let saved: ConvergenceRun = read_json(&self.path)?;
        let differs = |what: &str| StudyError::Resume {
            path: self.path.clone(),
            reason: format!("it was saved by a run with another {what}"),
        };
        if saved.scene != *scene {
            return Err(differs("scene"));
        }
        if !saved.settings.same_numbers(settings) {
            return Err(differs("setting (paths, levels, seed, T, p or schemes)"));
        }
        if saved.shard != shard {
            return Err(differs("shard"));
        }
        Ok(Some(saved))
    }

    /// Runs shard `shard` of the study of `scene` with `settings`, steered by `control`, but
    /// the paths in `saved` (from [`Checkpoint::load`]; they replace `control.done`), and
    /// saves the finished paths, with those of `saved`, in the checkpoint. When
    /// `control.stop` was raised before every path finished, [`Resumed::Interrupted`] comes
    /// back. The checkpoint stays until [`Checkpoint::remove`] (a study of several scenes
    /// resumes the finished ones from it too).
    pub fn run(
        &self,
        scene: &Scene,
        settings: &ConvergenceSettings,
        shard: (usize, usize),
        saved: Option<ConvergenceRun>,
        control: Control<'_>,
    ) -> Result<Resumed, StudyError> {
        let done = saved
            .as_ref()
            .map(ConvergenceRun::finished_paths)
            .unwrap_or_default();
        let control = Control {
            done: &done,
            ..control
        };
        let fresh = run_convergence(scene, settings, shard, control)?;
        let run = match saved {
            Some(saved) => saved.resume_with(fresh)?,
            None => fresh,
        };
        let (index, count) = shard;
        let selected = (index..settings.paths).step_by(count.max(1)).count();
        write_compact_json(&self.path, &run)?;
        if run.records.len() < selected {
            return Ok(Resumed::Interrupted {
                saved: run.records.len(),
                selected,
            });
        }
        Ok(Resumed::Finished(Box::new(run)))
    }

    /// Removes the checkpoint file (once the results it holds are in a report).
    pub fn remove(&self) -> Result<(), StudyError> {
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(StudyError::write(&self.path, e))
            }
            _ => Ok(()),
        }
    }
}
