//! Multilevel Monte Carlo (Giles 2008; Acta Numerica 2015) of a scene: E[f(X_T)] of its
//! observable, with [`sdae_mlmc`] as the algorithm and the scene's study schemes as the model.
//!
//! With the antithetic option (Giles and Szpruch 2014) the fine value is the average of f over
//! the fine path and its twin with each pair of consecutive fine increments swapped.
//!
//! - [`coarsest`]: level 0 moved to the first step count that runs, before the study.
//! - [`coupled`]: the level sampler of a scene: any study scheme on both paths of a pair, in
//!   SIMD-lane ensembles.
//! - [`quasi`]: randomized quasi-Monte Carlo paths (`--qmc`): multilevel QMC beside MLMC at
//!   every eps, the cost exponents, and single-level randomized QMC beside the direct standard
//!   run.
//! - [`settings`]: the `[mlmc]` table of a scene and which MLMC errors the input caused;
//!   [`run_settings`]: everything a study runs with, checked before it runs; [`sampler`]: the
//!   scene's level sampler for those settings, and work handed it.
//! - [`study`], [`report`] (with [`quasi_report`]), [`plots`]: the whole study of a scene and its files;
//!   [`rows`]: the study's rows its QMC part is set beside; [`cells`]: the cells and tables
//!   the reports share.
//! - [`shard`]: runs with a fixed plan, sharded and merged into exactly the unsharded sums (the
//!   command saves and reads the shards' files).
//! - [`expectation`]: E[f(X_T)] to a requested accuracy by whichever of standard Monte Carlo,
//!   randomized QMC, MLMC and multilevel QMC a short pilot predicts cheapest, and
//!   [`expect_report`] its report.
//! - [`plan_runs`]: a scene's plans through its sampler (derived, run, merged).
//!
//! The modules import one way: the settings, the sampler, the rows and the cells below the
//! runs (`coarsest`, `quasi`, `study`, `shard`, `expectation`, `plan_runs`), the reports and
//! plots above the runs whose results they print, the MLMC report above the MLQMC one.

pub mod cells;
pub mod coarsest;
pub mod coupled;
pub mod expect_report;
pub mod expectation;
pub mod plan_runs;
pub mod plots;
pub mod quasi;
pub mod quasi_report;
pub mod report;
pub mod rows;
pub mod run_settings;
pub mod sampler;
pub mod settings;
pub mod shard;
pub mod study;

pub use coupled::CoupledSampler;
pub use expectation::{ExpectRequest, SceneExpectation, scene_expectation, scene_expectation_with};
pub use quasi::QmcReport;
pub use run_settings::{MlmcSettings, QmcSettings};
pub use sampler::{SamplerTask, with_sampler};
pub use settings::{MlmcSpec, caused_by_input, study_error};
pub use study::{MlmcReport, run_mlmc, run_study, run_study_quasi};
