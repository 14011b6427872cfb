//! The saving side of a checkpoint while a run goes on: the records finished since the last
//! save wait in memory, and each save appends them as segments (see [`super::segments`]). The
//! first save of a process writes the whole file afresh (the header, the records it resumed
//! from and the new ones), which also drops a torn tail an earlier, killed process left; every
//! later save appends. So saving after every block costs time linear in the run.
//!
//! A save is synced to disk, which takes milliseconds on many disks, and a block of paths or
//! samples can take microseconds: saving after each of them would spend most of the run
//! waiting for the disk. So a save is due once the interval has passed *and* at least
//! [`PATIENCE`] times as long as the last save took: saving never takes more than about a tenth
//! of a run, whatever the interval asked for (0 included) and however slow the disk.

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use super::segments::{Appender, batches};
use sdae_study::StudyError;

/// A save waits, after the last one, at least this many times as long as that save took (and
/// at least the interval asked for): the saves take at most 1 / (1 + PATIENCE) of the run.
pub(crate) const PATIENCE: u32 = 9;

/// How a record is put into a segment's payload.
pub(crate) type WriteRecord<R> = fn(&mut Vec<u8>, &R) -> std::io::Result<()>;

/// The records of a run on their way into its checkpoint file.
pub(crate) struct Saves<R> {
    path: PathBuf,
    magic: &'static [u8],
    /// The header segment's payload (or why it could not be made: every save fails).
    header: Result<Vec<u8>, String>,
    write: WriteRecord<R>,
    every: Duration,
    state: Mutex<State<R>>,
}

struct State<R> {
    /// The file as this process wrote it; `None` before its first save.
    file: Option<Appender>,
    /// Records not in `file` yet (before the first save: all of them).
    pending: Vec<R>,
    /// Records handed over, the resumed ones included.
    added: usize,
    /// Bytes written so far.
    written: u64,
    /// When the last save was.
    last: Instant,
    /// How long the last save took.
    cost: Duration,
}

impl<R> Saves<R> {
    /// The saves of the checkpoint `path` (first line `magic`, header segment `header`) of a run
    /// resuming from `resumed`, saved when a record is handed over `every` after the last save.
    pub(crate) fn new(
        path: PathBuf, magic: &'static [u8], header: Result<Vec<u8>, String>,
        write: WriteRecord<R>, every: Duration, resumed: Vec<R>,
    ) -> Self {
        let state = State {
            file: None,
            added: resumed.len(),
            pending: resumed,
            written: 0,
            last: Instant::now(),
            cost: Duration::ZERO,
        };
        Saves {
            path,
            magic,
            header,
            write,
            every,
            state: Mutex::new(state),
        }
    }

    fn lock(&self) -> MutexGuard<'_, State<R>> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Hands over finished records; saves them (and those waiting) if a save is due: the
    /// interval has passed, and [`PATIENCE`] times the last save's duration. A failed periodic
    /// save is not fatal: the records wait for the next save, and the final save says whether
    /// they could be written.
    pub(crate) fn finished(&self, records: impl IntoIterator<Item = R>) {
        let mut state = self.lock();
        let before = state.pending.len();
        state.pending.extend(records);
        state.added += state.pending.len() - before;
        let wait = self.every.max(state.cost.saturating_mul(PATIENCE));
        if state.last.elapsed() >= wait {
            let _ = self.flush(&mut state);
        }
    }

    /// Saves the records waiting now; returns the bytes written.
    pub(crate) fn save(&self) -> Result<u64, StudyError> {
        let mut state = self.lock();
        self.flush(&mut state)
    }

    /// Records handed over so far, the resumed ones included.
    pub(crate) fn added(&self) -> usize {
        self.lock().added
    }

    /// Forgets how long the last save took, so that the next record handed over is saved at
    /// once (at interval 0).
    #[cfg(test)]
    pub(crate) fn forget_cost(&self) {
        self.lock().cost = Duration::ZERO;
    }

    /// Bytes written to the file so far.
    #[cfg(test)]
    pub(crate) fn written(&self) -> u64 {
        self.lock().written
    }

    /// Saves the records waiting, and when and how long it took.
    fn flush(&self, state: &mut State<R>) -> Result<u64, StudyError> {
        let start = Instant::now();
        let saved = self.append(state);
        state.last = Instant::now();
        state.cost = state.last - start;
        saved
    }

    /// Appends the records waiting to the file (writing it afresh at the first save).
    fn append(&self, state: &mut State<R>) -> Result<u64, StudyError> {
        let body =
            batches(&state.pending, self.write).map_err(|e| StudyError::write(&self.path, e))?;
        let bytes = match &mut state.file {
            Some(file) => file.append(&body)?,
            None => {
                let header = self
                    .header
                    .as_ref()
                    .map_err(|e| StudyError::write(&self.path, e))?;
                let (file, bytes) = Appender::create(&self.path, self.magic, header, &body)?;
                state.file = Some(file);
                bytes
            }
        };
        state.pending.clear();
        state.written += bytes;
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::super::segments::{FRAME, read};
    use super::*;

    fn write(out: &mut Vec<u8>, r: &[u8; 40]) -> std::io::Result<()> {
        out.extend_from_slice(r);
        Ok(())
    }

    /// Saves of 40-byte records into the file c.bin in the fresh folder named `name`, every
    /// record at once (interval 0), after the `resumed` records; the folder and the file.
    fn saves(name: &str, resumed: Vec<[u8; 40]>) -> (PathBuf, PathBuf, Saves<[u8; 40]>) {
        let dir = std::env::temp_dir().join(format!("sdae-{name}-{}", std::process::id()));
        let path = dir.join("c.bin");
        let saves = Saves::new(
            path.clone(),
            b"m\n",
            Ok(b"{}".to_vec()),
            write,
            Duration::ZERO,
            resumed,
        );
        (dir, path, saves)
    }

    #[test]
    fn saving_after_every_record_writes_each_record_once() {
        let (dir, path, saves) = saves("saves", vec![[1u8; 40]; 10]);
        saves.finished([[2u8; 40]]);
        // The first save: the magic line, the header and the 11 records.
        let first = 2 + (FRAME + 2) as u64 + (FRAME + 11 * 40) as u64;
        assert_eq!(saves.written(), first);
        // Every later save writes its new records and nothing else: linear in the run (the
        // saves' measured duration forgotten, so that each record is saved at once).
        for k in 1..=1000u64 {
            saves.forget_cost();
            saves.finished([[3u8; 40]]);
            assert_eq!(saves.written(), first + k * (FRAME as u64 + 40));
        }
        assert_eq!(saves.save().unwrap(), 0);
        assert_eq!(saves.added(), 1011);
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len() as u64, saves.written());
        let segments = read(&path, &bytes, b"m\n", &[]).unwrap();
        assert_eq!(segments.records.len(), 1001);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_slow_save_holds_the_next_ones_back() {
        let (dir, path, saves) = saves("saves-slow", Vec::new());
        saves.finished([[1u8; 40]]);
        let first = saves.written();
        assert!(first > 0);
        // A save that took an hour: the next is due nine hours later, even at interval 0.
        saves.lock().cost = Duration::from_secs(3600);
        for _ in 0..100 {
            saves.finished([[2u8; 40]]);
        }
        assert_eq!(saves.written(), first);
        // The final save writes them all, in one segment.
        assert_eq!(saves.save().unwrap(), (FRAME + 100 * 40) as u64);
        let bytes = std::fs::read(&path).unwrap();
        let segments = read(&path, &bytes, b"m\n", &[]).unwrap();
        assert_eq!(segments.records.len(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
