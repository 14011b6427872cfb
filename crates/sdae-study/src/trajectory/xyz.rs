//! Extended XYZ: one file per path, one frame per recorded time.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use super::{Frame, MAX_OPEN_FILES, PendingFile, Target, number};
use crate::error::StudyError;

/// Writes each path's frames to `<stem>.path-<p>.xyz`: the number of particles, a comment line
/// `Properties=species:S:1:pos:R:3:vel:R:3 time=.. step=.. path=.. scheme=..`, and a line per
/// particle (species, x, y, z, v_x, v_y, v_z; z = v_z = 0 for a planar system). At most
/// [`MAX_OPEN_FILES`] files are open at once: frames of more paths close them all and reopen
/// each to append when its next frame comes, so the frames may come in any order (a path's in
/// the order of time).
#[derive(Debug)]
pub struct XyzWriter {
    pub(super) target: Target,
    /// Each path's file, by path.
    files: BTreeMap<usize, PendingFile>,
    /// How many are open.
    open: usize,
}

impl XyzWriter {
    /// A writer of the paths into `target`.
    pub(super) fn new(target: Target) -> Self {
        Self {
            target,
            files: BTreeMap::new(),
            open: 0,
        }
    }

    /// Appends the frame to its path's file.
    pub fn write_frame(&mut self, frame: &Frame<'_>) -> Result<(), StudyError> {
        let text = self.frame_text(frame);
        if !self.files.contains_key(&frame.path) {
            let path = self
                .target
                .dir
                .join(format!("{}.path-{}.xyz", self.target.stem, frame.path));
            self.make_room()?;
            self.files.insert(frame.path, PendingFile::create(path)?);
            self.open += 1;
        }
        let closed = self.files.get(&frame.path).is_some_and(|f| !f.is_open());
        if closed {
            self.make_room()?;
            self.open += 1;
        }
        let file = self.files.get_mut(&frame.path).expect("inserted above");
        file.write(&text)
    }

    /// Closes every open file when [`MAX_OPEN_FILES`] are open.
    fn make_room(&mut self) -> Result<(), StudyError> {
        if self.open >= MAX_OPEN_FILES {
            for file in self.files.values_mut() {
                file.close()?;
            }
            self.open = 0;
        }
        Ok(())
    }

    /// The frame's lines.
    fn frame_text(&self, frame: &Frame<'_>) -> String {
        let particles = &self.target.particles;
        let mut text = String::with_capacity(160 + particles.count * 140);
        // Writing to a String cannot fail.
        let _ = writeln!(
            text,
            "{}\nProperties=species:S:1:pos:R:3:vel:R:3 time={} step={} path={} scheme={}",
            particles.count,
            number(frame.time),
            frame.step,
            frame.path,
            self.target.scheme
        );
        for i in 0..particles.count {
            text.push_str(particles.species);
            let (r, v) = (
                particles.point(frame.position, i),
                particles.point(frame.velocity, i),
            );
            for x in r.into_iter().chain(v) {
                text.push(' ');
                text.push_str(&number(x));
            }
            text.push('\n');
        }
        text
    }

    /// Puts every path's file in place; returns them by path.
    pub fn finish(self) -> Result<Vec<PathBuf>, StudyError> {
        self.files.into_values().map(PendingFile::commit).collect()
    }
}
