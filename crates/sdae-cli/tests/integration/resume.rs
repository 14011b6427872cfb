//! Nothing lost on interruption: a run stopped part way saves its finished paths, and resuming
//! it ends with exactly the report of an uninterrupted run (timings aside), through the library
//! and through the binary stopped by SIGTERM.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};

use sdae_cli::checkpoint::{Checkpoint, Resumed};
use sdae_study::StudyError;
use sdae_study::convergence::build_report;
use sdae_study::parallel::Control;

/// A report's JSON without what differs from run to run (timings, thread count).
fn numbers(json: &str) -> serde_json::Value {
    sdae_cli::compare::numbers_of(json).unwrap()
}

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-resume-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn a_stopped_run_resumed_equals_the_uninterrupted_run() {
    let (scene, mut settings) = common::small(30);
    settings.threads = 1;
    let whole = build_report(common::run(&scene, &settings, 0, 1));
    let dir = folder("library");
    let checkpoint = Checkpoint::new(dir.join("checkpoint.bin"));
    // Raised after the 7th path: no later block of paths starts.
    let stop = AtomicBool::new(false);
    let raise = |done: usize| {
        if done == 7 {
            stop.store(true, Ordering::Relaxed);
        }
    };
    let control = Control {
        progress: Some(&raise),
        stop: Some(&stop),
        ..Control::default()
    };
    let first = checkpoint.run(&scene, &settings, (0, 1), None, control);
    // Paths run in blocks: the block that holds the 7th path finishes whole.
    let Ok(Resumed::Interrupted { saved, selected }) = first else {
        panic!("the stopped run did not stop: {first:?}");
    };
    assert!(
        (7..30).contains(&saved) && selected == 30,
        "{saved} of {selected}"
    );
    // Resumed on another thread count: the saved paths are not run again.
    settings.threads = 2;
    let kept = saved;
    let saved = checkpoint.load(&scene, &settings, (0, 1)).unwrap();
    assert_eq!(saved.as_ref().map(|s| s.records.len()), Some(kept));
    let ran = AtomicBool::new(false);
    let count = |done: usize| ran.store(done > 30 - kept, Ordering::Relaxed);
    let control = Control {
        progress: Some(&count),
        ..Control::default()
    };
    let Ok(Resumed::Finished(run)) = checkpoint.run(&scene, &settings, (0, 1), saved, control)
    else {
        panic!("the resumed run did not finish");
    };
    assert!(!ran.load(Ordering::Relaxed), "a saved path ran again");
    let resumed = build_report(*run);
    let json = |r| serde_json::to_string(r).unwrap();
    assert_eq!(numbers(&json(&whole)), numbers(&json(&resumed)));
    checkpoint.remove().unwrap();
    assert!(!checkpoint.path().exists());
    checkpoint.remove().unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_of_another_study_is_refused() {
    let (scene, settings) = common::small(6);
    let dir = folder("other");
    let checkpoint = Checkpoint::new(dir.join("checkpoint.bin"));
    let done = checkpoint.run(&scene, &settings, (0, 1), None, Control::default());
    let Ok(Resumed::Finished(run)) = done else {
        panic!("the run did not finish: {done:?}");
    };
    // A finished run is saved whole before its report is written.
    let saved = checkpoint.load(&scene, &settings, (0, 1)).unwrap();
    assert_eq!(saved.map(|s| s.records), Some(run.records));
    let mut other = settings.clone();
    other.seed += 1;
    let err = checkpoint.load(&scene, &other, (0, 1)).unwrap_err();
    assert!(matches!(err, StudyError::Resume { .. }), "{err}");
    assert!(err.to_string().contains("another --seed (saved "), "{err}");
    assert!(checkpoint.load(&scene, &settings, (1, 2)).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

fn study(out: &Path, threads: &str, extra: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_sdae-study"));
    command
        .args(["--paths", "1000", "--levels", "3..7", "--ref-level", "10"])
        .args(["--threads", threads, "--out"])
        .arg(out)
        .args(extra)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped());
    command
}

#[test]
fn the_binary_stopped_by_sigterm_saves_its_paths_and_resumes_to_the_same_report() {
    let dir = folder("binary");
    let whole = study(&dir.join("whole"), "1", &[]).output().unwrap();
    assert!(
        whole.status.success(),
        "{}",
        String::from_utf8_lossy(&whole.stderr)
    );
    let out = dir.join("stopped");
    let mut child = study(&out, "1", &["--checkpoint-every", "0"])
        .spawn()
        .unwrap();
    // Stopped once it has saved some paths (a periodic checkpoint after every block).
    let checkpoint = out.join("pendulum").join("checkpoint-0-of-1.bin");
    while !checkpoint.exists() && child.try_wait().unwrap().is_none() {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let stopped = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    // 130 when stopped part way (0 only if it finished before the signal).
    match stopped.status.code() {
        Some(130) => {
            assert!(stderr.contains("--resume"), "{stderr}");
            assert!(out.join("pendulum").join("checkpoint-0-of-1.bin").exists());
            assert!(!out.join("pendulum").join("report.json").exists());
            let resumed = study(&out, "2", &["--resume"]).output().unwrap();
            let stderr = String::from_utf8_lossy(&resumed.stderr);
            assert!(resumed.status.success(), "{stderr}");
        }
        code => assert_eq!(code, Some(0), "{stderr}"),
    }
    assert!(!out.join("pendulum").join("checkpoint-0-of-1.bin").exists());
    let read = |d: &Path| std::fs::read_to_string(d.join("pendulum").join("report.json")).unwrap();
    assert_eq!(numbers(&read(&dir.join("whole"))), numbers(&read(&out)));
    let _ = std::fs::remove_dir_all(&dir);
}
