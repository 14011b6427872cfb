//! The splitting scheme BAOAB with SHAKE/RATTLE projections, and its geodesic form g-BAOAB:
//! the general path, which every Langevin system can take (the constraint, the mass, the
//! force and the noise as traits).

use sdae_ift::BallSolver;
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, Factorize, Mass, Solve, scratch_len};
use sdae_model::engine::LaneStore;
use sdae_model::{
    KappaProblem, LangevinForm, StepFailure, StepOutcome, StepResult, System, check_dimensions,
};

use crate::config::SplittingConfig;
use crate::error::SplittingError;
use crate::ou::OuFactors;

/// The Gram matrix storage of a system's constraint.
type Gram<S> = <<S as System>::Constraint as Constraint>::Gram;

/// A splitting scheme for constrained Langevin dynamics, M dv = [F(r) - gamma v] dt +
/// sigma dw + grad g(r) dmu, g(r) = 0 (seed Section 5.2): one step of size h is
///
/// ```text
/// B   v <- v + (h/2) M^-1 F(r),                      then RATTLE: v <- P_M(r) v
/// A   K_r times, with tau = h / (2 K_r):
///       SHAKE   r' = r + tau v + M^-1 grad g(r) kappa,   g(r') = 0  (Newton on kappa)
///               v  <- v + M^-1 grad g(r) kappa / tau    (= (r' - r) / tau)
///       RATTLE  v  <- P_M(r') v, r <- r'
/// O   v_i <- exp(-gamma w_i h) v_i + sigma w_i sqrt((1 - exp(-2 gamma w_i h)) / (2 gamma w_i h)) dw_i,
///       then RATTLE: v <- P_M(r) v                    (w_i = (M^-1)_ii)
/// A   as above
/// B   as above, at the new r
/// ```
///
/// P_M(r) v = v - M^-1 grad g(r) G_M(r)^-1 Dg(r) v is the M-orthogonal projection onto the
/// tangent space (seed Section 2.1). K_r = 1 is constrained BAOAB (Leimkuhler and Matthews
/// 2016, "V R O R V"), K_r = 3 the g-BAOAB of molecular-dynamics codes. The kappa system is the
/// seed's (eq. 3.1 upper part with eta h = tau), solved by Newton from kappa = 0 without the
/// homotopy: where no root lies near (tau |v| beyond the constraint's length scale, say) the
/// projection fails and the step is a typed failure ([`StepFailure::Root`]), which the
/// half-explicit scheme's truncation avoids.
///
/// **The O step's Gaussian.** The step's Brownian increment dw (the same increment every
/// scheme of a study gets on a path, the sum of the fine increments) gives xi = dw / sqrt(h),
/// exactly N(0, I) and independent across steps: the O step has the exact law of the
/// Ornstein-Uhlenbeck velocity, so weak errors and invariant measures are those of BAOAB.
/// The coupling with the driving path is the one the OU integral has with its own increment:
/// int_0^h exp(-c (h - s)) dw(s) differs from its variance-matched multiple of dw by a
/// mean-zero term of variance O(c^2 h^3), so strong errors against a reference on the same
/// Brownian path stay comparable (order up to 1 from the coupling).
///
/// **Unequal relaxation rates.** The O step is the exact update of each coordinate, then the
/// projection. Where gamma (M^-1)_ii is the same for every coordinate (one mass, equal masses,
/// or a friction proportional to the mass as in molecular-dynamics codes) the two commute and
/// the O step keeps the equilibrium velocity law N(0, kT P_M M^-1) exactly. Where the rates
/// differ, the projection discards O(h^2) of the velocity covariance per step, which builds up
/// to an O(h) bias of the kinetic temperature (measured on the rigid triatomic, masses 16, 1, 1:
/// 0.7% cold at h = 1.2e-3, docs/stability.md).
///
/// **The multiplier.** mu's increment over a step ([`Scheme::multiplier_increment`]) is the sum
/// of the step's constraint impulses: kappa / tau of each SHAKE and the multiplier of each
/// RATTLE projection.
///
/// [`Scheme::multiplier_increment`]: sdae_model::Scheme::multiplier_increment
#[derive(Debug, Clone)]
pub struct Splitting<S: System> {
    pub(crate) system: S,
    config: SplittingConfig,
    pub(crate) form: LangevinForm,
    /// (M^-1)_ii.
    pub(crate) inverse_mass: Vec<f64>,
    /// The O step's factors for the step size `ou_h`.
    pub(crate) ou: Vec<OuFactors>,
    ou_h: f64,
    solver: BallSolver<Gram<S>>,
    /// G_M(r) and its factors for the velocity projections, valid at `factored_at`.
    gram: Gram<S>,
    factor: <Gram<S> as Factorize>::Factor,
    /// F(r) at `cached_at`.
    force: Vec<f64>,
    /// The point of the cached force and factors (the last step's end), valid if `cached`.
    cached_at: Vec<f64>,
    cached: bool,
    factored: bool,
    r: Vec<f64>,
    v: Vec<f64>,
    y: Vec<f64>,
    x: Vec<f64>,
    u: Vec<f64>,
    zero: Vec<f64>,
    scratch: Vec<f64>,
    lambda: Vec<f64>,
    pub(crate) impulse: Vec<f64>,
    /// The buffers of the lane form of a constraint solved by Newton, kept between steps.
    pub(crate) lanes: LaneStore,
}

