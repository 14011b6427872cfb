//! Euler-Maruyama on the inherent SDE (seed eq. 2.4), and the pieces of an Euler step that the
//! other solvers share.

use sdae_lanes::{PathMask, Real};
use sdae_model::{KernelState, StepOutcome, StepResult};

use crate::error::ReferenceError;
use crate::inherent::{CurvedSystem, InherentSde};
use crate::kernel::{EulerParts, InherentKernel, Next, OnePath, Parts, Stepped};
use crate::updates;

/// One (possibly truncated) Euler-Maruyama step of the inherent SDE (seed eq. 2.4, multiplier
/// eq. 2.3), written once over [`Real`]: the parts at (r, v) ([`InherentKernel::parts`]),
/// the factor theta = min(1, c / (|f(r, v)| h)) of Remark 3.3 with `scale` = `Some(c)` (1
/// with `None`), |f|^2 = |v|^2 + |accel|^2, and
///
/// ```text
/// r' = r + theta h v,   v' = v + (theta h accel + noise_v),   dmu = theta h mu_rate + noise_mu
/// ```
///
/// into `next`. The paths where the parts were defined and the result is finite are decided.
#[inline(always)]
pub(crate) fn euler_step<T: Real, K: InherentKernel<T>>(
    kernel: &mut K, state: KernelState<'_, T>, h: f64, scale: Option<f64>,
    parts: &mut Parts<'_, T>, next: &mut Next<'_, T>,
) -> Result<Stepped<T>, K::Error> {
    let KernelState { r, v, dw } = state;
    let ok = kernel.parts(r, v, dw, parts)?;
    let theta = match scale {
        None => v[0].splat_like(1.0),
        Some(c) => updates::truncation(c, h, updates::drift_norm(v, parts.accel)),
    };
    let dt = theta * h;
    let state = r.iter().zip(v);
    let rates = parts.accel.iter().zip(parts.noise_v.iter());
    let out = next.r.iter_mut().zip(next.v.iter_mut());
    for ((nr, nv), ((ri, vi), (a, noise))) in out.zip(state.zip(rates)) {
        *nr = updates::euler_position(*ri, *vi, dt);
        *nv = updates::euler_velocity(*vi, *a, *noise, dt);
    }
    let rates = parts.mu_rate.iter().zip(parts.noise_mu.iter());
    for (d, (rate, noise)) in next.dmu.iter_mut().zip(rates) {
        *d = updates::euler_multiplier(*rate, *noise, dt);
    }
    let ok = ok.and(finished(kernel, next)?);
    Ok(Stepped {
        ok,
        eta: theta,
        newton_iterations: theta.splat_like(0.0),
    })
}

/// The paths whose r_{k+1}, v_{k+1} and dmu are finite; one path: a failure naming the first
/// that is not (v', then r', then dmu).
#[inline(always)]
pub(crate) fn finished<T: Real, K: InherentKernel<T>>(
    kernel: &K, next: &Next<'_, T>,
) -> Result<T::Mask, K::Error> {
    let velocity = kernel.finite("velocity after the step", next.v)?;
    let position = kernel.finite("position after the step", next.r)?;
    let multiplier = kernel.finite("multiplier increment", next.dmu)?;
    Ok(velocity.and(position).and(multiplier))
}

/// What a one-path step body works on: the kernel, the parts at (r, v) and the proposal.
pub(crate) type OnePathStep<'a, S> = (OnePath<'a, S>, Parts<'a, f64>, Next<'a, f64>);

/// What all Euler-type solvers hold: the inherent SDE, the step's parts, the proposed state
/// and the last dmu.
#[derive(Debug, Clone)]
pub(crate) struct EulerCore<S: CurvedSystem> {
    pub sde: InherentSde<S>,
    pub parts: EulerParts<Vec<f64>>,
    pub dmu: Vec<f64>,
    /// The proposed r_{k+1}, written back only once it is known to be finite.
    pub next_r: Vec<f64>,
    /// The proposed v_{k+1}.
    pub next_v: Vec<f64>,
}

impl<S: CurvedSystem> EulerCore<S> {
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        let sde = InherentSde::new(system)?;
        let (n, m) = (sde.dim(), sde.n_constraints());
        Ok(Self {
            sde,
            parts: EulerParts::new(n, m),
            dmu: vec![0.0; m],
            next_r: vec![0.0; n],
            next_v: vec![0.0; n],
        })
    }

    /// Checks a step's inputs and gives what a step body works on: the one-path kernel, the
    /// parts at (r, v) and the proposal (`next_r`, `next_v`, `dmu`).
    #[inline]
    pub fn checked(
        &mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64],
    ) -> Result<OnePathStep<'_, S>, ReferenceError> {
        self.sde.check_step_input(r, v, h, dw)?;
        let next = Next {
            r: &mut self.next_r,
            v: &mut self.next_v,
            dmu: &mut self.dmu,
        };
        Ok((OnePath(&mut self.sde), self.parts.view(), next))
    }

    /// Writes the proposed state to (r, v).
    #[inline]
    pub fn commit(&self, r: &mut [f64], v: &mut [f64]) {
        r.copy_from_slice(&self.next_r);
        v.copy_from_slice(&self.next_v);
    }
}

/// Euler-Maruyama on the inherent SDE, seed eq. 2.4 with the multiplier of eq. 2.3:
///
/// ```text
/// r' = r + v h
/// v' = v + M^-1 [P_M(r) a(r, v) - grad g(r) G_M(r)^-1 D^2 g(r)(v, v)] h + M^-1 P_M(r) B(r, v) dw
/// dmu = -G_M(r)^-1 { Dg(r) M^-1 [a h + B dw] + D^2 g(r)(v, v) h }
/// ```
///
/// Not projected: g(r_k) drifts by O(h) over a path. The drift grows like |v|^2 and is not
/// one-sided Lipschitz (Section 5.1), so large steps can blow up; that is reported as
/// [`ReferenceError::NonFinite`]. Use [`crate::TruncatedEulerMaruyama`] for a method that
/// cannot blow up.
#[derive(Debug, Clone)]
pub struct EulerMaruyama<S: CurvedSystem> {
    core: EulerCore<S>,
}

impl<S: CurvedSystem> EulerMaruyama<S> {
    /// The solver for `system`; fails unless 1 <= m < n and the mass has order n.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        Ok(Self {
            core: EulerCore::new(system)?,
        })
    }
}

impl<S: CurvedSystem> EulerMaruyama<S> {
    /// One Euler-Maruyama step of eq. 2.4 (see the type's documentation), proposed.
    fn propose(&mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> StepResult {
        let (mut kernel, mut parts, mut next) = self.core.checked(r, v, h, dw)?;
        let state = KernelState { r, v, dw };
        euler_step(&mut kernel, state, h, None, &mut parts, &mut next)?;
        Ok(StepOutcome::PLAIN)
    }
}

inherent_scheme!(EulerMaruyama);
