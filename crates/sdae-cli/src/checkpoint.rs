//! Nothing lost on interruption: a run saves the paths it finished to a checkpoint file, every
//! so often while it runs and when it is stopped early (Ctrl-C, or SIGTERM from a batch
//! system at its time limit), and the same study run again with resumption carries on from
//! them. Each path's numbers come from its own stream, so the resumed run ends with exactly the
//! records, and the report, of an uninterrupted one (timings aside).
//!
//! A checkpoint holds what the report reads and nothing more: a line naming the format, then
//! checksummed segments (module `segments`): a JSON header with the scene, the settings and the
//! shard, then batches of records in a compact binary form (f64 as their IEEE bits, so a record
//! reads back bit for bit; counts as LEB128 varints): about 80 bytes per scheme and level of a
//! path, a seventh of the same records in JSON. Each save appends the paths finished since the
//! last one (module `saves`), so saving after every block costs time linear in the run. A changed
//! bit is refused ([`StudyError::Checksum`]); a last segment cut short by a kill during a save
//! is dropped (its paths run again). What is read back is checked as strictly as shards are
//! merged ([`check_records`]).
//!
//! A [`RunLock`] keeps two runs from writing one checkpoint at the same time.

pub(crate) mod changed;
pub(crate) mod saves;
pub(crate) mod segments;

use std::io::Write;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::time::Duration;

use sdae_model::FailureKind;
use serde::{Deserialize, Serialize};

use self::saves::Saves;
use self::segments::{Appender, batches};
use crate::folders::process_alive;
use sdae_study::StudyError;
use sdae_study::convergence::{
    ConvergenceRun, ConvergenceSettings, check_records, run_convergence,
};
use sdae_study::lockstep::{PathRecord, TrackOutcome};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

/// The first line of a checkpoint file: its format and version.
const MAGIC: &[u8] = b"sdae-study checkpoint 3\n";

/// The first lines of the formats before checksums, refused by name.
const OLDER: [&[u8]; 2] = [b"sdae-study checkpoint 2\n", b"sdae-study checkpoint 1\n"];

/// How often a run saves its finished paths unless told otherwise.
pub const DEFAULT_INTERVAL: Duration = Duration::from_secs(60);

/// How a resumable run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Resumed {
    /// Every selected path finished: the whole run (with the saved paths it resumed from),
    /// every path of it in the checkpoint: write the report, then [`Checkpoint::remove`] it.
    Finished(Box<ConvergenceRun>),
    /// The stop flag was raised: `saved` of the shard's `selected` paths are in the checkpoint
    /// (none written when `saved` is 0).
    Interrupted {
        /// Paths saved so far.
        saved: usize,
        /// Paths of the shard.
        selected: usize,
    },
}

/// The paths an interrupted run saved, read back by [`Checkpoint::load`].
#[derive(Debug, Clone, PartialEq)]
pub struct SavedPaths {
    /// One record per finished path (checked: in range, in the shard, each once, each track
    /// with distances or a failure as the settings say).
    pub records: Vec<PathRecord>,
    /// Bytes of a last segment cut short (a process killed while saving), dropped: the paths
    /// it held run again. 0 when the file ends whole.
    pub torn: usize,
}

impl SavedPaths {
    /// A note on a torn last segment, if the file had one (for the resuming message).
    pub fn torn_note(&self) -> Option<String> {
        torn_note(self.torn)
    }
}

/// A note on `torn` bytes of a last segment dropped, if any.
pub(crate) fn torn_note(torn: usize) -> Option<String> {
    (torn > 0).then(|| {
        format!(
            "the last {torn} bytes of the checkpoint are a save cut short (the process was \
             killed while saving): dropped, what they held runs again"
        )
    })
}

/// What a checkpoint says about the run that wrote it.
#[derive(Serialize)]
struct HeaderOut<'a> {
    scene: &'a Scene,
    settings: &'a ConvergenceSettings,
    shard: (usize, usize),
}

/// [`HeaderOut`] read back.
#[derive(Deserialize)]
struct Header {
    scene: Scene,
    settings: ConvergenceSettings,
    shard: (usize, usize),
}

/// A checkpoint file and how often a run saves to it; `R` is the kind of run whose results it
/// holds ([`Checkpoint`], `MlmcCheckpoint`).
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointFile<R> {
    pub(crate) path: PathBuf,
    pub(crate) every: Duration,
    run: PhantomData<R>,
}

