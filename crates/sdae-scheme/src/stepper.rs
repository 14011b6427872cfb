//! One step of the half-explicit drift-truncated Euler scheme (seed eq. 3.1, 3.2).

use sdae_ift::{BallProblem, BallSolver, Certificate, Factorize, Method, Solve};
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, GramMatrix, GramStructure, Mass, scratch_len};

use crate::config::StepperConfig;
use crate::error::{SchemeError, StepFailure};
use crate::system::System;

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The truncation factor eta_k of eq. 3.2 (1 for the untruncated scheme).
    pub eta: f64,
    /// The kappa solver's certificate.
    pub certificate: Certificate,
    /// max |g(r_{k+1})|.
    pub position_residual: f64,
    /// max |Dg(r_{k+1}) v_{k+1}|, NaN when not monitored.
    pub velocity_residual: f64,
}

impl StepReport {
    /// Whether the homotopy fallback was needed.
    pub fn used_homotopy(&self) -> bool {
        self.certificate.method == Method::Homotopy
    }
}

/// The kappa system R(gamma) = g(y + M^-1 grad g(r) gamma), y = r + eta v h, with Jacobian
/// Dg(x) M^-1 grad g(r) at x = y + M^-1 grad g(r) gamma (seed eq. 3.1 upper part, eq. 3.10).
/// After a successful solve, r' is `y` if `at_y` and `x` otherwise (the solver's last
/// evaluation is at the root; at gamma = 0 the position is y itself and is not copied).
pub(crate) struct KappaProblem<'a, C, M> {
    pub(crate) constraint: &'a C,
    pub(crate) mass: &'a M,
    pub(crate) r: &'a [f64],
    pub(crate) y: &'a [f64],
    pub(crate) x: &'a mut [f64],
    pub(crate) scratch: &'a mut [f64],
    /// The residual floor of g near y (`Constraint::value_roundoff`).
    pub(crate) floor: f64,
    /// Whether the last evaluation was at gamma = 0, i.e. at x = y.
    pub(crate) at_y: bool,
}

impl<C, M> BallProblem for KappaProblem<'_, C, M>
where
    C: Constraint,
    C::Gram: Factorize,
    M: Mass,
{
    type Matrix = C::Gram;
    fn dim(&self) -> usize {
        self.constraint.n_constraints()
    }
    fn new_matrix(&self) -> C::Gram {
        self.constraint.new_gram()
    }
    #[inline(always)]
    fn evaluate(&mut self, gamma: &[f64], residual: &mut [f64], jacobian: Option<&mut C::Gram>) {
        let c = self.constraint;
        self.at_y = gamma.iter().all(|&g| g == 0.0);
        let x: &[f64] = if self.at_y {
            self.y
        } else {
            c.displace(self.r, gamma, self.mass, self.y, self.x);
            self.x
        };
        match jacobian {
            Some(j) => c.value_and_cross_gram(x, self.r, self.mass, self.scratch, residual, j),
            None => c.value(x, residual),
        }
    }
    /// The closed form of the kappa system where the constraint has one
    /// (`Constraint::kappa_quadratic`, e.g. the sphere with a diagonal mass).
    #[inline]
    fn quadratic(&mut self) -> Option<[f64; 3]> {
        self.constraint.kappa_quadratic(self.r, self.y, self.mass)
    }
    fn residual_floor(&self) -> f64 {
        self.floor
    }
}

/// The stepper: a system, the scheme's constants and all buffers of one path.
#[derive(Debug, Clone)]
pub struct Stepper<S: System>
where
    <S::Constraint as Constraint>::Gram: Factorize,
{
    system: S,
    config: StepperConfig,
    solver: BallSolver<<S::Constraint as Constraint>::Gram>,
    drift: Vec<f64>,
    y: Vec<f64>,
    x: Vec<f64>,
    force: Vec<f64>,
    lambda: Vec<f64>,
    /// Dg(r') v' when monitored.
    tangency: Vec<f64>,
    scratch: Vec<f64>,
}

