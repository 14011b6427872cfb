//! Euler-Maruyama on the inherent SDE (seed eq. 2.4), and the pieces of an Euler step that the
//! other solvers share.

use crate::error::{ReferenceError, check_finite};
use crate::inherent::{CurvedSystem, InherentSde};
use crate::updates;
use sdae_model::{StepOutcome, StepResult};

/// The coefficients of one Euler step at (r, v): drift and noise parts of dv and dmu.
#[derive(Debug, Clone)]
pub(crate) struct EulerParts {
    /// Velocity drift of eq. 2.4 (Lemma 4.2, second block).
    pub accel: Vec<f64>,
    /// Drift of mu, eq. 2.3.
    pub mu_rate: Vec<f64>,
    /// M^-1 P_M B dw (eq. 2.4).
    pub noise_v: Vec<f64>,
    /// -G_M^-1 Dg M^-1 B dw (eq. 2.3).
    pub noise_mu: Vec<f64>,
}

impl EulerParts {
    pub fn new(n: usize, m: usize) -> Self {
        Self {
            accel: vec![0.0; n],
            mu_rate: vec![0.0; m],
            noise_v: vec![0.0; n],
            noise_mu: vec![0.0; m],
        }
    }

    /// Factors G_M(r) and evaluates the drift parts, and the noise parts if `dw` is given and
    /// the system has noise (a scene without noise pays nothing for it).
    pub fn evaluate<S: CurvedSystem>(
        &mut self, sde: &mut InherentSde<S>, r: &[f64], v: &[f64], dw: Option<&[f64]>,
    ) -> Result<(), ReferenceError> {
        sde.prepare(r)?;
        sde.drift_prepared(r, v, &mut self.accel, &mut self.mu_rate);
        check_finite("inherent drift", &self.accel)?;
        match dw {
            Some(dw) if !dw.is_empty() => {
                sde.noise_prepared(r, v, dw, &mut self.noise_v, &mut self.noise_mu);
                check_finite("inherent diffusion", &self.noise_v)
            }
            _ => {
                self.noise_v.fill(0.0);
                self.noise_mu.fill(0.0);
                Ok(())
            }
        }
    }

    /// |f(r, v)| for the R^{2n} drift f = (v, accel) of Lemma 4.2 (Euclidean norm).
    pub fn drift_norm(&self, v: &[f64]) -> f64 {
        updates::drift_norm(v, &self.accel)
    }

    /// dmu = dt mu_rate + noise_mu.
    pub fn multiplier(&self, dt: f64, dmu: &mut [f64]) {
        for ((d, rate), noise) in dmu.iter_mut().zip(&self.mu_rate).zip(&self.noise_mu) {
            *d = updates::euler_multiplier(*rate, *noise, dt);
        }
    }

    /// The Euler update with drift time dt: r += dt v, v += dt accel + noise_v; dmu likewise.
    pub fn apply(&self, r: &mut [f64], v: &mut [f64], dt: f64, dmu: &mut [f64]) {
        for ((ri, vi), (a, n)) in r
            .iter_mut()
            .zip(v.iter_mut())
            .zip(self.accel.iter().zip(&self.noise_v))
        {
            *ri = updates::euler_position(*ri, *vi, dt);
            *vi = updates::euler_velocity(*vi, *a, *n, dt);
        }
        self.multiplier(dt, dmu);
    }
}

/// What all Euler-type solvers hold: the inherent SDE, the step's parts, the proposed state
/// and the last dmu.
#[derive(Debug, Clone)]
pub(crate) struct EulerCore<S: CurvedSystem> {
    pub sde: InherentSde<S>,
    pub parts: EulerParts,
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

    /// One (possibly truncated) Euler-Maruyama step into `next_r`, `next_v`, `dmu`: checks the
    /// inputs, evaluates the parts at (r, v), asks `truncation(h, |f|)` for the factor
    /// theta in (0, 1] and applies X' = X + theta h f(X) + sigma(X) dw. Returns theta.
    pub fn propose(
        &mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64], truncation: impl Fn(f64, f64) -> f64,
    ) -> Result<f64, ReferenceError> {
        self.sde.check_step_input(r, v, h, dw)?;
        self.parts.evaluate(&mut self.sde, r, v, Some(dw))?;
        let theta = truncation(h, self.parts.drift_norm(v));
        self.next_r.copy_from_slice(r);
        self.next_v.copy_from_slice(v);
        self.parts
            .apply(&mut self.next_r, &mut self.next_v, theta * h, &mut self.dmu);
        self.check_proposal()?;
        Ok(theta)
    }

    /// Fails with [`ReferenceError::NonFinite`] unless the proposed state and dmu are finite.
    pub fn check_proposal(&self) -> Result<(), ReferenceError> {
        check_finite("velocity after the step", &self.next_v)?;
        check_finite("position after the step", &self.next_r)?;
        check_finite("multiplier increment", &self.dmu)
    }

    /// Writes the proposed state to (r, v).
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
        self.core.propose(r, v, h, dw, |_, _| 1.0)?;
        Ok(StepOutcome::PLAIN)
    }
}

inherent_scheme!(EulerMaruyama);
