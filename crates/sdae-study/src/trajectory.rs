//! Trajectory files that the programs people look at molecules and fibers with open: extended
//! XYZ (VMD, OVITO, ASE), VTK (ParaView) and CSV, written as the states are produced.
//!
//! A writer ([`TrajectoryWriter`]) takes one recorded state of one path at a time
//! ([`Frame`]) and keeps only what the file being written needs, so that memory does not grow
//! with the number of steps; [`TrajectoryWriter::finish`] puts the files in place. Files are
//! written as `<name>.<process id>.tmp` and renamed when complete: a reader never sees half a
//! file, and a run that fails leaves none.
//!
//! - **XYZ** (`xyz`): one file per path, `<scene>.path-<p>.xyz`, one frame per recorded time,
//!   `Properties=species:S:1:pos:R:3:vel:R:3` with the time, step, path and scheme on the
//!   comment line and no `Lattice` (the systems are not periodic); a planar system's
//!   particles have z = 0.
//! - **VTK** (`vtk`): one XML unstructured grid per recorded time, `<scene>.<j>.vtu`, holding
//!   every path's chain of beads as one polyline (cell data `path`, point data `velocity`),
//!   and the collection `<scene>.pvd` that ParaView opens as one time series. Only a chain of
//!   beads in 3-D (a fiber, a chain molecule) has one.
//! - **CSV** (`csv`): one file `<scene>.csv`, a row per path and recorded time: path, step,
//!   time and the coordinates r_0 .. r_{n-1} as the system orders them.
//!
//! Numbers are written with every digit (Rust's shortest representation that reads back to
//! the same `f64`). A path that failed has no states after its failure in any file.
//!
//! ```
//! use sdae_study::integrator::SchemeKind;
//! use sdae_study::scene::Scene;
//! use sdae_study::simulate::{SimulateSettings, simulate};
//! use sdae_study::trajectory::{TrajectoryFormat, write_paths};
//! let scene = Scene::built_in("pendulum")?;
//! let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 2, 64, 7)?.every(16)?;
//! let paths = simulate(&scene, &settings, &|| false)?;
//! let dir = std::env::temp_dir().join(format!("sdae-doc-xyz-{}", std::process::id()));
//! let files = write_paths(&paths, &scene, TrajectoryFormat::Xyz, &dir)?;
//! assert_eq!(files.len(), 2); // one per path
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::StudyError;
use crate::scene::{Scene, SystemSpec};
use crate::simulate::SimulateSettings;

mod csv;
mod vtk;
mod writer;
mod xyz;

pub use crate::simulate::Frame;
pub use csv::CsvWriter;
pub use vtk::VtkWriter;
pub use writer::{TrajectoryWriter, write_paths};
pub use xyz::XyzWriter;

/// The most files an XYZ writer keeps open at once (one per path; more paths are reopened to
/// append, [`XyzWriter`]). A streamed run that writes XYZ runs this many paths at a time.
pub const MAX_OPEN_FILES: usize = 256;

/// The file format of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// Extended XYZ, one file per path (VMD, OVITO, ASE).
    Xyz,
    /// VTK XML unstructured grids of polylines, one per recorded time, and a `.pvd`
    /// collection (ParaView).
    Vtk,
    /// One CSV file: path, step, time and the coordinates.
    Csv,
}

impl TrajectoryFormat {
    /// Every format.
    pub const ALL: [TrajectoryFormat; 3] = [Self::Xyz, Self::Vtk, Self::Csv];

    /// The name the command line and the Python package use: `xyz`, `vtk` or `csv`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Xyz => "xyz",
            Self::Vtk => "vtk",
            Self::Csv => "csv",
        }
    }

    /// The format named `name` ([`TrajectoryFormat::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The format a scene's paths are written in by default: VTK for a fiber, extended XYZ
    /// for the rest (molecules, particles).
    pub fn default_for(scene: &Scene) -> Self {
        match scene.system {
            SystemSpec::Fiber(_) => Self::Vtk,
            _ => Self::Xyz,
        }
    }

    /// Whether the writer wants the frames of one recorded time together (VTK: one file per
    /// time) rather than those of one path (XYZ: one file per path).
    pub fn by_time(self) -> bool {
        self == Self::Vtk
    }
}

/// The particles of a scene's system: how its n coordinates are points in space.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Particles {
    /// The number of particles (n / dim).
    pub count: usize,
    /// Their space dimension, 2 or 3 (a planar system's points get z = 0 in the files).
    pub dim: usize,
    /// Whether they form a chain of beads (fiber, chain molecule), drawn as a polyline.
    pub chain: bool,
    /// The element name the XYZ files give them (`X`, a dummy atom: the systems are reduced
    /// models, not elements).
    pub species: &'static str,
}

