//! The time grid of a path: t_k = k h, h = T / N.

use crate::error::ModelError;

/// The grid t_k = k h, h = T / N, k = 0..=N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeGrid {
    t_end: f64,
    steps: usize,
    /// h = T / N, computed once.
    h: f64,
}

impl TimeGrid {
    /// T > 0 finite, N >= 1.
    pub fn new(t_end: f64, steps: usize) -> Result<Self, ModelError> {
        if !(t_end.is_finite() && t_end > 0.0) {
            return Err(ModelError::InvalidSetting {
                name: "T",
                value: t_end,
                reason: "final time must be finite and > 0",
            });
        }
        if steps == 0 {
            return Err(ModelError::InvalidSetting {
                name: "N",
                value: 0.0,
                reason: "number of steps must be >= 1",
            });
        }
        Ok(Self {
            t_end,
            steps,
            h: t_end / steps as f64,
        })
    }
    /// T.
    pub fn t_end(&self) -> f64 {
        self.t_end
    }
    /// N.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// h = T / N.
    pub fn h(&self) -> f64 {
        self.h
    }
    /// t_k.
    pub fn time(&self, k: usize) -> f64 {
        if k == self.steps {
            self.t_end
        } else {
            k as f64 * self.h()
        }
    }
}
