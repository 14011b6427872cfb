//! One step of the half-explicit drift-truncated Euler scheme (seed eq. 3.1, 3.2).

use sdae_ift::BallSolver;
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, GramMatrix, GramStructure, Mass, scratch_len};
use sdae_model::{
    StepFailure, StepOutcome, StepResult, System, UpdateBuffers, check_dimensions,
    check_step_input, constrained_update,
};

use sdae_model::engine::LaneStore;

use crate::config::StepperConfig;
use crate::error::SchemeError;
use crate::formulas::{self, ForceScale};

/// The stepper: a system, the scheme's constants and all buffers of one path.
#[derive(Debug, Clone)]
pub struct Stepper<S: System> {
    pub(crate) system: S,
    config: StepperConfig,
    solver: BallSolver<<S::Constraint as Constraint>::Gram>,
    drift: Vec<f64>,
    y: Vec<f64>,
    x: Vec<f64>,
    force: Vec<f64>,
    pub(crate) lambda: Vec<f64>,
    /// Dg(r') v' when monitored.
    tangency: Vec<f64>,
    scratch: Vec<f64>,
    /// kappa_{k+1} when the last step was decided in one lane (else the solver holds it).
    pub(crate) lane_root: Option<[f64; 1]>,
    /// The buffers of the lane form of an ensemble's step ([`crate::Ensemble`]).
    pub(crate) lanes: LaneStore,
}

impl<S: System> Stepper<S> {
    /// A stepper for `system` with the given constants. Checks that the parts fit.
    pub fn new(system: S, config: StepperConfig) -> Result<Self, SchemeError> {
        let (n, m) = check_dimensions(&system)?;
        let c = system.constraint();
        config.validate()?;
        let solver = BallSolver::new(c.new_gram(), config.solver);
        Ok(Self {
            solver,
            drift: vec![0.0; n],
            y: vec![0.0; n],
            x: vec![0.0; n],
            force: vec![0.0; n],
            lambda: vec![0.0; m],
            tangency: vec![0.0; m],
            scratch: vec![0.0; scratch_len(n, m)],
            lane_root: None,
            lanes: LaneStore::default(),
            system,
            config,
        })
    }

    /// The constants.
    pub fn config(&self) -> &StepperConfig {
        &self.config
    }

    /// kappa_{k+1} of the last successful step.
    pub fn kappa(&self) -> &[f64] {
        match &self.lane_root {
            Some(kappa) => kappa,
            None => self.solver.root(),
        }
    }

    /// Whether the last successful step was decided by the lane form at W = 1 ([`Scheme::step`](sdae_model::Scheme::step)
    /// on a sphere with a diagonal mass), not by the general path.
    pub fn last_step_in_one_lane(&self) -> bool {
        self.lane_root.is_some()
    }

    /// One step through the general path, which every system can take: the ball solver
    /// (closed form, Newton, the homotopy fallback) on the system's constraint, mass, drift
    /// and noise as traits. [`Scheme::step`](sdae_model::Scheme::step) takes it wherever the lane form (the code the
    /// [`Ensemble`](crate::Ensemble) runs W paths at a time, here at W = 1) does not apply or
    /// does not decide the step; where the lane form decides, both give the same numbers bit
    /// for bit (tests/tests/integration/one_lane.rs). For cross-checks.
    pub fn step_general(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        check_step_input(&self.system, r, v, h, dw)?;
        self.general_step(r, v, h, dw)
    }

    /// The general path after the input checks: fixed-size buffers for one constraint in the
    /// plane or in space (the pendulums; every pass over a vector unrolled), the stepper's
    /// buffers otherwise.
    pub(crate) fn general_step(
        &mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
    ) -> StepResult {
        let scalar_gram =
            <<S::Constraint as Constraint>::Gram as GramMatrix>::STRUCTURE == GramStructure::Scalar;
        let outcome = match (scalar_gram, r.len()) {
            (true, 2) => self.step_sized::<2>(r, v, h, dw),
            (true, 3) => self.step_sized::<3>(r, v, h, dw),
            _ => {
                let Self {
                    system,
                    config,
                    solver,
                    drift,
                    y,
                    x,
                    force,
                    lambda,
                    tangency,
                    scratch,
                    ..
                } = self;
                let buffers = Buffers {
                    drift,
                    y,
                    x,
                    force,
                    lambda,
                    tangency,
                    scratch,
                };
                half_explicit_step(system, config, solver, buffers, r, v, h, dw)
            }
        }?;
        // The solver holds this step's root.
        self.lane_root = None;
        Ok(outcome)
    }

    /// The truncation factor of eq. 3.2: eta = min(1, C_eta / (max(|v|, |v|^2, |a|) h)).
    pub fn eta(&self, v_norm: f64, a_norm: f64, h: f64) -> f64 {
        formulas::eta(self.config.c_eta, h, v_norm, a_norm, None)
    }

