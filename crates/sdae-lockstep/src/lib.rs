//! One Monte Carlo path of a study: every scheme at every level, and the fine reference, driven
//! in lockstep by one Brownian path.
//!
//! The finest increments are drawn once, a chunk at a time, and summed pairwise into the
//! increments of the coarser levels (a level of 2^k steps uses sums of 2^(fine - k) fine
//! increments), so every level sees the same Brownian path. The reference runs first over a
//! chunk and records its state on the finest level's grid; then each scheme and level steps a
//! block of paths through the chunk, and after each step every path's state is compared with
//! the reference's record at that time. Memory per path is bounded by the chunk, not by the
//! number of fine steps.
//!
//! The increments are each path's own pseudo-random streams, or its point of a randomization
//! of scrambled Sobol' points ([`PathNoise`], [`QuasiPaths`]): the chunks are filled through
//! [`EnsembleNoise`](sdae_noise::EnsembleNoise), the same for both.
//!
//! Each scheme and level steps its block of paths as one [`PathEnsemble`]: SIMD lanes where the
//! scheme and the system have a lane form ([`LaneEnsemble`](sdae_model::LaneEnsemble): every
//! built-in scheme on the pendulums), otherwise one path at a time through the scheme's step
//! (a user's scheme as a [`PathLoop`](sdae_model::PathLoop)); any
//! [`Scheme`](sdae_model::Scheme) runs here.
//!
//! The plan and the records are in [`PathPlan`] and [`PathRecord`], the runner is
//! [`run_block`] (and [`run_block_until`], [`run_block_with`]), the observables evaluated on the
//! paths are [`Observable`]s.

mod block;
mod noise;
mod observable;
mod plan;

pub use block::{BLOCK_PATHS, BlockEnsembles, run_block, run_block_until, run_block_with};
pub use noise::{PathNoise, QuasiPaths};
pub use observable::{Observable, ObservableFunction};
pub use plan::{Limits, Observing, PathPlan, PathRecord, TrackOutcome};

use sdae_model::PathEnsemble;

/// A boxed ensemble of paths of systems of type `S`.
pub type BoxedEnsemble<S> = Box<dyn PathEnsemble<System = S>>;
