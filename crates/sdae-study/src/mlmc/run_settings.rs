//! Everything an MLMC study of a scene runs with ([`MlmcSettings`]: the scene's `[mlmc]` table
//! with the command line's changes, and the randomized QMC part's [`QmcSettings`]), checked
//! before anything runs.

use serde::{Deserialize, Serialize};

use super::settings::MlmcSpec;
use crate::convergence::{MAX_THREADS, MIN_STEP};
use crate::integrator::SchemeKind;
use crate::scene::Scene;
use sdae_mlmc::MlmcError;
use sdae_mlmc::algorithm::Plan;
use sdae_mlmc::error::check_eps;
use sdae_mlmc::memory::samples_exceed_memory;
use sdae_mlmc::qmc::level::check_design;

/// Everything an MLMC study of a scene runs with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlmcSettings {
    /// The scene's `[mlmc]` table (or its defaults) with the command line's changes.
    pub spec: MlmcSpec,
    /// Final time T.
    pub t_end: f64,
    /// Seed of the sample streams.
    pub seed: u64,
    /// Worker threads (the numbers do not depend on them).
    pub threads: usize,
    /// Giles's N_0: samples on a level when it is first run.
    pub initial_samples: u64,
    /// Run standard Monte Carlo directly at the largest eps, or at the accuracy the MLMC
    /// part's work affords (for the measured speed-up).
    pub standard_run: bool,
    /// Randomized quasi-Monte Carlo paths beside the MLMC runs (`--qmc`): multilevel QMC at
    /// every eps and single-level QMC beside the direct standard run (the `quasi` module).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qmc: Option<QmcSettings>,
}

/// The largest step exponent a level may have (2^24 steps per path).
pub const MAX_STEP_EXPONENT: u32 = 24;

/// The [`MlmcError::Setting`] refusing the setting `key` of `value` by `rule`.
fn setting<T>(key: &'static str, value: String, rule: String) -> Result<T, MlmcError> {
    Err(MlmcError::Setting { key, value, rule })
}

/// Refuses a final time whose smallest step T / 2^`finest` is below [`MIN_STEP`].
fn check_step(t_end: f64, finest: u32) -> Result<(), MlmcError> {
    let h = t_end / 2f64.powi(finest as i32);
    if h >= MIN_STEP {
        return Ok(());
    }
    Err(MlmcError::Setting {
        key: "T",
        value: format!("{t_end:e}"),
        rule: format!(
            "gives the step h = T / 2^{finest} = {h:e} on the finest level: every step must be at \
             least {MIN_STEP:e} (2^-511), else the squared differences of the levels underflow"
        ),
    })
}

impl MlmcSettings {
    /// The scene's settings (its `[mlmc]` table, or the defaults), seed 2026 and every core (at
    /// most [`MAX_THREADS`]).
    pub fn for_scene(scene: &Scene) -> Self {
        Self {
            spec: scene.mlmc.clone().unwrap_or_default(),
            t_end: scene.t_end,
            seed: 2026,
            threads: std::thread::available_parallelism()
                .map_or(1, |n| n.get())
                .min(MAX_THREADS),
            initial_samples: 1024,
            standard_run: true,
            qmc: None,
        }
    }

    /// A quick run for CI: two test levels fewer, 1024 test samples and the two largest eps.
    pub fn quick(mut self) -> Self {
        let s = &mut self.spec;
        s.test_levels = s.test_levels.saturating_sub(2).max(2);
        s.test_samples = s.test_samples.min(1024);
        s.eps.sort_by(|a, b| b.total_cmp(a));
        s.eps.truncate(2);
        self.initial_samples = self.initial_samples.min(256);
        self
    }

    /// Checks every setting before anything runs, naming a bad one by its scene-file key
    /// (`mlmc.coarsest`, `T`, `threads`): the accuracies (finite, at least
    /// [`MIN_EPS`](sdae_mlmc::error::MIN_EPS)), the levels (their step exponents summed in
    /// checked arithmetic, at most [`MAX_STEP_EXPONENT`]), the smallest step T / 2^(k0 + L_max)
    /// at least [`MIN_STEP`], the threads (at most [`MAX_THREADS`]), and the convergence
    /// test's samples within the memory available ([`samples_exceed_memory`]).
    pub fn validate(&self) -> Result<(), MlmcError> {
        if let Some(qmc) = &self.qmc {
            qmc.validate()?;
        }
        self.validate_eps_and_time()?;
        let finest = self.finest_exponent()?;
        check_step(self.t_end, finest)?;
        self.validate_test()?;
        if self.threads == 0 || self.threads > MAX_THREADS {
            return setting(
                "threads",
                self.threads.to_string(),
                format!("must be in 1..={MAX_THREADS}"),
            );
        }
        let s = &self.spec;
        if SchemeKind::from_name(&s.scheme).is_none() {
            return setting(
                "mlmc.scheme",
                s.scheme.clone(),
                format!(
                    "one of {}",
                    SchemeKind::ALL.map(SchemeKind::name).join(", ")
                ),
            );
        }
        Ok(())
    }

