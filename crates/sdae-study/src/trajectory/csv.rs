//! CSV: one file, a row per path and recorded time.

use std::path::PathBuf;

use super::{Frame, PendingFile, Target, number};
use crate::error::StudyError;

/// Writes `<stem>.csv`: the header `path,step,time,r_0,..,r_{n-1}` and a row per frame, in the
/// order the frames come.
#[derive(Debug)]
pub struct CsvWriter {
    pub(super) target: Target,
    file: PendingFile,
}

impl CsvWriter {
    /// A writer into `target`, its header written.
    pub(super) fn new(target: Target) -> Result<Self, StudyError> {
        let mut file = PendingFile::create(target.dir.join(format!("{}.csv", target.stem)))?;
        let columns: Vec<String> = (0..target.particles.coordinates())
            .map(|i| format!("r_{i}"))
            .collect();
        file.write(&format!("path,step,time,{}\n", columns.join(",")))?;
        Ok(Self { target, file })
    }

    /// Appends the frame's row.
    pub fn write_frame(&mut self, frame: &Frame<'_>) -> Result<(), StudyError> {
        let mut row = format!("{},{},{}", frame.path, frame.step, number(frame.time));
        for &x in frame.position {
            row.push(',');
            row.push_str(&number(x));
        }
        row.push('\n');
        self.file.write(&row)
    }

    /// Puts the file in place; returns it.
    pub fn finish(self) -> Result<Vec<PathBuf>, StudyError> {
        Ok(vec![self.file.commit()?])
    }
}
