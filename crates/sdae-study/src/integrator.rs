//! The schemes a study compares, behind one object-safe interface: the half-explicit
//! drift-truncated Euler scheme (seed eq. 3.1-3.2) with several constants, and the solvers of the
//! inherent SDE (seed eq. 2.4) from `sdae-reference`.

use sdae_ift::{Factorize, IftError};
use sdae_manifold::vector::{dot, max_abs};
use sdae_manifold::{Constraint, Mass};
use sdae_reference::{
    CurvedSystem, EulerMaruyama, ProjectedEulerMaruyama, ReferenceError, ReferenceSolver,
    StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_scheme::{StepFailure, Stepper, StepperConfig, System};
use serde::{Deserialize, Serialize};

/// A scheme of the comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeKind {
    /// The seed's scheme with the theory's C_eta and C_kappa (Thm 3.4).
    HalfExplicitTheory,
    /// The seed's scheme with the scene's practical C_eta.
    HalfExplicitPractical,
    /// The half-explicit Euler scheme without truncation (eta = 1).
    HalfExplicitUntruncated,
    /// Euler-Maruyama on the inherent SDE.
    EulerMaruyama,
    /// Truncated Euler-Maruyama on the inherent SDE (Remark 3.3, drift of Lemma 4.2).
    TruncatedEulerMaruyama,
    /// Euler-Maruyama followed by projection onto the tangent bundle.
    ProjectedEulerMaruyama,
    /// Stochastic Heun on the inherent SDE (for noise B(r) that does not depend on v).
    StochasticHeun,
}

impl SchemeKind {
    /// Every scheme, in report order.
    pub const ALL: [SchemeKind; 7] = [
        SchemeKind::HalfExplicitTheory,
        SchemeKind::HalfExplicitPractical,
        SchemeKind::HalfExplicitUntruncated,
        SchemeKind::EulerMaruyama,
        SchemeKind::TruncatedEulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
        SchemeKind::StochasticHeun,
    ];

    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SchemeKind::HalfExplicitTheory => "half-explicit-theory",
            SchemeKind::HalfExplicitPractical => "half-explicit-practical",
            SchemeKind::HalfExplicitUntruncated => "half-explicit-untruncated",
            SchemeKind::EulerMaruyama => "euler-maruyama",
            SchemeKind::TruncatedEulerMaruyama => "truncated-euler-maruyama",
            SchemeKind::ProjectedEulerMaruyama => "projected-euler-maruyama",
            SchemeKind::StochasticHeun => "stochastic-heun",
        }
    }

    /// The scheme of a name, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the scheme keeps the constraint exactly (the half-explicit family and projected
    /// Euler-Maruyama) rather than drifting off the manifold by O(h).
    pub fn keeps_constraint(self) -> bool {
        !matches!(
            self,
            SchemeKind::EulerMaruyama
                | SchemeKind::TruncatedEulerMaruyama
                | SchemeKind::StochasticHeun
        )
    }
}

/// Why a path of a scheme stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FailureKind {
    /// The kappa system has no root (the homotopy stops at a fold, seed Fig. 1b).
    NoRoot,
    /// A root outside the ball or implausibly far (the second root, seed Fig. 1a).
    SpuriousRoot,
    /// Newton (and the homotopy) did not converge.
    NoConvergence,
    /// A singular Jacobian or Gram matrix.
    Singular,
    /// NaN or infinite values.
    NonFinite,
    /// Finite but beyond the study's blow-up bound.
    BlowUp,
    /// |g(r)| or |Dg(r) v| beyond the study's drift tolerance.
    ConstraintDrift,
    /// Anything else (an input the solver rejected).
    Other,
}

impl FailureKind {
    /// Every kind, in report order.
    pub const ALL: [FailureKind; 8] = [
        FailureKind::NoRoot,
        FailureKind::SpuriousRoot,
        FailureKind::NoConvergence,
        FailureKind::Singular,
        FailureKind::NonFinite,
        FailureKind::BlowUp,
        FailureKind::ConstraintDrift,
        FailureKind::Other,
    ];

    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            FailureKind::NoRoot => "no-root",
            FailureKind::SpuriousRoot => "spurious-root",
            FailureKind::NoConvergence => "no-convergence",
            FailureKind::Singular => "singular",
            FailureKind::NonFinite => "non-finite",
            FailureKind::BlowUp => "blow-up",
            FailureKind::ConstraintDrift => "constraint-drift",
            FailureKind::Other => "other",
        }
    }
}

