//! Nothing lost, whatever happens to a run: killed (SIGKILL) at random moments and resumed, it
//! ends with the report of an uninterrupted run; two stop signals save what the first promised;
//! bad output folders, locked folders, forgotten checkpoints, malformed checkpoints and shards,
//! a flipped bit in any checkpoint or shard, and two scenes of one name are refused before
//! anything runs (exit code 2); a save cut short is dropped and its paths run again.

use crate::common;

use crate::bits;
use crate::process;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use bits::sampled_bits;
use process::{binary, numbers, quick_weak, same_numbers_nothing_left, signal, stderr, wait_for};

use std::sync::atomic::{AtomicBool, Ordering};

use sdae_cli::checkpoint::{Checkpoint, Resumed};
use sdae_study::StudyError;
use sdae_study::convergence::{ConvergenceRun, ConvergenceSettings};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-faults-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A pendulum study of a few seconds, in blocks of 64 paths on one thread, saved after every
/// block.
fn long_study(out: &Path, extra: &[&str]) -> Command {
    let mut command = binary();
    command
        .args(["--paths", "1200", "--levels", "3..8", "--ref-level", "12"])
        .args(["--threads", "1", "--checkpoint-every", "0", "--out"])
        .arg(out)
        .args(extra);
    command
}

/// Delays from a seeded splitmix64 stream, in `range` milliseconds.
fn delays(seed: u64, count: usize, range: std::ops::Range<u64>) -> Vec<Duration> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            Duration::from_millis(range.start + z % (range.end - range.start))
        })
        .collect()
}

