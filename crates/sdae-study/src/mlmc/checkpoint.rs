//! Nothing lost on interruption, for MLMC runs: a run saves the sums of the blocks of samples
//! it finished to a checkpoint file, every so often while it runs and when it is stopped, and
//! the same run started again with resumption replays its algorithm, taking the saved sums of
//! a block instead of running it.
//!
//! This gives exactly the numbers of an uninterrupted run (timings aside): the adaptive
//! algorithm is deterministic (its cost model counts steps), the sums of block b of level l
//! depend only on the samples b BLOCK .. (b + 1) BLOCK, each drawn from its own stream
//! (seed, l, i), and the blocks are folded in block order whatever the thread count. So a
//! block is keyed by its level, its index and whether it holds pairs or single fine paths
//! ([`BlockKey`]); the convergence test, the adaptive run of each eps, the direct standard
//! Monte Carlo run and a plan's run all take their blocks from the same saved set.
//!
//! The file has the layout of the convergence study's checkpoints
//! ([`crate::checkpoint`]): a line naming the format, a JSON line with the scene, the settings,
//! the plan and shard (for a `--plan` run) and the number of blocks, then one record per block
//! (level, index and counts as LEB128 varints, a byte for pairs or single paths, the sums as
//! IEEE bits): about 70 bytes a block of 32 samples. What is read back is checked strictly.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::algorithm::Plan;
use super::sampler::{BLOCK, BlockKey, BlockStore};
use super::study::MlmcSettings;
use super::sums::LevelSums;
use crate::checkpoint::{
    DEFAULT_INTERVAL, Reader, RunLock, not_whole, parse_header, read_bytes, remove_checkpoint,
    write_checkpoint, write_f64, write_varint,
};
use crate::error::StudyError;
use crate::scene::Scene;

/// The first line of an MLMC checkpoint file: its format and version.
const MAGIC: &[u8] = b"sdae-study mlmc checkpoint 1\n";

/// Bytes of a block's record at the least: level, index and four counts of one byte each, the
/// pairs byte and seven numbers.
const MIN_RECORD: usize = 7 + 7 * 8;

/// Which MLMC run a checkpoint belongs to: the study of a scene with its settings, or a run of
/// a plan (all of it, or one shard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlmcRun {
    /// The scene.
    pub scene: Scene,
    /// The settings (the thread count does not matter).
    pub settings: MlmcSettings,
    /// The plan of a `--plan` run; `None` for the study.
    pub plan: Option<Plan>,
    /// Shard (i, n) of a sharded plan run.
    pub shard: Option<(u64, u64)>,
}

/// What an MLMC checkpoint says about the run that wrote it.
#[derive(Serialize, Deserialize)]
struct Header {
    run: MlmcRun,
    blocks: usize,
}

/// The blocks an interrupted run saved, read back by [`MlmcCheckpoint::load`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SavedBlocks {
    /// The sums of each block (checked: each once, within the run's levels and blocks, of
    /// [`BLOCK`] samples).
    pub blocks: BTreeMap<BlockKey, LevelSums>,
}

/// The checkpoint file of one MLMC run.
#[derive(Debug, Clone, PartialEq)]
pub struct MlmcCheckpoint {
    path: PathBuf,
    every: Duration,
}

