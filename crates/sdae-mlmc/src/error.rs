//! Why an MLMC run refused to start or stopped, and the bounds on the accuracy and the memory
//! that a run is checked against before it starts.

use std::sync::Arc;

/// Why an MLMC run refused to start or stopped.
#[derive(Debug, Clone, thiserror::Error)]
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
    /// The worker threads could not be started.
    #[error("cannot start {threads} worker threads: {message}")]
    Threads {
        /// How many were asked for.
        threads: usize,
        /// The thread pool's message.
        message: String,
    },
    /// An error of the model being sampled (building a worker, running its paths), kept whole:
    /// its caller recovers it with [`MlmcError::sampler_error`].
    #[error(transparent)]
    Sampler(Arc<dyn std::error::Error + Send + Sync + 'static>),
}

impl MlmcError {
    /// A sampler's own error, kept whole in [`MlmcError::Sampler`].
    pub fn sampler(error: impl std::error::Error + Send + Sync + 'static) -> Self {
        MlmcError::Sampler(Arc::new(error))
    }

    /// The sampler's error of type `E`, if this is one.
    pub fn sampler_error<E: std::error::Error + 'static>(&self) -> Option<&E> {
        match self {
            MlmcError::Sampler(e) => e.downcast_ref::<E>(),
            _ => None,
        }
    }

    /// The setting a [`MlmcError::Setting`] names, if this is one.
    pub fn setting_key(&self) -> Option<&'static str> {
        match self {
            MlmcError::Setting { key, .. } => Some(key),
            _ => None,
        }
    }
}

/// Equal when of the same kind with the same values; two sampler errors are equal when they
/// are the same error or say the same.
impl PartialEq for MlmcError {
    fn eq(&self, other: &Self) -> bool {
        use MlmcError::*;
        match (self, other) {
            (Eps { value: a }, Eps { value: b }) => a == b,
            (Levels { reason: a }, Levels { reason: b })
            | (Merge { reason: a }, Merge { reason: b }) => a == b,
            (
                Setting {
                    key: k,
                    value: v,
                    rule: r,
                },
                Setting {
                    key: k2,
                    value: v2,
                    rule: r2,
                },
            ) => (k, v, r) == (k2, v2, r2),
            (Interrupted, Interrupted) => true,
            (
                Threads {
                    threads: a,
                    message: m,
                },
                Threads {
                    threads: b,
                    message: n,
                },
            ) => (a, m) == (b, n),
            (Sampler(a), Sampler(b)) => Arc::ptr_eq(a, b) || a.to_string() == b.to_string(),
            _ => false,
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
    + 2 * size_of::<crate::sums::LevelSums>()
    + size_of::<crate::sampler::BlockKey>()) as u64;

/// `None` when a run that takes `samples` samples per level (counts as reals: predicted ones
/// may be huge, infinite or not a number, which counts as infinite) fits in the memory available, else the rule it breaks: the samples
/// and blocks it needs and the bytes they take ([`BLOCK_BYTES`] per block of
/// [`BLOCK`](crate::sampler::BLOCK) samples), against what the machine has. Overflow-free: the
/// count is summed in f64 and compared before it is converted.
pub fn samples_exceed_memory(samples: &[f64], what: &str) -> Option<String> {
    let block = crate::sampler::BLOCK as f64;
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
    let (limit, source) = sdae_stats::memory::available();
    let bytes = blocks * BLOCK_BYTES as f64;
    (bytes.is_nan() || bytes > limit as f64).then(|| {
        format!(
            "{what} take {total:.3e} samples in {blocks:.3e} blocks of {}, which need at least \
             {}, more than the {} available ({source})",
            crate::sampler::BLOCK,
            if bytes < u64::MAX as f64 {
                sdae_stats::memory::bytes(bytes as u64)
            } else {
                format!("{bytes:.3e} B")
            },
            sdae_stats::memory::bytes(limit)
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
        assert!(BLOCK_BYTES >= 8 + 2 * size_of::<crate::sums::LevelSums>() as u64);
    }
}