impl Particles {
    /// The particles of `scene`'s system: the pendulum's bob in 2-D or 3-D, the atoms of a
    /// molecule, the beads of a fiber. A system built in code has none known (refused).
    pub fn of(scene: &Scene) -> Result<Self, StudyError> {
        let (count, dim, chain) = match &scene.system {
            SystemSpec::Pendulum(p) => (1, p.dim, false),
            SystemSpec::ChainMolecule(p) => (p.atoms, 3, true),
            SystemSpec::Triatomic(_) => (3, 3, false),
            SystemSpec::Fiber(p) => (p.beads, 3, true),
            SystemSpec::Expressions(spec) => match (spec.particles, spec.dimension) {
                (Some(count), Some(dim @ 1..=3)) => (count, dim, false),
                _ => {
                    return Err(scene.invalid(
                        "system.expressions names its coordinates: give particles and \
                         dimension (at most 3) so that a trajectory file can place them",
                    ));
                }
            },
            SystemSpec::Custom(name) => {
                return Err(scene.invalid(format!(
                    "system '{name}' is built in code: its coordinates are not known as \
                     particles, so no trajectory file can place them"
                )));
            }
        };
        Ok(Self {
            count,
            dim,
            chain,
            species: "X",
        })
    }

    /// The coordinates n = count x dim.
    pub fn coordinates(&self) -> usize {
        self.count * self.dim
    }

    /// Particle i of the coordinates `x` as a point in 3-D (z = 0 for a planar system).
    pub fn point(&self, x: &[f64], i: usize) -> [f64; 3] {
        let mut p = [0.0; 3];
        p[..self.dim].copy_from_slice(&x[i * self.dim..(i + 1) * self.dim]);
        p
    }

    /// Refuses, naming `format`, a format these particles cannot have: VTK polylines need a
    /// chain of beads in 3-D.
    pub fn check(&self, format: TrajectoryFormat, scene: &Scene) -> Result<(), StudyError> {
        if format != TrajectoryFormat::Vtk || self.chain && self.dim == 3 {
            return Ok(());
        }
        let what = match self.count {
            1 => format!("one particle in {}-D", self.dim),
            k => format!("{k} particles in {}-D that form no chain", self.dim),
        };
        Err(StudyError::Setting {
            key: "format",
            value: format.name().into(),
            rule: format!(
                "VTK files hold chains of beads in 3-D as polylines (fibers, chain molecules); \
                 scene {}'s system is {what}: use xyz or csv",
                scene.name
            ),
        })
    }
}

/// What every writer knows of the trajectory: where its files go, their names and the
/// particles.
#[derive(Debug, Clone)]
pub struct Target {
    /// The folder of the files.
    pub dir: PathBuf,
    /// The files' name before the suffixes (the scene's name).
    pub stem: String,
    /// The scheme's name (XYZ comment lines).
    pub scheme: String,
    /// The system's particles.
    pub particles: Particles,
}

/// Characters a number takes at most in the files (sign, 17 digits, point, exponent).
const NUMBER_BYTES: u64 = 25;

/// An estimate (from above) of the bytes `format` takes for `paths` paths of `records`
/// recorded times of `particles`.
pub fn estimated_bytes(
    format: TrajectoryFormat, particles: &Particles, paths: usize, records: usize,
) -> u64 {
    let states = (paths as u64).saturating_mul(records as u64);
    let (count, number) = (particles.count as u64, NUMBER_BYTES + 1);
    let (per_state, per_record) = match format {
        // A comment line, and a line per particle: species, r and v.
        TrajectoryFormat::Xyz => (200 + count * (4 + 6 * number), 0),
        // Per path: points, velocities, connectivity, offset and path; a file's header and
        // its line in the collection per time.
        TrajectoryFormat::Vtk => (count * (6 * number + 24) + 64, 2048),
        // path, step, time and the n coordinates.
        TrajectoryFormat::Csv => (48 + particles.coordinates() as u64 * number, 0),
    };
    states
        .saturating_mul(per_state)
        .saturating_add((records as u64).saturating_mul(per_record))
}

/// The bytes free for an unprivileged user on the file system of `dir` (the nearest folder
/// that exists), where the system says (`statvfs`).
pub fn free_space(dir: &Path) -> Option<u64> {
    let existing = dir.ancestors().find(|d| d.exists())?;
    statvfs_available(existing)
}

