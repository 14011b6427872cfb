//! The splitting scheme BAOAB with SHAKE/RATTLE projections, and its geodesic form g-BAOAB:
//! the scheme, and its general path, which every Langevin system can take (the constraint,
//! the mass, the force and the noise as traits): the step body of `kernel.rs` over one path's
//! f64 with the ball solver and the Gram matrix's factors ([`OnePath`]).

use sdae_ift::BallSolver;
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, Factorize, GramMatrix, GramStructure, Mass, Solve, scratch_len};
use sdae_model::engine::LaneStore;
use sdae_model::{
    KappaProblem, LangevinForm, StepFailure, StepOutcome, StepResult, System, check_dimensions,
};

use crate::config::{SplittingConfig, StepSizes};
use crate::error::SplittingError;
use crate::kernel::{self, Motion, Shaken, SplittingKernel, StepNumbers, shake_impulse};
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
/// RATTLE projection. Where G_M is 1 x 1 (one constraint), the RATTLE multiplier is the
/// quotient -Dg(r) v / G_M(r) on every path, one path's and the lanes' alike.
///
/// **One step body.** The step is written once over the number type (`kernel.rs`): the
/// general path runs it over one path's f64, the ensemble's lanes over W paths (the sphere's
/// closed forms, Newton over a constraint's lane form), with each path's operations in the
/// same order, so that a lane is its path's step bit for bit.
///
/// [`Scheme::multiplier_increment`]: sdae_model::Scheme::multiplier_increment
#[derive(Debug, Clone)]
pub struct Splitting<S: System> {
    pub(crate) system: S,
    config: SplittingConfig,
    pub(crate) form: LangevinForm,
    /// (M^-1)_ii.
    pub(crate) inverse_mass: Vec<f64>,
    /// The sizes and the O step's factors of a step of size `numbers.sizes.h`.
    pub(crate) numbers: StepNumbers,
    /// The general path's solver, factors and buffers.
    work: Workspace<Gram<S>>,
    r: Vec<f64>,
    v: Vec<f64>,
    lambda: Vec<f64>,
    pub(crate) impulse: Vec<f64>,
    /// The buffers of the lane form of a constraint solved by Newton, kept between steps.
    pub(crate) lanes: LaneStore,
}

