//! [`Stepper`] as a [`Scheme`]: one path's step, through the sphere's lane form at W = 1 where
//! it applies and decides, else through the general step (seed eq. 3.1, 3.2).

use sdae_model::{Scheme, StepResult, System, check_step_input};

use crate::ensemble::sphere;
use crate::stepper::Stepper;

impl<S: System> Scheme for Stepper<S> {
    type System = S;

    fn system(&self) -> &S {
        &self.system
    }

    /// Advances (r, v) by one step of size h with Brownian increment dw (seed eq. 3.1):
    ///
    /// r' = r + eta v h + M^-1 grad g(r) kappa,                    g(r') = 0
    /// v' = v + M^-1 [eta a(r, v) h + B(r, v) dw + grad g(r) lambda], Dg(r') v' = 0
    ///
    /// On failure (r, v) are left unchanged.
    ///
    /// A sphere with a diagonal mass (the pendulums) steps through the lane form at W = 1 (the
    /// ensemble's code in plain f64); what it does not decide, and every other system, goes
    /// through the general path ([`Stepper::step_general`]). Inlined where the caller allows:
    /// a pendulum's step in a loop then costs what the lane form's arithmetic costs.
    #[inline]
    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        check_step_input(&self.system, r, v, h, dw)?;
        if let Some(step) = sphere::step_one_lane(self, r, v, h, dw) {
            self.lane_root = Some([step.kappa]);
            self.lambda[0] = step.lambda;
            return Ok(step.outcome);
        }
        self.general_step(r, v, h, dw)
    }

    /// lambda_{k+1} of the last successful step (the increment of mu, eq. 1.4).
    fn multiplier_increment(&self) -> &[f64] {
        &self.lambda
    }
}