/// What the position projections of a step add up to.
#[derive(Debug, Clone, Copy, Default)]
struct Projections {
    /// Newton iterations of all SHAKE projections.
    iterations: usize,
    /// max |g| after the last one.
    residual: f64,
}

impl<S: System> Splitting<S> {
    /// The scheme for `system`: it must have a Langevin form ([`System::langevin`]), a
    /// diagonal mass (the O step's exact update is taken coordinate by coordinate) and noise of
    /// dimension n (or none).
    pub fn new(system: S, config: SplittingConfig) -> Result<Self, SplittingError> {
        let (n, m) = check_dimensions(&system)?;
        config.with_substeps(config.substeps)?;
        config.with_tolerance(config.solver.tolerance)?;
        let form = system.langevin().ok_or(SplittingError::NotLangevin(
            "the drift has no constant friction or the noise is not additive",
        ))?;
        let mass = system.mass();
        let inverse_mass: Option<Vec<f64>> =
            (0..n).map(|i| mass.inverse_diagonal_entry(i)).collect();
        let inverse_mass = inverse_mass.filter(|_| <S::Mass as Mass>::DIAGONAL).ok_or(
            SplittingError::NotLangevin(
                "the O step's exact Ornstein-Uhlenbeck update needs a diagonal mass",
            ),
        )?;
        let l = system.noise_dim();
        if l != 0 && l != n {
            return Err(SplittingError::NotLangevin(
                "additive noise sigma I has n components (or none)",
            ));
        }
        let c = system.constraint();
        let gram = c.new_gram();
        Ok(Self {
            solver: BallSolver::new(c.new_gram(), config.solver),
            factor: gram.new_factor(),
            gram,
            form,
            inverse_mass,
            ou: vec![
                OuFactors {
                    decay: 1.0,
                    noise: 0.0
                };
                n
            ],
            ou_h: f64::NAN,
            force: vec![0.0; n],
            cached_at: vec![0.0; n],
            cached: false,
            factored: false,
            r: vec![0.0; n],
            v: vec![0.0; n],
            y: vec![0.0; n],
            x: vec![0.0; n],
            u: vec![0.0; n],
            zero: vec![0.0; n],
            scratch: vec![0.0; scratch_len(n, m)],
            lambda: vec![0.0; m],
            impulse: vec![0.0; m],
            lanes: LaneStore::default(),
            system,
            config,
        })
    }

    /// The settings.
    pub fn config(&self) -> &SplittingConfig {
        &self.config
    }

    /// The system's Langevin form (friction and noise amplitude).
    pub fn langevin_form(&self) -> &LangevinForm {
        &self.form
    }

    /// One step through the general path, which every system this scheme accepts can take;
    /// [`Scheme::step`](sdae_model::Scheme::step) takes it wherever the sphere's lane form at
    /// W = 1 does not apply or does not decide. (r, v) are unchanged on failure.
    pub fn step_general(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        sdae_model::check_step_input(&self.system, r, v, h, dw)?;
        self.general_step(r, v, h, dw)
    }

    /// The general path after the input checks.
    pub(crate) fn general_step(
        &mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
    ) -> StepResult {
        let reuse = self.cached && self.cached_at == r;
        self.cached = false;
        self.factored = reuse;
        self.r.copy_from_slice(r);
        self.v.copy_from_slice(v);
        self.impulse.fill(0.0);
        let tau = h / (2 * self.config.substeps) as f64;
        let mut projections = Projections::default();

        if !reuse {
            self.evaluate_force()?;
        }
        self.kick(0.5 * h);
        self.project_velocity()?;
        for _ in 0..self.config.substeps {
            self.geodesic_drift(tau, &mut projections)?;
        }
        self.ornstein_uhlenbeck(h, dw);
        self.project_velocity()?;
        for _ in 0..self.config.substeps {
            self.geodesic_drift(tau, &mut projections)?;
        }
        self.evaluate_force()?;
        self.kick(0.5 * h);
        self.project_velocity()?;

        let v_norm2 = norm2_squared(&self.v);
        if !v_norm2.is_finite() {
            return Err(StepFailure::NonFinite {
                what: "velocity after the step",
                size: v_norm2.sqrt(),
            });
        }
        r.copy_from_slice(&self.r);
        v.copy_from_slice(&self.v);
        self.cached_at.copy_from_slice(&self.r);
        self.cached = true;
        let velocity_residual = self.config.monitor_velocity_constraint.then(|| {
            self.system
                .constraint()
                .jacobian_mul(&self.r, &self.v, &mut self.lambda);
            max_abs(&self.lambda)
        });
        Ok(StepOutcome {
            eta: 1.0,
            newton_iterations: projections.iterations,
            certificate: None,
            position_residual: Some(projections.residual),
            velocity_residual,
        })
    }

