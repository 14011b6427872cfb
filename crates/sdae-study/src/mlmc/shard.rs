//! A study's runs with a fixed plan: the identity of their samples (the scene, scheme,
//! observable and seed), their shards ([`sdae_mlmc::shard`], which runs and merges them into
//! exactly the unsharded sums) and their report.

use serde::{Deserialize, Serialize};

use super::cells::{LevelColumn, interval, level_table};
use super::run_settings::MlmcSettings;
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::{MlmcEstimate, Plan, estimate_of_plan};
use sdae_mlmc::sampler::{LevelSampler, level_stats};
use sdae_mlmc::sums::{LevelStats, LevelSums};

pub use sdae_mlmc::shard::{BlockSums, merge, run_shard};

/// A shard's file: its part of a plan, block by block, with the identity of its samples.
pub type MlmcShard = sdae_mlmc::shard::MlmcShard<Identity>;

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
    let s = format!(
        "# MLMC plan run: {} ({}, E[{}(X_T)])\n\nSeed {}, level 0 on 2^{} steps, {}antithetic, \
         eps = {:.0e}.\n\nE[f(X_T)] = {} (95% + bias), bias estimate {:.2e}{}.\n\n",
        id.scene,
        id.scheme,
        id.observable,
        id.seed,
        id.coarsest,
        if id.antithetic { "" } else { "not " },
        e.eps,
        interval(&e.with_bias),
        e.bias,
        if e.converged {
            ""
        } else {
            " (above eps / sqrt(2))"
        }
    );
    use LevelColumn::*;
    let columns = [Level, Samples, MeanY, VarY, MeanP, Kurtosis, Check, Failed];
    s + &level_table(&columns, &report.levels)
}
