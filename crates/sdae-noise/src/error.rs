//! Bad settings and inputs of the increments ([`NoiseError`]).

use thiserror::Error;

/// A setting or input that the increments cannot be drawn with.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum NoiseError {
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
    /// A buffer does not have the size the increments need.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was compared.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
}

/// Fails with [`NoiseError::InvalidSetting`] unless the step size h is finite and > 0.
pub(crate) fn check_step_size(h: f64) -> Result<(), NoiseError> {
    if h.is_finite() && h > 0.0 {
        Ok(())
    } else {
        Err(NoiseError::InvalidSetting {
            name: "h",
            value: h,
            reason: "step size must be finite and > 0",
        })
    }
}

/// The whole steps a buffer of `len` increments holds in rows of `row` = l * stride entries:
/// None when there is nothing to fill (no row, or an empty buffer), else the number of rows;
/// fails with [`NoiseError::DimensionMismatch`] unless `len` is a multiple of `row`.
pub(crate) fn whole_rows(len: usize, row: usize) -> Result<Option<usize>, NoiseError> {
    if row == 0 || len == 0 {
        return Ok(None);
    }
    if !len.is_multiple_of(row) {
        return Err(NoiseError::DimensionMismatch {
            what: "increments buffer (a multiple of dim * stride)",
            expected: len.div_ceil(row) * row,
            found: len,
        });
    }
    Ok(Some(len / row))
}
