//! Drift-truncated Euler-Maruyama for the inherent SDE (seed Remark 3.3, after
//! Hutzenthaler-Jentzen, with the drift of Lemma 4.2).

use crate::error::ReferenceError;
use crate::euler::{EulerCore, euler_step};
use crate::inherent::{CurvedSystem, InherentSde};
use crate::updates;
use sdae_model::{KernelState, ModelError, StepOutcome, StepResult};

/// Truncated Euler-Maruyama on the inherent SDE written as an R^{2n} SDE
/// dX = f(X) dt + sigma(X) dw (seed Section 4.1, `eq:SDEstrongsetting`, with the coefficients of Lemma 4.2):
///
/// ```text
/// f(r, v)     = ( v , M^-1 [P_M(r) a(r, v) - grad g(r) G_M(r)^-1 D^2 g(r)(v, v)] )
/// sigma(r, v) = ( 0 , M^-1 P_M(r) B(r, v) )
/// theta       = min(1, c / (|f(r, v)| h)),   |f|^2 = |v|^2 + |M^-1 [...]|^2
/// X'          = X + theta f(X) h + sigma(X) dw
/// dmu         = -G_M^-1 { Dg M^-1 [a theta h + B dw] + D^2 g(v, v) theta h }   (eq. 2.3)
/// ```
///
/// with c = 1 by default (Hutzenthaler-Jentzen 2015, Section 3.6: the increment of the drift
/// is f h / max(1, |f| h)), so |theta f h| <= c and the drift can no longer produce the
/// double-exponential growth of plain Euler-Maruyama.
///
/// The formula displayed in Remark 3.3 of the seed has a typo: it reads
/// `|P_M a + Dg G_M^-1 D^2 g(v, v)|`. There `Dg(r)` (m x n) cannot act on the m-vector
/// G_M^-1 D^2 g(v, v); the term of eq. 2.4 is `- grad g(r) G_M^-1 D^2 g(v, v)` (grad g = Dg^T,
/// and a minus sign), and the velocity drift of the SDE in R^{2n} carries M^-1 (Lemma 4.2).
/// This solver uses the drift of Lemma 4.2 as written above.
#[derive(Debug, Clone)]
pub struct TruncatedEulerMaruyama<S: CurvedSystem> {
    core: EulerCore<S>,
    scale: f64,
}

impl<S: CurvedSystem> TruncatedEulerMaruyama<S> {
    /// The solver for `system` with c = 1; fails unless 1 <= m < n and the mass has order n.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        Ok(Self {
            core: EulerCore::new(system)?,
            scale: 1.0,
        })
    }

    /// Sets the truncation scale c (finite, > 0): theta = min(1, c / (|f| h)).
    pub fn with_scale(mut self, scale: f64) -> Result<Self, ReferenceError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(ModelError::InvalidSetting {
                name: "truncation scale c",
                value: scale,
                reason: "must be finite and > 0",
            }
            .into());
        }
        self.scale = scale;
        Ok(self)
    }

    /// The truncation scale c.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The truncation factor theta = min(1, c / (|f| h)).
    pub fn truncation(scale: f64, h: f64, drift_norm: f64) -> f64 {
        updates::truncation(scale, h, drift_norm)
    }
}

impl<S: CurvedSystem> TruncatedEulerMaruyama<S> {
    /// One truncated Euler-Maruyama step (see the type's documentation), proposed.
    fn propose(&mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> StepResult {
        let scale = Some(self.scale);
        let (mut kernel, mut parts, mut next) = self.core.checked(r, v, h, dw)?;
        let state = KernelState { r, v, dw };
        let stepped = euler_step(&mut kernel, state, h, scale, &mut parts, &mut next)?;
        Ok(StepOutcome {
            eta: stepped.eta,
            ..StepOutcome::PLAIN
        })
    }
}

inherent_scheme!(TruncatedEulerMaruyama);
