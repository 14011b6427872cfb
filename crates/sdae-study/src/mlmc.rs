//! Multilevel Monte Carlo (Giles 2008; Acta Numerica 2015) for E[f(X_T)] of a scene.
//!
//! E\[P_L\] = E\[P_0\] + sum_{l=1}^{L} E\[P_l - P_{l-1}\], with P_l = f(X_T) on the grid of
//! h_l = h_0 2^-l. Each correction is sampled on pairs driven by one Brownian path: the fine
//! path on h_l and the coarse path on h_{l-1}, whose increment over a step is the sum of the
//! two fine increments it spans. With the antithetic option (Giles and Szpruch 2014) the fine
//! value is the average of f over the fine path and its twin with each pair of consecutive
//! fine increments swapped.
//!
//! - [`sums`]: what a level's samples add up to (additive: shards and blocks merge exactly).
//! - [`sampler`]: the [`LevelSampler`] interface and the deterministic parallel driver (sample
//!   i of level l draws from its own stream (seed, l, i); blocks are folded in index order, so
//!   the sums do not depend on the thread count or the sharding).
//! - [`algorithm`]: Giles's adaptive algorithm, the convergence test of his `mlmc_test`, plans
//!   with fixed N_l, standard Monte Carlo on one level.
//! - [`fit`]: the rates alpha, beta, gamma with intervals.
//! - [`coupled`]: the level sampler of a scene: any study scheme on both paths of a pair, in
//!   SIMD-lane ensembles.
//! - [`study`], [`report`], [`plots`]: the whole study of a scene and its files.
//! - [`shard`]: runs with a fixed plan, sharded and merged into exactly the unsharded sums.
//! - [`plan_runs`]: a scene's plans through its sampler (derived, run, merged).
//! - [`checkpoint`]: the blocks a run finished, saved so that a stopped run resumes to exactly
//!   the numbers of an uninterrupted one.

pub mod algorithm;
pub mod checkpoint;
pub mod coupled;
pub mod fit;
pub mod plan_runs;
pub mod plots;
pub mod report;
pub mod sampler;
pub mod settings;
pub mod shard;
pub mod study;
pub mod sums;

pub use algorithm::{
    AdaptiveSettings, MlmcEstimate, Plan, adaptive, run_plan, standard_monte_carlo,
};
pub use coupled::CoupledSampler;
pub use fit::{Rates, fit_rates};
pub use sampler::{BLOCK, BlockKey, BlockStore, LevelSampler, RunControl};
pub use settings::{MlmcError, MlmcSpec};
pub use study::{MlmcReport, MlmcSettings, SamplerTask, run_mlmc, run_study, with_sampler};
pub use sums::{LevelStats, LevelSums, Sample};
