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
//! ([`crate::checkpoint`]): a line naming the format, then checksummed segments: a JSON header
//! with the scene, the settings and the plan and shard (for a `--plan` run), then batches of
//! block records (level, index and counts as LEB128 varints, a byte for pairs or single paths,
//! the sums as IEEE bits): about 70 bytes a block of 32 samples. Each save appends the blocks
//! finished since the last one; a changed bit is refused, a save cut short by a kill is
//! dropped (its blocks run again). What is read back is checked strictly, by the checks
//! `mlmc-merge` applies to shards ([`LevelSums::check_block`]).

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::sync::{Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use crate::checkpoint::changed::{Setting, first_changed, scene_change, shard_change, switch};
use crate::checkpoint::saves::Saves;
#[cfg(test)]
use crate::checkpoint::segments::{Appender, batches};
use crate::checkpoint::{
    CheckpointFile, Reader, parse_file, read_bytes, torn_note, write_f64, write_varint,
};
use sdae_mlmc::algorithm::Plan;
use sdae_mlmc::block::{BLOCK, BlockKey};
use sdae_mlmc::sampler::BlockStore;
use sdae_mlmc::sums::LevelSums;
use sdae_study::StudyError;
use sdae_study::mlmc::{MlmcSettings, QmcSettings};
use sdae_study::scene::{Scene, escaped};

/// The first line of an MLMC checkpoint file: its format and version.
const MAGIC: &[u8] = b"sdae-study mlmc checkpoint 2\n";

/// The first line of the format before checksums, refused by name.
const OLDER: [&[u8]; 1] = [b"sdae-study mlmc checkpoint 1\n"];

/// A saved block: its key and its sums.
type Block = (BlockKey, LevelSums);

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
}

/// The blocks an interrupted run saved, read back by [`MlmcCheckpoint::load`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SavedBlocks {
    /// The sums of each block (checked: each once, within the run's levels and blocks, of
    /// [`BLOCK`] samples).
    pub blocks: BTreeMap<BlockKey, LevelSums>,
    /// Bytes of a last segment cut short (a process killed while saving), dropped: the blocks
    /// it held run again. 0 when the file ends whole.
    pub torn: usize,
}

impl SavedBlocks {
    /// A note on a torn last segment, if the file had one (for the resuming message).
    pub fn torn_note(&self) -> Option<String> {
        torn_note(self.torn)
    }
}

/// The checkpoint file of one MLMC run.
pub type MlmcCheckpoint = CheckpointFile<MlmcRun>;

impl MlmcCheckpoint {
    /// The header, the blocks and the bytes of a torn last segment of the checkpoint file
    /// holding `bytes`: checksums verified, blocks read, nothing checked against a run.
    fn parse(&self, bytes: &[u8]) -> Result<(Header, Vec<Block>, usize), StudyError> {
        parse_file(&self.path, bytes, (MAGIC, &OLDER), "block", read_block)
    }

    /// The number of blocks the checkpoint file holds, if it exists and can be read (for
    /// messages; [`MlmcCheckpoint::load`] checks it).
    pub fn holds(&self) -> Option<usize> {
        let bytes = std::fs::read(&self.path).ok()?;
        self.parse(&bytes).ok().map(|(_, blocks, _)| blocks.len())
    }

    /// The blocks saved by an interrupted run of `run` (the thread count aside); `None` when
    /// there is no checkpoint file. A file that fails a checksum is a
    /// [`StudyError::Checksum`]; one that is not an MLMC checkpoint a [`StudyError::Read`];
    /// one of another run (scene, seed, observable, scheme, ... or plan), or holding a block
    /// twice, out of the run's range or not of [`BLOCK`] samples, a [`StudyError::Resume`]
    /// naming what differs.
    pub fn load(&self, run: &MlmcRun) -> Result<Option<SavedBlocks>, StudyError> {
        let Some(bytes) = read_bytes(&self.path)? else {
            return Ok(None);
        };
        let (header, records, torn) = self.parse(&bytes)?;
        if let Some(what) = difference(&header.run, run) {
            return Err(self.saved_by_another(&what));
        }
        let mut blocks = BTreeMap::new();
        for (key, sums) in records {
            if let Some(reason) = out_of_range(run, key, &sums) {
                return Err(self.refuse(reason));
            }
            if blocks.insert(key, sums).is_some() {
                return Err(self.refuse(format!(
                    "block {} of level {} appears twice",
                    key.block, key.level
                )));
            }
        }
        Ok(Some(SavedBlocks { blocks, torn }))
    }

