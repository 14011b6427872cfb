//! A stop signal at a random moment of any phase (paths or blocks running, the report being
//! computed or written), then SIGKILL after a random grace time, as a batch system does at its
//! time limit: within the grace the run saves what it finished and ends (exit code 130, or 0
//! when it was done, 131 when nothing had finished), and the same command with `--resume`
//! ends with exactly the numbers of an uninterrupted run. Runs save after every block
//! (`--checkpoint-every 0`), so a SIGKILL that comes first, even in the middle of a save,
//! loses at most the blocks in progress: what was saved before the signal stays saved.

use crate::process;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

use process::{binary, leftovers, numbers, signal, stderr};
use sdae_cli::checkpoint::Checkpoint;
use sdae_cli::mlmc_checkpoint::MlmcCheckpoint;

/// A study run by the tests: its command line (without `--out`) and its report file.
struct Study {
    name: &'static str,
    args: &'static [&'static str],
    /// The report's path under the output folder.
    report: &'static str,
    /// The checkpoint's path under the output folder.
    checkpoint: &'static str,
}

const CONVERGENCE: Study = Study {
    name: "convergence",
    args: &["--paths", "400", "--levels", "3..6", "--ref-level", "10"],
    report: "pendulum/report.json",
    checkpoint: "pendulum/checkpoint-0-of-1.bin",
};

const WEAK: Study = Study {
    name: "weak",
    args: &["weak", "--quick", "--paths", "600"],
    report: "pendulum/weak.json",
    checkpoint: "pendulum/weak-checkpoint-0-of-1.bin",
};

const MLMC: Study = Study {
    name: "mlmc",
    args: &["mlmc", "--quick"],
    report: "mlmc/pendulum/report.json",
    checkpoint: "mlmc/pendulum/mlmc-checkpoint.bin",
};

impl Study {
    /// The study on one thread, saved after every block, into `out`.
    fn command(&self, out: &Path, extra: &[&str]) -> Command {
        self.saved_every("0", out, extra)
    }

    /// The study on one thread, saved every `seconds`, into `out`.
    fn saved_every(&self, seconds: &str, out: &Path, extra: &[&str]) -> Command {
        let mut command = binary();
        command
            .args(self.args)
            .args(["--threads", "1", "--checkpoint-every", seconds, "--out"])
            .arg(out)
            .args(extra);
        command
    }

    /// The paths (blocks of samples for MLMC) the checkpoint in `out` holds now.
    fn saved(&self, out: &Path) -> usize {
        let file = out.join(self.checkpoint);
        if self.name == "mlmc" {
            MlmcCheckpoint::new(file).holds().unwrap_or(0)
        } else {
            Checkpoint::new(file).holds().map_or(0, |(paths, _)| paths)
        }
    }

