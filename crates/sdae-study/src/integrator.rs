//! The built-in schemes a study compares, each an implementation of the one step trait
//! [`Scheme`]: the half-explicit drift-truncated Euler scheme (seed eq. 3.1-3.2) with several
//! constants, and the solvers of the inherent SDE (seed eq. 2.4) from `sdae-reference`. Each
//! also comes as a [`PathEnsemble`](sdae_model::PathEnsemble) of many paths: each built-in
//! scheme has a lane form and runs as a [`LaneEnsemble`], which steps in SIMD lanes where the
//! system has a lane form; a user's scheme runs as a [`PathLoop`].

use sdae_model::{KernelScheme, Kernelized, LaneEnsemble, LaneScheme, PathLoop, Scheme};
use sdae_reference::{
    CurvedSystem, EulerMaruyama, ProjectedEulerMaruyama, StochasticHeun, TruncatedEulerMaruyama,
};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_splitting::{Splitting, SplittingConfig};
use serde::{Deserialize, Serialize};

use crate::error::StudyError;

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
    /// Beyond the seed: the practical variant with the Brownian increment of a truncated step
    /// scaled by sqrt(eta), so that the step is in law an untruncated step of size eta h
    /// (truncation that keeps the temperature).
    HalfExplicitRescaled,
    /// Beyond the seed: the size functional on each constraint's own length scale (the
    /// relative speed of neighbouring beads per segment length, with the largest force per
    /// particle), with the scene's `local_c_eta`; the seed's functional for a unit sphere.
    HalfExplicitLocal,
    /// Euler-Maruyama on the inherent SDE.
    EulerMaruyama,
    /// Truncated Euler-Maruyama on the inherent SDE (Remark 3.3, drift of Lemma 4.2).
    TruncatedEulerMaruyama,
    /// Euler-Maruyama followed by projection onto the tangent bundle.
    ProjectedEulerMaruyama,
    /// Stochastic Heun on the inherent SDE (diffusion at the left point: an Ito scheme, also
    /// where the noise depends on v).
    StochasticHeun,
    /// Constrained BAOAB with SHAKE/RATTLE projections (Langevin systems only): the
    /// molecular-dynamics standard, `sdae_splitting::SplittingConfig::baoab`.
    BaoabRattle,
    /// g-BAOAB, BAOAB with the scene's `geodesic_substeps` SHAKE/RATTLE substeps per drift
    /// (default 3; Langevin systems only).
    GBaoab,
}

impl SchemeKind {
    /// Every scheme, in report order.
    pub const ALL: [SchemeKind; 11] = [
        SchemeKind::HalfExplicitTheory,
        SchemeKind::HalfExplicitPractical,
        SchemeKind::HalfExplicitUntruncated,
        SchemeKind::HalfExplicitRescaled,
        SchemeKind::HalfExplicitLocal,
        SchemeKind::EulerMaruyama,
        SchemeKind::TruncatedEulerMaruyama,
        SchemeKind::ProjectedEulerMaruyama,
        SchemeKind::StochasticHeun,
        SchemeKind::BaoabRattle,
        SchemeKind::GBaoab,
    ];

    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SchemeKind::HalfExplicitTheory => "half-explicit-theory",
            SchemeKind::HalfExplicitPractical => "half-explicit-practical",
            SchemeKind::HalfExplicitUntruncated => "half-explicit-untruncated",
            SchemeKind::HalfExplicitRescaled => "half-explicit-rescaled",
            SchemeKind::HalfExplicitLocal => "half-explicit-local",
            SchemeKind::EulerMaruyama => "euler-maruyama",
            SchemeKind::TruncatedEulerMaruyama => "truncated-euler-maruyama",
            SchemeKind::ProjectedEulerMaruyama => "projected-euler-maruyama",
            SchemeKind::StochasticHeun => "stochastic-heun",
            SchemeKind::BaoabRattle => "baoab-rattle",
            SchemeKind::GBaoab => "g-baoab",
        }
    }

    /// The scheme of a name, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The scheme's weak order for smooth observables at a fixed time: 2 for the splitting
    /// schemes (BAOAB and g-BAOAB with SHAKE/RATTLE, Leimkuhler and Matthews), 1 for the
    /// half-explicit family and the Euler-type schemes on the inherent SDE (eq. 2.4). The weak
    /// study extrapolates its reference with it.
    pub fn weak_order(self) -> u32 {
        match self {
            SchemeKind::BaoabRattle | SchemeKind::GBaoab => 2,
            _ => 1,
        }
    }

    /// Whether the scheme keeps the constraint exactly (the half-explicit family, projected
    /// Euler-Maruyama and the splitting schemes) rather than drifting off the manifold by O(h).
    pub fn keeps_constraint(self) -> bool {
        !matches!(
            self,
            SchemeKind::EulerMaruyama
                | SchemeKind::TruncatedEulerMaruyama
                | SchemeKind::StochasticHeun
        )
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
    /// C_eta of the local size functional (`half-explicit-local`).
    pub local_c_eta: f64,
    /// K_r of `g-baoab`.
    pub geodesic_substeps: usize,
    /// The SHAKE tolerance of `baoab-rattle` and `g-baoab`.
    pub projection_tolerance: f64,
}