    /// The store of a run of `run` resuming from `saved` (from [`MlmcCheckpoint::load`]): set
    /// it as the run's [`RunControl::store`](sdae_mlmc::RunControl).
    pub fn journal<'a>(&'a self, run: &'a MlmcRun, saved: Option<SavedBlocks>) -> Journal<'a> {
        let saved = saved.unwrap_or_default().blocks;
        let header = serde_json::to_vec(&Header { run: run.clone() }).map_err(|e| e.to_string());
        let resumed: Vec<Block> = saved.iter().map(|(k, s)| (*k, *s)).collect();
        let saves = Saves::new(
            self.path.clone(),
            MAGIC,
            header,
            write_record,
            self.every,
            resumed,
        );
        Journal {
            keys: Mutex::new(saved.keys().copied().collect()),
            saved,
            saves,
            _run: std::marker::PhantomData,
        }
    }

    /// Writes `blocks` as the whole checkpoint of `run` (atomically).
    #[cfg(test)]
    fn write(&self, run: &MlmcRun, blocks: &[Block]) -> Result<(), StudyError> {
        let header = serde_json::to_vec(&Header { run: run.clone() })
            .map_err(|e| StudyError::write(&self.path, e))?;
        let body = batches(blocks, write_record).map_err(|e| StudyError::write(&self.path, e))?;
        Appender::create(&self.path, MAGIC, &header, &body).map(|_| ())
    }
}

/// What of `saved` differs from `run` (the thread count aside), named for a message: the
/// first differing setting by its flag with the saved and the asked value.
fn difference(saved: &MlmcRun, run: &MlmcRun) -> Option<String> {
    if saved.scene != run.scene {
        return Some(scene_change(&saved.scene, &run.scene));
    }
    let (a, b) = (&saved.settings, &run.settings);
    let same = MlmcSettings {
        threads: b.threads,
        ..a.clone()
    } == *b;
    let setting = (!same).then(|| {
        setting_change(a, b)
            .unwrap_or_else(|| "setting (eps, levels, samples or the standard run)".into())
    });
    setting
        .or_else(|| (saved.plan != run.plan).then(|| "plan".into()))
        .or_else(|| (saved.shard != run.shard).then(|| shard_change(saved.shard, run.shard)))
}

/// The first setting of `saved` that differs from `asked`, by its flag with both values.
fn setting_change(saved: &MlmcSettings, asked: &MlmcSettings) -> Option<String> {
    let each = |name: &'static str, value: fn(&MlmcSettings) -> String| -> Setting {
        (name, value(saved), value(asked))
    };
    fn qmc(s: &MlmcSettings, value: fn(&QmcSettings) -> String) -> String {
        s.qmc.as_ref().map_or("none".into(), value)
    }
    first_changed(&[
        each("--seed", |s| s.seed.to_string()),
        each("--observable", |s| escaped(&s.spec.observable)),
        each("--scheme", |s| escaped(&s.spec.scheme)),
        each("--antithetic", |s| {
            switch("--antithetic", s.spec.antithetic)
        }),
        each("--t-end", |s| format!("{:?}", s.t_end)),
        each("--coarsest", |s| s.spec.coarsest.to_string()),
        each("--max-level", |s| s.spec.max_level.to_string()),
        each("--test-levels", |s| s.spec.test_levels.to_string()),
        each("--test-samples", |s| s.spec.test_samples.to_string()),
        each("--eps", |s| format!("{:?}", s.spec.eps)),
        each("--qmc", |s| switch("--qmc", s.qmc.is_some())),
        each("--randomizations", |s| {
            qmc(s, |q| q.randomizations.to_string())
        }),
        each("--initial-points", |s| {
            qmc(s, |q| q.initial_points.to_string())
        }),
        each("--no-standard", |s| {
            switch("--no-standard", !s.standard_run)
        }),
        each("--quick", |s| format!("N_0 = {}", s.initial_samples)),
    ])
}

