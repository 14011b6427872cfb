//! The [`StepOutcome`] of each decided lane of a group, as the scalar stepper reports it.

use sdae_ift::{Certificate, Method};
use sdae_model::{LANE_BLOCK, LaneOutcomes, StepOutcome};

/// The numbers of a group's step outcomes, per lane: those of a root found without the
/// homotopy and certified without a rounding correction.
pub(super) struct LaneCertificates {
    pub(super) method: Method,
    pub(super) radius: f64,
    pub(super) monitor_velocity: bool,
    pub(super) eta: [f64; LANE_BLOCK],
    /// Newton iterations (0 in closed form).
    pub(super) iterations: [f64; LANE_BLOCK],
    pub(super) residual: [f64; LANE_BLOCK],
    pub(super) velocity_residual: [f64; LANE_BLOCK],
    pub(super) norm: [f64; LANE_BLOCK],
    pub(super) first_step: [f64; LANE_BLOCK],
    pub(super) contraction: [f64; LANE_BLOCK],
}

impl LaneOutcomes for LaneCertificates {
    /// The scalar stepper's outcome of lane `lane`'s step.
    #[inline(always)]
    fn outcome(&self, lane: usize) -> StepOutcome {
        let residual = self.residual[lane];
        let iterations = self.iterations[lane] as usize;
        StepOutcome {
            eta: self.eta[lane],
            newton_iterations: iterations,
            position_residual: Some(residual),
            certificate: Some(Certificate {
                iterations,
                homotopy_steps: 0,
                method: self.method,
                residual,
                norm: self.norm[lane],
                radius: self.radius,
                first_step: self.first_step[lane],
                contraction: self.contraction[lane],
                rounding: 0.0,
            }),
            velocity_residual: self.monitor_velocity.then(|| self.velocity_residual[lane]),
        }
    }
}