/// A boxed scheme stepping systems of type `S`.
pub type BoxedScheme<S> = Box<dyn Scheme<System = S>>;

pub use sdae_lockstep::BoxedEnsemble;

/// A built-in scheme as built (each has a lane form).
type Built<S> = Box<dyn LaneScheme<System = S>>;

/// Builds `kind` for `system`; fails with a reason if the scheme does not apply to it (no
/// theory bound, a setting the solver rejects).
pub fn build_integrator<S>(
    kind: SchemeKind, system: &S, constants: &SchemeConstants,
) -> Result<BoxedScheme<S>, StudyError>
where
    S: CurvedSystem + Clone + 'static,
{
    Ok(build_kind(kind, system, constants)?)
}

/// Builds `kind` for `paths` paths of `system` from (r0, v0) as a [`LaneEnsemble`] (SIMD lanes
/// where the system has a lane form, else path by path).
pub fn build_ensemble<S>(
    kind: SchemeKind, system: &S, constants: &SchemeConstants, paths: usize, r0: &[f64], v0: &[f64],
) -> Result<BoxedEnsemble<S>, StudyError>
where
    S: CurvedSystem + Clone + 'static,
{
    let scheme = build_kind(kind, system, constants)?;
    Ok(Box::new(LaneEnsemble::new(scheme, paths, r0, v0)?))
}

fn build_kind<S>(
    kind: SchemeKind, system: &S, constants: &SchemeConstants,
) -> Result<Built<S>, StudyError>
where
    S: CurvedSystem + Clone + 'static,
{
    let not_applicable = |reason: String| StudyError::SchemeNotApplicable {
        scheme: kind.name().into(),
        reason,
    };
    let stepper = |config: Result<StepperConfig, sdae_scheme::SchemeError>| {
        let config = config.map_err(|e| not_applicable(e.to_string()))?;
        let stepper =
            Stepper::new(system.clone(), config).map_err(|e| not_applicable(e.to_string()))?;
        Ok::<Built<S>, StudyError>(Box::new(stepper))
    };
    let inherent = |e: sdae_reference::ReferenceError| not_applicable(e.to_string());
    match kind {
        SchemeKind::HalfExplicitTheory => {
            let (c_eta, c_kappa) = constants.theory.ok_or_else(|| {
                not_applicable("no bound on C_g (eq. 2.2) is known for this scene".into())
            })?;
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
        SchemeKind::HalfExplicitRescaled => stepper(
            StepperConfig::new(constants.practical_c_eta, constants.c_kappa)
                .map(StepperConfig::rescaled),
        ),
        SchemeKind::HalfExplicitLocal => stepper(
            StepperConfig::new(constants.local_c_eta, constants.c_kappa).map(StepperConfig::local),
        ),
        SchemeKind::EulerMaruyama => Ok(Box::new(
            EulerMaruyama::new(system.clone()).map_err(inherent)?,
        )),
        SchemeKind::TruncatedEulerMaruyama => Ok(Box::new(
            TruncatedEulerMaruyama::new(system.clone()).map_err(inherent)?,
        )),
        SchemeKind::ProjectedEulerMaruyama => Ok(Box::new(
            ProjectedEulerMaruyama::new(system.clone()).map_err(inherent)?,
        )),
        SchemeKind::StochasticHeun => Ok(Box::new(
            StochasticHeun::new(system.clone()).map_err(inherent)?,
        )),
        SchemeKind::BaoabRattle | SchemeKind::GBaoab => {
            let substeps = match kind {
                SchemeKind::GBaoab => constants.geodesic_substeps,
                _ => 1,
            };
            let config = SplittingConfig::baoab()
                .with_substeps(substeps)
                .and_then(|c| c.with_tolerance(constants.projection_tolerance))
                .map_err(|e| not_applicable(e.to_string()))?;
            let scheme = Splitting::new(system.clone(), config)
                .map_err(|e| not_applicable(e.to_string()))?;
            Ok(Box::new(scheme))
        }
    }
}

/// Builds a fresh scheme (one per worker thread) or says why it does not apply.
type Build<S> = dyn Fn() -> Result<BoxedScheme<S>, StudyError> + Send + Sync;

/// Builds a fresh ensemble of the scheme for (paths, r0, v0).
type BuildEnsemble<S> =
    dyn Fn((usize, &[f64], &[f64])) -> Result<BoxedEnsemble<S>, StudyError> + Send + Sync;

/// A scheme of a study, by name: a built-in one ([`StudyScheme::built_in`]) or any
/// implementation of [`Scheme`] a user brings ([`StudyScheme::new`]). Each worker thread
/// builds its own instance, so a scheme needs no `Send` or `Sync` itself.
#[derive(Clone)]
pub struct StudyScheme<S> {
    name: String,
    build: std::sync::Arc<Build<S>>,
    ensemble: std::sync::Arc<BuildEnsemble<S>>,
    time_changed: bool,
}

impl<S: sdae_model::System + 'static> StudyScheme<S> {
    /// A scheme named `name` (as it appears in reports), built by `build`, which says why
    /// the scheme does not apply when it does not. Its paths are stepped one at a time
    /// ([`PathLoop`]).
    pub fn new<F, T>(name: impl Into<String>, build: F) -> Self
    where
        F: Fn() -> Result<T, String> + Send + Sync + 'static,
        T: Scheme<System = S> + 'static,
    {
        Self::assemble(name.into(), build, |scheme, paths, r0, v0| {
            Ok(Box::new(PathLoop::new(scheme, paths, r0, v0)?))
        })
    }

    /// A scheme written once over the number type ([`KernelScheme`]) named `name`, built by
    /// `build`: its paths are stepped in SIMD lanes where its system's constraint offers a
    /// lane form for its mass ([`Kernelized`] in a [`LaneEnsemble`]), and one at a time
    /// elsewhere, with the same numbers either way.
    pub fn in_lanes<F, K>(name: impl Into<String>, build: F) -> Self
    where
        F: Fn() -> Result<K, String> + Send + Sync + 'static,
        K: KernelScheme<System = S>,
    {
        let build = move || Kernelized::new(build()?).map_err(|e| e.to_string());
        Self::assemble(name.into(), build, |scheme, paths, r0, v0| {
            Ok(Box::new(LaneEnsemble::new(scheme, paths, r0, v0)?))
        })
    }

    /// A scheme built by `build`, whose ensembles `ensemble` makes of one instance.
    fn assemble<F, T>(name: String, build: F, ensemble: EnsembleOf<T, S>) -> Self
    where
        F: Fn() -> Result<T, String> + Send + Sync + 'static,
        T: Scheme<System = S> + 'static,
    {
        let scheme = name.clone();
        let one = move || {
            build().map_err(|reason| StudyError::SchemeNotApplicable {
                scheme: scheme.clone(),
                reason,
            })
        };
        let one = std::sync::Arc::new(one);
        let single = one.clone();
        Self {
            name,
            build: std::sync::Arc::new(move || Ok(Box::new(single()?) as BoxedScheme<S>)),
            ensemble: std::sync::Arc::new(move |(paths, r0, v0)| ensemble(one()?, paths, r0, v0)),
            time_changed: false,
        }
    }
}

