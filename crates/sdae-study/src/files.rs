//! Writing result files so that a reader never sees half a file: each is written to a
//! temporary file in the same folder and renamed into place (a rename within one file system
//! is atomic), so an interrupted run leaves the previous file or the new one, never a torn one.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::error::StudyError;

/// Writes to `path` atomically what `write` puts into the file (through a buffer, so that a
/// large file is never held in memory whole), creating the folder if needed. The temporary
/// file is `<path>.<process id>.tmp`; it is removed if the write fails (the command removes
/// those a killed process left).
pub fn write_with(
    path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), StudyError> {
    let fail = |e: std::io::Error| StudyError::write(path, e);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(fail)?;
    }
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(format!(".{}.tmp", std::process::id()));
    let written = File::create(&temporary).and_then(|file| {
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        out.flush()
    });
    written
        .and_then(|()| std::fs::rename(&temporary, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&temporary);
            fail(e)
        })
}

/// Writes `contents` to `path` atomically, creating the folder if needed.
pub fn write_atomically(path: &Path, contents: &str) -> Result<(), StudyError> {
    write_with(path, |out| out.write_all(contents.as_bytes()))
}

/// Serializes `value` as pretty JSON (with a final newline) and writes it atomically.
pub fn write_json<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), StudyError> {
    write_with(path, |out| {
        serde_json::to_writer_pretty(&mut *out, value)?;
        out.write_all(b"\n")
    })
}

/// Reads a JSON file written by [`write_json`].
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, StudyError> {
    let fail = |message: String| StudyError::Read {
        path: path.into(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| fail(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_replace_whole_files_and_leave_no_temporary() {
        let dir = std::env::temp_dir().join(format!("sdae-files-{}", std::process::id()));
        let path = dir.join("nested").join("report.json");
        write_atomically(&path, "first").unwrap();
        write_atomically(&path, "second").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second");
        let left: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(left.len(), 1, "a temporary file was left behind");
        // A folder that cannot be created is a typed error naming the path.
        let blocked = path.join("under-a-file.json");
        assert!(matches!(
            write_atomically(&blocked, "x"),
            Err(StudyError::Write { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