/// The checkpoint file of one convergence run (one scene, one shard of one study).
pub type Checkpoint = CheckpointFile<ConvergenceRun>;

impl<R> CheckpointFile<R> {
    /// A checkpoint kept at `path`, saved every [`DEFAULT_INTERVAL`] while a run goes on.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        CheckpointFile {
            path: path.into(),
            every: DEFAULT_INTERVAL,
            run: PhantomData,
        }
    }

    /// The same checkpoint saved every `every` while a run goes on (at the end of the block
    /// that finishes after the interval; `Duration::ZERO`: after every block).
    pub fn every(self, every: Duration) -> Self {
        CheckpointFile { every, ..self }
    }

    /// Where the run's results are kept.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Removes the checkpoint file (once the results it holds are in a report); one that is
    /// not there is no error.
    pub fn remove(&self) -> Result<(), StudyError> {
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(StudyError::write(&self.path, e))
            }
            _ => Ok(()),
        }
    }

    /// Takes the lock of this checkpoint (and so of the run's results): see [`RunLock`].
    pub fn lock(&self) -> Result<RunLock, StudyError> {
        RunLock::beside(&self.path)
    }

    /// The [`StudyError::Resume`] refusing to resume from this checkpoint, saying why.
    pub(crate) fn refuse(&self, reason: String) -> StudyError {
        StudyError::Resume {
            path: self.path.clone(),
            reason,
        }
    }

    /// The refusal of a checkpoint saved by a run with another `what` (scene, shard, ...).
    pub(crate) fn saved_by_another(&self, what: &str) -> StudyError {
        self.refuse(format!("it was saved by a run with another {what}"))
    }
}

/// The paths of shard `shard` = (index, count) of `paths` paths.
fn selected(shard: (usize, usize), paths: usize) -> usize {
    let (index, count) = shard;
    (index..paths).step_by(count.max(1)).count()
}