impl MlmcCheckpoint {
    /// A checkpoint kept at `path`, saved every [`DEFAULT_INTERVAL`] while a run goes on.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        MlmcCheckpoint {
            path: path.into(),
            every: DEFAULT_INTERVAL,
        }
    }

    /// The same checkpoint saved every `every` while a run goes on (when the first block that
    /// finishes after the interval finishes; `Duration::ZERO`: after every block).
    pub fn every(self, every: Duration) -> Self {
        MlmcCheckpoint { every, ..self }
    }

    /// Where the blocks are kept.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The number of blocks the checkpoint file holds, if it exists and its header can be read
    /// (for messages; [`MlmcCheckpoint::load`] checks it).
    pub fn holds(&self) -> Option<usize> {
        let bytes = std::fs::read(&self.path).ok()?;
        let (header, _): (Header, _) = parse_header(&bytes, MAGIC).ok()?;
        Some(header.blocks)
    }

    /// The blocks saved by an interrupted run of `run` (the thread count aside); `None` when
    /// there is no checkpoint file. A file that is not an MLMC checkpoint or is cut short is a
    /// [`StudyError::Read`]; one of another run (scene, seed, observable, scheme, ... or plan),
    /// or holding a block twice or out of the run's range, a [`StudyError::Resume`] naming
    /// what differs.
    pub fn load(&self, run: &MlmcRun) -> Result<Option<SavedBlocks>, StudyError> {
        let Some(bytes) = read_bytes(&self.path)? else {
            return Ok(None);
        };
        let unreadable = |m| not_whole(&self.path, m);
        let (header, body): (Header, _) = parse_header(&bytes, MAGIC).map_err(unreadable)?;
        if header.blocks > body.len() / MIN_RECORD {
            return Err(unreadable(format!(
                "{} blocks do not fit in the file",
                header.blocks
            )));
        }
        let mut reader = Reader::new(body);
        let records = (0..header.blocks)
            .map(|k| {
                read_block(&mut reader)
                    .map_err(|m| unreadable(format!("block {k} of {}: {m}", header.blocks)))
            })
            .collect::<Result<Vec<_>, _>>()?;
        reader.end().map_err(unreadable)?;
        let refuse = |reason: String| StudyError::Resume {
            path: self.path.clone(),
            reason,
        };
        if let Some(what) = difference(&header.run, run) {
            return Err(refuse(format!("it was saved by a run with another {what}")));
        }
        let mut blocks = BTreeMap::new();
        for (key, sums) in records {
            if let Some(reason) = out_of_range(run, key, &sums) {
                return Err(refuse(reason));
            }
            if blocks.insert(key, sums).is_some() {
                return Err(refuse(format!(
                    "block {} of level {} appears twice",
                    key.block, key.level
                )));
            }
        }
        Ok(Some(SavedBlocks { blocks }))
    }

    /// The store of a run of `run` resuming from `saved` (from [`MlmcCheckpoint::load`]): set
    /// it as the run's [`RunControl::store`](super::RunControl).
    pub fn journal<'a>(&'a self, run: &'a MlmcRun, saved: Option<SavedBlocks>) -> Journal<'a> {
        let saved = saved.unwrap_or_default().blocks;
        Journal {
            checkpoint: self,
            run,
            state: Mutex::new(State {
                blocks: saved.clone(),
                last: Instant::now(),
            }),
            saved,
        }
    }

    fn write(
        &self, run: &MlmcRun, blocks: &BTreeMap<BlockKey, LevelSums>,
    ) -> Result<(), StudyError> {
        let header = Header {
            run: run.clone(),
            blocks: blocks.len(),
        };
        write_checkpoint(&self.path, MAGIC, &header, |out| {
            blocks
                .iter()
                .try_for_each(|(key, sums)| write_block(out, *key, sums))
        })
    }

    /// Removes the checkpoint file (once the results it holds are in a report).
    pub fn remove(&self) -> Result<(), StudyError> {
        remove_checkpoint(&self.path)
    }

    /// Takes the lock of this checkpoint (and so of the run's results): see [`RunLock`].
    pub fn lock(&self) -> Result<RunLock, StudyError> {
        RunLock::beside(&self.path)
    }
}

/// What of `saved` differs from `run` (the thread count aside), named for a message.
fn difference(saved: &MlmcRun, run: &MlmcRun) -> Option<&'static str> {
    let (a, b) = (&saved.settings, &run.settings);
    let checks = [
        (saved.scene == run.scene, "scene"),
        (a.seed == b.seed, "seed"),
        (a.spec.observable == b.spec.observable, "observable"),
        (a.spec.scheme == b.spec.scheme, "scheme"),
        (a.spec.antithetic == b.spec.antithetic, "antithetic setting"),
        (
            a.t_end.to_bits() == b.t_end.to_bits() && a.spec.coarsest == b.spec.coarsest,
            "time grid (T or the coarsest level)",
        ),
        (
            MlmcSettings {
                threads: b.threads,
                ..a.clone()
            } == *b,
            "setting (eps, levels, samples or the standard run)",
        ),
        (saved.plan == run.plan, "plan"),
        (saved.shard == run.shard, "shard"),
    ];
    checks
        .into_iter()
        .find(|(same, _)| !same)
        .map(|(_, what)| what)
}

/// Why block `key` with `sums` cannot belong to `run`, if it cannot.
fn out_of_range(run: &MlmcRun, key: BlockKey, sums: &LevelSums) -> Option<String> {
    let BlockKey { level, block, .. } = key;
    let name = format!("block {block} of level {level}");
    if sums.attempted() != BLOCK
        || sums.failed_fine > sums.failed
        || sums.failed_coarse > sums.failed
    {
        return Some(format!(
            "{name} counts {} samples with a value and {} failed ({} fine, {} coarse), not a \
             block of {BLOCK}",
            sums.samples, sums.failed, sums.failed_fine, sums.failed_coarse
        ));
    }
    match &run.plan {
        None if level > run.settings.spec.max_level => Some(format!(
            "{name} is above L_max = {}",
            run.settings.spec.max_level
        )),
        None => None,
        Some(plan) => {
            let blocks = plan.samples.get(level as usize).map(|n| n.div_ceil(BLOCK));
            let (index, count) = run.shard.unwrap_or((0, 1));
            match blocks {
                Some(n) if key.coupled && block < n && block % count.max(1) == index => None,
                _ => Some(format!(
                    "{name} is not a block of the plan's pairs (N_l {:?}) of shard {index}/{count}",
                    plan.samples
                )),
            }
        }
    }
}