    /// [`Scheme::step`](sdae_model::Scheme::step) for n = N, m = 1 with the buffers on the stack.
    fn step_sized<const N: usize>(
        &mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
    ) -> StepResult {
        let (mut drift, mut y, mut x, mut force) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
        let (mut lambda, mut tangency) = ([0.0; 1], [0.0; 1]);
        let mut scratch = [0.0; SIZED_SCRATCH];
        let buffers = Buffers {
            drift: &mut drift,
            y: &mut y,
            x: &mut x,
            force: &mut force,
            lambda: &mut lambda,
            tangency: &mut tangency,
            scratch: &mut scratch[..scratch_len(N, 1)],
        };
        let (r, v) = (&mut r[..N], &mut v[..N]);
        let outcome = half_explicit_step(
            &self.system,
            &self.config,
            &mut self.solver,
            buffers,
            r,
            v,
            h,
            dw,
        )?;
        self.lambda.copy_from_slice(&lambda);
        Ok(outcome)
    }
}

/// Scratch length of [`Stepper::step_sized`]: `scratch_len(3, 1)`.
const SIZED_SCRATCH: usize = scratch_len(3, 1);

/// The per-step vectors of length n (drift, y, x, force) and m (lambda, tangency).
struct Buffers<'a> {
    drift: &'a mut [f64],
    y: &'a mut [f64],
    x: &'a mut [f64],
    force: &'a mut [f64],
    lambda: &'a mut [f64],
    tangency: &'a mut [f64],
    scratch: &'a mut [f64],
}

/// The body of [`Scheme::step`](sdae_model::Scheme::step) of [`Stepper`] after the input checks, inlined into each caller so that
/// fixed-size buffers give fixed-size loops. Seed eq. 3.1: y = r + eta h v, the kappa root
/// r' = y + M^-1 grad g(r) kappa on g = 0, v' = v~ + M^-1 grad g(r) lambda with
/// Dg(r') v' = 0.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn half_explicit_step<S: System>(
    system: &S, config: &StepperConfig,
    solver: &mut BallSolver<<S::Constraint as Constraint>::Gram>, buffers: Buffers<'_>,
    r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
) -> StepResult {
    let Buffers {
        drift,
        y,
        x,
        force,
        lambda,
        tangency,
        scratch,
    } = buffers;
    let constraint = system.constraint();
    let mass = system.mass();

    let (v_norm2, a_norm2) = checked_motion(system, r, v, drift)?;
    let local = if config.local_size {
        constraint.local_motion(r, v, drift)
    } else {
        None
    };
    let eta = formulas::eta(config.c_eta, h, v_norm2.sqrt(), a_norm2.sqrt(), local);
    let eta_h = eta * h;
    for ((yi, ri), vi) in y.iter_mut().zip(r.iter()).zip(v.iter()) {
        *yi = formulas::drifted(*ri, *vi, eta_h);
    }
    // v~ is formed before the root (it does not depend on it) so that the solver can solve
    // the lambda system Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~, whose matrix is the Newton
    // matrix at the root, in the pass that factors that matrix.
    let scale = ForceScale::new(config.rescale_noise, eta, h);
    free_velocity(system, &scale, r, v, dw, drift, force);

    // v' into the drift buffer (a is no longer needed).
    let (certificate, at_y) = constrained_update(
        constraint,
        mass,
        solver,
        config.c_kappa,
        r,
        y,
        force,
        UpdateBuffers {
            x,
            scratch,
            lambda,
            new_v: drift,
        },
    )?;
    let r_new: &[f64] = if at_y { y } else { x };
    r.copy_from_slice(r_new);
    v.copy_from_slice(drift);
    let velocity_residual = config.monitor_velocity_constraint.then(|| {
        constraint.jacobian_mul(r, v, tangency);
        max_abs(tangency)
    });
    Ok(StepOutcome {
        eta,
        newton_iterations: certificate.iterations,
        position_residual: Some(certificate.residual),
        certificate: Some(certificate),
        velocity_residual,
    })
}

/// |v|^2 and |a|^2 with the drift a(r, v) written into `drift`; a failure if either is not
/// finite.
#[inline(always)]
fn checked_motion<S: System>(
    system: &S, r: &[f64], v: &[f64], drift: &mut [f64],
) -> Result<(f64, f64), StepFailure> {
    let v_norm2 = norm2_squared(v);
    if !v_norm2.is_finite() {
        return Err(StepFailure::NonFinite {
            what: "velocity v_k",
            size: v_norm2.sqrt(),
        });
    }
    system.drift(r, v, drift);
    let a_norm2 = norm2_squared(drift);
    if !a_norm2.is_finite() {
        return Err(StepFailure::NonFinite {
            what: "drift a(r, v)",
            size: a_norm2.sqrt(),
        });
    }
    Ok((v_norm2, a_norm2))
}

/// The velocity before the constraint force, v~ = v + M^-1 (eta h a + B dw) (seed eq. 3.1),
/// written into `force`; with rescaled noise and eta < 1, v + M^-1 (eta h a + sqrt(eta) B dw),
/// in law a step of eta h ([`ForceScale`]).
#[inline(always)]
fn free_velocity<S: System>(
    system: &S, scale: &ForceScale<f64>, r: &[f64], v: &[f64], dw: &[f64], drift: &[f64],
    force: &mut [f64],
) {
    for (f, a) in force.iter_mut().zip(drift.iter()) {
        *f = scale.drift_h * a;
    }
    system.add_noise(r, v, dw, force);
    scale.rescale(force);
    system.mass().apply_inverse(force);
    for (f, vi) in force.iter_mut().zip(v.iter()) {
        *f += vi;
    }
}
