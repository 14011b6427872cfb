//! The studies against exact laws, closed forms and independent solvers: convergence, stability,
//! equipartition, weak errors and MLMC, the scenes, and the reports (snapshots).
//!
//! One test binary for the crate: each file below is a module of it.

mod bias_intervals;
mod equipartition;
mod expect_coverage;
mod expression_law;
mod expression_scenes;
mod invariant_bias;
/// The scalar linear SDEs of sdae-mlmc's suite (which uses the rest of the module).
#[allow(dead_code)]
#[path = "../../../sdae-mlmc/tests/integration/linear.rs"]
mod linear;
mod lockstep;
mod mlmc;
mod plots;
mod qmc;
mod quick_report;
mod scenes;
mod simulate;
mod stability_report;
mod truncated_levels;
mod weak;
mod weak_order_coverage;
mod weak_qmc;
mod weak_run;
mod weak_verdicts;
