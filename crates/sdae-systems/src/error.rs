//! The error type of this crate and the parameter checks that produce it.

use sdae_manifold::ManifoldError;
use sdae_model::ModelError;
use thiserror::Error;

/// A parameter set that does not describe a valid system.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SystemError {
    /// A scalar parameter breaks its rule.
    #[error("invalid parameter {name} = {value}: {rule}")]
    InvalidParameter {
        /// Parameter name, as in the parameter struct.
        name: &'static str,
        /// The offending value (counts converted to f64).
        value: f64,
        /// What the parameter must satisfy.
        rule: &'static str,
    },
    /// An entry of a list parameter breaks its rule.
    #[error("invalid entry {index} of {name} = {value}: {rule}")]
    InvalidEntry {
        /// Parameter name, as in the parameter struct.
        name: &'static str,
        /// Index of the first offending entry.
        index: usize,
        /// Its value.
        value: f64,
        /// What each entry must satisfy.
        rule: &'static str,
    },
    /// A list parameter has the wrong number of entries.
    #[error("{name} has {found} entries, expected {expected}")]
    WrongLength {
        /// Parameter name, as in the parameter struct.
        name: &'static str,
        /// Number of entries the system needs.
        expected: usize,
        /// Number of entries given.
        found: usize,
    },
    /// The constraint or the mass matrix could not be built.
    #[error(transparent)]
    Manifold(#[from] ManifoldError),
    /// The parts of the system do not fit together.
    #[error(transparent)]
    Model(#[from] ModelError),
}

impl SystemError {
    /// The name of the parameter at fault (`None` for errors of the constraint or the mass).
    pub fn parameter(&self) -> Option<&'static str> {
        match self {
            Self::InvalidParameter { name, .. }
            | Self::InvalidEntry { name, .. }
            | Self::WrongLength { name, .. } => Some(name),
            Self::Manifold(_) | Self::Model(_) => None,
        }
    }
}

/// Fails unless `value` is finite and >= 0.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<f64, SystemError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SystemError::InvalidParameter {
            name,
            value,
            rule: "must be finite and >= 0",
        })
    }
}

/// Fails unless `value` is finite and > 0.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, SystemError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SystemError::InvalidParameter {
            name,
            value,
            rule: "must be finite and > 0",
        })
    }
}

/// Fails unless `value` is finite.
pub(crate) fn finite(name: &'static str, value: f64) -> Result<f64, SystemError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SystemError::InvalidParameter {
            name,
            value,
            rule: "must be finite",
        })
    }
}

/// Fails unless every entry is finite; names the first that is not.
pub(crate) fn finite_entries(name: &'static str, values: &[f64]) -> Result<(), SystemError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(SystemError::InvalidEntry {
            name,
            index,
            value: values[index],
            rule: "must be finite",
        }),
    }
}

/// The most particles (atoms, beads) a built-in system takes: 10^6, a state of 3 x 10^6
/// coordinates (24 MB per vector). Larger counts are refused before anything is allocated.
pub const MAX_PARTICLES: usize = 1_000_000;

/// Fails unless `min` <= `value` <= [`MAX_PARTICLES`] (`rule` says what `min` is for).
pub(crate) fn particle_count(
    name: &'static str, value: usize, min: usize, rule: &'static str,
) -> Result<usize, SystemError> {
    let rule = if value < min {
        rule
    } else if value > MAX_PARTICLES {
        "must be at most 10^6 (MAX_PARTICLES)"
    } else {
        return Ok(value);
    };
    Err(SystemError::InvalidParameter {
        name,
        value: value as f64,
        rule,
    })
}