#[cfg(unix)]
fn statvfs_available(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let path = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut stat = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `path` is a NUL-terminated string and `stat` points to writable memory of the
    // size statvfs fills; it is read only when the call succeeds.
    let status = unsafe { libc::statvfs(path.as_ptr(), stat.as_mut_ptr()) };
    if status != 0 {
        return None;
    }
    // SAFETY: statvfs returned 0, so it filled `stat`.
    let stat = unsafe { stat.assume_init() };
    #[allow(clippy::unnecessary_cast)] // the fields' widths differ between platforms
    Some((stat.f_bavail as u64).saturating_mul(stat.f_frsize as u64))
}

#[cfg(not(unix))]
fn statvfs_available(_dir: &Path) -> Option<u64> {
    None
}

/// Refuses, naming `paths` and the numbers, a trajectory of `settings` in `format` that would
/// not fit in the free space of the file system of `dir` (skipped where the system does not
/// say how much is free).
pub fn check_room(
    format: TrajectoryFormat, particles: &Particles, settings: &SimulateSettings, dir: &Path,
) -> Result<(), StudyError> {
    let needed = estimated_bytes(format, particles, settings.paths, settings.records());
    match free_space(dir) {
        Some(free) if needed > free => Err(StudyError::Setting {
            key: "paths",
            value: settings.paths.to_string(),
            rule: format!(
                "the {} files of {} paths x {} recorded times need about {}, more than the {} \
                 free on {}",
                format.name(),
                settings.paths,
                settings.records(),
                sdae_stats::memory::bytes(needed),
                sdae_stats::memory::bytes(free),
                dir.display()
            ),
        }),
        _ => Ok(()),
    }
}

/// A scene's name as a file name: letters, digits, '-', '_' and '.' kept, the rest '_'.
fn file_stem(name: &str) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.is_empty() || stem.starts_with('.') {
        format!("scene{stem}")
    } else {
        stem
    }
}

/// A number with every digit: Rust's shortest representation that reads back to the same
/// `f64`, in exponent form outside [1e-5, 1e16) so that no number takes hundreds of digits.
pub(crate) fn number(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-5..1e16).contains(&a) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A file written as `<path>.<pid>.tmp` and renamed to `path` when complete; closed and
/// reopened to append when many are written at once; removed if dropped before.
#[derive(Debug)]
pub(crate) struct PendingFile {
    path: PathBuf,
    temporary: PathBuf,
    out: Option<BufWriter<File>>,
}

impl PendingFile {
    /// Creates the temporary file of `path`.
    pub(crate) fn create(path: PathBuf) -> Result<Self, StudyError> {
        let mut temporary = path.clone().into_os_string();
        temporary.push(format!(".{}.tmp", std::process::id()));
        let temporary = PathBuf::from(temporary);
        let file = File::create(&temporary).map_err(|e| StudyError::write(&temporary, e))?;
        Ok(Self {
            path,
            temporary,
            out: Some(BufWriter::new(file)),
        })
    }

    /// The open file, reopened to append if it was closed.
    pub(crate) fn out(&mut self) -> Result<&mut BufWriter<File>, StudyError> {
        if self.out.is_none() {
            let file = std::fs::OpenOptions::new()
                .append(true)
                .open(&self.temporary)
                .map_err(|e| StudyError::write(&self.temporary, e))?;
            self.out = Some(BufWriter::new(file));
        }
        Ok(self.out.as_mut().expect("opened above"))
    }

    /// Writes `text`.
    pub(crate) fn write(&mut self, text: &str) -> Result<(), StudyError> {
        let temporary = self.temporary.clone();
        self.out()?
            .write_all(text.as_bytes())
            .map_err(|e| StudyError::write(temporary, e))
    }

    /// Whether the file is open.
    pub(crate) fn is_open(&self) -> bool {
        self.out.is_some()
    }

    /// Flushes and closes the file (it stays in place, to be reopened).
    pub(crate) fn close(&mut self) -> Result<(), StudyError> {
        match self.out.take() {
            Some(mut out) => out
                .flush()
                .map_err(|e| StudyError::write(&self.temporary, e)),
            None => Ok(()),
        }
    }

    /// Flushes the file and renames it into place; returns its path.
    pub(crate) fn commit(mut self) -> Result<PathBuf, StudyError> {
        self.close()?;
        std::fs::rename(&self.temporary, &self.path)
            .map_err(|e| StudyError::write(&self.path, e))?;
        // Renamed: nothing is left to remove on drop.
        self.temporary = PathBuf::new();
        Ok(std::mem::take(&mut self.path))
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if !self.temporary.as_os_str().is_empty() {
            self.out = None;
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

#[cfg(test)]
mod tests;
