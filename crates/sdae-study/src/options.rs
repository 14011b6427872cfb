//! What a caller changes of a scene's study settings, in one place for every front end: the
//! command line's flags and the Python package's keywords are turned into these options, and
//! the options into settings by the same code, so that one request gives the same study
//! whichever way it came.
//!
//! Every field left at `None` (or empty, or false) keeps the scene's value.

use crate::StudyError;
use crate::convergence::ConvergenceSettings;
use crate::integrator::SchemeKind;
use crate::mlmc::QmcSettings;
use crate::mlmc::study::MlmcSettings;
use crate::scene::Scene;

/// Randomizations of a weak study's randomized quasi-Monte Carlo paths when none are given.
pub const WEAK_RANDOMIZATIONS: usize = 16;
/// Randomizations per level of multilevel QMC when none are given.
pub const MLQMC_RANDOMIZATIONS: u32 = 32;
/// Points of each randomization when a multilevel QMC level is first run, when none are given.
pub const MLQMC_INITIAL_POINTS: u64 = 32;

/// The options of every Monte Carlo study over paths (convergence, weak, stability).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnsembleOptions {
    /// Monte Carlo paths.
    pub paths: Option<usize>,
    /// Seed of the path streams.
    pub seed: Option<u64>,
    /// Worker threads asked for (capped by [`started_threads`]).
    pub threads: Option<usize>,
    /// A small run: fewer paths and levels, as each study's `quick` settings say.
    pub quick: bool,
}

/// The threads a study of `paths` paths starts when `threads` are asked for: at most one per
/// path and 4 per available core (the numbers do not depend on it).
pub fn started_threads(threads: usize, paths: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    threads.min(paths.max(1)).min(4 * cores)
}

impl EnsembleOptions {
    /// `s` with the paths, seed and threads given; the threads capped by [`started_threads`].
    pub fn apply(&self, mut s: ConvergenceSettings) -> ConvergenceSettings {
        s.paths = self.paths.unwrap_or(s.paths);
        s.seed = self.seed.unwrap_or(s.seed);
        s.threads = started_threads(self.threads.unwrap_or(s.threads), s.paths);
        s
    }

    /// The stability settings of `scene` ([`crate::stability::stability_settings`]) with these
    /// options; a scene without a `[stability]` table is refused.
    pub fn stability_settings(&self, scene: &Scene) -> Result<ConvergenceSettings, StudyError> {
        crate::stability::stability_settings(scene, self.quick)
            .map(|s| self.apply(s))
            .ok_or_else(|| no_table(scene, "stability"))
    }
}

/// The refusal of a study whose table `table` the scene lacks.
fn no_table(scene: &Scene, table: &str) -> StudyError {
    StudyError::Invalid {
        scene: scene.name.clone(),
        message: format!("has no [{table}] table"),
    }
}

/// The options of the convergence study.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConvergenceOptions {
    /// Paths, seed, threads, quick.
    pub ensemble: EnsembleOptions,
    /// The schemes compared (empty: all that apply).
    pub schemes: Vec<SchemeKind>,
    /// The reference's scheme.
    pub reference_scheme: Option<SchemeKind>,
    /// Step counts N = 2^a .. 2^b.
    pub levels: Option<(u32, u32)>,
    /// The reference's 2^r steps.
    pub ref_level: Option<u32>,
    /// Final time.
    pub t_end: Option<f64>,
    /// Errors are L^p norms over paths.
    pub p: Option<f64>,
}

impl ConvergenceOptions {
    /// The convergence settings of `scene`: its defaults, the levels given, then when quick at
    /// most 200 paths, five levels (unless given) and a reference 2^4 times finer than the
    /// finest, then the other options.
    pub fn settings(&self, scene: &Scene) -> ConvergenceSettings {
        let mut s = ConvergenceSettings::for_scene(scene);
        if let Some((a, b)) = self.levels {
            s.coarsest = a;
            s.finest = b;
        }
        if self.ensemble.quick {
            s.paths = s.paths.min(200);
            if self.levels.is_none() {
                s.finest = s.finest.min(s.coarsest + 4);
            }
            s.reference = Some(s.finest + 4);
        }
        if !self.schemes.is_empty() {
            s.schemes = self.schemes.clone();
        }
        s.reference_scheme = self.reference_scheme.unwrap_or(s.reference_scheme);
        s.reference = self.ref_level.or(s.reference);
        s.t_end = self.t_end.unwrap_or(s.t_end);
        s.p = self.p.unwrap_or(s.p);
        self.ensemble.apply(s)
    }
}