/// How a [`StudyScheme`] makes an ensemble of `paths` paths from (r0, v0) of one instance.
type EnsembleOf<T, S> = fn(T, usize, &[f64], &[f64]) -> Result<BoxedEnsemble<S>, StudyError>;

impl<S> StudyScheme<S> {
    /// The name used in reports.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether the scheme is a time change of an untruncated one (`half-explicit-rescaled`: a
    /// truncated step of size h is in law an untruncated step of size eta h), so that time
    /// averages run over its own clock sum_k eta_k h (grid time minus the clock lag).
    pub fn time_changed(&self) -> bool {
        self.time_changed
    }

    /// A new instance, or why the scheme does not apply.
    pub fn build(&self) -> Result<BoxedScheme<S>, StudyError> {
        (self.build)()
    }

    /// A new ensemble of `paths` paths from (r0, v0), or why the scheme does not apply.
    pub fn build_ensemble(
        &self, paths: usize, r0: &[f64], v0: &[f64],
    ) -> Result<BoxedEnsemble<S>, StudyError> {
        (self.ensemble)((paths, r0, v0))
    }
}

impl<S: CurvedSystem + Clone + Send + Sync + 'static> StudyScheme<S> {
    /// The built-in scheme `kind` for `system` with `constants`.
    pub fn built_in(kind: SchemeKind, system: &S, constants: &SchemeConstants) -> Self {
        let (system, constants) = (system.clone(), *constants);
        let for_ensemble = system.clone();
        Self {
            name: kind.name().into(),
            build: std::sync::Arc::new(move || build_integrator(kind, &system, &constants)),
            ensemble: std::sync::Arc::new(move |(paths, r0, v0)| {
                build_ensemble(kind, &for_ensemble, &constants, paths, r0, v0)
            }),
            time_changed: kind == SchemeKind::HalfExplicitRescaled,
        }
    }
}

impl<S> std::fmt::Debug for StudyScheme<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StudyScheme")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}
