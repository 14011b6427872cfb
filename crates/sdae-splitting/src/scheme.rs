//! [`Splitting`] as a [`Scheme`]: one path's step, through the sphere's lane form at W = 1
//! where it applies and decides, else through the general path.

use sdae_model::{Scheme, StepResult, System, check_step_input};

use crate::sphere;
use crate::splitting::Splitting;

impl<S: System> Scheme for Splitting<S> {
    type System = S;

    fn system(&self) -> &S {
        &self.system
    }

    /// One step B A O A B ([`Splitting`]); (r, v) are unchanged on failure.
    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        check_step_input(&self.system, r, v, h, dw)?;
        self.refresh_numbers(h);
        if let Some((outcome, impulse)) = sphere::step_one_lane(self, r, v, h, dw) {
            self.impulse[0] = impulse;
            return Ok(outcome);
        }
        self.general_step(r, v, h, dw)
    }

    /// The sum of the last successful step's constraint impulses (kappa / tau of each SHAKE
    /// projection, lambda of each RATTLE projection).
    fn multiplier_increment(&self) -> &[f64] {
        &self.impulse
    }
}