/// The header, the records (read with `read`, named `what` in messages) and the bytes of a
/// torn last segment of the checkpoint file at `path` holding `bytes`, whose magic line is
/// `magic.0` (or one of the older lines `magic.1`): checksums verified, records read, nothing
/// checked against a run.
pub(crate) fn parse_file<H: serde::de::DeserializeOwned, T>(
    path: &Path, bytes: &[u8], magic: (&[u8], &[&[u8]]), what: &str,
    read: impl FnMut(&mut Reader<'_>) -> Result<T, String>,
) -> Result<(H, Vec<T>, usize), StudyError> {
    let unreadable = |m| not_whole(path, m);
    let segments = segments::read(path, bytes, magic.0, magic.1)?;
    let header: H =
        serde_json::from_slice(segments.header).map_err(|e| unreadable(format!("header: {e}")))?;
    let records = read_payloads(&segments.records, what, read).map_err(unreadable)?;
    Ok((header, records, segments.torn))
}

/// Every record in the segments' `payloads`, read with `read`; a malformed one is named by its
/// segment and place.
fn read_payloads<T>(
    payloads: &[&[u8]], what: &str, mut read: impl FnMut(&mut Reader<'_>) -> Result<T, String>,
) -> Result<Vec<T>, String> {
    let mut records = Vec::new();
    for (k, payload) in payloads.iter().enumerate() {
        let mut reader = Reader::new(payload);
        let mut n = 0;
        while reader.left() > 0 {
            let record =
                read(&mut reader).map_err(|m| format!("segment {}, {what} {n}: {m}", k + 1))?;
            records.push(record);
            n += 1;
        }
    }
    Ok(records)
}

impl Checkpoint {
    /// The header, the records and the bytes of a torn last segment of the checkpoint file
    /// holding `bytes`: checksums verified, records read, nothing checked against a run.
    fn parse(&self, bytes: &[u8]) -> Result<(Header, Vec<PathRecord>, usize), StudyError> {
        parse_file(&self.path, bytes, (MAGIC, &OLDER), "record", |r| r.record())
    }

    /// The number of paths the checkpoint file holds and of the paths of its shard, if it
    /// exists and can be read (for messages; [`Checkpoint::load`] checks it).
    pub fn holds(&self) -> Option<(usize, usize)> {
        let bytes = std::fs::read(&self.path).ok()?;
        let (header, records, _) = self.parse(&bytes).ok()?;
        Some((records.len(), selected(header.shard, header.settings.paths)))
    }

    /// The paths saved by an interrupted run of the same scene, settings (the thread count
    /// aside) and shard; `None` when there is no checkpoint file. A file that fails a checksum
    /// is a [`StudyError::Checksum`]; one that is not a checkpoint a [`StudyError::Read`]; one
    /// of another run, or holding a path twice, out of range, of another shard or otherwise
    /// not a record of the run ([`check_records`]), a [`StudyError::Resume`].
    pub fn load(
        &self, scene: &Scene, settings: &ConvergenceSettings, shard: (usize, usize),
    ) -> Result<Option<SavedPaths>, StudyError> {
        let Some(bytes) = read_bytes(&self.path)? else {
            return Ok(None);
        };
        let (header, records, torn) = self.parse(&bytes)?;
        if header.scene != *scene {
            return Err(self.saved_by_another(&changed::scene_change(&header.scene, scene)));
        }
        if !header.settings.same_numbers(settings) {
            let what = changed::convergence_change(&header.settings, settings)
                .unwrap_or_else(|| "setting (paths, levels, seed, T, p or schemes)".into());
            return Err(self.saved_by_another(&what));
        }
        if header.shard != shard {
            let (a, b) = (header.shard, shard);
            let what = changed::shard_change(
                Some((a.0 as u64, a.1 as u64)),
                Some((b.0 as u64, b.1 as u64)),
            );
            return Err(self.saved_by_another(&what));
        }
        check_records(&records, settings, shard, None).map_err(|reason| self.refuse(reason))?;
        Ok(Some(SavedPaths { records, torn }))
    }

    /// The header segment of a run's checkpoint.
    fn header(
        &self, scene: &Scene, settings: &ConvergenceSettings, shard: (usize, usize),
    ) -> Result<Vec<u8>, StudyError> {
        let header = HeaderOut {
            scene,
            settings,
            shard,
        };
        serde_json::to_vec(&header).map_err(|e| StudyError::write(&self.path, e))
    }

    /// Runs shard `shard` of the study of `scene` with `settings`, steered by `control`, but
    /// the paths in `saved` (from [`Checkpoint::load`]; they replace `control.done`). While it
    /// runs, the paths finished since the last save are appended to the checkpoint each time
    /// the interval has passed (the first save writes the file afresh with the saved paths);
    /// when the run ends they are appended once more: [`Resumed::Interrupted`] when
    /// `control.stop` was raised before every path finished, else [`Resumed::Finished`] with
    /// every path in the checkpoint, which stays until [`Checkpoint::remove`] (after the
    /// report is written).
    pub fn run(
        &self, scene: &Scene, settings: &ConvergenceSettings, shard: (usize, usize),
        saved: Option<SavedPaths>, control: Control<'_>,
    ) -> Result<Resumed, StudyError> {
        let saved = saved.map_or_else(Vec::new, |s| s.records);
        let done: Vec<usize> = saved.iter().map(|r| r.index).collect();
        let header = self
            .header(scene, settings, shard)
            .map_err(|e| e.to_string());
        let saves = Saves::new(
            self.path.clone(),
            MAGIC,
            header,
            write_record::<Vec<u8>>,
            self.every,
            saved.clone(),
        );
        let periodically = |block: &[PathRecord]| saves.finished(block.iter().cloned());
        let control = Control {
            done: &done,
            finished: Some(&periodically),
            ..control
        };
        let mut run = run_convergence(scene, settings, shard, control)?;
        run.records.extend(saved);
        run.records.sort_by_key(|r| r.index);
        run.check_records().map_err(|reason| self.refuse(reason))?;
        // Whole or not, the run's paths are saved: a report that follows may be stopped or
        // fail to be written, and --resume writes it from them without running again.
        if saves.added() == run.records.len() {
            if !run.records.is_empty() {
                saves.save()?;
            }
        } else {
            // Records that did not pass through the periodic saves: write them all.
            self.save(&run)?;
        }
        let selected = selected(shard, settings.paths);
        if run.records.len() < selected {
            return Ok(Resumed::Interrupted {
                saved: run.records.len(),
                selected,
            });
        }
        Ok(Resumed::Finished(Box::new(run)))
    }

    /// Saves the records of `run` in the checkpoint, rewriting it (atomically: the previous
    /// checkpoint or this one, never a torn file).
    pub fn save(&self, run: &ConvergenceRun) -> Result<(), StudyError> {
        let header = self.header(&run.scene, &run.settings, run.shard)?;
        let body = batches(&run.records, write_record::<Vec<u8>>)
            .map_err(|e| StudyError::write(&self.path, e))?;
        Appender::create(&self.path, MAGIC, &header, &body).map(|_| ())
    }
}

/// The bytes of a checkpoint file, `None` when there is none; an unreadable one is a
/// [`StudyError::Read`].
pub(crate) fn read_bytes(path: &Path) -> Result<Option<Vec<u8>>, StudyError> {
    match std::fs::read(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        other => other.map(Some).map_err(|e| not_whole(path, e.to_string())),
    }
}

/// The [`StudyError::Read`] of a checkpoint file that is not whole, saying why.
fn not_whole(path: &Path, message: String) -> StudyError {
    StudyError::Read {
        path: path.to_path_buf(),
        message: format!("not a whole checkpoint: {message}"),
    }
}

/// The code of an optional failure kind: 0 for none, else 1 + its place in
/// [`FailureKind::ALL`].
fn failure_code(kind: Option<FailureKind>) -> u8 {
    kind.and_then(|k| FailureKind::ALL.iter().position(|&a| a == k))
        .map_or(0, |i| i as u8 + 1)
}

/// A count as an LEB128 varint.
pub(crate) fn write_varint(out: &mut impl Write, mut value: u64) -> std::io::Result<()> {
    loop {
        let byte = (value & 0x7f) as u8;
        value >>= 7;
        if value == 0 {
            return out.write_all(&[byte]);
        }
        out.write_all(&[byte | 0x80])?;
    }
}

/// A number bit for bit (its IEEE bits, little-endian).
pub(crate) fn write_f64(out: &mut impl Write, x: f64) -> std::io::Result<()> {
    out.write_all(&x.to_bits().to_le_bytes())
}

/// A count, then that many numbers bit for bit (observed values).
fn write_values(out: &mut impl Write, values: &[f64]) -> std::io::Result<()> {
    write_varint(out, values.len() as u64)?;
    values.iter().try_for_each(|&x| write_f64(out, x))
}

/// One path's record, as [`Reader`] reads it back.
fn write_record<W: Write>(out: &mut W, r: &PathRecord) -> std::io::Result<()> {
    write_varint(out, r.index as u64)?;
    out.write_all(&[failure_code(r.reference_failure)])?;
    write_f64(out, r.reference_seconds)?;
    write_varint(out, r.tracks.len() as u64)?;
    for t in &r.tracks {
        let flags = u8::from(t.distances.is_some())
            | (u8::from(t.kinetic_energy.is_some()) << 1)
            | (u8::from(t.time_average.is_some()) << 2);
        out.write_all(&[flags, failure_code(t.failure)])?;
        for d in t.distances.iter().flatten() {
            write_f64(out, *d)?;
        }
        write_f64(out, t.seconds)?;
        let counts = [
            t.steps,
            t.truncated_steps,
            t.newton_iterations,
            t.homotopy_steps,
            t.rounding_certified_steps,
        ];
        for c in counts {
            write_varint(out, c as u64)?;
        }
        for x in [
            t.clock_lag,
            t.max_position_residual,
            t.max_velocity_residual,
        ] {
            write_f64(out, x)?;
        }
        for x in t.kinetic_energy.iter().chain(&t.time_average) {
            write_f64(out, *x)?;
        }
        write_values(out, &t.observed)?;
    }
    write_values(out, &r.reference_observed)?;
    write_values(out, &r.reference_coarse_observed)
}

/// Reads what [`write_record`] (and the other checkpoints' writers) wrote, failing with a
/// message on a short or malformed input.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// A reader of `bytes` from their start.
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }

    /// Bytes not read yet.
    pub(crate) fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or("the file is cut short")?;
        let taken = &self.bytes[self.at..end];
        self.at = end;
        Ok(taken)
    }

    /// One byte.
    pub(crate) fn byte(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    /// What [`write_f64`] wrote.
    pub(crate) fn f64(&mut self) -> Result<f64, String> {
        let bytes: [u8; 8] = self.take(8)?.try_into().map_err(|_| "short f64")?;
        Ok(f64::from_bits(u64::from_le_bytes(bytes)))
    }

    /// What [`write_varint`] wrote.
    pub(crate) fn count(&mut self) -> Result<usize, String> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let byte = self.byte()?;
            value |= u64::from(byte & 0x7f) << shift;
            if byte & 0x80 == 0 {
                return usize::try_from(value).map_err(|_| "a count beyond usize".into());
            }
        }
        Err("a count of more than 64 bits".into())
    }

    /// What [`write_values`] wrote; a count beyond the rest of the file is refused before
    /// anything is allocated for it.
    fn values(&mut self) -> Result<Vec<f64>, String> {
        let count = self.count()?;
        if count > self.left() / 8 {
            return Err(format!("{count} observed values do not fit in the file"));
        }
        (0..count).map(|_| self.f64()).collect()
    }

    fn failure(&mut self) -> Result<Option<FailureKind>, String> {
        match self.byte()? {
            0 => Ok(None),
            code => FailureKind::ALL
                .get(usize::from(code) - 1)
                .map(|&k| Some(k))
                .ok_or_else(|| format!("failure code {code} is no failure kind")),
        }
    }

    fn record(&mut self) -> Result<PathRecord, String> {
        let index = self.count()?;
        let reference_failure = self.failure()?;
        let reference_seconds = self.f64()?;
        let tracks = self.count()?;
        // Each track takes at least 2 + 8 * 4 + 5 bytes: a count beyond the rest of the file
        // is refused before anything is allocated for it.
        if tracks > self.left() / 39 {
            return Err(format!("{tracks} tracks do not fit in the file"));
        }
        let tracks = (0..tracks)
            .map(|_| self.track())
            .collect::<Result<_, _>>()?;
        Ok(PathRecord {
            index,
            reference_failure,
            reference_seconds,
            tracks,
            reference_observed: self.values()?,
            reference_coarse_observed: self.values()?,
        })
    }

    fn track(&mut self) -> Result<TrackOutcome, String> {
        let flags = self.byte()?;
        if flags > 7 {
            return Err(format!("track flags {flags} are not 0 to 7"));
        }
        let failure = self.failure()?;
        let distances = if flags & 1 == 1 {
            Some([self.f64()?, self.f64()?, self.f64()?])
        } else {
            None
        };
        let seconds = self.f64()?;
        let mut counts = [0usize; 5];
        for c in &mut counts {
            *c = self.count()?;
        }
        let [
            steps,
            truncated_steps,
            newton_iterations,
            homotopy_steps,
            rounding,
        ] = counts;
        let (clock_lag, max_position_residual) = (self.f64()?, self.f64()?);
        let max_velocity_residual = self.f64()?;
        let kinetic_energy = if flags & 2 == 2 {
            Some(self.f64()?)
        } else {
            None
        };
        let time_average = if flags & 4 == 4 {
            Some(self.f64()?)
        } else {
            None
        };
        let observed = self.values()?;
        Ok(TrackOutcome {
            distances,
            failure,
            seconds,
            steps,
            truncated_steps,
            newton_iterations,
            homotopy_steps,
            rounding_certified_steps: rounding,
            clock_lag,
            max_position_residual,
            max_velocity_residual,
            kinetic_energy,
            time_average,
            observed,
        })
    }
}

