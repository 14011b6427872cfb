//! The output folders of the command: checked writable before a run, cleared of the
//! temporary files a killed process left, and which processes are alive (for the locks).

use std::io::Write;
use std::path::Path;

use sdae_study::StudyError;

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

#[cfg(test)]
mod tests {
    use super::*;

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
