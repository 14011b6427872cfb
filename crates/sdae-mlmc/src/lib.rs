//! Multilevel Monte Carlo (Giles 2008; Acta Numerica 2015) for E[f(X_T)] of any model that
//! samples pairs of paths on two step sizes driven by one Brownian path.
//!
//! E\[P_L\] = E\[P_0\] + sum_{l=1}^{L} E\[P_l - P_{l-1}\], with P_l = f(X_T) on the grid of
//! h_l = h_0 2^-l. Each correction is sampled on pairs driven by one Brownian path: the fine
//! path on h_l and the coarse path on h_{l-1}, whose increment over a step is the sum of the
//! two fine increments it spans. The model is a [`LevelSampler`]; this crate knows nothing of
//! its equations.
//!
//! - [`block`]: the block of [`BLOCK`] samples a run takes, stores and shards as one, and its
//!   name ([`BlockKey`]).
//! - [`sums`]: what a level's samples add up to (additive: shards and blocks merge exactly).
//! - [`sampler`]: the [`LevelSampler`] interface and the deterministic parallel driver (sample
//!   i of level l draws from its own stream (seed, l, i); blocks are folded in index order, so
//!   the sums do not depend on the thread count or the sharding), with a [`BlockStore`] that
//!   keeps finished blocks (a checkpoint: a resumed run folds exactly the uninterrupted sums),
//!   and each level's statistics ([`level_stats`]).
//! - [`algorithm`]: Giles's adaptive algorithm, plans with fixed N_l, standard Monte Carlo on
//!   one level.
//! - [`mod@expectation`]: E\[P\] to a requested accuracy by whichever of standard Monte Carlo,
//!   randomized QMC, MLMC and multilevel QMC a short pilot predicts cheapest.
//! - [`shard`]: a plan's run split into shards (on the nodes of a cluster) and merged into
//!   exactly the sums of the unsharded run.
//! - [`fit`]: the rates alpha, beta, gamma of the convergence test with intervals.
//! - [`qmc`]: multilevel randomized quasi-Monte Carlo (Giles and Waterhouse 2009) over a
//!   [`QuasiSampler`], whose samples are points of randomized low-discrepancy sequences.
//! - [`error`]: why a run refused to start or stopped, and the bound on the accuracy.
//! - [`memory`]: the bound on the memory a run's blocks take, checked before it starts.
//!
//! The modules import one way: `error` and `block` at the bottom, then `sums`, `sampler` and
//! `memory`, then the algorithms above them.
//!
//! The README's example (E\[X_1\] of geometric Brownian motion in 28 lines) runs as a test.

#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExample;

pub mod algorithm;
pub mod block;
pub mod error;
pub mod expectation;
pub mod fit;
pub mod memory;
pub mod qmc;
pub mod sampler;
pub mod shard;
pub mod sums;

#[cfg(test)]
mod test_sampler;

pub use algorithm::{
    AdaptiveSettings, MlmcEstimate, Plan, adaptive, run_plan, standard_monte_carlo,
};
pub use block::{BLOCK, BlockKey};
pub use error::MlmcError;
pub use expectation::{
    CostMeasure, Expectation, ExpectationSettings, Method, Prediction, expectation,
    expectation_quasi,
};
pub use fit::{Rates, fit_rates};
pub use qmc::{
    MlqmcEstimate, QuasiEstimate, QuasiLevel, QuasiSampler, QuasiSettings, cost_exponent,
    cost_exponent_of, mlqmc, standard_quasi_monte_carlo,
};
pub use sampler::{BlockStore, LevelSampler, RunControl, level_stats};
pub use sums::{LevelStats, LevelSums, Sample};