fn write_block(out: &mut impl Write, key: BlockKey, s: &LevelSums) -> std::io::Result<()> {
    write_varint(out, u64::from(key.level))?;
    write_varint(out, key.block)?;
    out.write_all(&[u8::from(key.coupled)])?;
    for c in [s.samples, s.failed_fine, s.failed_coarse, s.failed] {
        write_varint(out, c)?;
    }
    [s.y1, s.y2, s.y3, s.y4, s.p1, s.p2, s.seconds]
        .into_iter()
        .try_for_each(|x| write_f64(out, x))
}

/// Reads what [`write_block`] wrote.
fn read_block(reader: &mut Reader<'_>) -> Result<(BlockKey, LevelSums), String> {
    let level = u32::try_from(reader.count()?).map_err(|_| "a level beyond u32")?;
    let block = reader.count()? as u64;
    let coupled = match reader.byte()? {
        0 => false,
        1 => true,
        other => return Err(format!("pairs byte {other} is not 0 or 1")),
    };
    let mut counts = [0u64; 4];
    for c in &mut counts {
        *c = reader.count()? as u64;
    }
    let [samples, failed_fine, failed_coarse, failed] = counts;
    let mut x = [0f64; 7];
    for v in &mut x {
        *v = reader.f64()?;
    }
    let [y1, y2, y3, y4, p1, p2, seconds] = x;
    let key = BlockKey {
        level,
        block,
        coupled,
    };
    let sums = LevelSums {
        samples,
        failed_fine,
        failed_coarse,
        failed,
        y1,
        y2,
        y3,
        y4,
        p1,
        p2,
        seconds,
    };
    Ok((key, sums))
}

/// The blocks a run has so far and when they were last saved.
struct State {
    blocks: BTreeMap<BlockKey, LevelSums>,
    last: Instant,
}

/// The [`BlockStore`] of a run with a checkpoint: hands out the saved blocks, collects the
/// blocks run, and saves them all in the checkpoint each time the interval has passed.
pub struct Journal<'a> {
    checkpoint: &'a MlmcCheckpoint,
    run: &'a MlmcRun,
    saved: BTreeMap<BlockKey, LevelSums>,
    state: Mutex<State>,
}

impl Journal<'_> {
    /// The blocks resumed from.
    pub fn resumed(&self) -> usize {
        self.saved.len()
    }

    /// The blocks saved or run so far.
    pub fn blocks(&self) -> usize {
        self.lock().blocks.len()
    }

    /// Saves every block so far in the checkpoint (atomically: the previous checkpoint or this
    /// one, never a torn file).
    pub fn save(&self) -> Result<(), StudyError> {
        let mut state = self.lock();
        state.last = Instant::now();
        self.checkpoint.write(self.run, &state.blocks)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl BlockStore for Journal<'_> {
    fn saved(&self, key: BlockKey) -> Option<LevelSums> {
        self.saved.get(&key).copied()
    }

    fn finished(&self, key: BlockKey, sums: &LevelSums) {
        let mut state = self.lock();
        state.blocks.entry(key).or_insert(*sums);
        if state.last.elapsed() >= self.checkpoint.every {
            // A failed periodic save is not fatal: the run goes on, and the final save (or the
            // report) says whether the results could be written.
            let _ = self.checkpoint.write(self.run, &state.blocks);
            state.last = Instant::now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_read_back_bit_for_bit_and_cut_records_are_refused() {
        let key = BlockKey {
            level: 7,
            block: 1 << 40,
            coupled: false,
        };
        let sums = LevelSums {
            samples: 30,
            failed_fine: 2,
            failed_coarse: 1,
            failed: 2,
            y1: -0.0,
            y2: f64::MIN_POSITIVE,
            y3: 1e300,
            y4: 0.1,
            p1: -3.5,
            p2: 12.25,
            seconds: 1.5e-3,
        };
        let mut bytes = Vec::new();
        write_block(&mut bytes, key, &sums).unwrap();
        assert!(bytes.len() >= MIN_RECORD);
        let read = read_block(&mut Reader::new(&bytes)).unwrap();
        assert_eq!(read.0, key);
        assert!(read.1.same_samples(&sums) && read.1.seconds == sums.seconds);
        for cut in [0, 3, bytes.len() - 1] {
            assert!(read_block(&mut Reader::new(&bytes[..cut])).is_err());
        }
    }
}