    /// The folder of the report (where the checkpoint and lock files are).
    fn folder(&self, out: &Path) -> PathBuf {
        out.join(self.report)
            .parent()
            .expect("a report in a folder")
            .to_path_buf()
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-stop-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A seeded splitmix64 stream of numbers in [0, 1).
struct Uniform(u64);

impl Uniform {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Waits for the child up to `grace`; kills it (SIGKILL) if it is still running then.
/// Returns its output and whether it ended by itself.
fn wait_or_kill(mut child: Child, grace: Duration) -> (Output, bool) {
    let start = Instant::now();
    while start.elapsed() < grace {
        if child.try_wait().unwrap().is_some() {
            return (child.wait_with_output().unwrap(), true);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let ended = child.try_wait().unwrap().is_some();
    if !ended {
        child.kill().unwrap();
    }
    (child.wait_with_output().unwrap(), ended)
}

/// `tries` runs of `study`, each sent SIGTERM at a random moment of an uninterrupted run's
/// time and SIGKILL a random grace time later (from 0 to 1.5 s; every fourth try 5 s, which a
/// run must meet), then resumed: the numbers of the uninterrupted run every time.
fn stopped_anywhere(study: &Study, tries: usize, seed: u64) {
    let dir = scratch(study.name);
    let whole = dir.join("whole");
    let start = Instant::now();
    let uninterrupted = study.command(&whole, &[]).output().unwrap();
    let length = start.elapsed();
    assert!(uninterrupted.status.success(), "{}", stderr(&uninterrupted));
    let expected = numbers(&whole.join(study.report));
    let mut random = Uniform(seed);
    let mut outcomes = std::collections::BTreeMap::new();
    for k in 0..tries {
        let out = dir.join(format!("try-{k}"));
        let child = study.command(&out, &[]).spawn().unwrap();
        // Not before the process could set up its handler (a few milliseconds).
        let moment = length.mul_f64(1.1 * random.next());
        std::thread::sleep(moment.max(Duration::from_millis(100)));
        let before = study.saved(&out);
        signal(&child, "TERM");
        let must_end = k % 4 == 3;
        let grace = if must_end {
            Duration::from_secs(5)
        } else {
            Duration::from_secs_f64(1.5 * random.next())
        };
        let (stopped, ended) = wait_or_kill(child, grace);
        let text = stderr(&stopped);
        let code = stopped.status.code();
        let what = format!(
            "{} try {k}: {code:?} after a grace of {grace:?}\n{text}",
            study.name
        );
        assert!(ended || !must_end, "did not end within the grace: {what}");
        if ended {
            assert!(matches!(code, Some(0 | 130 | 131)), "{what}");
        }
        if code == Some(130) {
            assert!(
                text.contains("saved in") && text.contains("--resume"),
                "{what}"
            );
        }
        // What was saved before the signal is still there, whatever came after it (a SIGKILL
        // in the middle of a save loses at most that save), unless the report is written.
        if !out.join(study.report).exists() {
            let after = study.saved(&out);
            assert!(
                after >= before,
                "{what}\nsaved {before} before, {after} after"
            );
        }
        *outcomes.entry(code).or_insert(0usize) += 1;
        if code != Some(0) {
            let resumed = study.command(&out, &["--resume"]).output().unwrap();
            assert!(
                resumed.status.success(),
                "{what}\nresumed: {}",
                stderr(&resumed)
            );
        }
        assert_eq!(numbers(&out.join(study.report)), expected, "{what}");
        let left = leftovers(&study.folder(&out));
        assert!(left.is_empty(), "{what}\nleft behind: {left:?}");
        let _ = std::fs::remove_dir_all(&out);
    }
    // The moments reach both the runs' middle and their end.
    assert!(
        outcomes.get(&Some(130)).copied().unwrap_or(0) >= 2,
        "{}: {outcomes:?}",
        study.name
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_convergence_study_stopped_anywhere_resumes_to_the_same_numbers() {
    stopped_anywhere(&CONVERGENCE, 8, 44);
}

#[test]
fn a_weak_study_stopped_anywhere_resumes_to_the_same_numbers() {
    stopped_anywhere(&WEAK, 8, 45);
}

#[test]
fn an_mlmc_study_stopped_anywhere_resumes_to_the_same_numbers() {
    stopped_anywhere(&MLMC, 8, 46);
}

/// The thorough variant, with twice the tries and other moments (about a minute):
/// `cargo test -p sdae-cli --test integration -- --ignored`.
#[test]
#[ignore]
fn every_study_stopped_anywhere_resumes_to_the_same_numbers_thoroughly() {
    stopped_anywhere(&CONVERGENCE, 17, 144);
    stopped_anywhere(&WEAK, 17, 145);
    stopped_anywhere(&MLMC, 16, 146);
}

/// A stop signal after the last path finished, while the report is computed: the paths are
/// saved before the report, so the process ends at once (exit code 130) and --resume writes
/// the report without running a path again.
#[test]
fn a_stop_while_the_report_is_computed_ends_at_once_with_everything_saved() {
    let dir = scratch("report-phase");
    let out = dir.join("out");
    let mut child = WEAK.saved_every("1000", &out, &[]).spawn().unwrap();
    // The first checkpoint is the one written when every path has finished.
    let checkpoint = WEAK.folder(&out).join("weak-checkpoint-0-of-1.bin");
    process::wait_for(&checkpoint, &mut child);
    signal(&child, "TERM");
    let (stopped, ended) = wait_or_kill(child, Duration::from_secs(5));
    let text = stderr(&stopped);
    assert!(ended, "{text}");
    match stopped.status.code() {
        // Finished the report before the signal: nothing to check.
        Some(0) => {}
        code => {
            assert_eq!(code, Some(130), "{text}");
            assert!(text.contains("all 600 paths are saved"), "{text}");
            let resumed = WEAK.command(&out, &["--resume"]).output().unwrap();
            let again = stderr(&resumed);
            assert!(resumed.status.success(), "{again}");
            assert!(again.contains("resuming from 600 of 600 paths"), "{again}");
        }
    }
    assert!(out.join(WEAK.report).exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A closed standard output (`| head -1`) ends the printing, not the study: the report is
/// written and the exit code is 0.
#[test]
fn a_closed_standard_output_does_not_stop_the_study() {
    let dir = scratch("closed-stdout");
    for study in [&CONVERGENCE, &WEAK, &MLMC] {
        let out = dir.join(study.name);
        let mut child = study
            .command(&out, &[])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end at once: every line the study prints meets a broken pipe.
        drop(child.stdout.take());
        let done = child.wait_with_output().unwrap();
        assert!(done.status.success(), "{}: {}", study.name, stderr(&done));
        assert!(out.join(study.report).exists(), "{}", study.name);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
