//! Convergence studies of the half-explicit drift-truncated Euler scheme (seed eq. 3.1-3.2).
//!
//! [`pendulum_study`] runs the seed's stochastic pendulum (Section 5.1) at several step sizes
//! on the same Brownian paths and compares each level with a fine-step reference of the scheme
//! itself: strong errors (L^p over paths of the sup over the grid), observed orders, run time
//! and solver diagnostics.
//! Path i draws from its own stream, so the numbers do not depend on the thread count.

mod pendulum;
pub mod plots;
pub mod stats;

pub use pendulum::{
    Errors, LevelOutcome, LevelReport, Orders, PathRecord, PendulumStudy, Shard, StudyReport,
    build_report, merge_shards, pendulum_study, run_paths,
};