/// The general path's SHAKE solver, G_M(r) with its factors, F(r), and buffers.
#[derive(Debug, Clone)]
struct Workspace<G: Factorize> {
    solver: BallSolver<G>,
    /// G_M(r) and its factors for the velocity projections.
    gram: G,
    factor: G::Factor,
    /// F(r) at `cached_at`.
    force: Vec<f64>,
    /// The point of the cached force and factors (the last step's end), valid if `cached`.
    cached_at: Vec<f64>,
    cached: bool,
    y: Vec<f64>,
    x: Vec<f64>,
    u: Vec<f64>,
    zero: Vec<f64>,
    scratch: Vec<f64>,
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
        let work = Workspace {
            solver: BallSolver::new(c.new_gram(), config.solver),
            factor: gram.new_factor(),
            gram,
            force: vec![0.0; n],
            cached_at: vec![0.0; n],
            cached: false,
            y: vec![0.0; n],
            x: vec![0.0; n],
            u: vec![0.0; n],
            zero: vec![0.0; n],
            scratch: vec![0.0; scratch_len(n, m)],
        };
        Ok(Self {
            work,
            form,
            inverse_mass,
            numbers: StepNumbers {
                sizes: StepSizes::new(&config, f64::NAN),
                ou: vec![
                    OuFactors {
                        decay: 1.0,
                        noise: 0.0
                    };
                    n
                ],
                monitor_velocity: config.monitor_velocity_constraint,
            },
            r: vec![0.0; n],
            v: vec![0.0; n],
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

    /// The general path after the input checks: the step body over one path ([`OnePath`]),
    /// from F(r) and G_M(r)'s factors of the last step where it ended at r.
    pub(crate) fn general_step(
        &mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
    ) -> StepResult {
        self.refresh_numbers(h);
        let work = &mut self.work;
        let resumed = work.cached && work.cached_at == r;
        work.cached = false;
        self.r.copy_from_slice(r);
        self.v.copy_from_slice(v);
        let mut one_path = OnePath {
            constraint: self.system.constraint(),
            mass: self.system.mass(),
            inverse_mass: &self.inverse_mass,
            numbers: &self.numbers,
            work,
            at_y: false,
        };
        let mut m = Motion::new(
            &mut self.r,
            &mut self.v,
            &mut self.impulse,
            &mut self.lambda,
            0.0,
        );
        let velocity_residual = kernel::step(&self.system, &mut one_path, &mut m, dw, resumed)?;
        let outcome = StepOutcome {
            eta: 1.0,
            // A sum of iteration counts, exact in f64.
            newton_iterations: m.iterations as usize,
            certificate: None,
            position_residual: Some(m.residual),
            velocity_residual,
        };
        r.copy_from_slice(&self.r);
        v.copy_from_slice(&self.v);
        self.work.cached_at.copy_from_slice(&self.r);
        self.work.cached = true;
        Ok(outcome)
    }

    /// The sizes and the O step's factors of a step of size h, computed when h changes.
    pub(crate) fn refresh_numbers(&mut self, h: f64) {
        let numbers = &mut self.numbers;
        if numbers.sizes.h != h {
            for (f, &w) in numbers.ou.iter_mut().zip(&self.inverse_mass) {
                *f = OuFactors::new(&self.form, w, h);
            }
            numbers.sizes = StepSizes::new(&self.config, h);
        }
    }
}

/// The step body's kernel for one path: the constraint and the mass as traits, SHAKE by the
/// ball solver without a ball, G_M(r) by the factors of its storage, typed failures.
struct OnePath<'a, C: Constraint, M: Mass> {
    constraint: &'a C,
    mass: &'a M,
    inverse_mass: &'a [f64],
    numbers: &'a StepNumbers,
    work: &'a mut Workspace<C::Gram>,
    /// Whether the last SHAKE's root is y itself (kappa = 0), else x.
    at_y: bool,
}

impl<C: Constraint, M: Mass> SplittingKernel<f64> for OnePath<'_, C, M> {
    type Rows = Vec<f64>;
    type Failure = StepFailure;
    fn numbers(&self) -> &StepNumbers {
        self.numbers
    }
    #[inline(always)]
    fn inverse_mass(&self, k: usize, x: f64) -> f64 {
        self.inverse_mass[k] * x
    }
    fn evaluate_force<S: System>(&mut self, system: &S, r: &[f64]) -> Result<(), StepFailure> {
        system.drift(r, &self.work.zero, &mut self.work.force);
        Ok(())
    }
    fn force(&self) -> &[f64] {
        &self.work.force
    }
    fn check_finite(&self, what: &'static str, x: &[f64]) -> Result<bool, StepFailure> {
        let size = norm2_squared(x);
        if !size.is_finite() {
            return Err(StepFailure::NonFinite {
                what,
                size: size.sqrt(),
            });
        }
        Ok(true)
    }
    /// G_M(r)'s factors, a typed failure where it is singular; lambda by the factors, or as
    /// the quotient where G_M(r) is a scalar.
    fn rattle_multiplier(
        &mut self, r: &Vec<f64>, v: &Vec<f64>, refactor: bool, lambda: &mut [f64],
    ) -> Result<bool, StepFailure> {
        let (c, work) = (self.constraint, &mut *self.work);
        if refactor {
            c.cross_gram(r, r, self.mass, &mut work.scratch, &mut work.gram);
            work.gram
                .factor_into(&mut work.factor)
                .map_err(|source| StepFailure::Singular {
                    what: "G_M(r) of the RATTLE velocity projection",
                    source,
                })?;
        }
        c.jacobian_mul(r, v, lambda);
        for l in lambda.iter_mut() {
            *l = -*l;
        }
        if <C::Gram as GramMatrix>::STRUCTURE == GramStructure::Scalar {
            lambda[0] /= work.gram.entry(0, 0);
        } else {
            work.factor.solve_in_place(lambda);
        }
        Ok(true)
    }
    fn displace(&mut self, r: &Vec<f64>, z: &[f64], v: &mut Vec<f64>) {
        let u = &mut self.work.u;
        self.constraint.displace(r, z, self.mass, v, u);
        std::mem::swap(v, u);
    }
    /// The ball solver from kappa = 0 in an unbounded ball; a failure where it finds no root.
    fn shake(
        &mut self, r: &Vec<f64>, v: &Vec<f64>, impulse: &mut [f64],
    ) -> Result<Shaken<f64>, StepFailure> {
        let (c, work, tau) = (self.constraint, &mut *self.work, self.numbers.sizes.tau);
        for ((yi, ri), vi) in work.y.iter_mut().zip(r).zip(v) {
            *yi = ri + tau * vi;
        }
        let mut problem = KappaProblem {
            constraint: c,
            mass: self.mass,
            r,
            y: &work.y,
            x: &mut work.x,
            scratch: &mut work.scratch,
            floor: c.roundoff().floor(max_abs(&work.y)),
            at_y: false,
            velocity: None,
        };
        let certificate = work
            .solver
            .solve(&mut problem, f64::INFINITY)
            .map_err(|source| StepFailure::Root {
                what: "SHAKE projection onto g = 0",
                source,
            })?;
        self.at_y = problem.at_y;
        let inverse_tau = self.numbers.sizes.inverse_tau;
        shake_impulse(work.solver.root(), inverse_tau, impulse);
        Ok(Shaken {
            ok: true,
            iterations: certificate.iterations as f64,
            residual: certificate.residual,
        })
    }
    fn move_to_root(&mut self, r: &mut Vec<f64>) {
        let root = if self.at_y {
            &mut self.work.y
        } else {
            &mut self.work.x
        };
        std::mem::swap(r, root);
    }
    fn velocity_residual(&mut self, r: &Vec<f64>, v: &Vec<f64>, scratch: &mut [f64]) -> f64 {
        self.constraint.jacobian_mul(r, v, scratch);
        max_abs(scratch)
    }
}
