//! Stop signals (Ctrl-C, SIGTERM, SIGHUP) in every phase of a run.
//!
//! - While paths (or blocks of samples) run, the first signal raises [`STOP`]: no new path
//!   starts, the paths in progress are dropped, and the finished ones are saved by the run.
//! - Once everything a run finished is saved (its checkpoint holds every path, or every block,
//!   and the report is being computed and written: [`all_saved`]), a signal ends the process
//!   at once with exit code 130, saying where the results are: nothing is left to save, and a
//!   batch system's SIGKILL after its grace time can no longer lose anything.
//!
//! Later signals change nothing: the finished work the first one promised is saved whatever
//! comes after it (but SIGKILL, which loses what finished since the last periodic save).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Raised by the first stop signal.
pub static STOP: AtomicBool = AtomicBool::new(false);

/// The stop signals received so far.
static SIGNALS: AtomicUsize = AtomicUsize::new(0);

/// What a stop signal does now.
struct Phase {
    /// `Some(message)` while everything finished is saved: a signal prints the message and
    /// ends the process (exit code 130).
    saved: Option<String>,
    /// The lock files this process holds, removed when a signal ends it.
    locks: Vec<PathBuf>,
}

static PHASE: Mutex<Phase> = Mutex::new(Phase {
    saved: None,
    locks: Vec::new(),
});

fn phase() -> std::sync::MutexGuard<'static, Phase> {
    PHASE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Installs the handler of Ctrl-C, SIGTERM and SIGHUP.
pub fn catch_signals() {
    let installed = ctrlc::set_handler(|| {
        STOP.store(true, Ordering::SeqCst);
        let first = SIGNALS.fetch_add(1, Ordering::SeqCst) == 0;
        let phase = phase();
        if let Some(message) = &phase.saved {
            leave(&phase.locks, message);
        }
        if first {
            note!(
                "\nstopping: the paths in progress are dropped, the finished ones are being saved"
            );
        } else {
            note!("\nalready stopping: the finished paths are being saved");
        }
    });
    if let Err(e) = installed {
        note!(
            "sdae-study: warning: cannot catch Ctrl-C and SIGTERM ({e}); an interrupted run saves \
             only its periodic checkpoints"
        );
    }
}

/// Notes a lock file this process took, to be removed if a signal ends the process.
pub fn hold(lock: PathBuf) {
    phase().locks.push(lock);
}

/// From now on everything the run finished is saved, as `message` says (where, and how
/// --resume writes the results): a stop signal ends the process at once with it (exit code
/// 130). A signal that came before this call ends the process now.
pub fn all_saved(message: String) {
    let mut phase = phase();
    if STOP.load(Ordering::SeqCst) {
        leave(&phase.locks, &message);
    }
    phase.saved = Some(message);
}

/// The results are written (or a new run begins): a stop signal is a save point again.
pub fn running() {
    phase().saved = None;
}

/// Ends the process after a stop signal when nothing is left to save: removes this process's
/// locks, prints `message`, exit code 130.
fn leave(locks: &[PathBuf], message: &str) -> ! {
    let me = std::process::id();
    for lock in locks {
        let holder = std::fs::read_to_string(lock)
            .ok()
            .and_then(|t| t.split_whitespace().next()?.parse::<u32>().ok());
        if holder == Some(me) {
            let _ = std::fs::remove_file(lock);
        }
    }
    note!("\n{message}");
    std::process::exit(130)
}
