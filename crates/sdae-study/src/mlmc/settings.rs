//! The `[mlmc]` table of a scene and the errors of an MLMC study.

use serde::{Deserialize, Serialize};

use crate::error::StudyError;

/// Why an MLMC study refused to run or stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MlmcError {
    /// An accuracy eps that is not finite and > 0.
    #[error("eps = {value}: the accuracy must be finite and > 0")]
    Eps {
        /// The value given.
        value: f64,
    },
    /// Levels the scene cannot run.
    #[error("levels: {reason}")]
    Levels {
        /// What is wrong, with the numbers.
        reason: String,
    },
    /// Another setting out of range.
    #[error("{key} = {value}: {rule}")]
    Setting {
        /// The setting.
        key: &'static str,
        /// The value given.
        value: String,
        /// What it must satisfy.
        rule: String,
    },
    /// Shard files that do not make up one run, or a plan that does not fit the run.
    #[error("cannot merge the MLMC shards: {reason}")]
    Merge {
        /// What does not fit.
        reason: String,
    },
    /// A stop signal arrived; no result was written.
    #[error("interrupted")]
    Interrupted,
    /// An error of the study machinery (scene, scheme, threads, files).
    #[error(transparent)]
    Study(#[from] StudyError),
}

impl MlmcError {
    /// Whether the error was caused by the input (a setting, a file), before anything ran.
    pub fn is_input(&self) -> bool {
        match self {
            MlmcError::Study(e) => matches!(
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
            ),
            MlmcError::Interrupted => false,
            _ => true,
        }
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

/// The smallest accuracy eps: 2^-511 = sqrt(f64::MIN_POSITIVE), about 1.5e-154. Below it the
/// mean square error eps^2 that the sample counts N_l ~ 2 V_l / eps^2 divide by is not a
/// normal float (0 or subnormal), and the counts are infinite or meaningless.
pub const MIN_EPS: f64 = 1.4916681462400413e-154;

/// Checks an accuracy: finite and > 0, and at least [`MIN_EPS`] (its square a normal float).
pub fn check_eps(eps: f64) -> Result<f64, MlmcError> {
    if !(eps.is_finite() && eps > 0.0) {
        return Err(MlmcError::Eps { value: eps });
    }
    if eps < MIN_EPS {
        return Err(MlmcError::Setting {
            key: "mlmc.eps",
            value: format!("{eps:e}"),
            rule: format!(
                "eps^2 = {:e} is not a normal float, so the sample counts 2 V_l / eps^2 \
                 overflow: the accuracy must be at least {MIN_EPS:e} (2^-511)",
                eps * eps
            ),
        });
    }
    Ok(eps)
}

/// Bytes a run holds for each block of samples it takes: the block's index and sums while its
/// level runs, and its key and sums in the checkpoint's journal (which keeps every block of
/// the run).
pub const BLOCK_BYTES: u64 = (size_of::<u64>()
    + 2 * size_of::<super::sums::LevelSums>()
    + size_of::<super::sampler::BlockKey>()) as u64;

/// `None` when a run that takes `samples` samples per level (counts as reals: predicted ones
/// may be huge, infinite or not a number, which counts as infinite) fits in the memory available, else the rule it breaks: the samples
/// and blocks it needs and the bytes they take ([`BLOCK_BYTES`] per block of
/// [`BLOCK`](super::sampler::BLOCK) samples), against what the machine has. Overflow-free: the
/// count is summed in f64 and compared before it is converted.
pub fn samples_exceed_memory(samples: &[f64], what: &str) -> Option<String> {
    let block = super::sampler::BLOCK as f64;
    // A count that is not a number is no count a run can hold.
    let count = |n: f64| {
        if n.is_nan() {
            f64::INFINITY
        } else {
            n.max(0.0)
        }
    };
    let blocks: f64 = samples.iter().map(|&n| (count(n) / block).ceil()).sum();
    let total: f64 = samples.iter().map(|&n| count(n)).sum();
    let (limit, source) = crate::memory::available();
    let bytes = blocks * BLOCK_BYTES as f64;
    (bytes.is_nan() || bytes > limit as f64).then(|| {
        format!(
            "{what} take {total:.3e} samples in {blocks:.3e} blocks of {}, which need at least \
             {}, more than the {} available ({source})",
            super::sampler::BLOCK,
            if bytes < u64::MAX as f64 {
                crate::memory::bytes(bytes as u64)
            } else {
                format!("{bytes:.3e} B")
            },
            crate::memory::bytes(limit)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_accuracy_is_the_square_root_of_the_smallest_normal_float() {
        assert_eq!(MIN_EPS, f64::MIN_POSITIVE.sqrt());
        assert!((MIN_EPS * MIN_EPS).is_normal());
        assert_eq!(check_eps(MIN_EPS), Ok(MIN_EPS));
        let err = check_eps(1e-300).unwrap_err();
        let message = err.to_string();
        assert!(
            message.starts_with("mlmc.eps = 1e-300: eps^2 = 0e0 is not a normal float"),
            "{message}"
        );
        assert_eq!(check_eps(-1.0), Err(MlmcError::Eps { value: -1.0 }));
    }

    #[test]
    fn sample_counts_beyond_the_memory_are_named_without_overflow() {
        assert_eq!(samples_exceed_memory(&[4096.0; 7], "the test"), None);
        for huge in [1e12, 1e18, 1e300, f64::INFINITY, f64::NAN] {
            let rule = samples_exceed_memory(&[1024.0, huge], "the plan's levels")
                .unwrap_or_else(|| panic!("{huge} samples accepted"));
            assert!(rule.starts_with("the plan's levels take "), "{rule}");
            assert!(rule.contains("available"), "{rule}");
        }
        // The bytes of a block: its index, its sums twice (in flight and in the journal), its
        // key.
        assert!(BLOCK_BYTES >= 8 + 2 * size_of::<super::super::sums::LevelSums>() as u64);
    }
}
