//! The constrained update of one path (seed eq. 3.1): from a point y and a free velocity v~,
//! the position r' = y + M^-1 grad g(r) kappa on the manifold (the kappa root connected to 0
//! in the ball of radius C_kappa, by the ball solver of `sdae-ift`) and the velocity
//! v' = v~ + M^-1 grad g(r) lambda tangent there (Dg(r') v' = 0). The half-explicit step is
//! this update with y = r + eta h v; a scheme written over the number type reaches it through
//! [`StepKernel::constrain`](crate::StepKernel::constrain).

use sdae_ift::{BallSolver, Certificate};
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, Mass, Solve};

use crate::error::StepFailure;
use crate::tangent::{KappaProblem, lambda_right_hand_side};

/// The buffers of one path's constrained update: the root's point x (n), the constraint's
/// workspace (`scratch_len(n, m)`), lambda (m) and v' (n).
pub struct UpdateBuffers<'a> {
    /// x = y + M^-1 grad g(r) kappa, the root's point unless it is y itself.
    pub x: &'a mut [f64],
    /// The constraint's workspace.
    pub scratch: &'a mut [f64],
    /// lambda.
    pub lambda: &'a mut [f64],
    /// v'.
    pub new_v: &'a mut [f64],
}

/// The constrained update from r, y and the free velocity v~ (seed eq. 3.1): the kappa root in
/// the ball of `radius` (closed form where the constraint has one, else Newton and the
/// homotopy of eq. 3.10), with the lambda system Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~
/// solved with the root's factors (in the pass that factors them, where the solver can), and
/// v' into `new_v`. Returns the root's certificate and whether r' is y itself (a root of 0;
/// else r' is in `x`); a failure where the root is not found or v' is not finite.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn constrained_update<C: Constraint, M: Mass>(
    constraint: &C, mass: &M, solver: &mut BallSolver<C::Gram>, radius: f64, r: &[f64], y: &[f64],
    free_velocity: &[f64], buffers: UpdateBuffers<'_>,
) -> Result<(Certificate, bool), StepFailure> {
    let UpdateBuffers {
        x,
        scratch,
        lambda,
        new_v,
    } = buffers;
    // NaN when y is (then so is g(y), and the step fails on it whatever the floor).
    let floor = constraint.roundoff().floor(max_abs(y));
    let (certificate, at_y) = {
        let mut problem = KappaProblem {
            constraint,
            mass,
            r,
            y,
            x,
            scratch,
            floor,
            at_y: false,
            velocity: Some(free_velocity),
        };
        let certificate =
            solver
                .solve(&mut problem, radius)
                .map_err(|source| StepFailure::Root {
                    what: "kappa system",
                    source,
                })?;
        (certificate, problem.at_y)
    };
    let r_new: &[f64] = if at_y { y } else { x };
    match solver.companion() {
        Some(solution) => lambda.copy_from_slice(solution),
        None => {
            lambda_right_hand_side(constraint, r_new, free_velocity, lambda);
            solver.root_factor().solve_in_place(lambda);
        }
    }
    constraint.displace(r, lambda, mass, free_velocity, new_v);
    let new_v_norm2 = norm2_squared(new_v);
    if !new_v_norm2.is_finite() {
        return Err(StepFailure::NonFinite {
            what: "velocity after the step",
            size: new_v_norm2.sqrt(),
        });
    }
    Ok((certificate, at_y))
}
