//! A scene's plans through its sampler: the plan for an eps from a study's convergence test,
//! a plan run whole or by shard, and the report of merged shards.
//!
//! These take a scene, not a sampler, so that the samplers of the built-in systems are
//! compiled here once and not again in every program that calls them.

use super::run_settings::MlmcSettings;
use super::sampler::{SamplerTask, with_sampler};
use super::shard::{Identity, MlmcShard, PlanReport, plan_report, run_shard};
use super::study::MlmcReport;
use crate::scene::Scene;
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::plan_from_test;
use sdae_mlmc::algorithm::{Plan, run_plan};
use sdae_mlmc::sampler::{LevelSampler, RunControl};
use sdae_mlmc::sums::LevelSums;

/// The plan that reaches `eps` by the convergence test of `report`.
pub fn plan_for_eps(
    scene: &Scene, settings: &MlmcSettings, report: &MlmcReport, eps: f64,
) -> Result<Plan, MlmcError> {
    struct FromTest<'a> {
        report: &'a MlmcReport,
        eps: f64,
    }
    impl SamplerTask for FromTest<'_> {
        type Output = Plan;
        fn run<L: LevelSampler>(self, sampler: &L) -> Result<Plan, MlmcError> {
            plan_from_test(sampler, &self.report.test, self.eps)
        }
    }
    with_sampler(scene, settings, FromTest { report, eps })
}

/// What a plan's run gives: a shard's blocks or the whole plan's report.
#[derive(Debug)]
pub enum PlanRun {
    /// Shard i of n: its blocks, to be merged.
    Shard(Box<MlmcShard>),
    /// The whole plan: its report.
    Whole(Box<PlanReport>),
}

/// Runs `plan` on `scene`: all of it, or shard (i, n) of it. The plan is checked first
/// ([`MlmcSettings::validate_plan`]).
pub fn run_scene_plan(
    scene: &Scene, settings: &MlmcSettings, control: &RunControl<'_>, plan: Plan,
    shard: Option<(u64, u64)>,
) -> Result<PlanRun, MlmcError> {
    settings.validate_plan(&plan)?;
    struct Task<'a, 'b> {
        control: &'a RunControl<'b>,
        identity: Identity,
        plan: Plan,
        shard: Option<(u64, u64)>,
    }
    impl SamplerTask for Task<'_, '_> {
        type Output = PlanRun;
        fn run<L: LevelSampler>(self, sampler: &L) -> Result<PlanRun, MlmcError> {
            match self.shard {
                Some(shard) => Ok(PlanRun::Shard(Box::new(run_shard(
                    sampler,
                    self.control,
                    self.identity,
                    self.plan,
                    shard,
                )?))),
                None => {
                    let sums = run_plan(sampler, self.control, &self.plan.samples)?;
                    let report = plan_report(sampler, self.identity, self.plan, sums)?;
                    Ok(PlanRun::Whole(Box::new(report)))
                }
            }
        }
    }
    let identity = Identity::of(&scene.name, settings);
    let task = Task {
        control,
        identity,
        plan,
        shard,
    };
    with_sampler(scene, settings, task)
}

/// The report of a plan from its merged sums (see [`super::shard::merge`]).
pub fn merged_report(
    scene: &Scene, settings: &MlmcSettings, identity: Identity, plan: Plan, sums: Vec<LevelSums>,
) -> Result<PlanReport, MlmcError> {
    struct Report {
        identity: Identity,
        plan: Plan,
        sums: Vec<LevelSums>,
    }
    impl SamplerTask for Report {
        type Output = PlanReport;
        fn run<L: LevelSampler>(self, sampler: &L) -> Result<PlanReport, MlmcError> {
            plan_report(sampler, self.identity, self.plan, self.sums)
        }
    }
    let task = Report {
        identity,
        plan,
        sums,
    };
    with_sampler(scene, settings, task)
}
