//! What the `sdae-study` command keeps on disk between runs, over the studies of
//! [`sdae_study`] (which never call it):
//!
//! - [`checkpoint`]: the finished paths of a convergence run, appended in checksummed
//!   segments, so that a stopped run resumes to exactly the numbers of an uninterrupted one,
//!   and the lock that keeps two runs out of one folder;
//! - [`mlmc_checkpoint`]: the same for the blocks of an MLMC run;
//! - [`shards`] and [`sealed`]: shard files, JSON with a checksum of their content, that
//!   `merge` and `mlmc-merge` read;
//! - [`folders`]: output folders checked before a run and cleared of what killed processes
//!   left;
//! - [`compare`]: the numbers of two reports, without what differs between runs.
//!
//! The command's arguments, output folders, signals and progress are in its binary.

pub mod checkpoint;
pub mod compare;
pub mod folders;
pub mod mlmc_checkpoint;
pub mod sealed;
pub mod shards;