impl From<&IftError> for FailureKind {
    fn from(error: &IftError) -> Self {
        match error {
            IftError::NoRoot { .. } => FailureKind::NoRoot,
            IftError::OutsideBall { .. } | IftError::Implausible { .. } => {
                FailureKind::SpuriousRoot
            }
            IftError::NoConvergence { .. } => FailureKind::NoConvergence,
            IftError::Singular { .. } => FailureKind::Singular,
            IftError::NonFinite { .. } => FailureKind::NonFinite,
        }
    }
}

impl From<&StepFailure> for FailureKind {
    fn from(failure: &StepFailure) -> Self {
        match failure {
            StepFailure::Kappa(e) => e.into(),
            StepFailure::NonFiniteDrift { .. } | StepFailure::NonFiniteVelocity { .. } => {
                FailureKind::NonFinite
            }
            StepFailure::Input(_) => FailureKind::Other,
        }
    }
}

impl From<&ReferenceError> for FailureKind {
    fn from(error: &ReferenceError) -> Self {
        match error {
            ReferenceError::NonFinite { .. } => FailureKind::NonFinite,
            ReferenceError::SingularGram { .. } => FailureKind::Singular,
            ReferenceError::Projection { source } => source.into(),
            _ => FailureKind::Other,
        }
    }
}

/// What one step did, in the terms every scheme shares.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepInfo {
    /// The drift was truncated (eta < 1 or theta < 1).
    pub truncated: bool,
    /// Newton iterations (of the kappa system or of the projection).
    pub newton_iterations: usize,
    /// The homotopy fallback was needed.
    pub homotopy: bool,
}

/// One scheme, stepping a path of a system with n coordinates, m constraints and l noise
/// components.
pub trait Integrator {
    /// The scheme.
    fn kind(&self) -> SchemeKind;
    /// (n, m, l).
    fn dims(&self) -> (usize, usize, usize);
    /// Advances (r, v) by one step of size h with Brownian increment dw and writes the increment
    /// of mu (eq. 1.4 for the scheme, eq. 2.3 for the inherent SDE) to `dmu`.
    fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
        dmu: &mut [f64],
    ) -> Result<StepInfo, FailureKind>;
    /// (max |g(r)|, max |Dg(r) v|); `scratch` has length m.
    fn residuals(&self, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64);
    /// The kinetic energy v^T M v / 2; `scratch` has length n.
    fn kinetic_energy(&self, v: &[f64], scratch: &mut [f64]) -> f64;
}

fn kinetic_of<M: Mass>(mass: &M, v: &[f64], scratch: &mut [f64]) -> f64 {
    mass.apply(v, scratch);
    0.5 * dot(v, scratch)
}

fn residuals_of<C: Constraint>(c: &C, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64) {
    c.value(r, scratch);
    let position = max_abs(scratch);
    c.jacobian_mul(r, v, scratch);
    (position, max_abs(scratch))
}

/// The half-explicit scheme (seed eq. 3.1-3.2) as an [`Integrator`].
struct HalfExplicit<S>
where
    S: System<Constraint: Constraint<Gram: Factorize>>,
{
    kind: SchemeKind,
    stepper: Stepper<S>,
}

impl<S> Integrator for HalfExplicit<S>
where
    S: CurvedSystem,
{
    fn kind(&self) -> SchemeKind {
        self.kind
    }
    fn dims(&self) -> (usize, usize, usize) {
        let s = self.stepper.system();
        let c = s.constraint();
        (c.dim(), c.n_constraints(), s.noise_dim())
    }
    fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
        dmu: &mut [f64],
    ) -> Result<StepInfo, FailureKind> {
        let report = self
            .stepper
            .step(r, v, h, dw)
            .map_err(|e| FailureKind::from(&e))?;
        dmu.copy_from_slice(self.stepper.lambda());
        Ok(StepInfo {
            truncated: report.eta < 1.0,
            newton_iterations: report.certificate.iterations,
            homotopy: report.used_homotopy(),
        })
    }
    fn residuals(&self, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64) {
        residuals_of(self.stepper.system().constraint(), r, v, scratch)
    }
    fn kinetic_energy(&self, v: &[f64], scratch: &mut [f64]) -> f64 {
        kinetic_of(self.stepper.system().mass(), v, scratch)
    }
}

