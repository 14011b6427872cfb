//! The first level that runs: a level 0 too coarse for the scene (every path of 4 steps fails
//! on a small circle) is moved to finer steps before the study starts, and the report says so.
//!
//! The probe runs the first convergence test's paths of level 0 alone (the fine paths, on the
//! calling thread, out of any checkpoint) on 2^k0 steps, then 2^(k0 + 1), ...: the first step
//! count on which at most one path in ten fails is level 0. The finest step count allowed,
//! 2^(k0 + L_max), stays where it was. The probe depends only on the settings, so a resumed
//! run moves level 0 exactly as the interrupted one did.

use serde::Serialize;

use sdae_mlmc::sampler::probe_level;
use sdae_mlmc::{LevelSampler, LevelSums, MlmcError};

use super::run_settings::MlmcSettings;
use super::sampler::{SamplerTask, with_sampler};
use crate::scene::Scene;
use sdae_mlmc::qmc::QuasiSampler;

/// The share of a level's probe paths that may fail before it counts as not running.
pub const MAX_FAILED_SHARE: f64 = 0.1;

/// A level 0 that did not run: its steps and how many of its probe paths failed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelThatFailed {
    /// Its steps are 2^exponent.
    pub exponent: u32,
    /// Probe paths that failed.
    pub failed: u64,
    /// Probe paths run.
    pub attempted: u64,
}

/// Level 0 moved to finer steps: from 2^asked to 2^ran, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoarsestMoved {
    /// The coarsest exponent asked for (`mlmc.coarsest`).
    pub asked: u32,
    /// The coarsest exponent run.
    pub ran: u32,
    /// The step counts that did not run.
    pub failed: Vec<LevelThatFailed>,
}

impl CoarsestMoved {
    /// One sentence for the warnings.
    pub fn describe(&self) -> String {
        format!(
            "level 0 moved from 2^{} to 2^{} steps, the first that runs ({}; at most one path in \
             ten may fail); the finest level allowed is unchanged",
            self.asked,
            self.ran,
            listed(&self.failed)
        )
    }
}

/// "on 2^2 steps 1024 of 1024 paths failed, ...".
fn listed(failed: &[LevelThatFailed]) -> String {
    let each: Vec<String> = failed
        .iter()
        .map(|f| {
            format!(
                "on 2^{} steps {} of {} paths failed",
                f.exponent, f.failed, f.attempted
            )
        })
        .collect();
    each.join(", ")
}

/// Probes level 0 of a sampler: its probe paths' sums.
struct Probe {
    samples: u64,
}

impl SamplerTask for Probe {
    type Output = LevelSums;
    fn run<L: LevelSampler + QuasiSampler>(self, sampler: &L) -> Result<LevelSums, MlmcError> {
        probe_level(sampler, 0, self.samples)
    }
}

/// Whether a probe's paths ran: at most [`MAX_FAILED_SHARE`] of them failed.
fn runs(probe: &LevelSums) -> bool {
    (probe.failed as f64) <= MAX_FAILED_SHARE * probe.attempted() as f64
}

/// The settings with level 0 on the first step count that runs (see the module's
/// documentation), and the move if there was one. The finest level allowed stays: each step
/// up takes one level from `mlmc.max_level`, down to the convergence test's levels (and at
/// least 2); past that the study cannot run and the error names the step counts tried.
pub fn first_level_that_runs(
    scene: &Scene, settings: &MlmcSettings,
) -> Result<(MlmcSettings, Option<CoarsestMoved>), MlmcError> {
    let spec = &settings.spec;
    let samples = spec.test_samples.max(2);
    let moves = spec.max_level.saturating_sub(spec.test_levels.max(2));
    let mut failed = Vec::new();
    for step in 0..=moves {
        let mut moved = settings.clone();
        moved.spec.coarsest = spec.coarsest + step;
        moved.spec.max_level = spec.max_level - step;
        let probe = with_sampler(scene, &moved, Probe { samples })?;
        if runs(&probe) {
            let note = (step > 0).then_some(CoarsestMoved {
                asked: spec.coarsest,
                ran: moved.spec.coarsest,
                failed,
            });
            return Ok((moved, note));
        }
        failed.push(LevelThatFailed {
            exponent: moved.spec.coarsest,
            failed: probe.failed,
            attempted: probe.attempted(),
        });
    }
    Err(MlmcError::Levels {
        reason: format!(
            "no level 0 runs: {} (tried up to 2^{} steps, which leaves the convergence test's {} \
             levels below the finest allowed, 2^{})",
            listed(&failed),
            spec.coarsest + moves,
            spec.test_levels + 1,
            u64::from(spec.coarsest) + u64::from(spec.max_level)
        ),
    })
}
