//! One step of the half-explicit drift-truncated Euler scheme (seed eq. 3.1, 3.2).

use crate::step::{HalfExplicitKernel, Update, half_explicit_step};
use sdae_ift::{BallSolver, Certificate};
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, GramMatrix, GramStructure, Mass, scratch_len};
use sdae_model::{
    StepFailure, StepOutcome, StepResult, System, UpdateBuffers, check_dimensions,
    check_step_input, constrained_update,
};

use sdae_model::engine::LaneStore;

use crate::config::StepperConfig;
use crate::error::SchemeError;
use crate::formulas;

/// The stepper: a system, the scheme's constants and all buffers of one path.
///
/// A chain molecule's path under Langevin dynamics ([`run_path`](sdae_model::run_path)):
///
/// ```
/// use sdae_model::{NoObserver, TimeGrid, run_path};
/// use sdae_noise::GaussianIncrements;
/// use sdae_scheme::{Stepper, StepperConfig};
/// use sdae_systems::{ChainMoleculeParams, chain_molecule};
/// let molecule = chain_molecule(&ChainMoleculeParams::default())?;
/// let (mut r, mut v) = molecule.initial_state();
/// let mut noise = GaussianIncrements::for_path(1, 0, molecule.noise_dimension());
/// let config = StepperConfig::for_system(&molecule)?.with_c_eta(1.0)?;
/// let mut stepper = Stepper::new(molecule, config)?;
/// let grid = TimeGrid::new(1.0, 1000)?;
/// let diagnostics = run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut NoObserver)?;
/// assert!(diagnostics.max_position_residual < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// A rigid triatomic stepped by hand ([`Scheme::step`](sdae_model::Scheme::step)):
///
/// ```
/// use sdae_model::{Scheme, System};
/// use sdae_noise::{GaussianIncrements, IncrementSource};
/// use sdae_scheme::{Stepper, StepperConfig};
/// use sdae_systems::{RigidTriatomicParams, rigid_triatomic};
/// let molecule = rigid_triatomic(&RigidTriatomicParams::default())?;
/// let (mut r, mut v) = molecule.initial_state();
/// let config = StepperConfig::for_system(&molecule)?.with_c_eta(1.0)?;
/// let mut noise = GaussianIncrements::for_path(5, 0, molecule.noise_dim());
/// let mut dw = vec![0.0; molecule.noise_dim()];
/// let mut stepper = Stepper::new(molecule, config)?;
/// for _ in 0..100 {
///     noise.next_increment(1e-3, &mut dw);
///     stepper.step(&mut r, &mut v, 1e-3, &dw)?;
/// }
/// assert!(stepper.system().kinetic_energy(&v) > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// An inextensible fiber in turbulent air, with C_kappa left infinite:
///
/// ```
/// use sdae_model::{NoObserver, TimeGrid, run_path};
/// use sdae_noise::GaussianIncrements;
/// use sdae_scheme::{Stepper, StepperConfig};
/// use sdae_systems::{Fiber, FiberParams};
/// let fiber = Fiber::new(&FiberParams::default())?;
/// let (mut r, mut v) = fiber.zigzag(0.2);
/// let mut noise = GaussianIncrements::for_path(3, 0, fiber.noise_dimension());
/// let config = StepperConfig::new(1.0, f64::INFINITY)?;
/// let mut stepper = Stepper::new(fiber, config)?;
/// let grid = TimeGrid::new(0.1, 200)?;
/// let diagnostics = run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut NoObserver)?;
/// assert!(diagnostics.max_position_residual < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
    /// buffers otherwise. Out of line, so that [`Scheme::step`](sdae_model::Scheme::step)'s
    /// path through the lane form at W = 1 stays small enough to be inlined into its caller.
    #[inline(never)]
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
                one_path_step(system, config, solver, buffers, r, v, h, dw)
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
        let outcome = one_path_step(
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

/// The body of [`Scheme::step`](sdae_model::Scheme::step) of [`Stepper`] after the input checks,
/// inlined into each caller so that fixed-size buffers give fixed-size loops: the step of seed
/// eq. 3.1-3.2 written once ([`half_explicit_step`]) on [`OnePath`], then
/// (r, v) <- (r_{k+1}, v_{k+1}).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn one_path_step<S: System>(
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
    let mut kernel = OnePath {
        system,
        solver,
        c_kappa: config.c_kappa,
        y,
        x,
        new_v: drift,
        tangency,
        scratch,
        certificate: None,
        at_y: false,
    };
    let step = half_explicit_step(&mut kernel, config, h, [r, v, dw], force, lambda)?;
    let certificate = kernel
        .certificate
        .expect("a decided step has the root's certificate");
    let r_new: &[f64] = if kernel.at_y { kernel.y } else { kernel.x };
    r.copy_from_slice(r_new);
    v.copy_from_slice(kernel.new_v);
    Ok(StepOutcome {
        eta: step.eta,
        newton_iterations: certificate.iterations,
        position_residual: Some(certificate.residual),
        certificate: Some(certificate),
        velocity_residual: step.update.velocity_residual,
    })
}