#[test]
fn killed_at_random_moments_and_resumed_it_ends_with_the_uninterrupted_report() {
    let dir = folder("sigkill");
    let whole = long_study(&dir.join("whole"), &[]).output().unwrap();
    assert!(whole.status.success(), "{}", stderr(&whole));
    let out = dir.join("killed");
    let scene_dir = out.join("pendulum");
    let checkpoint = Checkpoint::new(scene_dir.join("checkpoint-0-of-1.bin"));
    let saved = || checkpoint.holds().map_or(0, |(n, _)| n);
    let mut runs = Vec::new();
    // Each run is killed at a random moment after it saved more paths than the one before
    // (so that the study gets on), perhaps in the middle of its next save.
    for delay in delays(2026, 3, 0..300) {
        let before = saved();
        let mut child = long_study(&out, &["--resume"]).spawn().unwrap();
        let start = Instant::now();
        while saved() <= before && child.try_wait().unwrap().is_none() {
            assert!(start.elapsed() < Duration::from_secs(60), "no progress");
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(delay);
        if child.try_wait().unwrap().is_none() {
            child.kill().unwrap();
        }
        runs.push(child.wait_with_output().unwrap());
    }
    let killed = runs.iter().filter(|r| r.status.code().is_none()).count();
    assert!(killed >= 2, "only {killed} of the runs were killed");
    let last = long_study(&out, &["--resume"]).output().unwrap();
    runs.push(last);
    let last = runs.last().unwrap();
    assert!(last.status.success(), "{}", stderr(last));
    // A killed run leaves its lock: the next run takes it over, says so, and resumes.
    for pair in runs.windows(2) {
        if pair[0].status.code().is_none() {
            let text = stderr(&pair[1]);
            assert!(text.contains("taken over"), "{text}");
            assert!(text.contains("resuming from"), "{text}");
        }
    }
    same_numbers_nothing_left(
        &dir.join("whole/pendulum/report.json"),
        &scene_dir.join("report.json"),
        &scene_dir,
        &dir,
    );
}

#[test]
fn two_stop_signals_save_the_finished_paths_and_exit_130() {
    let dir = folder("twice");
    let checkpoint = dir.join("pendulum").join("checkpoint-0-of-1.bin");
    for second in ["TERM", "INT"] {
        let mut child = long_study(&dir, &[]).spawn().unwrap();
        wait_for(&checkpoint, &mut child);
        signal(&child, "TERM");
        signal(&child, second);
        let stopped = child.wait_with_output().unwrap();
        let text = stderr(&stopped);
        if stopped.status.code() == Some(0) {
            continue; // finished before the signals: nothing to check
        }
        assert_eq!(stopped.status.code(), Some(130), "{text}");
        assert!(text.contains("paths are saved in"), "{text}");
        assert!(text.contains("--resume"), "{text}");
        assert!(checkpoint.exists());
        let cp = Checkpoint::new(&checkpoint);
        let (saved, of) = cp.holds().expect("a readable checkpoint");
        assert!(saved > 0 && saved < of && of == 1200, "{saved} of {of}");
        assert!(
            text.contains(&format!("{saved} of 1200 paths are saved")),
            "{text}"
        );
        cp.remove().unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stop_before_any_path_finished_exits_131() {
    let dir = folder("nothing");
    // A reference of 2^20 steps: the first block of paths takes far longer than the start.
    let child = binary()
        .args([
            "--paths",
            "64",
            "--ref-level",
            "20",
            "--threads",
            "1",
            "--out",
        ])
        .arg(&dir)
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    signal(&child, "TERM");
    let stopped = child.wait_with_output().unwrap();
    let text = stderr(&stopped);
    assert_eq!(stopped.status.code(), Some(131), "{text}");
    assert!(text.contains("nothing saved"), "{text}");
    assert!(!dir.join("pendulum").join("checkpoint-0-of-1.bin").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the binary and requires exit code 2 with every one of `words` in its message.
fn refused(command: &mut Command, words: &[&str]) -> String {
    let out = command.output().unwrap();
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{text}");
    for word in words {
        assert!(text.contains(word), "'{word}' not in\n{text}");
    }
    text
}

fn quick(out: &Path, extra: &[&str]) -> Command {
    let mut command = binary();
    command
        .args(["--quick", "--paths", "8", "--threads", "1", "--out"])
        .arg(out)
        .args(extra);
    command
}

#[test]
fn unusable_output_folders_are_refused_before_running() {
    let dir = folder("out");
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    refused(&mut quick(&file, &[]), &["cannot write", "a-file"]);
    let long = dir.join("n".repeat(300));
    refused(&mut quick(&long, &[]), &["cannot write"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_is_neither_replaced_nor_resumed_by_another_run() {
    let dir = folder("forgotten");
    let scene_dir = dir.join("pendulum");
    let checkpoint = scene_dir.join("checkpoint-0-of-1.bin");
    // An interrupted run's checkpoint (its paths saved by the library, as the binary does).
    let (scene, mut settings) = common::small(8);
    settings.threads = 1;
    let run = common::run(&scene, &settings, 0, 1);
    Checkpoint::new(&checkpoint).save(&run).unwrap();
    // Without --resume, a run (here a --quick check) refuses to replace it.
    refused(
        &mut quick(&dir, &[]),
        &[
            "checkpoint-0-of-1.bin",
            "8 of 8 paths",
            "--resume",
            "--fresh",
        ],
    );
    assert!(checkpoint.exists());
    // With --resume, a run of other settings names what differs.
    refused(
        &mut quick(&dir, &["--resume"]),
        &["cannot resume", "another --levels (saved 2..4, asked 3..7)"],
    );
    // A live run holds the lock: a second run in the folder is refused.
    let lock = scene_dir.join("checkpoint-0-of-1.bin.lock");
    std::fs::write(&lock, format!("{} {}\n", std::process::id(), host())).unwrap();
    refused(&mut quick(&dir, &["--fresh"]), &["held by process", "lock"]);
    std::fs::remove_file(&lock).unwrap();
    // --fresh discards it and says so; --resume with nothing to resume says so.
    let fresh = quick(&dir, &["--fresh"]).output().unwrap();
    assert!(fresh.status.success(), "{}", stderr(&fresh));
    assert!(stderr(&fresh).contains("discarding"), "{}", stderr(&fresh));
    let resumed = quick(&dir, &["--resume"]).output().unwrap();
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert!(stderr(&resumed).contains("nothing to resume"));
    let _ = std::fs::remove_dir_all(&dir);
}

fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "this-host".into())
}

/// A small run and a checkpoint in a folder of its own, to save malformed versions of the run
/// in and resume from.
struct Malformed {
    scene: Scene,
    settings: ConvergenceSettings,
    dir: PathBuf,
    checkpoint: Checkpoint,
    run: ConvergenceRun,
}

impl Malformed {
    /// A run of 8 paths on one thread, and its checkpoint (not yet written).
    fn new() -> Self {
        let (scene, mut settings) = common::small(8);
        settings.threads = 1;
        let dir = folder("malformed");
        let checkpoint = Checkpoint::new(dir.join("checkpoint.bin"));
        let run = common::run(&scene, &settings, 0, 1);
        Self {
            scene,
            settings,
            dir,
            checkpoint,
            run,
        }
    }

    /// Loads the checkpoint and resumes the run from it.
    fn resume(&self) -> Result<Resumed, StudyError> {
        let c = &self.checkpoint;
        let saved = c.load(&self.scene, &self.settings, (0, 1))?;
        c.run(
            &self.scene,
            &self.settings,
            (0, 1),
            saved,
            Control::default(),
        )
    }

    /// Saves the run's first `keep` records as `spoil` changes them, and returns the error
    /// resuming from them gives, required to be a [`StudyError::Resume`].
    fn resume_refused(&self, keep: usize, spoil: impl FnOnce(&mut ConvergenceRun)) -> String {
        let mut bad = self.run.clone();
        bad.records.truncate(keep);
        spoil(&mut bad);
        self.checkpoint.save(&bad).unwrap();
        let err = self.resume().unwrap_err();
        assert!(matches!(err, StudyError::Resume { .. }), "{err}");
        err.to_string()
    }
}

#[test]
fn malformed_checkpoints_are_refused_with_a_typed_error() {
    let m = Malformed::new();
    malformed_records_are_refused(&m);
    let bytes = cut_checkpoints_are_refused_or_dropped(&m);
    // A good one resumes to the whole run.
    std::fs::write(m.checkpoint.path(), &bytes).unwrap();
    let Ok(Resumed::Finished(resumed)) = m.resume() else {
        panic!("a good checkpoint did not resume");
    };
    // The saved records read back bit for bit; the report's numbers are the whole run's.
    assert_eq!(resumed.records[..4], m.run.records[..4]);
    let report = |r| serde_json::to_string(&sdae_study::convergence::build_report(r)).unwrap();
    let numbers_of = |json: String| sdae_cli::compare::numbers_of(&json).unwrap();
    assert_eq!(
        numbers_of(report(*resumed)),
        numbers_of(report(m.run.clone()))
    );
    damaged_checkpoints_are_refused_by_the_binary(&m.dir.join("out"), &bytes);
    let _ = std::fs::remove_dir_all(&m.dir);
}

/// Records that do not fit the run are refused on resuming, naming what is wrong.
fn malformed_records_are_refused(m: &Malformed) {
    // A record with fewer tracks.
    let err = m.resume_refused(3, |short| {
        short.records[1].tracks.pop();
    });
    assert!(err.contains("scheme-level results"), "{err}");
    // A duplicated record, and one out of range.
    for index in [2, 8] {
        let err = m.resume_refused(3, |bad| bad.records[0].index = index);
        assert!(err.contains(&format!("path {index}")), "{err}");
    }
    // A track with neither distances nor a failure: refused on load, as merge refuses it.
    let err = m.resume_refused(3, |lost| {
        lost.records[2].tracks[0].distances = None;
        lost.records[2].tracks[0].failure = None;
    });
    assert!(
        err.contains("path 2: scheme-level result 0 has neither"),
        "{err}"
    );
}

/// A checkpoint of the run's first 4 records cut short in its header is refused, one cut short
/// in its last segment resumes whole; returns the checkpoint's bytes.
fn cut_checkpoints_are_refused_or_dropped(m: &Malformed) -> Vec<u8> {
    let checkpoint = &m.checkpoint;
    // A file cut short in its header, or not a checkpoint at all: refused.
    let mut partial = m.run.clone();
    partial.records.truncate(4);
    checkpoint.save(&partial).unwrap();
    let bytes = std::fs::read(checkpoint.path()).unwrap();
    for cut in [10, 40] {
        std::fs::write(checkpoint.path(), &bytes[..cut]).unwrap();
        let err = m.resume().unwrap_err();
        assert!(matches!(err, StudyError::Checksum { .. }), "{err}");
    }
    // Cut short in its last segment (a save killed midway): the segment is dropped, its paths
    // run again, and the run ends whole.
    for cut in [bytes.len() - 1, bytes.len() - 200] {
        std::fs::write(checkpoint.path(), &bytes[..cut]).unwrap();
        let saved = checkpoint
            .load(&m.scene, &m.settings, (0, 1))
            .unwrap()
            .unwrap();
        assert!(saved.records.is_empty() && saved.torn > 0, "{}", saved.torn);
        assert!(saved.torn_note().unwrap().contains("dropped"));
        let Ok(Resumed::Finished(whole)) = m.resume() else {
            panic!("a torn checkpoint did not resume");
        };
        assert_eq!(whole.records.len(), 8);
    }
    bytes
}

/// Through the binary writing to `out`: the checkpoint `bytes` with a flipped bit, or in the
/// format before checksums, are refused (exit code 2), naming the file.
fn damaged_checkpoints_are_refused_by_the_binary(out: &Path, bytes: &[u8]) {
    let file = out.join("pendulum").join("checkpoint-0-of-1.bin");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    let mut flipped = bytes.to_vec();
    flipped[bytes.len() / 2] ^= 4;
    std::fs::write(&file, &flipped).unwrap();
    refused(
        &mut quick(out, &["--resume"]),
        &["checkpoint-0-of-1.bin", "checksum"],
    );
    // A checkpoint of the format before checksums is refused by name.
    let mut old = b"sdae-study checkpoint 2\n".to_vec();
    old.extend_from_slice(&bytes[24..]);
    std::fs::write(&file, &old).unwrap();
    refused(
        &mut quick(out, &["--resume"]),
        &["checkpoint-0-of-1.bin", "older version"],
    );
}

#[test]
fn malformed_and_repeated_shards_are_refused_by_merge_with_exit_2() {
    let dir = folder("shards");
    for i in 0..2 {
        let shard = format!("{i}/2");
        let out = quick(&dir.join(format!("s{i}")), &["--shard", &shard])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let shard0 = dir.join("s0/pendulum/shard-0-of-2.json");
    // The same shard twice.
    let twice = dir.join("twice");
    std::fs::create_dir_all(&twice).unwrap();
    std::fs::copy(&shard0, twice.join("shard-0-of-2.json")).unwrap();
    let merge = |dirs: &[&Path]| {
        let mut command = binary();
        command
            .arg("merge")
            .args(dirs)
            .arg("--out")
            .arg(dir.join("m"));
        command
    };
    refused(
        &mut merge(&[&dir.join("s0"), &dir.join("s1"), &twice]),
        &["appears twice"],
    );
    // A record with a track less (the file sealed again, with a checksum that fits): refused,
    // not a panic.
    let good = sdae_cli::shards::read_convergence(&shard0).unwrap();
    let mut short = good.clone();
    short.records[0].tracks.pop();
    sdae_cli::shards::write_convergence(&short, &shard0).unwrap();
    refused(
        &mut merge(&[&dir.join("s0"), &dir.join("s1")]),
        &["shard 0/2", "scheme-level results"],
    );
    // A track with no distances and no failure: refused as a resumed checkpoint would be.
    let mut lost = good.clone();
    lost.records[1].tracks[2].distances = None;
    lost.records[1].tracks[2].failure = None;
    sdae_cli::shards::write_convergence(&lost, &shard0).unwrap();
    refused(
        &mut merge(&[&dir.join("s0"), &dir.join("s1")]),
        &["shard 0/2", "neither distances nor a failure"],
    );
    sdae_cli::shards::write_convergence(&good, &shard0).unwrap();
    // Every sampled bit flipped, in the format line, the records, the checksum line: refused,
    // naming the file and its checksum.
    let bytes = std::fs::read(&shard0).unwrap();
    for bit in sampled_bits(bytes.len()) {
        let mut flipped = bytes.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        std::fs::write(&shard0, &flipped).unwrap();
        refused(
            &mut merge(&[&dir.join("s0"), &dir.join("s1")]),
            &["shard-0-of-2.json", "checksum"],
        );
    }
    // A shard of the format before checksums (bare JSON) is refused by name.
    std::fs::write(&shard0, serde_json::to_string(&good).unwrap()).unwrap();
    refused(
        &mut merge(&[&dir.join("s0"), &dir.join("s1")]),
        &["shard-0-of-2.json", "older version"],
    );
    // Not a shard at all.
    std::fs::write(&shard0, "{").unwrap();
    refused(&mut merge(&[&dir.join("s0")]), &["shard-0-of-2.json"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn two_scenes_of_one_name_are_refused() {
    let dir = folder("names");
    let file = dir.join("pendulum.toml");
    std::fs::write(
        &file,
        include_str!("../../../sdae-study/scenes/pendulum.toml"),
    )
    .unwrap();
    refused(
        quick(&dir, &["--scene", "pendulum", "--scene-file"]).arg(&file),
        &["two scenes are named pendulum"],
    );
    assert!(!dir.join("pendulum").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stability_study_stopped_in_its_second_scene_resumes_to_the_same_report() {
    let dir = folder("stability");
    let study = |out: &Path, extra: &[&str]| {
        let mut command = binary();
        command
            .args(["stability", "--quick", "--paths", "600", "--threads", "1"])
            .args(["--scene", "fast-pendulum,long-pendulum"])
            .args(["--checkpoint-every", "0", "--out"])
            .arg(out)
            .args(extra);
        command
    };
    let whole = study(&dir.join("whole"), &[]).output().unwrap();
    assert!(whole.status.success(), "{}", stderr(&whole));
    let out = dir.join("stopped");
    let second = out.join("stability").join("long-pendulum.checkpoint.bin");
    let mut child = study(&out, &[]).spawn().unwrap();
    wait_for(&second, &mut child);
    signal(&child, "TERM");
    let stopped = child.wait_with_output().unwrap();
    match stopped.status.code() {
        Some(130) => {
            let first = out.join("stability").join("fast-pendulum.checkpoint.bin");
            assert!(first.exists() && second.exists());
            let resumed = study(&out, &["--resume"]).output().unwrap();
            let text = stderr(&resumed);
            assert!(resumed.status.success(), "{text}");
            assert!(
                text.contains("fast-pendulum: resuming from 600 of 600"),
                "{text}"
            );
        }
        code => assert_eq!(code, Some(0), "{}", stderr(&stopped)),
    }
    assert_eq!(
        numbers(&dir.join("whole/stability/report.json")),
        numbers(&out.join("stability/report.json"))
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `settings` on `scene` with a checkpoint at `file` saved after every block, stopped
/// once half the paths finished: the checkpoint holds a header and a segment per block saved.
fn interrupted(file: &Path, scene: &Scene, settings: &ConvergenceSettings) -> Checkpoint {
    let stop = AtomicBool::new(false);
    let half = settings.paths / 2;
    let progress = |done: usize| {
        if done >= half {
            stop.store(true, Ordering::SeqCst);
        }
    };
    let control = Control {
        progress: Some(&progress),
        stop: Some(&stop),
        ..Control::default()
    };
    let checkpoint = Checkpoint::new(file).every(Duration::ZERO);
    let ended = checkpoint.run(scene, settings, (0, 1), None, control);
    assert!(
        matches!(ended, Ok(Resumed::Interrupted { saved, .. }) if saved >= half),
        "{ended:?}"
    );
    checkpoint
}

/// Flips the sampled bits of the checkpoint `file` one at a time; each time `command` must be
/// refused (exit code 2) naming the file and the checksum.
fn every_flip_refused(file: &Path, command: impl Fn() -> Command) {
    let bytes = std::fs::read(file).unwrap();
    let name = file.file_name().unwrap().to_str().unwrap();
    for bit in sampled_bits(bytes.len()) {
        let mut flipped = bytes.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        std::fs::write(file, &flipped).unwrap();
        refused(&mut command(), &[name, "checksum"]);
    }
    std::fs::write(file, &bytes).unwrap();
}

#[test]
fn a_flipped_bit_in_a_convergence_or_weak_checkpoint_is_refused_naming_the_checksum() {
    let dir = folder("flips");
    let out = dir.join("out");
    let scene = Scene::built_in("pendulum").unwrap();
    let (_, mut settings) = common::small(64);
    settings.threads = 1;
    let file = out.join("pendulum").join("checkpoint-0-of-1.bin");
    interrupted(&file, &scene, &settings);
    every_flip_refused(&file, || quick(&out, &["--resume"]));
    let mut weak = sdae_study::weak::weak_settings(&scene, true).unwrap();
    weak.paths = 64;
    weak.threads = 1;
    std::fs::remove_file(&file).unwrap();
    let file = out.join("pendulum").join("weak-checkpoint-0-of-1.bin");
    interrupted(&file, &scene, &weak);
    every_flip_refused(&file, || quick_weak(&out, 8, &["--resume"]));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_save_cut_short_is_dropped_and_the_resumed_run_equals_the_uninterrupted_one() {
    let dir = folder("torn");
    let (scene, mut settings) = common::small(64);
    settings.threads = 1;
    let whole = common::run(&scene, &settings, 0, 1);
    let checkpoint = interrupted(&dir.join("checkpoint.bin"), &scene, &settings);
    let bytes = std::fs::read(checkpoint.path()).unwrap();
    let saved = checkpoint.load(&scene, &settings, (0, 1)).unwrap().unwrap();
    assert_eq!(saved.torn, 0);
    let before = saved.records.len();
    for cut in [1, 5, 300] {
        std::fs::write(checkpoint.path(), &bytes[..bytes.len() - cut]).unwrap();
        let torn = checkpoint.load(&scene, &settings, (0, 1)).unwrap().unwrap();
        assert!(torn.torn > 0 && torn.records.len() < before, "cut {cut}");
        let Ok(Resumed::Finished(resumed)) =
            checkpoint.run(&scene, &settings, (0, 1), Some(torn), Control::default())
        else {
            panic!("a checkpoint cut by {cut} bytes did not resume");
        };
        let report = |r| serde_json::to_string(&sdae_study::convergence::build_report(r)).unwrap();
        let numbers = |json: String| sdae_cli::compare::numbers_of(&json).unwrap();
        assert_eq!(
            numbers(report(*resumed)),
            numbers(report(whole.clone())),
            "cut {cut}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