/// Why block `key` with `sums` cannot belong to `run`, if it cannot.
fn out_of_range(run: &MlmcRun, key: BlockKey, sums: &LevelSums) -> Option<String> {
    let BlockKey { level, block, .. } = key;
    let name = format!("block {block} of level {level}");
    if let Err(reason) = sums.check_block() {
        return Some(format!("{name} {reason}"));
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

/// A block's record, as [`read_block`] reads it back.
fn write_record(out: &mut Vec<u8>, (key, sums): &Block) -> std::io::Result<()> {
    write_block(out, *key, sums)
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

/// The [`BlockStore`] of a run with a checkpoint: hands out the saved blocks, collects the
/// blocks run, and appends those finished since the last save to the checkpoint each time the
/// interval has passed.
pub struct Journal<'a> {
    saved: BTreeMap<BlockKey, LevelSums>,
    /// The blocks saved or run so far (a block run twice is saved once).
    keys: Mutex<BTreeSet<BlockKey>>,
    saves: Saves<Block>,
    _run: std::marker::PhantomData<&'a MlmcRun>,
}

impl Journal<'_> {
    /// The blocks resumed from.
    pub fn resumed(&self) -> usize {
        self.saved.len()
    }

    /// The blocks saved or run so far.
    pub fn blocks(&self) -> usize {
        self.saves.added()
    }

    /// Saves the blocks finished since the last save in the checkpoint (appended; the first
    /// save of a run writes the file afresh).
    pub fn save(&self) -> Result<(), StudyError> {
        self.saves.save().map(|_| ())
    }
}

impl BlockStore for Journal<'_> {
    fn saved(&self, key: BlockKey) -> Option<LevelSums> {
        self.saved.get(&key).copied()
    }

    fn finished(&self, key: BlockKey, sums: &LevelSums) {
        let mut keys = self.keys.lock().unwrap_or_else(PoisonError::into_inner);
        if keys.insert(key) {
            self.saves.finished([(key, *sums)]);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

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
        assert!(bytes.len() >= 7 + 7 * 8);
        let read = read_block(&mut Reader::new(&bytes)).unwrap();
        assert_eq!(read.0, key);
        assert!(read.1.same_samples(&sums) && read.1.seconds == sums.seconds);
        for cut in [0, 3, bytes.len() - 1] {
            assert!(read_block(&mut Reader::new(&bytes[..cut])).is_err());
        }
    }

    fn block(level: u32, block: u64) -> Block {
        let key = BlockKey {
            level,
            block,
            coupled: true,
        };
        let sums = LevelSums {
            samples: BLOCK - 1,
            failed_fine: 1,
            failed: 1,
            y1: 0.5 * block as f64,
            y2: 0.25,
            p1: -1.0,
            p2: 1.0,
            seconds: 1e-3,
            ..LevelSums::default()
        };
        (key, sums)
    }

    fn run() -> MlmcRun {
        let scene = Scene::built_in("pendulum").unwrap();
        MlmcRun {
            settings: MlmcSettings::for_scene(&scene),
            scene,
            plan: None,
            shard: None,
        }
    }

    #[test]
    fn a_journal_appends_each_block_once_and_a_torn_tail_is_dropped() {
        let dir = std::env::temp_dir().join(format!("sdae-mlmc-ckpt-{}", std::process::id()));
        let checkpoint = MlmcCheckpoint::new(dir.join("c.bin")).every(Duration::ZERO);
        let run = run();
        let journal = checkpoint.journal(&run, None);
        let mut sizes = Vec::new();
        for b in 0..20 {
            let (key, sums) = block(0, b);
            journal.saves.forget_cost();
            journal.finished(key, &sums);
            journal.finished(key, &sums);
            sizes.push(std::fs::metadata(checkpoint.path()).unwrap().len());
        }
        // After the first save, each save appends one block's segment: linear in the run.
        let steps: Vec<u64> = sizes.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(steps.iter().all(|&s| s == steps[0] && s < 100), "{steps:?}");
        journal.save().unwrap();
        let saved = checkpoint.load(&run).unwrap().unwrap();
        assert_eq!((saved.blocks.len(), saved.torn), (20, 0));
        // A save cut short: the last block is dropped, the others resume.
        let bytes = std::fs::read(checkpoint.path()).unwrap();
        std::fs::write(checkpoint.path(), &bytes[..bytes.len() - 9]).unwrap();
        let saved = checkpoint.load(&run).unwrap().unwrap();
        assert_eq!(saved.blocks.len(), 19);
        assert!(saved.torn > 0 && saved.torn_note().is_some());
        // A resumed journal writes the file afresh at its first save: the torn tail is gone.
        let journal = checkpoint.journal(&run, Some(saved));
        let (key, sums) = block(0, 19);
        journal.finished(key, &sums);
        let saved = checkpoint.load(&run).unwrap().unwrap();
        assert_eq!((saved.blocks.len(), saved.torn), (20, 0));
        // Any flipped bit is refused, naming the checksum.
        let bytes = std::fs::read(checkpoint.path()).unwrap();
        for bit in (0..bytes.len() * 8).step_by(7) {
            let mut flipped = bytes.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            std::fs::write(checkpoint.path(), &flipped).unwrap();
            let err = checkpoint.load(&run).unwrap_err();
            assert!(
                matches!(err, StudyError::Checksum { .. }),
                "bit {bit}: {err}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_block_that_is_not_whole_is_refused_on_load() {
        let dir = std::env::temp_dir().join(format!("sdae-mlmc-short-{}", std::process::id()));
        let checkpoint = MlmcCheckpoint::new(dir.join("c.bin"));
        let run = run();
        let mut short = block(1, 3);
        short.1.samples -= 1;
        checkpoint.write(&run, &[block(1, 2), short]).unwrap();
        let err = checkpoint.load(&run).unwrap_err();
        assert!(matches!(err, StudyError::Resume { .. }), "{err}");
        assert!(err.to_string().contains("not a block of 32"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