    /// F(r) = a(r, 0) at the current r; a failure if it is not finite.
    fn evaluate_force(&mut self) -> Result<(), StepFailure> {
        self.system.drift(&self.r, &self.zero, &mut self.force);
        let size = norm2_squared(&self.force);
        if !size.is_finite() {
            return Err(StepFailure::NonFinite {
                what: "force F(r)",
                size: size.sqrt(),
            });
        }
        Ok(())
    }

    /// B: v <- v + dt M^-1 F(r).
    fn kick(&mut self, dt: f64) {
        for ((vi, fi), wi) in self.v.iter_mut().zip(&self.force).zip(&self.inverse_mass) {
            *vi += dt * (wi * fi);
        }
    }

    /// The O step's factors for h, computed when h changes.
    pub(crate) fn refresh_ou(&mut self, h: f64) {
        if self.ou_h != h {
            for (f, &w) in self.ou.iter_mut().zip(&self.inverse_mass) {
                *f = OuFactors::new(&self.form, w, h);
            }
            self.ou_h = h;
        }
    }

    /// O: the exact Ornstein-Uhlenbeck update of v over h ([`OuFactors`]).
    fn ornstein_uhlenbeck(&mut self, h: f64, dw: &[f64]) {
        self.refresh_ou(h);
        for (vi, f) in self.v.iter_mut().zip(&self.ou) {
            *vi *= f.decay;
        }
        for ((vi, f), w) in self.v.iter_mut().zip(&self.ou).zip(dw) {
            *vi += f.noise * w;
        }
    }

    /// RATTLE: v <- P_M(r) v = v + M^-1 grad g(r) lambda with G_M(r) lambda = -Dg(r) v,
    /// factoring G_M(r) unless it is factored at this r.
    fn project_velocity(&mut self) -> Result<(), StepFailure> {
        let (c, mass) = (self.system.constraint(), self.system.mass());
        if !self.factored {
            c.cross_gram(&self.r, &self.r, mass, &mut self.scratch, &mut self.gram);
            self.gram
                .factor_into(&mut self.factor)
                .map_err(|source| StepFailure::Singular {
                    what: "G_M(r) of the RATTLE velocity projection",
                    source,
                })?;
            self.factored = true;
        }
        c.jacobian_mul(&self.r, &self.v, &mut self.lambda);
        for l in self.lambda.iter_mut() {
            *l = -*l;
        }
        self.factor.solve_in_place(&mut self.lambda);
        for (i, l) in self.impulse.iter_mut().zip(&self.lambda) {
            *i += l;
        }
        c.displace(&self.r, &self.lambda, mass, &self.v, &mut self.u);
        std::mem::swap(&mut self.v, &mut self.u);
        Ok(())
    }

    /// A geodesic substep of length tau: SHAKE onto g = 0, the velocity (r' - r) / tau, RATTLE.
    fn geodesic_drift(
        &mut self, tau: f64, projections: &mut Projections,
    ) -> Result<(), StepFailure> {
        let (c, mass) = (self.system.constraint(), self.system.mass());
        for ((yi, ri), vi) in self.y.iter_mut().zip(&self.r).zip(&self.v) {
            *yi = ri + tau * vi;
        }
        let mut problem = KappaProblem {
            constraint: c,
            mass,
            r: &self.r,
            y: &self.y,
            x: &mut self.x,
            scratch: &mut self.scratch,
            floor: c.roundoff().floor(max_abs(&self.y)),
            at_y: false,
            velocity: None,
        };
        let certificate = self
            .solver
            .solve(&mut problem, f64::INFINITY)
            .map_err(|source| StepFailure::Root {
                what: "SHAKE projection onto g = 0",
                source,
            })?;
        let at_y = problem.at_y;
        projections.iterations += certificate.iterations;
        projections.residual = certificate.residual;
        let inverse_tau = 1.0 / tau;
        for (l, k) in self.lambda.iter_mut().zip(self.solver.root()) {
            *l = k * inverse_tau;
        }
        for (i, l) in self.impulse.iter_mut().zip(&self.lambda) {
            *i += l;
        }
        c.displace(&self.r, &self.lambda, mass, &self.v, &mut self.u);
        std::mem::swap(&mut self.v, &mut self.u);
        let r_new = if at_y { &mut self.y } else { &mut self.x };
        std::mem::swap(&mut self.r, r_new);
        self.factored = false;
        self.project_velocity()
    }
}
