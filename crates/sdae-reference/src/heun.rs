//! Stochastic Heun: trapezoidal drift with an Euler-Maruyama predictor on the same increment.

use sdae_lanes::{PathMask, Real};
use sdae_model::{KernelState, StepOutcome, StepResult};

use crate::error::ReferenceError;
use crate::euler::{EulerCore, euler_step, finished};
use crate::inherent::{CurvedSystem, InherentSde};
use crate::kernel::{EulerParts, InherentKernel, Next, Parts, Stepped};
use crate::updates;

/// One stochastic Heun step (see [`StochasticHeun`]), written once over [`Real`]: the
/// Euler-Maruyama predictor X~ = (r~, v~) into `next` ([`euler_step`], with the parts at
/// (r, v) in `parts`), the drift parts at X~ into `predictor`, then in place of X~
///
/// ```text
/// r' = r + h/2 (v + v~),   v' = v + h/2 (accel + accel~) + noise_v,
/// dmu = h/2 (mu_rate + mu_rate~) + noise_mu
/// ```
///
/// The paths where the predictor, the parts at it and the result are defined and finite are
/// decided.
#[inline(always)]
pub(crate) fn heun_step<T: Real, K: InherentKernel<T>>(
    kernel: &mut K, state: KernelState<'_, T>, h: f64, parts: &mut Parts<'_, T>,
    predictor: &mut Parts<'_, T>, next: &mut Next<'_, T>,
) -> Result<Stepped<T>, K::Error> {
    let predicted = euler_step(kernel, state, h, None, parts, next)?;
    let at_predictor = kernel.parts(next.r, next.v, &[], predictor)?;
    let KernelState { r, v, .. } = state;
    let half = v[0].splat_like(0.5 * h);
    let state = r.iter().zip(v);
    let accel = parts.accel.iter().zip(predictor.accel.iter());
    let out = next.r.iter_mut().zip(next.v.iter_mut());
    for (((nr, nv), (ri, vi)), ((a, a_tilde), noise)) in
        out.zip(state).zip(accel.zip(parts.noise_v.iter()))
    {
        let v_tilde = *nv;
        *nr = updates::heun_position(*ri, *vi, v_tilde, half);
        *nv = updates::heun_velocity(*vi, *a, *a_tilde, *noise, half);
    }
    let rates = parts.mu_rate.iter().zip(predictor.mu_rate.iter());
    for (d, ((rate, rate_tilde), noise)) in
        next.dmu.iter_mut().zip(rates.zip(parts.noise_mu.iter()))
    {
        *d = updates::heun_multiplier(*rate, *rate_tilde, *noise, half);
    }
    let ok = predicted.ok.and(at_predictor).and(finished(kernel, next)?);
    Ok(Stepped { ok, ..predicted })
}

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
    predictor: EulerParts<Vec<f64>>,
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
        let (mut kernel, mut parts, mut next) = self.core.checked(r, v, h, dw)?;
        let mut predictor = self.predictor.view();
        let state = KernelState { r, v, dw };
        heun_step(&mut kernel, state, h, &mut parts, &mut predictor, &mut next)?;
        Ok(StepOutcome::PLAIN)
    }
}

inherent_scheme!(StochasticHeun);
