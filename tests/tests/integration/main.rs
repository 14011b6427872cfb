//! Cross-crate integration and snapshot tests of the sdae workspace, as one test binary: the
//! schemes, the reference solvers and the ensemble engine on the built-in and user-assembled
//! systems (exact laws, closed forms, bit-for-bit agreement of lanes and paths, typed errors,
//! fixed-seed diagnostics).
//!
//! `no_allocation.rs` stays a binary of its own (`tests/tests/no_allocation.rs`): it installs a
//! counting `#[global_allocator]`, and a global allocator is per binary: here it would
//! instrument every other test's allocations as well.

mod common;

mod bad_inputs;
mod certificate_rounding;
mod chain_ensemble;
mod computes_only_what_it_needs;
mod constraint_preservation;
mod diagnostics_snapshots;
mod ensemble;
mod fiber_dynamics;
mod free_rotor;
mod general_engine;
mod hypersurface;
mod interpolation;
mod kernel_scheme;
mod langevin_equipartition;
mod local_size;
mod one_lane;
mod pendulum_closed_form;
mod rescaled_noise;
mod roots;
mod runaway;
mod splitting;
mod system_constraints;
mod user_systems;
mod velocity_noise;