    /// Checks the accuracies (at least one, each as [`check_eps`] does) and the final time
    /// (finite and > 0).
    fn validate_eps_and_time(&self) -> Result<(), MlmcError> {
        let s = &self.spec;
        if s.eps.is_empty() {
            return setting("mlmc.eps", "[]".into(), "at least one accuracy".into());
        }
        for &eps in &s.eps {
            check_eps(eps)?;
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return setting(
                "T",
                self.t_end.to_string(),
                "the final time must be finite and > 0".into(),
            );
        }
        Ok(())
    }

    /// The step exponent k0 + L_max of the finest level, checked: level 0 on at least 2 steps
    /// and at most 2^[`MAX_STEP_EXPONENT`] (else `mlmc.coarsest` is refused), and the sum in
    /// checked arithmetic at most [`MAX_STEP_EXPONENT`] (else `mlmc.max_level`).
    fn finest_exponent(&self) -> Result<u32, MlmcError> {
        let s = &self.spec;
        if s.coarsest == 0 {
            return setting(
                "mlmc.coarsest",
                "0".into(),
                "level 0 must have at least 2 steps (coarsest >= 1): one step of the \
                 half-explicit schemes moves the position by h v_0 alone, so P_0 of a \
                 position observable has no variance and N_l ~ sqrt(V_l) gives level 0 \
                 no samples"
                    .into(),
            );
        }
        let reach = u64::from(s.coarsest) + u64::from(s.max_level);
        if s.coarsest > MAX_STEP_EXPONENT {
            return setting(
                "mlmc.coarsest",
                s.coarsest.to_string(),
                format!(
                    "level 0 on 2^{} steps is above the 2^{MAX_STEP_EXPONENT} steps per path a \
                     level may have (with levels 0..={} the finest would have 2^{reach} steps)",
                    s.coarsest, s.max_level
                ),
            );
        }
        let finest = s
            .coarsest
            .checked_add(s.max_level)
            .filter(|&k| k <= MAX_STEP_EXPONENT);
        let Some(finest) = finest else {
            return setting(
                "mlmc.max_level",
                s.max_level.to_string(),
                format!(
                    "the levels 0..={} on 2^{} steps at level 0 reach 2^{reach} steps per path \
                     at the finest, above 2^{MAX_STEP_EXPONENT}",
                    s.max_level, s.coarsest
                ),
            );
        };
        Ok(finest)
    }

    /// Checks the convergence test: at least 3 levels within L_max, at least 2 samples per
    /// level (of the test and initially), and its samples within the memory available.
    fn validate_test(&self) -> Result<(), MlmcError> {
        let s = &self.spec;
        if s.test_levels < 2 || s.test_levels > s.max_level {
            return setting(
                "mlmc.test_levels",
                s.test_levels.to_string(),
                format!(
                    "the convergence test's levels 0..={} must number at least 3 and stay \
                     within L_max = {}",
                    s.test_levels, s.max_level
                ),
            );
        }
        if s.test_samples < 2 || self.initial_samples < 2 {
            return setting(
                "mlmc.test_samples",
                s.test_samples.min(self.initial_samples).to_string(),
                "at least 2 samples per level".into(),
            );
        }
        let test = vec![s.test_samples as f64; s.test_levels as usize + 1];
        if let Some(rule) = samples_exceed_memory(&test, "the convergence test's levels") {
            return setting("mlmc.test_samples", s.test_samples.to_string(), rule);
        }
        Ok(())
    }

    /// Checks a plan against these settings before it runs, naming what is wrong by the plan's
    /// key: its eps as [`check_eps`] does, at least one level, at most
    /// [`MAX_STEP_EXPONENT`] - k0 levels above level 0 (so at most 2^24 steps per path), the
    /// smallest step T / 2^(k0 + L) at least [`MIN_STEP`], at least 2 samples per level, and
    /// all its samples within the memory available ([`samples_exceed_memory`]).
    pub fn validate_plan(&self, plan: &Plan) -> Result<(), MlmcError> {
        check_eps(plan.eps).map_err(|e| match e {
            MlmcError::Eps { value } => MlmcError::Setting {
                key: "plan.eps",
                value: value.to_string(),
                rule: "the accuracy must be finite and > 0".into(),
            },
            MlmcError::Setting { value, rule, .. } => MlmcError::Setting {
                key: "plan.eps",
                value,
                rule,
            },
            other => other,
        })?;
        let Some(top) = plan.samples.len().checked_sub(1) else {
            return setting("plan.samples", "[]".into(), "names no level".into());
        };
        let k0 = self.spec.coarsest;
        let finest = u32::try_from(top)
            .ok()
            .and_then(|l| k0.checked_add(l))
            .filter(|&k| k <= MAX_STEP_EXPONENT);
        let Some(finest) = finest else {
            return setting(
                "plan.samples",
                format!("{} levels", plan.samples.len()),
                format!(
                    "levels 0..={top} on 2^{k0} steps at level 0 reach 2^{} steps per path, \
                     above 2^{MAX_STEP_EXPONENT}: at most {} levels",
                    top as u64 + u64::from(k0),
                    MAX_STEP_EXPONENT.saturating_sub(k0) + 1
                ),
            );
        };
        check_step(self.t_end, finest)?;
        if let Some((l, n)) = plan.samples.iter().enumerate().find(|(_, n)| **n < 2) {
            return setting(
                "plan.samples",
                format!("{n} at level {l}"),
                "at least 2 samples per level".into(),
            );
        }
        let samples: Vec<f64> = plan.samples.iter().map(|&n| n as f64).collect();
        if let Some(rule) = samples_exceed_memory(&samples, "the plan's levels") {
            let total: u128 = plan.samples.iter().map(|&n| u128::from(n)).sum();
            return setting("plan.samples", format!("{total} in all"), rule);
        }
        Ok(())
    }

