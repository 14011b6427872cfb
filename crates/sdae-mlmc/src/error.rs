//! Why an MLMC run refused to start or stopped, and the bound on the accuracy that a run is
//! checked against before it starts (the bound on its memory is the `memory` module's).

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
}