/// The lock of one run's checkpoint and results: a file created only if it does not exist,
/// holding the process id, the host and the Slurm job (id and restart count, if any) of the
/// run that took it, removed when the lock is dropped. A lock left by a process of this host
/// that is gone (killed), or by an earlier restart of the same Slurm job, is taken over; one
/// held by a live process, or by a process of another host (whose life cannot be checked from
/// here), is a [`StudyError::Locked`].
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    /// The process id of a run that had died holding the lock, if it was taken over.
    pub took_over: Option<u32>,
}

/// The Slurm job this process runs in and how often it was requeued, as written into a lock:
/// a requeued job keeps its id and counts its restarts, so a lock of an earlier restart of the
/// same job, on whatever host, is known to be stale.
fn slurm_job() -> Option<(String, u32)> {
    let id = std::env::var("SLURM_JOB_ID").ok()?;
    let restart = std::env::var("SLURM_RESTART_COUNT")
        .ok()
        .and_then(|r| r.trim().parse().ok())
        .unwrap_or(0);
    Some((id.trim().to_string(), restart))
}

/// This machine's name, as written into a lock.
fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "this-host".into())
}

impl RunLock {
    /// Takes the lock of the checkpoint `checkpoint`: the file `<checkpoint>.lock`.
    pub fn beside(checkpoint: &Path) -> Result<RunLock, StudyError> {
        let mut name = checkpoint.as_os_str().to_owned();
        name.push(".lock");
        RunLock::take(PathBuf::from(name))
    }

