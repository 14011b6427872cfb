//! The `[mlmc]` table of a scene, and which MLMC errors a user's input caused.

use sdae_mlmc::MlmcError;
use serde::{Deserialize, Serialize};

use crate::error::StudyError;

impl From<StudyError> for MlmcError {
    fn from(e: StudyError) -> Self {
        MlmcError::sampler(e)
    }
}

/// The study's error inside an MLMC error, if it carries one.
pub fn study_error(e: &MlmcError) -> Option<&StudyError> {
    e.sampler_error::<StudyError>()
}

/// Whether an MLMC error was caused by the input (a setting, a file), before anything ran.
pub fn caused_by_input(e: &MlmcError) -> bool {
    match e {
        MlmcError::Sampler(_) => study_error(e).is_some_and(|e| {
            matches!(
                e,
                StudyError::Setting { .. }
                    | StudyError::Format { .. }
                    | StudyError::Io { .. }
                    | StudyError::Invalid { .. }
                    | StudyError::Unknown(_)
                    | StudyError::SchemeNotApplicable { .. }
                    | StudyError::Read { .. }
                    | StudyError::Checksum { .. }
                    | StudyError::UnknownObservable { .. }
                    | StudyError::ObservableNeedsOutput { .. }
            )
        }),
        MlmcError::Interrupted | MlmcError::Threads { .. } => false,
        _ => true,
    }
}

/// The `[mlmc]` table of a scene: what an MLMC study of it estimates and on which levels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MlmcSpec {
    /// The observable f of E[f(X_T)] (a built-in observable of the scene's system: `cos_angle`, `end_to_end`, ...).
    #[serde(default = "default_observable")]
    pub observable: String,
    /// Level 0 has 2^k0 steps.
    #[serde(default = "default_coarsest")]
    pub coarsest: u32,
    /// The finest level the algorithm may add (L_max).
    #[serde(default = "default_max_level")]
    pub max_level: u32,
    /// Levels 0..=this of the convergence test.
    #[serde(default = "default_test_levels")]
    pub test_levels: u32,
    /// Samples per level of the convergence test.
    #[serde(default = "default_test_samples")]
    pub test_samples: u64,
    /// The accuracies of the complexity table (root mean square error eps).
    #[serde(default = "default_eps")]
    pub eps: Vec<f64>,
    /// The scheme on both paths of a pair.
    #[serde(default = "default_scheme")]
    pub scheme: String,
    /// Antithetic fine paths (for multiplicative noise).
    #[serde(default)]
    pub antithetic: bool,
}

fn default_observable() -> String {
    "cos_angle".into()
}
fn default_coarsest() -> u32 {
    2
}
fn default_max_level() -> u32 {
    12
}
fn default_test_levels() -> u32 {
    6
}
fn default_test_samples() -> u64 {
    4096
}
fn default_eps() -> Vec<f64> {
    vec![1e-2, 5e-3, 2e-3, 1e-3]
}
fn default_scheme() -> String {
    "half-explicit-practical".into()
}

impl Default for MlmcSpec {
    fn default() -> Self {
        Self {
            observable: default_observable(),
            coarsest: default_coarsest(),
            max_level: default_max_level(),
            test_levels: default_test_levels(),
            test_samples: default_test_samples(),
            eps: default_eps(),
            scheme: default_scheme(),
            antithetic: false,
        }
    }
}
