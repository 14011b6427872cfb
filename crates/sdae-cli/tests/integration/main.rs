//! The sdae-study command: its arguments and errors, reports that are the same whatever the threads,
//! shards or interruptions, checkpoints and shards that survive faults, and stops at any moment.
//!
//! One test binary for the crate: each file below is a module of it.

mod bits;
mod cli;
mod command_line;
mod common;
mod expect_command;
mod expression_refusals;
mod faults;
mod mlmc_command_line;
mod mlmc_resume;
mod named_refusals;
mod process;
mod resume;
mod sharding;
mod simulate_command;
mod stop_anywhere;