/// The step's [`HalfExplicitKernel`] for one path: the system's drift, noise and constraint as
/// traits, the kappa root by the ball solver (closed form, Newton, the homotopy fallback) with
/// typed failures.
struct OnePath<'a, S: System> {
    system: &'a S,
    solver: &'a mut BallSolver<<S::Constraint as Constraint>::Gram>,
    c_kappa: f64,
    /// y = r + eta h v.
    y: &'a mut [f64],
    /// The root's point, r_{k+1} unless it is y ([`OnePath::at_y`]).
    x: &'a mut [f64],
    /// v_{k+1}.
    new_v: &'a mut [f64],
    /// Dg(r') v' when monitored.
    tangency: &'a mut [f64],
    scratch: &'a mut [f64],
    /// The kappa root's certificate.
    certificate: Option<Certificate>,
    /// Whether r_{k+1} is y (a root of 0).
    at_y: bool,
}

impl<S: System> HalfExplicitKernel<f64> for OnePath<'_, S> {
    type Stop = StepFailure;
    #[inline(always)]
    fn norm2(&self, what: &'static str, x: &[f64]) -> Result<f64, StepFailure> {
        let norm2 = norm2_squared(x);
        if !norm2.is_finite() {
            return Err(StepFailure::NonFinite {
                what,
                size: norm2.sqrt(),
            });
        }
        Ok(norm2)
    }
    #[inline(always)]
    fn drift(&mut self, r: &[f64], v: &[f64], out: &mut [f64]) -> Result<(), StepFailure> {
        self.system.drift(r, v, out);
        Ok(())
    }
    #[inline(always)]
    fn add_noise(
        &mut self, r: &[f64], v: &[f64], dw: &[f64], out: &mut [f64],
    ) -> Result<(), StepFailure> {
        self.system.add_noise(r, v, dw, out);
        Ok(())
    }
    #[inline(always)]
    fn local_motion(&self, r: &[f64], v: &[f64], a: &[f64], _: f64, _: f64) -> Option<f64> {
        self.system.constraint().local_motion(r, v, a)
    }
    /// v~ = v + M^-1 force, then [`constrained_update`] (the lambda system solved with the
    /// root's factors in the pass that factors them, where the solver can).
    #[inline(always)]
    fn constrain(
        &mut self, r: &[f64], v: &[f64], eta_h: f64, force: &mut [f64], dmu: &mut [f64],
        monitor: bool,
    ) -> Result<Update<f64>, StepFailure> {
        for ((yi, ri), vi) in self.y.iter_mut().zip(r).zip(v) {
            *yi = formulas::drifted(*ri, *vi, eta_h);
        }
        let (constraint, mass) = (self.system.constraint(), self.system.mass());
        mass.apply_inverse(force);
        for (f, vi) in force.iter_mut().zip(v) {
            *f += vi;
        }
        let (certificate, at_y) = constrained_update(
            constraint,
            mass,
            self.solver,
            self.c_kappa,
            r,
            self.y,
            force,
            UpdateBuffers {
                x: self.x,
                scratch: self.scratch,
                lambda: dmu,
                new_v: self.new_v,
            },
        )?;
        self.certificate = Some(certificate);
        self.at_y = at_y;
        let velocity_residual = monitor.then(|| {
            let r_new: &[f64] = if at_y { self.y } else { self.x };
            constraint.jacobian_mul(r_new, self.new_v, self.tangency);
            max_abs(self.tangency)
        });
        Ok(Update {
            ok: true,
            newton_iterations: certificate.iterations as f64,
            position_residual: certificate.residual,
            velocity_residual,
            contraction: certificate.contraction,
            kappa_norm: certificate.norm,
        })
    }
}
