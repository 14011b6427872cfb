//! Runs with a fixed plan, split into shards and merged into exactly the unsharded sums.
//!
//! A plan's level l holds the blocks 0..ceil(N_l / BLOCK); shard i of n runs the blocks b with
//! b mod n = i ([`shard_blocks`]) and saves each block's sums. Merging sorts every level's
//! blocks, checks that each is there exactly once and is a whole block
//! ([`LevelSums::check_block`], the check a checkpoint's blocks pass too), and folds them in
//! block order: the order an unsharded run of the plan folds them in, so the merged sums are
//! the same bits. A shard carries an identity `I` of the caller's (what makes samples the same
//! samples: the model, its settings, the seed); shards of other identities are refused.

use serde::{Deserialize, Serialize};

use crate::MlmcError;
use crate::algorithm::Plan;
use crate::block::BLOCK;
use crate::sampler::{LevelSampler, RunControl, shard_blocks};
use crate::sums::LevelSums;

/// The sums of one block of a level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlockSums {
    /// Block b: samples b BLOCK .. (b + 1) BLOCK.
    pub block: u64,
    /// Its sums.
    pub sums: LevelSums,
}

/// A shard's part of a plan, block by block, with the identity `I` of its samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlmcShard<I> {
    /// Whose samples.
    pub identity: I,
    /// The plan run.
    pub plan: Plan,
    /// (i, n): shard i of n.
    pub shard: (u64, u64),
    /// Per level, the blocks this shard ran.
    pub levels: Vec<Vec<BlockSums>>,
}

/// Runs shard `shard` = (i, n) of `plan`, whose samples are `identity`'s.
pub fn run_shard<L: LevelSampler, I>(
    sampler: &L, control: &RunControl<'_>, identity: I, plan: Plan, shard: (u64, u64),
) -> Result<MlmcShard<I>, MlmcError> {
    if shard.1 == 0 || shard.0 >= shard.1 {
        return Err(MlmcError::Setting {
            key: "shard",
            value: format!("{}/{}", shard.0, shard.1),
            rule: "I/N with 0 <= I < N".into(),
        });
    }
    let mut levels = Vec::with_capacity(plan.samples.len());
    for (l, &n) in plan.samples.iter().enumerate() {
        let blocks = shard_blocks(n, shard);
        let sums = control.sample_blocks(sampler, l as u32, &blocks, true)?;
        levels.push(
            blocks
                .into_iter()
                .zip(sums)
                .map(|(block, sums)| BlockSums { block, sums })
                .collect(),
        );
    }
    Ok(MlmcShard {
        identity,
        plan,
        shard,
        levels,
    })
}

/// Merges the shards of one plan into its per-level sums: every shard 0..n exactly once, the
/// same identity and plan, every block of every level exactly once.
pub fn merge<I: Clone + PartialEq + std::fmt::Debug>(
    shards: &[MlmcShard<I>],
) -> Result<(I, Plan, Vec<LevelSums>), MlmcError> {
    let fail = |reason: String| MlmcError::Merge { reason };
    let first = shards
        .first()
        .ok_or_else(|| fail("no shard files".into()))?;
    let count = first.shard.1;
    let mut seen = vec![false; count as usize];
    for s in shards {
        if s.identity != first.identity || s.plan != first.plan {
            return Err(fail(format!(
                "shard {}/{} belongs to another run ({:?}, N_l {:?}) than shard {}/{} ({:?}, N_l {:?})",
                s.shard.0,
                s.shard.1,
                s.identity,
                s.plan.samples,
                first.shard.0,
                count,
                first.identity,
                first.plan.samples
            )));
        }
        if s.shard.1 != count
            || s.shard.0 >= count
            || std::mem::replace(&mut seen[s.shard.0 as usize], true)
        {
            return Err(fail(format!(
                "shard {}/{} is repeated or does not fit {count} shards",
                s.shard.0, s.shard.1
            )));
        }
        if s.levels.len() != first.plan.samples.len() {
            return Err(fail(format!(
                "shard {}/{} has {} levels, the plan {}",
                s.shard.0,
                count,
                s.levels.len(),
                first.plan.samples.len()
            )));
        }
    }
    if let Some(missing) = seen.iter().position(|s| !s) {
        return Err(fail(format!("shard {missing}/{count} is missing")));
    }
    let mut merged = Vec::with_capacity(first.plan.samples.len());
    for (l, &n) in first.plan.samples.iter().enumerate() {
        let mut blocks: Vec<&BlockSums> = shards.iter().flat_map(|s| &s.levels[l]).collect();
        blocks.sort_by_key(|b| b.block);
        let expected = n.div_ceil(BLOCK);
        let complete = blocks.len() as u64 == expected
            && blocks.iter().enumerate().all(|(k, b)| b.block == k as u64);
        if !complete {
            return Err(fail(format!(
                "level {l}: the shards hold {} blocks, the plan {expected} (0..{expected} once each)",
                blocks.len()
            )));
        }
        let mut sums = LevelSums::default();
        for b in blocks {
            b.sums
                .check_block()
                .map_err(|reason| fail(format!("level {l}: block {} {reason}", b.block)))?;
            sums.merge(&b.sums);
        }
        merged.push(sums);
    }
    Ok((first.identity.clone(), first.plan.clone(), merged))
}
