//! The writer of any format ([`TrajectoryWriter`]) and the writing of already simulated paths
//! ([`write_paths`]).

use std::path::{Path, PathBuf};

use super::{CsvWriter, Particles, Target, TrajectoryFormat, VtkWriter, XyzWriter, file_stem};
use crate::error::StudyError;
use crate::scene::Scene;
use crate::simulate::{Frame, SimulatedPaths};

/// A trajectory file being written ([`TrajectoryWriter::create`]): takes the frames as they
/// are produced, puts the files in place on [`TrajectoryWriter::finish`], and removes what it
/// wrote if dropped before.
#[derive(Debug)]
pub enum TrajectoryWriter {
    /// Extended XYZ.
    Xyz(XyzWriter),
    /// VTK.
    Vtk(VtkWriter),
    /// CSV.
    Csv(CsvWriter),
}

impl TrajectoryWriter {
    /// A writer of `format` for the paths of `scheme` on `scene`, into the folder `dir`
    /// (created if needed). Refuses a format the scene's system cannot have
    /// ([`Particles::check`]) and a folder that cannot be made.
    pub fn create(
        format: TrajectoryFormat, scene: &Scene, scheme: &str, dir: &Path,
    ) -> Result<Self, StudyError> {
        let particles = Particles::of(scene)?;
        particles.check(format, scene)?;
        std::fs::create_dir_all(dir).map_err(|e| StudyError::write(dir, e))?;
        let target = Target {
            dir: dir.to_path_buf(),
            stem: file_stem(&scene.name),
            scheme: scheme.to_string(),
            particles,
        };
        Ok(match format {
            TrajectoryFormat::Xyz => Self::Xyz(XyzWriter::new(target)),
            TrajectoryFormat::Vtk => Self::Vtk(VtkWriter::new(target)),
            TrajectoryFormat::Csv => Self::Csv(CsvWriter::new(target)?),
        })
    }

    /// Writes one recorded state of one path. VTK wants the frames of one recorded time
    /// together ([`TrajectoryFormat::by_time`]): a frame of a time already written is refused.
    pub fn write_frame(&mut self, frame: &Frame<'_>) -> Result<(), StudyError> {
        let n = match self {
            Self::Xyz(w) => w.target.particles.coordinates(),
            Self::Vtk(w) => w.target.particles.coordinates(),
            Self::Csv(w) => w.target.particles.coordinates(),
        };
        if frame.position.len() != n || frame.velocity.len() != n {
            return Err(StudyError::Setting {
                key: "frame",
                value: format!("{} and {}", frame.position.len(), frame.velocity.len()),
                rule: format!("r and v must have the system's {n} coordinates"),
            });
        }
        match self {
            Self::Xyz(w) => w.write_frame(frame),
            Self::Vtk(w) => w.write_frame(frame),
            Self::Csv(w) => w.write_frame(frame),
        }
    }

    /// Completes the files and puts them in place; returns them (XYZ: by path; VTK: the
    /// collection, then the files by time; CSV: the one file).
    pub fn finish(self) -> Result<Vec<PathBuf>, StudyError> {
        match self {
            Self::Xyz(w) => w.finish(),
            Self::Vtk(w) => w.finish(),
            Self::Csv(w) => w.finish(),
        }
    }
}

/// Writes already simulated paths as `format` into the folder `out` (created if needed), the
/// files named after `scene` ([`TrajectoryWriter`]); returns the files written. The paths'
/// NaN states (after a failure) are left out.
pub fn write_paths(
    paths: &SimulatedPaths, scene: &Scene, format: TrajectoryFormat, out: &Path,
) -> Result<Vec<PathBuf>, StudyError> {
    let mut writer = TrajectoryWriter::create(format, scene, &paths.scheme, out)?;
    let (count, times, n) = (paths.diagnostics.len(), paths.times.len(), paths.n);
    let frame = |p: usize, j: usize| {
        let at = (p * times + j) * n;
        Frame {
            path: p,
            step: (paths.times[j] / paths.h).round() as usize,
            time: paths.times[j],
            position: &paths.positions[at..at + n],
            velocity: &paths.velocities[at..at + n],
        }
    };
    let order: Vec<(usize, usize)> = if format.by_time() {
        (0..times)
            .flat_map(|j| (0..count).map(move |p| (p, j)))
            .collect()
    } else {
        (0..count)
            .flat_map(|p| (0..times).map(move |j| (p, j)))
            .collect()
    };
    for (p, j) in order {
        let frame = frame(p, j);
        if frame.position.iter().all(|x| !x.is_nan()) {
            writer.write_frame(&frame)?;
        }
    }
    writer.finish()
}
