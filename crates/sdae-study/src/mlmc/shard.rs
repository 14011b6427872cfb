//! Runs with a fixed plan, split into shards and merged into exactly the unsharded sums.
//!
//! A plan's level l holds the blocks 0..ceil(N_l / BLOCK); shard i of n runs the blocks b with
//! b mod n = i and saves each block's sums. Merging sorts every level's blocks, checks that
//! each is there exactly once and is a whole block ([`LevelSums::check_block`], the check a
//! checkpoint's blocks pass too), and folds them in block order: the order an unsharded run of
//! the plan folds them in, so the merged sums are the same bits.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::study::MlmcSettings;
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::{MlmcEstimate, Plan, estimate_of_plan};
use sdae_mlmc::sampler::{BLOCK, LevelSampler, RunControl, shard_blocks};
use sdae_mlmc::sums::{LevelStats, LevelSums, level_stats};

/// What makes samples the same samples: the scene and everything that shapes a sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identity {
    /// The scene.
    pub scene: String,
    /// The scheme.
    pub scheme: String,
    /// The observable.
    pub observable: String,
    /// Final time T.
    pub t_end: f64,
    /// Level 0 has 2^coarsest steps.
    pub coarsest: u32,
    /// Antithetic fine paths.
    pub antithetic: bool,
    /// Seed of the sample streams.
    pub seed: u64,
}

impl Identity {
    /// The identity of a scene's samples under `settings`.
    pub fn of(scene: &str, settings: &MlmcSettings) -> Self {
        let s = &settings.spec;
        Self {
            scene: scene.into(),
            scheme: s.scheme.clone(),
            observable: s.observable.clone(),
            t_end: settings.t_end,
            coarsest: s.coarsest,
            antithetic: s.antithetic,
            seed: settings.seed,
        }
    }
}

/// The sums of one block of a level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlockSums {
    /// Block b: samples b BLOCK .. (b + 1) BLOCK.
    pub block: u64,
    /// Its sums.
    pub sums: LevelSums,
}

/// A shard's file: its part of a plan, block by block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlmcShard {
    /// Whose samples.
    pub identity: Identity,
    /// The plan run.
    pub plan: Plan,
    /// (i, n): shard i of n.
    pub shard: (u64, u64),
    /// Per level, the blocks this shard ran.
    pub levels: Vec<Vec<BlockSums>>,
}

/// Runs shard `shard` = (i, n) of `plan`, whose samples are `identity`'s.
pub fn run_shard<L: LevelSampler>(
    sampler: &L, control: &RunControl<'_>, identity: Identity, plan: Plan, shard: (u64, u64),
) -> Result<MlmcShard, MlmcError> {
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
pub fn merge(shards: &[MlmcShard]) -> Result<(Identity, Plan, Vec<LevelSums>), MlmcError> {
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

/// The report of a run with a fixed plan (at once or merged from shards).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// Whose samples.
    pub identity: Identity,
    /// The plan.
    pub plan: Plan,
    /// The estimate.
    pub estimate: MlmcEstimate,
    /// Per level, `mlmc_test`'s statistics.
    pub levels: Vec<LevelStats>,
}

/// The report of a plan's sums.
pub fn plan_report<L: LevelSampler>(
    sampler: &L, identity: Identity, plan: Plan, levels: Vec<LevelSums>,
) -> Result<PlanReport, MlmcError> {
    let stats = level_stats(&levels, sampler);
    let estimate = estimate_of_plan(sampler, &plan, levels)?;
    Ok(PlanReport {
        identity,
        plan,
        estimate,
        levels: stats,
    })
}

/// The Markdown summary of a plan's run.
pub fn plan_markdown(report: &PlanReport) -> String {
    let (id, e) = (&report.identity, &report.estimate);
    let mut s = format!(
        "# MLMC plan run: {} ({}, E[{}(X_T)])\n\nSeed {}, level 0 on 2^{} steps, {}antithetic, \
         eps = {:.0e}.\n\nEstimate {:.6} [{:.6}, {:.6}] (95%), bias estimate {:.2e}{}.\n\n",
        id.scene,
        id.scheme,
        id.observable,
        id.seed,
        id.coarsest,
        if id.antithetic { "" } else { "not " },
        e.eps,
        e.estimate.estimate,
        e.estimate.ci_low,
        e.estimate.ci_high,
        e.bias,
        if e.converged {
            ""
        } else {
            " (above eps / sqrt(2))"
        }
    );
    s.push_str("| l | samples | mean Y_l | var Y_l | mean P_l | kurtosis | check | failed (fine/coarse) |\n|---|---|---|---|---|---|---|---|\n");
    for l in &report.levels {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4e} | {:.4e} | {:.6} | {:.2} | {:.2} | {}/{} |",
            l.level,
            l.samples,
            l.mean_y,
            l.var_y,
            l.mean_p,
            l.kurtosis,
            l.consistency,
            l.failed_fine,
            l.failed_coarse
        );
    }
    s
}
