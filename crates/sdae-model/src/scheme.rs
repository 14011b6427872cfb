//! The one step trait that every scheme implements: the half-explicit stepper (seed eq. 3.1),
//! the inherent-SDE solvers (eq. 2.4) and a user's own scheme.

use sdae_ift::{Certificate, Method};

use crate::error::StepFailure;
use crate::system::System;

/// What one step did, in the terms every scheme shares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome {
    /// The drift truncation factor in (0, 1]: eta_k of seed eq. 3.2, theta of a truncated
    /// Euler-Maruyama step (Remark 3.3); 1 when the drift was not truncated.
    pub eta: f64,
    /// Newton iterations of the step's root solve (the kappa system, a projection); 0 without.
    pub newton_iterations: usize,
    /// The certificate of the kappa root (seed Thm 3.4), for schemes that solve for one.
    pub certificate: Option<Certificate>,
    /// max |g(r_{k+1})| where the scheme measured it on the way (otherwise the path driver
    /// measures it).
    pub position_residual: Option<f64>,
    /// max |Dg(r_{k+1}) v_{k+1}| where the scheme measured it.
    pub velocity_residual: Option<f64>,
}

impl StepOutcome {
    /// An untruncated step without a root solve, residuals not measured.
    pub const PLAIN: StepOutcome = StepOutcome {
        eta: 1.0,
        newton_iterations: 0,
        certificate: None,
        position_residual: None,
        velocity_residual: None,
    };

    /// Whether the drift was truncated (eta < 1).
    pub fn truncated(&self) -> bool {
        self.eta < 1.0
    }

    /// Whether the homotopy fallback was needed for the kappa root.
    pub fn used_homotopy(&self) -> bool {
        self.certificate
            .is_some_and(|c| c.method == Method::Homotopy)
    }
}

/// What [`Scheme::step`] returns: the step's [`StepOutcome`], or the [`StepFailure`] that
/// left (r, v) unchanged.
pub type StepResult = Result<StepOutcome, StepFailure>;

/// A one-step scheme for a constrained stochastic mechanical system (seed eq. 1.1): from
/// (r_k, v_k), a step size h and the Brownian increment dw_k = w(t_{k+1}) - w(t_k) to
/// (r_{k+1}, v_{k+1}) and the multiplier increment mu_{k+1} - mu_k.
///
/// The path driver [`run_path`](crate::run_path), the studies and the shared tests are written
/// against this trait, so a scheme defined outside the workspace runs everywhere the built-in
/// ones do. It is object safe for a fixed system: `Box<dyn Scheme<System = S>>`.
pub trait Scheme {
    /// The system stepped.
    type System: System;
    /// The system.
    fn system(&self) -> &Self::System;
    /// Advances (r, v) by one step of size h with the Brownian increment dw (length l). On
    /// failure (r, v) are left unchanged.
    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult;
    /// The increment of mu over the last successful step (length m): lambda_{k+1} of seed eq.
    /// 1.4 for the half-explicit scheme, eq. 2.3 for the inherent SDE.
    fn multiplier_increment(&self) -> &[f64];
}

impl<T: Scheme + ?Sized> Scheme for Box<T> {
    type System = T::System;
    fn system(&self) -> &Self::System {
        (**self).system()
    }
    #[inline]
    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        (**self).step(r, v, h, dw)
    }
    fn multiplier_increment(&self) -> &[f64] {
        (**self).multiplier_increment()
    }
}