/// A solver of the inherent SDE as an [`Integrator`].
struct Inherent<R> {
    kind: SchemeKind,
    solver: R,
}

impl<R> Integrator for Inherent<R>
where
    R: ReferenceSolver,
{
    fn kind(&self) -> SchemeKind {
        self.kind
    }
    fn dims(&self) -> (usize, usize, usize) {
        let sde = self.solver.sde();
        (sde.dim(), sde.n_constraints(), sde.noise_dim())
    }
    fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
        dmu: &mut [f64],
    ) -> Result<StepInfo, FailureKind> {
        let report = self
            .solver
            .step(r, v, h, dw)
            .map_err(|e| FailureKind::from(&e))?;
        dmu.copy_from_slice(self.solver.multiplier_increment());
        Ok(StepInfo {
            truncated: report.truncation < 1.0,
            newton_iterations: report.projection_iterations,
            homotopy: false,
        })
    }
    fn residuals(&self, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64) {
        residuals_of(self.solver.sde().system().constraint(), r, v, scratch)
    }
    fn kinetic_energy(&self, v: &[f64], scratch: &mut [f64]) -> f64 {
        kinetic_of(self.solver.sde().system().mass(), v, scratch)
    }
}

/// The constants of the half-explicit family for one scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SchemeConstants {
    /// The theory's (C_eta, C_kappa) (Thm 3.4) where C_g is known.
    pub theory: Option<(f64, f64)>,
    /// The practical C_eta.
    pub practical_c_eta: f64,
    /// C_kappa of the practical and untruncated variants (infinite: only the plausibility check).
    pub c_kappa: f64,
}

/// Builds `kind` for `system`; fails with a reason if the scheme does not apply to it (no
/// theory bound, noise that depends on v for Heun, a setting the solver rejects).
pub fn build_integrator<S>(
    kind: SchemeKind,
    system: &S,
    constants: &SchemeConstants,
) -> Result<Box<dyn Integrator>, String>
where
    S: CurvedSystem + Clone + 'static,
{
    let stepper = |config: Result<StepperConfig, sdae_scheme::SchemeError>| {
        let config = config.map_err(|e| e.to_string())?;
        let stepper = Stepper::new(system.clone(), config).map_err(|e| e.to_string())?;
        Ok::<Box<dyn Integrator>, String>(Box::new(HalfExplicit { kind, stepper }))
    };
    let inherent = |e: ReferenceError| e.to_string();
    match kind {
        SchemeKind::HalfExplicitTheory => {
            let (c_eta, c_kappa) = constants
                .theory
                .ok_or("no bound on C_g (eq. 2.2) is known for this scene")?;
            stepper(StepperConfig::new(c_eta, c_kappa))
        }
        SchemeKind::HalfExplicitPractical => stepper(StepperConfig::new(
            constants.practical_c_eta,
            constants.c_kappa,
        )),
        SchemeKind::HalfExplicitUntruncated => stepper(
            StepperConfig::new(constants.practical_c_eta, constants.c_kappa)
                .map(StepperConfig::untruncated),
        ),
        SchemeKind::EulerMaruyama => Ok(Box::new(Inherent {
            kind,
            solver: EulerMaruyama::new(system.clone()).map_err(inherent)?,
        })),
        SchemeKind::TruncatedEulerMaruyama => Ok(Box::new(Inherent {
            kind,
            solver: TruncatedEulerMaruyama::new(system.clone()).map_err(inherent)?,
        })),
        SchemeKind::ProjectedEulerMaruyama => Ok(Box::new(Inherent {
            kind,
            solver: ProjectedEulerMaruyama::new(system.clone()).map_err(inherent)?,
        })),
        SchemeKind::StochasticHeun => Ok(Box::new(Inherent {
            kind,
            solver: StochasticHeun::new(system.clone()).map_err(inherent)?,
        })),
    }
}
