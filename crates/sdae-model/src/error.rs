//! Errors shared by every scheme: bad settings and inputs ([`ModelError`]), why a step failed
//! ([`StepFailure`], classified by [`FailureKind`]), and where along a path ([`StepError`]; a
//! whole path's [`PathFailure`](crate::PathFailure) carries its diagnostics too).

use sdae_ift::IftError;
use sdae_lanes::LineVec;
use sdae_manifold::{LinearError, ManifoldError};
use sdae_noise::NoiseError;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A setting or input that a system or scheme cannot run with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// A constraint, mass or state check failed.
    #[error(transparent)]
    Manifold(#[from] ManifoldError),
    /// A setting is out of range.
    #[error("invalid setting {name} = {value}: {reason}")]
    InvalidSetting {
        /// Setting name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// Two parts of the system, or an argument and the system, do not fit together.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was compared.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// A path index at or beyond the number of paths of an ensemble.
    #[error("path index {index} out of range: the ensemble has {paths} paths (0..{paths})")]
    PathIndex {
        /// The index given.
        index: usize,
        /// The number of paths.
        paths: usize,
    },
    /// A buffer the size of the input asks for cannot be allocated (its length overflows, or
    /// the memory is not there).
    #[error("cannot allocate {what}: {len} entries of {entry_bytes} bytes")]
    Allocation {
        /// Which buffer.
        what: &'static str,
        /// Its number of entries (`usize::MAX` if that count overflows).
        len: usize,
        /// The size of one entry.
        entry_bytes: usize,
    },
}

/// The increments' bad settings and sizes ([`NoiseError`], e.g. of
/// [`EnsembleIncrements::fill`](sdae_noise::EnsembleIncrements::fill)) are the model's, with
/// the same fields and messages.
impl From<NoiseError> for ModelError {
    fn from(error: NoiseError) -> Self {
        match error {
            NoiseError::InvalidSetting {
                name,
                value,
                reason,
            } => ModelError::InvalidSetting {
                name,
                value,
                reason,
            },
            NoiseError::DimensionMismatch {
                what,
                expected,
                found,
            } => ModelError::DimensionMismatch {
                what,
                expected,
                found,
            },
        }
    }
}

/// A vector of `rows * cols` copies of `value`, or [`ModelError::Allocation`] if that length
/// overflows or the memory cannot be reserved: the buffers of an ensemble whose size comes
/// from its caller.
pub(crate) fn try_filled<T: Clone>(
    what: &'static str, value: T, rows: usize, cols: usize,
) -> Result<Vec<T>, ModelError> {
    let len = checked_len::<T>(what, rows, cols)?;
    let mut buffer = Vec::new();
    buffer
        .try_reserve_exact(len)
        .map_err(|_| allocation::<T>(what, len))?;
    buffer.resize(len, value);
    Ok(buffer)
}

/// [`try_filled`] in a buffer whose values start on a cache line ([`LineVec`]), for the
/// lanes' states.
pub(crate) fn try_lines<T: Copy>(
    what: &'static str, value: T, rows: usize, cols: usize,
) -> Result<LineVec<T>, ModelError> {
    let len = checked_len::<T>(what, rows, cols)?;
    LineVec::try_from_elem(value, len).ok_or(allocation::<T>(what, len))
}

/// rows * cols, or the allocation error of `what` where it overflows.
fn checked_len<T>(what: &'static str, rows: usize, cols: usize) -> Result<usize, ModelError> {
    rows.checked_mul(cols)
        .ok_or(allocation::<T>(what, usize::MAX))
}

/// The failure to allocate `len` entries of `T` for `what`.
fn allocation<T>(what: &'static str, len: usize) -> ModelError {
    ModelError::Allocation {
        what,
        len,
        entry_bytes: std::mem::size_of::<T>(),
    }
}

/// Fails with [`ModelError::DimensionMismatch`] unless `found == expected`.
pub fn check_dim(what: &'static str, expected: usize, found: usize) -> Result<(), ModelError> {
    if expected == found {
        Ok(())
    } else {
        Err(ModelError::DimensionMismatch {
            what,
            expected,
            found,
        })
    }
}

/// Fails with [`ModelError::InvalidSetting`] unless the step size h is finite and > 0.
pub fn check_step_size(h: f64) -> Result<(), ModelError> {
    if h.is_finite() && h > 0.0 {
        Ok(())
    } else {
        Err(ModelError::InvalidSetting {
            name: "h",
            value: h,
            reason: "step size must be finite and > 0",
        })
    }
}

/// Why a path of a scheme stopped, in the terms every report uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FailureKind {
    /// The kappa system has no root (the homotopy stops at a fold, seed Fig. 1b).
    NoRoot,
    /// A root outside the ball or implausibly far (the second root, seed Fig. 1a).
    SpuriousRoot,
    /// Newton (and the homotopy) did not converge.
    NoConvergence,
    /// A singular Jacobian or Gram matrix.
    Singular,
    /// NaN or infinite values.
    NonFinite,
    /// Finite but beyond the study's blow-up bound.
    BlowUp,
    /// |g(r)| or |Dg(r) v| beyond the study's drift tolerance.
    ConstraintDrift,
    /// Anything else (an input the solver rejected).
    Other,
}

