//! Stochastic Heun: trapezoidal drift with an Euler-Maruyama predictor on the same increment.

use crate::error::ReferenceError;
use crate::euler::{EulerCore, EulerParts};
use crate::inherent::{CurvedSystem, InherentSde};
use crate::updates;
use sdae_model::{StepOutcome, StepResult};

/// Stochastic Heun for the inherent SDE (seed eq. 2.4) as an SDE in R^{2n},
/// dX = f(X) dt + sigma(X) dw with f, sigma of Lemma 4.2:
///
/// ```text
/// X~  = X + f(X) h + sigma(X) dw                              (predictor: Euler-Maruyama)
/// X'  = X + [f(X) + f(X~)] h / 2 + sigma(X) dw                (trapezoidal drift, same dw)
/// dmu = [rate(X) + rate(X~)] h / 2 - G_M(r)^-1 Dg(r) M^-1 B dw (eq. 2.3, same quadrature)
/// ```
///
/// Why not Milstein: the noise enters only the velocity equation, sigma = (0, M^-1 P_M(r) B).
/// The Milstein correction is sum_{j,k} (L^j sigma_k) I_(j,k) with L^j = sum_i sigma_ij d/dx_i;
/// sigma_ij is zero in the position block, so L^j differentiates only in v, and if B depends
/// on r alone (additive noise, the pendulum, Langevin dynamics) sigma does not depend on v:
/// L^j sigma_k = 0. Euler-Maruyama then already is the Milstein scheme, of strong order 1, and
/// the next terms of the Ito-Taylor expansion need the area-type integral int_0^h w ds, which
/// the increments alone do not determine (Clark-Cameron): no method that uses only dw has
/// strong order above 1. What can be improved is the drift: Heun's trapezoidal rule has
/// deterministic order 2, so the error constant is smaller when the drift dominates.
///
/// Expected strong order: 1 when B does not depend on v (order 2 without noise). If B depends
/// on v the diffusion is still evaluated at the left point, so the method stays consistent
/// with the Ito SDE, but only with strong order 1/2. The drift is not truncated: large steps
/// can blow up ([`ReferenceError::NonFinite`]).
#[derive(Debug, Clone)]
pub struct StochasticHeun<S: CurvedSystem> {
    core: EulerCore<S>,
    /// The drift parts at the predictor X~.
    predictor: EulerParts,
}

impl<S: CurvedSystem> StochasticHeun<S> {
    /// The solver for `system`; fails unless 1 <= m < n and the mass has order n.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        let core = EulerCore::new(system)?;
        let (n, m) = (core.sde.dim(), core.sde.n_constraints());
        Ok(Self {
            core,
            predictor: EulerParts::new(n, m),
        })
    }
}

impl<S: CurvedSystem> StochasticHeun<S> {
    /// One stochastic Heun step (see the type's documentation), proposed.
    fn propose(&mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> StepResult {
        let core = &mut self.core;
        // Predictor X~ = X + f(X) h + sigma(X) dw into core.next_r, core.next_v.
        core.propose(r, v, h, dw, |_, _| 1.0)?;
        self.predictor
            .evaluate(&mut core.sde, &core.next_r, &core.next_v, None)?;
        // Corrector, element by element over the predictor's buffers.
        let half = 0.5 * h;
        let parts = &core.parts;
        for i in 0..r.len() {
            let v_tilde = core.next_v[i];
            core.next_r[i] = updates::heun_position(r[i], v[i], v_tilde, half);
            core.next_v[i] = updates::heun_velocity(
                v[i],
                parts.accel[i],
                self.predictor.accel[i],
                parts.noise_v[i],
                half,
            );
        }
        for (((d, rate0), rate1), noise) in core
            .dmu
            .iter_mut()
            .zip(&parts.mu_rate)
            .zip(&self.predictor.mu_rate)
            .zip(&parts.noise_mu)
        {
            *d = updates::heun_multiplier(*rate0, *rate1, *noise, half);
        }
        core.check_proposal()?;
        Ok(StepOutcome::PLAIN)
    }
}

inherent_scheme!(StochasticHeun);