/// The options of the weak-error study.
#[derive(Debug, Clone, PartialEq)]
pub struct WeakOptions {
    /// Paths, seed, threads, quick.
    pub ensemble: EnsembleOptions,
    /// Randomized quasi-Monte Carlo paths with this many randomizations (`None`: Monte Carlo).
    pub randomizations: Option<usize>,
}

impl WeakOptions {
    /// The weak settings of `scene` ([`crate::weak::weak_settings`]) with these options: with
    /// R randomizations and no paths given, the paths rounded down to R n with n the largest
    /// power of two that fits (at least one point per randomization); then the paths, seed and
    /// threads ([`EnsembleOptions::apply`]). A scene without a `[weak]` table is refused.
    pub fn settings(&self, scene: &Scene) -> Result<ConvergenceSettings, StudyError> {
        let mut s = crate::weak::weak_settings(scene, self.ensemble.quick)
            .ok_or_else(|| no_table(scene, "weak"))?;
        if let Some(r) = self.randomizations {
            s.randomizations = Some(r);
            if self.ensemble.paths.is_none() && r > 0 {
                let n = (s.paths / r).max(1);
                s.paths = r * (1usize << n.ilog2());
            }
        }
        Ok(self.ensemble.apply(s))
    }
}

/// The options of the MLMC study of a scene's E[f(X_T)].
#[derive(Debug, Clone, PartialEq)]
pub struct MlmcOptions {
    /// The observable f (a built-in observable of the scene's system).
    pub observable: Option<String>,
    /// The scheme on both paths of each pair.
    pub scheme: Option<String>,
    /// The accuracies eps of the complexity table (empty: the scene's).
    pub eps: Vec<f64>,
    /// Antithetic fine paths.
    pub antithetic: bool,
    /// Level 0 on 2^k steps.
    pub coarsest: Option<u32>,
    /// The finest level the algorithm may add.
    pub max_level: Option<u32>,
    /// The convergence test runs levels 0..=L.
    pub test_levels: Option<u32>,
    /// Samples per level of the convergence test.
    pub test_samples: Option<u64>,
    /// Final time.
    pub t_end: Option<f64>,
    /// Seed of the sample streams.
    pub seed: u64,
    /// Worker threads.
    pub threads: Option<usize>,
    /// A run of seconds ([`MlmcSettings::quick`]).
    pub quick: bool,
    /// The direct standard Monte Carlo run at the largest eps.
    pub standard_run: bool,
    /// Multilevel randomized QMC beside MLMC.
    pub qmc: Option<QmcSettings>,
}

impl Default for MlmcOptions {
    fn default() -> Self {
        MlmcOptions {
            observable: None,
            scheme: None,
            eps: Vec::new(),
            antithetic: false,
            coarsest: None,
            max_level: None,
            test_levels: None,
            test_samples: None,
            t_end: None,
            seed: 2026,
            threads: None,
            quick: false,
            standard_run: true,
            qmc: None,
        }
    }
}

impl MlmcOptions {
    /// The MLMC settings of `scene` ([`MlmcSettings::for_scene`]) with these options, then
    /// [`MlmcSettings::quick`] when quick. Not checked: see [`MlmcSettings::validate_for`].
    pub fn settings(&self, scene: &Scene) -> MlmcSettings {
        let mut s = MlmcSettings::for_scene(scene);
        let spec = &mut s.spec;
        if let Some(o) = &self.observable {
            spec.observable = o.clone();
        }
        if let Some(scheme) = &self.scheme {
            spec.scheme = scheme.clone();
        }
        if !self.eps.is_empty() {
            spec.eps = self.eps.clone();
        }
        spec.antithetic |= self.antithetic;
        spec.coarsest = self.coarsest.unwrap_or(spec.coarsest);
        spec.max_level = self.max_level.unwrap_or(spec.max_level);
        spec.test_levels = self.test_levels.unwrap_or(spec.test_levels);
        spec.test_samples = self.test_samples.unwrap_or(spec.test_samples);
        s.t_end = self.t_end.unwrap_or(s.t_end);
        s.seed = self.seed;
        s.threads = self.threads.unwrap_or(s.threads);
        s.standard_run = self.standard_run;
        s.qmc = self.qmc;
        if self.quick { s.quick() } else { s }
    }
}