    /// [`Self::validate`], and the observable checked against the scene (its system has it,
    /// and the scene computes the outputs it reads): every input error before anything runs.
    pub fn validate_for(&self, scene: &Scene) -> Result<(), MlmcError> {
        self.validate()?;
        crate::observable::check(scene, &self.spec.observable)?;
        Ok(())
    }
}

/// The randomized QMC part of an MLMC study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QmcSettings {
    /// Randomizations R per level (at least 2; Giles and Waterhouse take 32).
    pub randomizations: u32,
    /// Points n_0 of each randomization when a level is first run (a power of two).
    pub initial_points: u64,
}

impl Default for QmcSettings {
    /// R = 32 randomizations of n_0 = 32 points (one block of paths per randomization).
    fn default() -> Self {
        Self {
            randomizations: 32,
            initial_points: 32,
        }
    }
}

impl QmcSettings {
    /// Checks R >= 2 and n_0 a power of two.
    pub fn validate(&self) -> Result<(), MlmcError> {
        check_design(
            self.randomizations,
            self.initial_points,
            "mlqmc.initial_points",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> MlmcSettings {
        MlmcSettings::for_scene(&Scene::built_in("pendulum").unwrap())
    }

    fn key_of(e: MlmcError) -> &'static str {
        match e {
            MlmcError::Setting { key, .. } => key,
            other => panic!("not a setting: {other}"),
        }
    }

    #[test]
    fn settings_are_bounded_in_checked_arithmetic() {
        let mut s = settings();
        assert_eq!(s.validate(), Ok(()));
        s.spec.coarsest = u32::MAX;
        s.spec.max_level = 2;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("2^4294967297 steps"), "{err}");
        assert_eq!(key_of(err), "mlmc.coarsest");
        s.spec.coarsest = 20;
        s.spec.max_level = 12;
        assert_eq!(key_of(s.validate().unwrap_err()), "mlmc.max_level");
        s.spec.coarsest = 2;
        s.spec.max_level = u32::MAX;
        assert_eq!(key_of(s.validate().unwrap_err()), "mlmc.max_level");
        let mut s = settings();
        s.spec.test_samples = 1_000_000_000_000;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("available"), "{err}");
        assert_eq!(key_of(err), "mlmc.test_samples");
        let mut s = settings();
        s.threads = MAX_THREADS + 1;
        assert_eq!(key_of(s.validate().unwrap_err()), "threads");
        let mut s = settings();
        s.t_end = 5e-324;
        let err = s.validate().unwrap_err();
        assert!(err.to_string().contains("2^-511"), "{err}");
        assert_eq!(key_of(err), "T");
        s.t_end = MIN_STEP * 2f64.powi(14);
        assert_eq!(s.validate(), Ok(()));
        s.t_end /= 2.0;
        assert_eq!(key_of(s.validate().unwrap_err()), "T");
    }

    #[test]
    fn plans_are_checked_before_they_run() {
        let s = settings();
        let plan = |eps: f64, samples: Vec<u64>| Plan { eps, samples };
        assert_eq!(s.validate_plan(&plan(1e-2, vec![4096, 1024, 256])), Ok(()));
        let refused = |p: Plan, words: &[&str]| {
            let err = s.validate_plan(&p).unwrap_err();
            let message = err.to_string();
            for w in words {
                assert!(message.contains(w), "'{w}' not in {message}");
            }
        };
        refused(plan(1e-2, vec![]), &["plan.samples = []", "names no level"]);
        refused(
            plan(-1.0, vec![64; 3]),
            &["plan.eps = -1", "finite and > 0"],
        );
        refused(plan(f64::NAN, vec![64; 3]), &["plan.eps = NaN"]);
        refused(plan(1e-300, vec![64; 3]), &["plan.eps = 1e-300", "2^-511"]);
        refused(
            plan(1e-2, vec![64; 40]),
            &[
                "plan.samples = 40 levels",
                "at most 23 levels",
                "2^41 steps",
            ],
        );
        refused(plan(1e-2, vec![64, 1, 64]), &["1 at level 1", "at least 2"]);
        refused(
            plan(1e-2, vec![1_000_000_000_000_000_000, 64]),
            &["plan.samples", "in all", "available"],
        );
        refused(
            plan(1e-2, vec![u64::MAX; 23]),
            &["plan.samples", "available"],
        );
    }
}
