//! Nothing lost when an MLMC run is stopped: stopped by SIGTERM it saves the blocks of samples
//! it finished (exit code 130) and `--resume` ends with exactly the numbers of an uninterrupted
//! run; a checkpoint of another run is refused (exit code 2, naming what differs), and one
//! found without `--resume` is refused unless `--fresh` discards it. A flipped bit in a
//! checkpoint or a shard is refused naming the checksum; a save cut short is dropped and its
//! blocks run again; `mlmc-merge` refuses a block that is not whole, as resuming does.

use crate::bits;
use crate::common::scratch;
use crate::process;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use bits::sampled_bits;
use process::{binary, numbers, quick_weak, same_numbers_nothing_left, signal, stderr, wait_for};

/// A quick MLMC study of the pendulum at `eps` (on one thread unless `extra` says otherwise),
/// writing to `out`.
fn mlmc(out: &Path, eps: &str, extra: &[&str]) -> Command {
    let threads = if extra.contains(&"--threads") {
        &[][..]
    } else {
        &["--threads", "1"][..]
    };
    let mut command = binary();
    command
        .args(["mlmc", "--quick", "--test-samples", "512", "--eps", eps])
        .args(threads)
        .arg("--out")
        .arg(out)
        .args(extra);
    command
}

/// Runs the command and requires exit code 2 with every one of `words` in its message.
fn refused(command: &mut Command, words: &[&str]) {
    let out = command.output().unwrap();
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{text}");
    for word in words {
        assert!(text.contains(word), "'{word}' not in\n{text}");
    }
}

#[test]
fn an_mlmc_study_stopped_by_sigterm_resumes_to_the_numbers_of_an_uninterrupted_run() {
    let dir = scratch("mlmc-resume-study");
    // Long enough (a few seconds) that the signal, sent as soon as the first block is saved,
    // comes while it runs.
    let eps = "4e-3";
    let whole = mlmc(&dir.join("whole"), eps, &[]).output().unwrap();
    assert_eq!(whole.status.code(), Some(0), "{}", stderr(&whole));
    let out = dir.join("stopped");
    let scene = out.join("mlmc/pendulum");
    let checkpoint = scene.join("mlmc-checkpoint.bin");
    let mut child = mlmc(&out, eps, &["--checkpoint-every", "0"])
        .spawn()
        .unwrap();
    wait_for(&checkpoint, &mut child);
    signal(&child, "TERM");
    let stopped = child.wait_with_output().unwrap();
    let text = stderr(&stopped);
    assert_eq!(stopped.status.code(), Some(130), "{text}");
    assert!(text.contains("blocks of samples are saved in"), "{text}");
    assert!(text.contains("--resume"), "{text}");
    assert!(checkpoint.exists() && !scene.join("report.json").exists());
    // Resumed on two threads: the same numbers.
    let resumed = mlmc(&out, eps, &["--resume", "--threads", "2"])
        .output()
        .unwrap();
    let text = stderr(&resumed);
    assert_eq!(resumed.status.code(), Some(0), "{text}");
    assert!(text.contains("resuming from"), "{text}");
    // The report is written, then the checkpoint and its lock are gone.
    same_numbers_nothing_left(
        &dir.join("whole/mlmc/pendulum/report.json"),
        &scene.join("report.json"),
        &scene,
        &dir,
    );
}

