//! VTK: an XML unstructured grid of polylines per recorded time and a `.pvd` collection.
//!
//! Written by hand: the format is a few tags of ASCII text, and the Rust VTK crate (`vtkio`)
//! builds each file from a model held whole in memory, has no `.pvd` collections, and brings
//! XML, serialization and compression libraries (a C library among them) that these files do
//! not need.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::{Frame, PendingFile, Target, number};
use crate::error::StudyError;
use crate::files::write_atomically;

/// `VTK_POLY_LINE`, the VTK cell type of a polyline.
const POLY_LINE: u8 = 4;

/// Writes `<stem>.<j>.vtu` for the j-th recorded time (j with six digits or more): every
/// path's particles as one polyline (cell data `path`, point data `velocity`, field data
/// `TimeValue`), and on [`VtkWriter::finish`] the collection `<stem>.pvd` of the files with
/// their times. The frames of one time come together; a file is written when the next time's
/// first frame comes.
#[derive(Debug)]
pub struct VtkWriter {
    pub(super) target: Target,
    /// The current time's step and time.
    current: Option<(usize, f64)>,
    /// The current time's paths, and their points and velocities (3 per particle).
    paths: Vec<usize>,
    points: Vec<f64>,
    velocities: Vec<f64>,
    /// The files written, with their times.
    written: Vec<(PathBuf, f64)>,
}

impl VtkWriter {
    /// A writer into `target`.
    pub(super) fn new(target: Target) -> Self {
        Self {
            target,
            current: None,
            paths: Vec::new(),
            points: Vec::new(),
            velocities: Vec::new(),
            written: Vec::new(),
        }
    }

    /// Adds the frame to its time's file; writes the previous time's file when the frame
    /// starts a new time. Refuses a frame of a time already written.
    pub fn write_frame(&mut self, frame: &Frame<'_>) -> Result<(), StudyError> {
        if self.current.is_some_and(|(step, _)| step != frame.step) {
            self.flush()?;
        }
        if self.current.is_none() {
            if let Some(last) = self.written.last().map(|(_, t)| *t)
                && frame.time <= last
            {
                return Err(StudyError::Setting {
                    key: "frame",
                    value: format!("t = {}", frame.time),
                    rule: format!(
                        "VTK files are written by time: frames of one time come together, in \
                         the order of time (the last file written is t = {last})"
                    ),
                });
            }
            self.current = Some((frame.step, frame.time));
        }
        let particles = &self.target.particles;
        self.paths.push(frame.path);
        for i in 0..particles.count {
            self.points.extend(particles.point(frame.position, i));
            self.velocities.extend(particles.point(frame.velocity, i));
        }
        Ok(())
    }

    /// Writes the current time's file.
    fn flush(&mut self) -> Result<(), StudyError> {
        let Some((_, time)) = self.current.take() else {
            return Ok(());
        };
        let name = format!("{}.{:06}.vtu", self.target.stem, self.written.len());
        let path = self.target.dir.join(name);
        write_atomically(&path, &self.grid(time))?;
        self.written.push((path, time));
        self.paths.clear();
        self.points.clear();
        self.velocities.clear();
        Ok(())
    }

    /// The current time's unstructured grid.
    fn grid(&self, time: f64) -> String {
        let count = self.target.particles.count;
        let (cells, points) = (self.paths.len(), self.points.len() / 3);
        let mut text = String::with_capacity(64 * points + 1024);
        let _ = write!(
            text,
            "<?xml version=\"1.0\"?>\n\
             <VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
             header_type=\"UInt64\">\n<UnstructuredGrid>\n<FieldData>\n\
             <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" \
             format=\"ascii\">{}</DataArray>\n</FieldData>\n\
             <Piece NumberOfPoints=\"{points}\" NumberOfCells=\"{cells}\">\n",
            number(time)
        );
        text.push_str("<PointData Vectors=\"velocity\">\n");
        data_array(&mut text, "Float64", "velocity", 3, &self.velocities);
        text.push_str("</PointData>\n<CellData Scalars=\"path\">\n");
        integer_array(&mut text, "Int64", "path", self.paths.iter().copied());
        text.push_str("</CellData>\n<Points>\n");
        data_array(&mut text, "Float64", "position", 3, &self.points);
        text.push_str("</Points>\n<Cells>\n");
        integer_array(&mut text, "Int64", "connectivity", 0..points);
        integer_array(
            &mut text,
            "Int64",
            "offsets",
            (1..=cells).map(|c| c * count),
        );
        integer_array(&mut text, "UInt8", "types", (0..cells).map(|_| POLY_LINE));
        text.push_str("</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        text
    }

    /// Writes the last time's file and the collection; returns the collection and then the
    /// files by time.
    pub fn finish(mut self) -> Result<Vec<PathBuf>, StudyError> {
        self.flush()?;
        let mut pvd = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<Collection>\n",
        );
        for (path, time) in &self.written {
            let file = path.file_name().map(|f| f.to_string_lossy().into_owned());
            let _ = writeln!(
                pvd,
                "<DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>",
                number(*time),
                file.unwrap_or_default()
            );
        }
        pvd.push_str("</Collection>\n</VTKFile>\n");
        let collection = self.target.dir.join(format!("{}.pvd", self.target.stem));
        let mut file = PendingFile::create(collection)?;
        file.write(&pvd)?;
        let mut files = vec![file.commit()?];
        files.extend(
            std::mem::take(&mut self.written)
                .into_iter()
                .map(|(path, _)| path),
        );
        Ok(files)
    }
}

/// A writer dropped before [`VtkWriter::finish`] removes the files it wrote: a run that fails
/// leaves no series without its collection.
impl Drop for VtkWriter {
    fn drop(&mut self) {
        for (path, _) in &self.written {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// A `DataArray` of floating-point numbers with `components` per tuple, every digit kept.
fn data_array(text: &mut String, kind: &str, name: &str, components: usize, values: &[f64]) {
    let _ = writeln!(
        text,
        "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" \
         format=\"ascii\">"
    );
    for tuple in values.chunks(components) {
        let line: Vec<String> = tuple.iter().map(|&x| number(x)).collect();
        text.push_str(&line.join(" "));
        text.push('\n');
    }
    text.push_str("</DataArray>\n");
}

/// A `DataArray` of integers.
fn integer_array<T: std::fmt::Display>(
    text: &mut String, kind: &str, name: &str, values: impl Iterator<Item = T>,
) {
    let _ = writeln!(
        text,
        "<DataArray type=\"{kind}\" Name=\"{name}\" format=\"ascii\">"
    );
    for value in values {
        let _ = write!(text, "{value} ");
    }
    text.push_str("\n</DataArray>\n");
}