impl FailureKind {
    /// Every kind, in report order.
    pub const ALL: [FailureKind; 8] = [
        FailureKind::NoRoot,
        FailureKind::SpuriousRoot,
        FailureKind::NoConvergence,
        FailureKind::Singular,
        FailureKind::NonFinite,
        FailureKind::BlowUp,
        FailureKind::ConstraintDrift,
        FailureKind::Other,
    ];

    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            FailureKind::NoRoot => "no-root",
            FailureKind::SpuriousRoot => "spurious-root",
            FailureKind::NoConvergence => "no-convergence",
            FailureKind::Singular => "singular",
            FailureKind::NonFinite => "non-finite",
            FailureKind::BlowUp => "blow-up",
            FailureKind::ConstraintDrift => "constraint-drift",
            FailureKind::Other => "other",
        }
    }
}

impl std::fmt::Display for FailureKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl From<&IftError> for FailureKind {
    fn from(error: &IftError) -> Self {
        match error {
            IftError::NoRoot { .. } => FailureKind::NoRoot,
            IftError::OutsideBall { .. }
            | IftError::Implausible { .. }
            | IftError::NotContracting { .. } => FailureKind::SpuriousRoot,
            IftError::NoConvergence { .. } => FailureKind::NoConvergence,
            IftError::Singular { .. } => FailureKind::Singular,
            IftError::NonFinite { .. } => FailureKind::NonFinite,
        }
    }
}

/// Why one step of a scheme failed. On failure a scheme leaves (r, v) unchanged.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StepFailure {
    /// A root solve of the step (the kappa system of seed eq. 3.1, a projection onto the
    /// manifold) found no acceptable root.
    #[error("{what}: {source}")]
    Root {
        /// Which system of equations.
        what: &'static str,
        /// The root solver's error.
        source: IftError,
    },
    /// A matrix the step factors (G_M(r), seed Section 2.1) is singular: Dg(r) lacks full rank.
    #[error("{what} is singular (Dg(r) lacks full rank): {source}")]
    Singular {
        /// Which matrix.
        what: &'static str,
        /// The factorization's error.
        source: LinearError,
    },
    /// A value became NaN or infinite (the blow-up of an untruncated drift that grows like
    /// |v|^2, seed Section 5.1, or a drift or noise that returned NaN).
    #[error("non-finite {what}: max |entry| = {size:e}")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
        /// max |entry| (NaN or infinite).
        size: f64,
    },
    /// A step input has the wrong size or value.
    #[error("invalid step input: {0}")]
    Input(#[from] ModelError),
    /// A failure of a user's scheme, classified by the scheme itself.
    #[error("{kind}: {message}")]
    Other {
        /// How reports count it.
        kind: FailureKind,
        /// What happened.
        message: String,
    },
}

impl StepFailure {
    /// How reports count this failure.
    pub fn kind(&self) -> FailureKind {
        match self {
            StepFailure::Root { source, .. } => source.into(),
            StepFailure::Singular { .. } => FailureKind::Singular,
            StepFailure::NonFinite { .. } => FailureKind::NonFinite,
            StepFailure::Input(_) => FailureKind::Other,
            StepFailure::Other { kind, .. } => *kind,
        }
    }

    /// The failure of a step whose Brownian increment `dw` has a NaN or infinite entry: a
    /// non-finite result is blamed on that input ([`StepFailure::NonFinite`] of the increment,
    /// with its largest |entry|) instead of on the quantity that showed it; any other failure
    /// is kept.
    pub fn blaming_increment(self, dw: &[f64]) -> StepFailure {
        let size = sdae_manifold::vector::max_abs(dw);
        match self {
            StepFailure::NonFinite { .. } if !size.is_finite() => StepFailure::NonFinite {
                what: "Brownian increment dw (an input of the step)",
                size,
            },
            failure => failure,
        }
    }

    /// Fails with [`StepFailure::NonFinite`] unless every entry of `values` is finite.
    pub fn check_finite(what: &'static str, values: &[f64]) -> Result<(), StepFailure> {
        let size = sdae_manifold::vector::max_abs(values);
        if size.is_finite() {
            Ok(())
        } else {
            Err(StepFailure::NonFinite { what, size })
        }
    }
}

impl From<LinearError> for StepFailure {
    fn from(source: LinearError) -> Self {
        match source {
            LinearError::NonFinite { .. } => StepFailure::NonFinite {
                what: "Gram matrix G_M(r)",
                size: f64::NAN,
            },
            LinearError::Singular { .. } => StepFailure::Singular {
                what: "Gram matrix G_M(r)",
                source,
            },
        }
    }
}

/// A step of a path failed: what, at which step and time.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("step {step} (t = {time}) failed: {failure}")]
pub struct StepError {
    /// Index k of the failing step (from t_k to t_{k+1}); 0 for checks before the first step.
    pub step: usize,
    /// t_k.
    pub time: f64,
    /// What went wrong.
    pub failure: StepFailure,
}