/// The option that sets a study setting the library names `key` (`study.paths`, `T`,
/// `mlmc.eps`), as a front end spells its options in snake case (`paths`, `t_end`, `eps`);
/// `None` for a setting no option sets.
pub fn option_of(key: &str) -> Option<&'static str> {
    Some(match key {
        "study.paths" => "paths",
        "study.levels" => "levels",
        "study.reference" => "ref_level",
        "T" => "t_end",
        "p" => "p",
        "threads" => "threads",
        "schemes" => "schemes",
        "mlmc.eps" => "eps",
        "mlmc.coarsest" => "coarsest",
        "mlmc.max_level" => "max_level",
        "mlmc.test_levels" => "test_levels",
        "mlmc.test_samples" => "test_samples",
        "mlmc.scheme" => "scheme",
        "mlqmc.randomizations" | "weak.randomizations" => "randomizations",
        "mlqmc.initial_points" => "initial_points",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pendulum() -> Scene {
        Scene::built_in("pendulum").unwrap()
    }

    #[test]
    fn no_options_keep_the_scenes_settings() {
        let scene = pendulum();
        let s = ConvergenceOptions::default().settings(&scene);
        let mut want = ConvergenceSettings::for_scene(&scene);
        want.threads = started_threads(want.threads, want.paths);
        assert_eq!(s, want);
        let m = MlmcOptions::default().settings(&scene);
        assert_eq!(m, MlmcSettings::for_scene(&scene));
    }

    #[test]
    fn quick_convergence_runs_five_levels_and_a_reference_sixteen_times_finer() {
        let scene = pendulum();
        let options = ConvergenceOptions {
            ensemble: EnsembleOptions {
                quick: true,
                paths: Some(7),
                ..EnsembleOptions::default()
            },
            ..ConvergenceOptions::default()
        };
        let s = options.settings(&scene);
        assert_eq!(s.paths, 7);
        assert_eq!(s.finest, s.coarsest + 4);
        assert_eq!(s.reference, Some(s.finest + 4));
    }

    #[test]
    fn weak_qmc_paths_are_randomizations_times_a_power_of_two() {
        let scene = pendulum();
        let options = WeakOptions {
            ensemble: EnsembleOptions::default(),
            randomizations: Some(16),
        };
        let s = options.settings(&scene).unwrap();
        let n = s.paths / 16;
        assert_eq!(s.paths % 16, 0);
        assert!(n.is_power_of_two(), "{}", s.paths);
        let plain = crate::weak::weak_settings(&scene, false).unwrap().paths;
        assert!(
            s.paths <= plain && 2 * s.paths > plain,
            "{} of {plain}",
            s.paths
        );
    }

    #[test]
    fn a_missing_table_is_refused_naming_it() {
        let fiber = Scene::built_in("fiber").unwrap();
        let weak = WeakOptions {
            ensemble: EnsembleOptions::default(),
            randomizations: None,
        };
        let e = weak.settings(&fiber).unwrap_err();
        assert!(
            e.to_string().contains("scene fiber: has no [weak] table"),
            "{e}"
        );
        let e = EnsembleOptions::default()
            .stability_settings(&pendulum())
            .unwrap_err();
        assert!(
            e.to_string()
                .contains("scene pendulum: has no [stability] table"),
            "{e}"
        );
    }

    #[test]
    fn threads_are_capped_by_the_paths_and_the_cores() {
        assert_eq!(started_threads(10_000, 8), 8);
        assert_eq!(started_threads(1, 8), 1);
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(started_threads(1024, 1 << 20), 1024.min(4 * cores));
    }

    #[test]
    fn every_option_key_names_a_snake_case_option() {
        for key in ["study.paths", "T", "mlmc.eps", "weak.randomizations"] {
            let option = option_of(key).unwrap();
            assert!(option.chars().all(|c| c.is_ascii_lowercase() || c == '_'));
        }
        assert_eq!(option_of("study.coarsest"), None);
    }
}
