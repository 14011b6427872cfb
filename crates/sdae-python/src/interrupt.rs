//! Long runs with the interpreter's lock released: the work runs on a thread of its own while
//! the calling thread waits for its result and, every [`POLL`] until it comes, checks for
//! signals; on Ctrl-C it raises the stop flag the work watches, waits for the work to end (it
//! ends within a few hundred steps) and raises `KeyboardInterrupt`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread looks for signals while the work runs.
const POLL: Duration = Duration::from_millis(50);

/// Runs `work` with the interpreter's lock released, handing it a stop check that turns true
/// once a signal handler raised (Ctrl-C); the handler's exception is then raised here.
pub fn run_interruptible<T, W>(py: Python<'_>, work: W) -> PyResult<T>
where
    T: Send,
    W: FnOnce(&(dyn Fn() -> bool + Sync)) -> T + Send,
{
    let stop = AtomicBool::new(false);
    let stopped = || stop.load(Ordering::Relaxed);
    let (done, mut result) = channel();
    std::thread::scope(|scope| {
        scope.spawn(|| {
            // The receiver is gone only once the caller stopped waiting (a signal).
            let _ = done.send(work(&stopped));
        });
        loop {
            // The receiver goes into the released section and back (it is Send, not Sync).
            let (received, back) = py.detach(move || (result.recv_timeout(POLL), result));
            result = back;
            match received {
                Ok(value) => return Ok(value),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err("the run ended without a result"));
                }
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(signal) = py.check_signals() {
                        stop.store(true, Ordering::Relaxed);
                        return Err(signal);
                    }
                }
            }
        }
    })
}
