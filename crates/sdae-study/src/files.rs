//! Writing result files so that a reader never sees half a file: each is written to a
//! temporary file in the same folder and renamed into place (a rename within one file system
//! is atomic), so an interrupted run leaves the previous file or the new one, never a torn one.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::error::StudyError;

/// Writes to `path` atomically what `write` puts into the file (through a buffer, so that a
/// large file is never held in memory whole), creating the folder if needed. The temporary
/// file is `<path>.<process id>.tmp`; it is removed if the write fails, and
/// [`remove_stale_temporaries`] removes those a killed process left.
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

/// Whether process `pid` of this machine is alive: `None` where that cannot be told (no
/// `/proc`).
pub fn process_alive(pid: u32) -> Option<bool> {
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(Path::new(&format!("/proc/{pid}")).exists())
}

/// Creates the folder `dir` and checks that a file can be written in it (created, written and
/// removed), so that a study refuses an output folder it cannot use before it runs.
pub fn check_writable(dir: &Path) -> Result<(), StudyError> {
    std::fs::create_dir_all(dir).map_err(|e| StudyError::write(dir, e))?;
    let probe = dir.join(format!(".write-check.{}.tmp", std::process::id()));
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .and_then(|mut file| {
            file.write_all(b"sdae-study\n")?;
            file.sync_all()
        });
    let _ = std::fs::remove_file(&probe);
    written.map_err(|e| StudyError::write(dir, format!("the folder is not writable: {e}")))
}

/// Removes the temporary files `<name>.<pid>.tmp` in `dir`, for the file names `names`, that
/// a process of this machine no longer alive left behind (killed while writing); returns how
/// many. Temporary files of live processes, and all of them where liveness cannot be told,
/// are kept.
pub fn remove_stale_temporaries(dir: &Path, names: &[&str]) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let stale = |file: &str| -> bool {
        let Some(rest) = file.strip_suffix(".tmp") else {
            return false;
        };
        let Some((name, pid)) = rest.rsplit_once('.') else {
            return false;
        };
        let pid = pid.parse::<u32>().ok();
        names.contains(&name)
            && pid.is_some_and(|p| p != std::process::id() && process_alive(p) == Some(false))
    };
    entries
        .flatten()
        .filter(|e| e.file_name().to_str().is_some_and(stale))
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
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

/// The fields of a report that differ between runs of one study: timings, what is computed
/// from them (an MLMC report's costs in seconds, speed-up, the slope of its seconds per sample
/// and its standard run's predicted seconds), the thread count, and a shard file's checksum
/// (which covers its timings).
pub const RUN_DEPENDENT: [&str; 13] = [
    "seconds_per_path",
    "steps_per_second",
    "threads",
    "seconds",
    "seconds_per_sample",
    "mlmc_seconds",
    "speedup",
    "mlmc_cost",
    "standard_cost",
    "gamma_seconds",
    "predicted_seconds",
    "cap_seconds",
    "crc32",
];

/// A report (or shard) in JSON without its [`RUN_DEPENDENT`] fields: what is equal for every
/// run of one study, sharded and merged, interrupted and resumed, on any thread count.
pub fn numbers_of(json: &str) -> Result<serde_json::Value, serde_json::Error> {
    fn strip(value: &mut serde_json::Value) {
        match value {
            serde_json::Value::Object(map) => {
                for key in RUN_DEPENDENT {
                    map.remove(key);
                }
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut value = serde_json::from_str(json)?;
    strip(&mut value);
    Ok(value)
}

/// Where two reports' numbers ([`numbers_of`]) first differ, as a JSON pointer with both
/// values (`None` when they are equal): `/schemes/2/levels/3/errors/r: 0.0123 against 0.0124`.
pub fn first_difference(a: &serde_json::Value, b: &serde_json::Value) -> Option<String> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(u, v).map(|d| format!("/{k}{d}")),
                (u, v) => Some(format!("/{k}: {} against {}", shown(u), shown(v))),
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (u, v))| first_difference(u, v).map(|d| format!("/{i}{d}"))),
        (Value::Array(x), Value::Array(y)) => {
            Some(format!(": {} entries against {}", x.len(), y.len()))
        }
        _ if a == b => None,
        _ => Some(format!(": {a} against {b}")),
    }
}

/// A value of [`first_difference`], or "nothing" where a key is missing.
fn shown(v: Option<&serde_json::Value>) -> String {
    v.map_or_else(|| "nothing".to_string(), ToString::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_difference_is_named_by_its_pointer() {
        let a = numbers_of(r#"{"seconds": 1, "x": [1, {"y": 2.5, "z": 1}], "w": 1}"#).unwrap();
        let same = numbers_of(r#"{"seconds": 9, "x": [1, {"y": 2.5, "z": 1}], "w": 1}"#).unwrap();
        assert_eq!(first_difference(&a, &same), None);
        let other = numbers_of(r#"{"x": [1, {"y": 2.25, "z": 1}], "w": 1}"#).unwrap();
        assert_eq!(
            first_difference(&a, &other).as_deref(),
            Some("/x/1/y: 2.5 against 2.25")
        );
        let shorter = numbers_of(r#"{"x": [1], "w": 1}"#).unwrap();
        assert_eq!(
            first_difference(&a, &shorter).as_deref(),
            Some("/x: 2 entries against 1")
        );
        let missing = numbers_of(r#"{"x": [1, {"y": 2.5, "z": 1}]}"#).unwrap();
        assert_eq!(
            first_difference(&a, &missing).as_deref(),
            Some("/w: 1 against nothing")
        );
    }

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

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_and_others_kept() {
        let dir = std::env::temp_dir().join(format!("sdae-files-tmp-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A process id above the kernel's limit (4194304) is never alive.
        let dead = dir.join("report.json.4999999.tmp");
        let live = dir.join(format!("report.json.{}.tmp", std::process::id()));
        let other = dir.join("notes.txt.4999999.tmp");
        for file in [&dead, &live, &other] {
            std::fs::write(file, "x").unwrap();
        }
        if process_alive(4_999_999) == Some(false) {
            assert_eq!(remove_stale_temporaries(&dir, &["report.json"]), 1);
            assert!(!dead.exists());
        }
        assert!(live.exists() && other.exists());
        check_writable(&dir.join("sub")).unwrap();
        assert!(check_writable(&live.join("x")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