#[test]
fn a_plan_shard_stopped_by_sigterm_resumes_to_the_same_shard() {
    let dir = scratch("mlmc-resume-plan");
    let plan = dir.join("plan.json");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        &plan,
        r#"{"eps": 0.004, "samples": [1500000, 150000, 40000, 10000]}"#,
    )
    .unwrap();
    let shard = |out: &Path, extra: &[&str]| {
        let mut command = binary();
        command
            .args(["mlmc", "--plan"])
            .arg(&plan)
            .args(["--shard", "1/2", "--threads", "1", "--out"])
            .arg(out)
            .args(extra);
        command
    };
    let whole = shard(&dir.join("whole"), &[]).output().unwrap();
    assert_eq!(whole.status.code(), Some(0), "{}", stderr(&whole));
    let out = dir.join("stopped");
    let scene = out.join("mlmc/pendulum");
    let checkpoint = scene.join("mlmc-plan-checkpoint-1-of-2.bin");
    let mut child = shard(&out, &["--checkpoint-every", "0"]).spawn().unwrap();
    wait_for(&checkpoint, &mut child);
    signal(&child, "TERM");
    let stopped = child.wait_with_output().unwrap();
    assert_eq!(stopped.status.code(), Some(130), "{}", stderr(&stopped));
    // Another shard's run does not take this checkpoint.
    std::fs::rename(&checkpoint, scene.join("mlmc-plan-checkpoint-0-of-2.bin")).unwrap();
    refused(
        binary()
            .args(["mlmc", "--plan"])
            .arg(&plan)
            .args(["--shard", "0/2", "--resume", "--out"])
            .arg(&out),
        &["cannot resume", "shard"],
    );
    std::fs::rename(scene.join("mlmc-plan-checkpoint-0-of-2.bin"), &checkpoint).unwrap();
    let resumed = shard(&out, &["--resume"]).output().unwrap();
    assert_eq!(resumed.status.code(), Some(0), "{}", stderr(&resumed));
    let file = "mlmc/pendulum/mlmc-shard-1-of-2.json";
    assert_eq!(
        numbers(&dir.join("whole").join(file)),
        numbers(&out.join(file))
    );
    assert!(!checkpoint.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn checkpoints_of_other_runs_and_forgotten_checkpoints_are_refused() {
    let dir = scratch("mlmc-resume-refused");
    let eps = "2e-2";
    let whole = mlmc(&dir.join("whole"), eps, &[]).output().unwrap();
    assert_eq!(whole.status.code(), Some(0), "{}", stderr(&whole));
    // A report that cannot be written (a folder in its place) leaves every block in the
    // checkpoint (exit code 1).
    let out = dir.join("run");
    let scene = out.join("mlmc/pendulum");
    let checkpoint = scene.join("mlmc-checkpoint.bin");
    std::fs::create_dir_all(scene.join("report.json")).unwrap();
    let failed = mlmc(&out, eps, &["--checkpoint-every", "0"])
        .output()
        .unwrap();
    let text = stderr(&failed);
    assert_eq!(failed.status.code(), Some(1), "{text}");
    assert!(text.contains("without running again"), "{text}");
    assert!(checkpoint.exists());
    std::fs::remove_dir(scene.join("report.json")).unwrap();
    other_runs_and_forgotten_checkpoints_are_refused(&out, eps);
    assert!(checkpoint.exists());
    let bytes = std::fs::read(&checkpoint).unwrap();
    flipped_bits_are_refused(&out, eps, &checkpoint, &bytes);
    saved_blocks_resume_to_the_whole_run(&dir, eps, &checkpoint, &bytes);
    // --fresh discards a checkpoint (here of another seed) and runs afresh.
    std::fs::write(&checkpoint, &bytes).unwrap();
    let fresh = mlmc(&out, eps, &["--fresh", "--seed", "7"])
        .output()
        .unwrap();
    let text = stderr(&fresh);
    assert_eq!(fresh.status.code(), Some(0), "{text}");
    assert!(text.contains("discarding"), "{text}");
    assert!(!checkpoint.exists());
    // --resume with nothing to resume says so.
    let nothing = mlmc(&out, eps, &["--resume"]).output().unwrap();
    assert_eq!(nothing.status.code(), Some(0), "{}", stderr(&nothing));
    assert!(stderr(&nothing).contains("nothing to resume"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// With the checkpoint of a run at `eps` in `out`: a run of another seed or observable is
/// refused naming what differs, and one without `--resume` saying what the checkpoint holds.
fn other_runs_and_forgotten_checkpoints_are_refused(out: &Path, eps: &str) {
    // Another seed or observable: refused, naming what differs.
    refused(
        &mut mlmc(out, eps, &["--resume", "--seed", "7"]),
        &[
            "cannot resume",
            "mlmc-checkpoint.bin",
            "another --seed (saved 2026, asked 7)",
        ],
    );
    refused(
        &mut mlmc(out, eps, &["--resume", "--observable", "energy"]),
        &[
            "cannot resume",
            "another --observable (saved cos_angle, asked energy)",
        ],
    );
    // Without --resume: refused, saying what the checkpoint holds.
    refused(
        &mut mlmc(out, eps, &[]),
        &[
            "mlmc-checkpoint.bin",
            "blocks of samples",
            "--resume",
            "--fresh",
        ],
    );
}

/// The checkpoint `bytes` with a flipped bit anywhere (its format line, header, segments,
/// checksums) are refused on resuming, naming the checksum.
fn flipped_bits_are_refused(out: &Path, eps: &str, checkpoint: &Path, bytes: &[u8]) {
    for bit in sampled_bits(bytes.len()) {
        let mut flipped = bytes.to_vec();
        flipped[bit / 8] ^= 1 << (bit % 8);
        std::fs::write(checkpoint, &flipped).unwrap();
        refused(
            &mut mlmc(out, eps, &["--resume"]),
            &["mlmc-checkpoint.bin", "checksum"],
        );
    }
}

/// The numbers of the MLMC report of the pendulum under `out`.
fn report_numbers(out: &Path) -> serde_json::Value {
    numbers(&out.join("mlmc/pendulum/report.json"))
}

/// Resuming from the checkpoint `bytes` of the run in `dir`/run, cut short in its last save
/// or whole, writes the numbers of the uninterrupted run in `dir`/whole.
fn saved_blocks_resume_to_the_whole_run(dir: &Path, eps: &str, checkpoint: &Path, bytes: &[u8]) {
    let out = dir.join("run");
    // A save cut short (a kill while appending): dropped, its blocks run again, and the report
    // is the uninterrupted run's.
    std::fs::write(checkpoint, &bytes[..bytes.len() - 5]).unwrap();
    let resumed = mlmc(&out, eps, &["--resume"]).output().unwrap();
    let text = stderr(&resumed);
    assert_eq!(resumed.status.code(), Some(0), "{text}");
    assert!(text.contains("dropped"), "{text}");
    assert_eq!(report_numbers(&dir.join("whole")), report_numbers(&out));
    std::fs::remove_file(out.join("mlmc/pendulum/report.json")).unwrap();
    std::fs::write(checkpoint, bytes).unwrap();
    // --resume writes the report from the saved blocks: the uninterrupted run's numbers.
    let resumed = mlmc(&out, eps, &["--resume"]).output().unwrap();
    let text = stderr(&resumed);
    assert_eq!(resumed.status.code(), Some(0), "{text}");
    assert!(text.contains("resuming from"), "{text}");
    assert_eq!(report_numbers(&dir.join("whole")), report_numbers(&out));
    assert!(!checkpoint.exists());
}

#[test]
fn mlmc_shards_with_a_flipped_bit_or_a_block_not_whole_are_refused_by_merge() {
    let dir = scratch("mlmc-shard-faults");
    std::fs::create_dir_all(&dir).unwrap();
    let plan = dir.join("plan.json");
    std::fs::write(&plan, r#"{"eps": 0.02, "samples": [256, 64, 64]}"#).unwrap();
    let shards = dir.join("shards");
    for shard in ["0/2", "1/2"] {
        let ran = binary()
            .args(["mlmc", "--plan"])
            .arg(&plan)
            .args(["--shard", shard, "--threads", "1", "--out"])
            .arg(&shards)
            .output()
            .unwrap();
        assert_eq!(ran.status.code(), Some(0), "{}", stderr(&ran));
    }
    let merge = || {
        let mut command = binary();
        command
            .arg("mlmc-merge")
            .arg(shards.join("mlmc/pendulum"))
            .arg("--out")
            .arg(dir.join("merged"));
        command
    };
    let merged = merge().output().unwrap();
    assert_eq!(merged.status.code(), Some(0), "{}", stderr(&merged));
    let file = shards.join("mlmc/pendulum/mlmc-shard-0-of-2.json");
    let bytes = std::fs::read(&file).unwrap();
    for bit in sampled_bits(bytes.len()) {
        let mut flipped = bytes.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        std::fs::write(&file, &flipped).unwrap();
        refused(&mut merge(), &["mlmc-shard-0-of-2.json", "checksum"]);
    }
    // A block of 31 samples, sealed again with a checksum that fits: refused as a checkpoint's
    // would be.
    std::fs::write(&file, &bytes).unwrap();
    let mut short = sdae_cli::shards::read_mlmc(&file).unwrap();
    short.levels[1][0].sums.samples -= 1;
    sdae_cli::shards::write_mlmc(&short, &file).unwrap();
    refused(&mut merge(), &["level 1", "not a block of 32"]);
    // A shard of the format before checksums (bare JSON) is refused by name.
    std::fs::write(&file, serde_json::to_string(&short).unwrap()).unwrap();
    refused(&mut merge(), &["mlmc-shard-0-of-2.json", "older version"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Saving after every block of samples (`--checkpoint-every 0`) changes no number and costs
/// at most about twice the default interval's run: a save synced to disk after each of the
/// thousands of blocks made the run 25 times as long.
#[test]
fn saving_after_every_block_changes_no_number_and_costs_little() {
    let dir = scratch("mlmc-save-often");
    let timed = |name: &str, extra: &[&str]| {
        let start = Instant::now();
        let ran = binary()
            .args([
                "mlmc",
                "--threads",
                "1",
                "--eps",
                "1e-2,2e-3",
                "--no-standard",
            ])
            .args(["--test-samples", "1024", "--out"])
            .arg(dir.join(name))
            .args(extra)
            .output()
            .unwrap();
        assert_eq!(ran.status.code(), Some(0), "{}", stderr(&ran));
        start.elapsed()
    };
    let default = timed("default", &[]);
    let often = timed("often", &["--checkpoint-every", "0"]);
    assert_eq!(
        report_numbers(&dir.join("default")),
        report_numbers(&dir.join("often"))
    );
    assert!(
        often <= 2 * default + Duration::from_secs(2),
        "--checkpoint-every 0 took {often:?}, the default {default:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A resume with another --qmc setting or another R is refused naming the flag with the saved
/// and the asked value, for MLMC and for the weak study.
#[test]
fn a_resume_with_other_qmc_settings_names_them() {
    let dir = scratch("mlmc-resume-qmc");
    let eps = "2e-2";
    // A run whose report cannot be written (a folder in its place) keeps its checkpoint.
    let out = dir.join("run");
    let scene = out.join("mlmc/pendulum");
    std::fs::create_dir_all(scene.join("report.json")).unwrap();
    let qmc = ["--qmc", "--randomizations", "4"];
    let failed = mlmc(&out, eps, &qmc).output().unwrap();
    assert_eq!(failed.status.code(), Some(1), "{}", stderr(&failed));
    assert!(scene.join("mlmc-checkpoint.bin").exists());
    refused(
        &mut mlmc(&out, eps, &["--resume", "--qmc", "--randomizations", "8"]),
        &[
            "cannot resume",
            "another --randomizations (saved 4, asked 8)",
        ],
    );
    refused(
        &mut mlmc(&out, eps, &["--resume"]),
        &["another --qmc (saved with --qmc, asked without --qmc)"],
    );
    refused(
        &mut mlmc(
            &out,
            eps,
            &[
                "--resume",
                "--qmc",
                "--randomizations",
                "4",
                "--initial-points",
                "64",
            ],
        ),
        &["another --initial-points (saved 32, asked 64)"],
    );
    // The weak study's randomized QMC paths.
    let weak = |extra: &[&str]| quick_weak(&out, 64, extra);
    std::fs::create_dir_all(out.join("pendulum/weak.json")).unwrap();
    let failed = weak(&["--qmc", "--randomizations", "4"]).output().unwrap();
    assert_eq!(failed.status.code(), Some(1), "{}", stderr(&failed));
    refused(
        &mut weak(&["--resume", "--qmc", "--randomizations", "8"]),
        &[
            "cannot resume",
            "another --randomizations (saved 4, asked 8)",
        ],
    );
    refused(
        &mut weak(&["--resume"]),
        &["another --qmc (saved with --qmc, asked without --qmc)"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}
