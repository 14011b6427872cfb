//! Long runs with the interpreter's lock released: the work runs on a thread of its own while
//! the calling thread waits for its result and, every [`POLL`] until it comes, checks for
//! signals and draws the progress line. On Ctrl-C it raises the stop flag the work watches,
//! waits (the lock still released) for the work to end, within a few hundred steps, and raises
//! `KeyboardInterrupt`. Signals reach Python's main thread only: a run started from another
//! thread runs to its end.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread looks for signals while the work runs.
const POLL: Duration = Duration::from_millis(50);

/// What the work and the waiting thread share: the stop flag and the items done.
#[derive(Default)]
pub struct Run {
    stop: AtomicBool,
    done: AtomicU64,
}

impl Run {
    /// Whether the run was asked to stop.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The stop flag, for the library's run controls.
    pub fn flag(&self) -> &AtomicBool {
        &self.stop
    }

    /// Counts `items` more done.
    pub fn advance(&self, items: u64) {
        self.done.fetch_add(items, Ordering::Relaxed);
    }
}

/// A progress line on `sys.stderr`: "scene pendulum: 120/200 paths, 3.2 s".
pub struct Meter {
    /// What runs.
    pub label: String,
    /// The items to do, if known.
    pub total: Option<u64>,
    /// What an item is ("paths", "samples").
    pub unit: &'static str,
    /// How long the run goes before the line is first drawn (short runs print nothing).
    pub after: Duration,
}

impl Meter {
    /// The line of `total` `unit` of `label`, drawn once the run has gone `after` seconds;
    /// `None` (no line) without `after`.
    pub fn after(
        after: Option<f64>, label: String, total: Option<u64>, unit: &'static str,
    ) -> Option<Meter> {
        after.map(|after| Meter {
            label,
            total,
            unit,
            after: Duration::try_from_secs_f64(after).unwrap_or(Duration::ZERO),
        })
    }

    /// The line for `done` items after `elapsed`.
    fn line(&self, done: u64, elapsed: Duration) -> String {
        let of = self.total.map_or(String::new(), |t| format!("/{t}"));
        format!(
            "{}: {done}{of} {}, {:.1} s",
            self.label,
            self.unit,
            elapsed.as_secs_f64()
        )
    }

    /// Writes `text` over the current line of `sys.stderr` (a failed write is ignored: the
    /// progress line never stops a run).
    fn draw(py: Python<'_>, text: &str) {
        let _ = py
            .import("sys")
            .and_then(|sys| sys.getattr("stderr"))
            .and_then(|err| {
                err.call_method1("write", (text,))?;
                err.call_method0("flush")
            });
    }
}

/// Runs `work` with the interpreter's lock released, handing it the [`Run`] whose stop flag
/// turns true once a signal handler raised (Ctrl-C); the handler's exception is then raised
/// here. With a `meter`, the progress is drawn on `sys.stderr` once the run has gone
/// `meter.after`, and cleared at the end. A panic of the work is a `RuntimeError` with its message.
pub fn run_interruptible<T, W>(py: Python<'_>, meter: Option<Meter>, work: W) -> PyResult<T>
where
    T: Send,
    W: FnOnce(&Run) -> T + Send,
{
    let run = Run::default();
    let started = Instant::now();
    // A line asked for at once is drawn before the first wait, however short the run.
    let mut drawn = match &meter {
        Some(m) if m.after.is_zero() => redraw(py, Some(m), &run, started, 0),
        _ => 0,
    };
    let (done, mut result) = channel();
    let outcome = std::thread::scope(|scope| {
        let shared = &run;
        scope.spawn(move || {
            // The sender goes with the work: the receiver sees the result, or the end.
            let _ = done.send(catch_unwind(AssertUnwindSafe(|| work(shared))));
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
                        run.stop.store(true, Ordering::Relaxed);
                        py.detach(move || {
                            let _ = result.recv();
                        });
                        return Err(signal);
                    }
                    drawn = redraw(py, meter.as_ref(), &run, started, drawn);
                }
            }
        }
    });
    if drawn > 0 {
        Meter::draw(py, &format!("\r{:drawn$}\r", ""));
    }
    outcome
}

/// Draws `meter`'s line over the `drawn` characters of the last one once the run has gone
/// `meter.after`; returns the characters now on the line.
fn redraw(
    py: Python<'_>, meter: Option<&Meter>, run: &Run, started: Instant, drawn: usize,
) -> usize {
    match meter {
        Some(meter) if started.elapsed() >= meter.after => {
            let line = meter.line(run.done.load(Ordering::Relaxed), started.elapsed());
            Meter::draw(py, &format!("\r{line:<drawn$}"));
            line.len()
        }
        _ => drawn,
    }
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
