//! Long runs with the interpreter's lock released: the work runs on a thread of its own while
//! the calling thread waits for its result and, every [`POLL`] until it comes, checks for
//! signals. On Ctrl-C it raises the stop flag the work watches, waits (the lock still
//! released) for the work to end, within a few hundred steps, and raises `KeyboardInterrupt`.
//! Signals reach Python's main thread only: a run started from another thread runs to its end.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread looks for signals while the work runs.
const POLL: Duration = Duration::from_millis(50);

/// Runs `work` with the interpreter's lock released, handing it a stop check that turns true
/// once a signal handler raised (Ctrl-C); the handler's exception is then raised here. A
/// panic of the work is a `RuntimeError` with its message.
pub fn run_interruptible<T, W>(py: Python<'_>, work: W) -> PyResult<T>
where
    T: Send,
    W: FnOnce(&(dyn Fn() -> bool + Sync)) -> T + Send,
{
    let stop = AtomicBool::new(false);
    let stopped = || stop.load(Ordering::Relaxed);
    let (done, mut result) = channel();
    std::thread::scope(|scope| {
        scope.spawn(move || {
            // The sender goes with the work: the receiver sees the result, or the end.
            let _ = done.send(catch_unwind(AssertUnwindSafe(|| work(&stopped))));
        });
        loop {
            // The receiver goes into the released section and back (it is Send, not Sync).
            let (received, back) = py.detach(move || (result.recv_timeout(POLL), result));
            result = back;
            match received {
                Ok(Ok(value)) => return Ok(value),
                Ok(Err(panic)) => return Err(PyRuntimeError::new_err(panic_message(&*panic))),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err("the run ended without a result"));
                }
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(signal) = py.check_signals() {
                        stop.store(true, Ordering::Relaxed);
                        py.detach(move || {
                            let _ = result.recv();
                        });
                        return Err(signal);
                    }
                }
            }
        }
    })
}

/// What a panic said.
fn panic_message(panic: &(dyn Any + Send)) -> String {
    let text = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into());
    format!("the run panicked: {text}")
}