impl<S: System> Stepper<S>
where
    <S::Constraint as Constraint>::Gram: Factorize,
{
    /// A stepper for `system` with the given constants. Checks that the parts fit.
    pub fn new(system: S, config: StepperConfig) -> Result<Self, SchemeError> {
        let c = system.constraint();
        let (n, m) = (c.dim(), c.n_constraints());
        if m == 0 || m >= n {
            return Err(SchemeError::DimensionMismatch {
                what: "number of constraints m (need 1 <= m < n)",
                expected: n.saturating_sub(1),
                found: m,
            });
        }
        system.mass().check_order(n)?;
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
            system,
            config,
        })
    }

    /// The system.
    pub fn system(&self) -> &S {
        &self.system
    }

    /// The constants.
    pub fn config(&self) -> &StepperConfig {
        &self.config
    }

    /// kappa_{k+1} of the last successful step.
    pub fn kappa(&self) -> &[f64] {
        self.solver.root()
    }

    /// lambda_{k+1} of the last successful step (the increment of mu, eq. 1.4).
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }

    /// The truncation factor of eq. 3.2: eta = min(1, C_eta / (max(|v|, |v|^2, |a|) h)).
    pub fn eta(&self, v_norm: f64, a_norm: f64, h: f64) -> f64 {
        eta(&self.config, v_norm, a_norm, h)
    }

    /// Checks the lengths of a step's inputs and the step size.
    fn check_input(&self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> Result<(), StepFailure> {
        let n = self.system.constraint().dim();
        let l = self.system.noise_dim();
        let mismatch = |what, expected, found| {
            StepFailure::Input(SchemeError::DimensionMismatch {
                what,
                expected,
                found,
            })
        };
        if r.len() != n {
            return Err(mismatch("position r", n, r.len()));
        }
        if v.len() != n {
            return Err(mismatch("velocity v", n, v.len()));
        }
        if dw.len() != l {
            return Err(mismatch("Brownian increment dw", l, dw.len()));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(StepFailure::Input(SchemeError::InvalidSetting {
                name: "h",
                value: h,
                reason: "step size must be finite and > 0",
            }));
        }
        Ok(())
    }

    /// Advances (r, v) by one step of size h with Brownian increment dw (seed eq. 3.1):
    ///
    /// r' = r + eta v h + M^-1 grad g(r) kappa,                    g(r') = 0
    /// v' = v + M^-1 [eta a(r, v) h + B(r, v) dw + grad g(r) lambda], Dg(r') v' = 0
    ///
    /// On failure (r, v) are left unchanged.
    pub fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
    ) -> Result<StepReport, StepFailure> {
        self.check_input(r, v, h, dw)?;
        if <<S::Constraint as Constraint>::Gram as GramMatrix>::STRUCTURE == GramStructure::Scalar {
            // One constraint in the plane or in space (the pendulums): buffers of a size known
            // at compile time, so that every pass over a vector is unrolled.
            match r.len() {
                2 => return self.step_sized::<2>(r, v, h, dw),
                3 => return self.step_sized::<3>(r, v, h, dw),
                _ => {}
            }
        }
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
        advance(system, config, solver, buffers, r, v, h, dw)
    }

    /// [`Stepper::step`] for n = N, m = 1 with the buffers on the stack.
    fn step_sized<const N: usize>(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
    ) -> Result<StepReport, StepFailure> {
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
        let report = advance(
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
        Ok(report)
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

/// The body of [`Stepper::step`] after the input checks, inlined into each caller so that
/// fixed-size buffers give fixed-size loops.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn advance<S: System>(
    system: &S,
    config: &StepperConfig,
    solver: &mut BallSolver<<S::Constraint as Constraint>::Gram>,
    buffers: Buffers<'_>,
    r: &mut [f64],
    v: &mut [f64],
    h: f64,
    dw: &[f64],
) -> Result<StepReport, StepFailure>
where
    <S::Constraint as Constraint>::Gram: Factorize,
{
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

    let v_norm2 = norm2_squared(v);
    if !v_norm2.is_finite() {
        return Err(StepFailure::NonFiniteVelocity { norm2: v_norm2 });
    }
    system.drift(r, v, drift);
    let a_norm2 = norm2_squared(drift);
    if !a_norm2.is_finite() {
        let index = drift.iter().position(|x| !x.is_finite()).unwrap_or(0);
        return Err(StepFailure::NonFiniteDrift { index });
    }
    let eta = eta(config, v_norm2.sqrt(), a_norm2.sqrt(), h);
    let eta_h = eta * h;
    let mut max_abs_y: f64 = 0.0;
    for ((yi, ri), vi) in y.iter_mut().zip(r.iter()).zip(v.iter()) {
        *yi = ri + eta_h * vi;
        max_abs_y = max_abs_y.max(yi.abs());
    }

    let (certificate, at_y) = {
        let mut problem = KappaProblem {
            constraint,
            mass,
            r,
            y,
            x,
            scratch,
            floor: constraint.value_roundoff(max_abs_y),
            at_y: false,
        };
        let certificate = solver.solve(&mut problem, config.c_kappa)?;
        (certificate, problem.at_y)
    };
    let r_new: &[f64] = if at_y { y } else { x };

    // Velocity: v~ = v + M^-1 (eta a h + B dw); lambda from Dg(r') M^-1 grad g(r) lambda
    // = -Dg(r') v~, whose matrix is the Newton matrix at the root, already factored.
    for (f, a) in force.iter_mut().zip(drift.iter()) {
        *f = eta_h * a;
    }
    system.add_noise(r, v, dw, force);
    mass.apply_inverse(force);
    for (f, vi) in force.iter_mut().zip(v.iter()) {
        *f += vi;
    }
    constraint.jacobian_mul(r_new, force, lambda);
    for l in lambda.iter_mut() {
        *l = -*l;
    }
    solver.root_factor().solve_in_place(lambda);
    // v' = v~ + M^-1 grad g(r) lambda, into the drift buffer (a is no longer needed).
    constraint.displace(r, lambda, mass, force, drift);
    let new_v_norm2 = norm2_squared(drift);
    if !new_v_norm2.is_finite() {
        return Err(StepFailure::NonFiniteVelocity { norm2: new_v_norm2 });
    }
    r.copy_from_slice(r_new);
    v.copy_from_slice(drift);
    let velocity_residual = if config.monitor_velocity_constraint {
        constraint.jacobian_mul(r, v, tangency);
        max_abs(tangency)
    } else {
        f64::NAN
    };
    Ok(StepReport {
        eta,
        position_residual: certificate.residual,
        certificate,
        velocity_residual,
    })
}

/// The truncation factor of eq. 3.2: eta = min(1, C_eta / (max(|v|, |v|^2, |a|) h)).
#[inline]
fn eta(config: &StepperConfig, v_norm: f64, a_norm: f64, h: f64) -> f64 {
    match config.c_eta {
        None => 1.0,
        Some(c_eta) => {
            let size = v_norm.max(v_norm * v_norm).max(a_norm) * h;
            if size > c_eta { c_eta / size } else { 1.0 }
        }
    }
}