    /// Takes the lock file `path`, creating its folder.
    pub fn take(path: PathBuf) -> Result<RunLock, StudyError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| StudyError::write(dir, e))?;
        }
        let job = slurm_job();
        let me = match &job {
            Some((id, restart)) => format!("{} {} {id} {restart}\n", std::process::id(), host()),
            None => format!("{} {}\n", std::process::id(), host()),
        };
        let mut took_over = None;
        loop {
            let created = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path);
            match created {
                Ok(mut file) => {
                    file.write_all(me.as_bytes())
                        .map_err(|e| StudyError::write(&path, e))?;
                    return Ok(RunLock { path, took_over });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(StudyError::write(&path, e)),
            }
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            let mut words = text.split_whitespace();
            let pid = words.next().and_then(|p| p.parse::<u32>().ok());
            let holder = words.next().unwrap_or("").to_string();
            let holder_job = (
                words.next(),
                words.next().and_then(|r| r.parse::<u32>().ok()),
            );
            let requeued = match (&job, holder_job) {
                (Some((id, restart)), (Some(held), Some(held_restart))) => {
                    held == id && held_restart < *restart
                }
                _ => false,
            };
            let locked = |pid: u32| StudyError::Locked {
                path: path.clone(),
                pid,
                host: holder.clone(),
            };
            match pid {
                Some(pid) if took_over.is_none() && requeued => {
                    took_over = Some(pid);
                    let _ = std::fs::remove_file(&path);
                }
                Some(pid) if holder != host() => return Err(locked(pid)),
                Some(pid) if took_over.is_none() && process_alive(pid) == Some(false) => {
                    took_over = Some(pid);
                    let _ = std::fs::remove_file(&path);
                }
                Some(pid) => return Err(locked(pid)),
                // Being written by the run that creates it, or not a lock file at all.
                None => return Err(locked(0)),
            }
        }
    }

    /// Where the lock is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        let mine = std::fs::read_to_string(&self.path)
            .ok()
            .and_then(|t| t.split_whitespace().next()?.parse::<u32>().ok());
        if mine == Some(std::process::id()) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome(k: usize) -> TrackOutcome {
        TrackOutcome {
            distances: k
                .is_multiple_of(2)
                .then_some([0.1 * k as f64, f64::NAN, 1e-300]),
            failure: (k % 3 == 1).then_some(FailureKind::ALL[k % 8]),
            seconds: 1.5e-3 * k as f64,
            steps: 1 << 20,
            truncated_steps: k,
            newton_iterations: usize::MAX >> 3,
            homotopy_steps: 0,
            rounding_certified_steps: 7,
            clock_lag: -0.0,
            max_position_residual: f64::INFINITY,
            max_velocity_residual: 3e-17,
            kinetic_energy: (!k.is_multiple_of(2)).then_some(0.25),
            time_average: k.is_multiple_of(3).then_some(-0.125 * k as f64),
            observed: (0..k).map(|j| 0.5 * j as f64 - 1.0).collect(),
        }
    }

    #[test]
    fn records_read_back_bit_for_bit_and_cut_files_are_refused() {
        let record = PathRecord {
            index: 300,
            reference_failure: Some(FailureKind::BlowUp),
            reference_seconds: 0.5,
            tracks: (0..6).map(outcome).collect(),
            reference_observed: vec![0.25, -0.0, f64::MIN_POSITIVE],
            reference_coarse_observed: vec![0.5, f64::MAX, -3.0],
        };
        let mut bytes = Vec::new();
        write_record(&mut bytes, &record).unwrap();
        let read = Reader::new(&bytes).record().unwrap();
        // NaN != NaN: compare the bits through the debug text.
        assert_eq!(format!("{read:?}"), format!("{record:?}"));
        for cut in [1, 10, bytes.len() / 2, bytes.len() - 1] {
            let short = Reader::new(&bytes[..cut]).record();
            assert!(short.is_err(), "cut at {cut} of {}", bytes.len());
        }
    }
}
