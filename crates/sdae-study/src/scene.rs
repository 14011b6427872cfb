//! Scenes: a system, its parameters, the initial state, T, the outputs it needs and the study
//! defaults, as data (a TOML file). Built-in scenes ship as files in `scenes/`; users write their
//! own in the same format. Unknown keys and missing values are errors that name the key.
//!
//! ```
//! use sdae_study::scene::Scene;
//! let scene = Scene::from_toml(
//!     r#"
//! name = "my-pendulum"
//! T = 2.0
//! outputs = ["position", "velocity"]
//! [system.pendulum]
//! dim = 2
//! length = 1.0
//! gravity = 9.81
//! noise = 0.5
//! friction = 0.1
//! [initial]
//! position = [0.0, -1.0]
//! velocity = [0.3, 0.0]
//! "#,
//! )?;
//! assert_eq!(scene.name, "my-pendulum");
//! assert!(!scene.wants(sdae_study::scene::Output::Multiplier));
//! # Ok::<(), sdae_study::StudyError>(())
//! ```

use sdae_expr_system::ExpressionSpec;
use sdae_manifold::{BeadChain, check_state};
use sdae_model::{INITIAL_STATE_TOLERANCE, project_state};
use sdae_reference::CurvedSystem;
use sdae_systems::{ChainMoleculeParams, FiberParams, PendulumParams, RigidTriatomicParams};
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::StudyError;
use crate::integrator::SchemeConstants;

pub use crate::catalog::BUILT_IN;

mod expressions;
mod systems;

pub use systems::{Built, BuiltRunner, SceneSystem, SystemVisitor};

/// A name (or value) the user typed, as messages show it: its control characters escaped as
/// Rust escapes them (`pend\nulum`, `a\0b`, `\u{1b}`), the rest as typed, so that a refused
/// name prints on one line and cannot drive the terminal. Escaping twice changes nothing.
pub fn escaped(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// What a study of the scene computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Output {
    /// Errors of the position r.
    Position,
    /// Errors of the velocity v.
    Velocity,
    /// Errors of the multiplier mu (accumulated only when asked for).
    Multiplier,
    /// The time-averaged kinetic energy v^T M v / 2 (equipartition).
    KineticEnergy,
}

/// The system of a scene, by kind: a table `[system.<kind>]` with the kind's parameters (the
/// kinds' registry is [`SystemSpec::visit`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SystemSpec {
    /// The stochastic pendulum (seed 5.1).
    Pendulum(PendulumParams),
    /// A chain molecule with rigid bonds under Langevin dynamics (seed 5.2).
    ChainMolecule(ChainMoleculeParams),
    /// A rigid triatomic molecule in a harmonic trap under Langevin dynamics (seed 5.2).
    Triatomic(RigidTriatomicParams),
    /// An inextensible fiber in turbulent air (seed 5.3).
    Fiber(FiberParams),
    /// A system written as expressions (`[system.expressions]`, the keys of
    /// [`ExpressionSpec`]): coordinates, masses, parameters, constraints g(q) = 0, a potential,
    /// forces, friction and kT or noise, observables, and the initial state, which the spec
    /// gives itself: a scene with an expression system takes no `[initial]` table.
    Expressions(Box<ExpressionSpec>),
    /// A system built in code (named here), run through the library API with
    /// [`Scene::prepare_custom`] and the studies' `*_on` functions; a scene file cannot build it.
    Custom(String),
}

/// A named initial shape of a chain of beads (chain molecule, fiber).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Shape {
    /// Straight, from bead 0 at the origin along -z (an ill-conditioned Gram matrix).
    Straight,
    /// A planar zigzag in the x-y plane, segments at +/- this angle (rad) to the x axis.
    Zigzag(f64),
}

/// The initial state: explicit vectors, a named shape, or the system's default where left out.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// A named shape for chains of beads (instead of `position`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<Shape>,
    /// r_0 (default: the system's rest configuration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<Vec<f64>>,
    /// v_0 (default: 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec<f64>>,
    /// Project (r_0, v_0) onto the tangent bundle first (otherwise it must lie on it).
    #[serde(default)]
    pub project: bool,
}

/// Constants of the half-explicit scheme for this scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SchemeSpec {
    /// The practical C_eta.
    pub practical_c_eta: f64,
    /// C_kappa of the practical and untruncated variants (default: infinite, leaving only the
    /// solver's plausibility check).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "sdae_stats::json_f64::option"
    )]
    pub c_kappa: Option<f64>,
    /// C_eta of `half-explicit-local` (beyond the seed): the largest turn of a constraint's
    /// length per step, in radians, with the local size functional; one value for every
    /// system, no scaling with the number of beads (default 0.5).
    #[serde(default = "default_local_c_eta")]
    pub local_c_eta: f64,
    /// K_r of `g-baoab`: geodesic SHAKE/RATTLE substeps per half drift (default 3).
    #[serde(
        default = "default_geodesic_substeps",
        skip_serializing_if = "is_default_substeps"
    )]
    pub geodesic_substeps: usize,
    /// The SHAKE tolerance on max |g| of `baoab-rattle` and `g-baoab` (default 1e-12).
    #[serde(
        default = "default_projection_tolerance",
        skip_serializing_if = "is_default_tolerance"
    )]
    pub projection_tolerance: f64,
}

fn default_local_c_eta() -> f64 {
    0.5
}

fn default_geodesic_substeps() -> usize {
    sdae_splitting::G_BAOAB_SUBSTEPS
}

fn is_default_substeps(k: &usize) -> bool {
    *k == default_geodesic_substeps()
}

fn default_projection_tolerance() -> f64 {
    sdae_splitting::DEFAULT_TOLERANCE
}

fn is_default_tolerance(t: &f64) -> bool {
    *t == default_projection_tolerance()
}

impl Default for SchemeSpec {
    fn default() -> Self {
        Self {
            practical_c_eta: 1.0,
            c_kappa: None,
            local_c_eta: default_local_c_eta(),
            geodesic_substeps: default_geodesic_substeps(),
            projection_tolerance: default_projection_tolerance(),
        }
    }
}

/// Declares a settings struct whose last fields are the optional study defaults `paths`,
/// `levels` and `reference`, after the fields written out. The fields are declared in place
/// (not flattened) so that `deny_unknown_fields` keeps working.
macro_rules! with_study_defaults {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[$field_meta:meta])*
                pub $field:ident: $ty:ty,
            )*
        }
    ) => {
        $(#[$meta])*
        pub struct $name {
            $(
                $(#[$field_meta])*
                pub $field: $ty,
            )*
            /// Monte Carlo paths.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub paths: Option<usize>,
            /// Level exponents [A, B]: N = 2^A .. 2^B.
            #[serde(
                default,
                skip_serializing_if = "Option::is_none",
                deserialize_with = "sdae_systems::exact::option_array"
            )]
            pub levels: Option<[u32; 2]>,
            /// Reference level R (2^R steps).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub reference: Option<u32>,
        }
    };
}

with_study_defaults! {
    /// Default study settings of the scene (the command line overrides them).
    #[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct StudyDefaults {}
}

/// Settings of the stability study for a stiff or extreme scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StabilitySpec {
    /// The stiff or extreme case the scene stands for.
    pub case: String,
    /// Monte Carlo paths.
    pub paths: usize,
    /// Level exponents [A, B]: N = 2^A .. 2^B.
    #[serde(deserialize_with = "sdae_systems::exact::array")]
    pub levels: [u32; 2],
    /// Reference level R (2^R steps), where a reference is affordable and trustworthy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<u32>,
    /// |g(r)| or |Dg(r) v| above this counts as constraint drift (default 1e-2).
    #[serde(default = "default_drift_tolerance")]
    #[serde(with = "sdae_stats::json_f64")]
    pub drift_tolerance: f64,
    /// |r_i| or |v_i| above this counts as a blow-up (default 1e8).
    #[serde(default = "default_blow_up")]
    #[serde(with = "sdae_stats::json_f64")]
    pub blow_up: f64,
}

fn default_drift_tolerance() -> f64 {
    1e-2
}

fn default_blow_up() -> f64 {
    1e8
}

/// Settings of the equipartition study for a Langevin scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EquipartitionSpec {
    /// The final time of the runs (long enough to reach equilibrium after the burn-in).
    #[serde(rename = "T")]
    pub t_end: f64,
    /// Monte Carlo paths.
    pub paths: usize,
    /// Level exponents [A, B]: N = 2^A .. 2^B over T.
    #[serde(deserialize_with = "sdae_systems::exact::array")]
    pub levels: [u32; 2],
    /// The kinetic energy is averaged over t >= burn_in.
    pub burn_in: f64,
    /// The values of C_eta of the half-explicit scheme to compare.
    pub c_eta: Vec<f64>,
    /// An observable of the scene's system (for a system written as expressions, also an
    /// expression of its state) whose time average (with the kinetic
    /// energy's burn-in) measures the schemes' invariant-measure bias: against its closed form
    /// where the system has one ([`SystemSpec::exact_average`]), else against the finest
    /// g-baoab estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub configurational: Option<String>,
}

with_study_defaults! {
    /// Settings of the weak-error study: the observables f whose expectations E[f(X_T)] it
    /// measures, exact values of some of them, and the study's defaults.
    #[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct WeakSpec {
        /// Observables of the scene's system (see
        /// `observable::names_for`; for a system written as
        /// expressions, also expressions of its coordinates and velocities).
        pub observables: Vec<String>,
        /// Exact values of E[f(X_T)] for some of the observables, by name: the weak error is
        /// then measured against them, otherwise against the reference on the same paths.
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        pub exact: BTreeMap<String, f64>,
    }
}

/// A scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Name (used for the report's files).
    pub name: String,
    /// One line on what the scene shows.
    #[serde(default)]
    pub description: String,
    /// Final time T.
    #[serde(rename = "T")]
    pub t_end: f64,
    /// What the study computes.
    pub outputs: Vec<Output>,
    /// The system.
    pub system: SystemSpec,
    /// The initial state.
    #[serde(default)]
    pub initial: InitialSpec,
    /// Constants of the half-explicit scheme.
    #[serde(default)]
    pub scheme: SchemeSpec,
    /// Study defaults.
    #[serde(default)]
    pub study: StudyDefaults,
    /// Settings of the stability study, for stiff and extreme scenes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability: Option<StabilitySpec>,
    /// Settings of the equipartition study, for Langevin scenes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub equipartition: Option<EquipartitionSpec>,
    /// Settings of the multilevel Monte Carlo study (`mlmc`); the defaults where left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mlmc: Option<crate::mlmc::MlmcSpec>,
    /// Settings of the weak-error study: the observables it measures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weak: Option<WeakSpec>,
}

/// A system built from a scene, ready to run.
#[derive(Debug, Clone)]
pub struct Prepared<S> {
    /// The system.
    pub system: S,
    /// r_0 on the manifold.
    pub position: Vec<f64>,
    /// v_0 tangent.
    pub velocity: Vec<f64>,
    /// Constants of the half-explicit family.
    pub constants: SchemeConstants,
    /// The equipartition value (n - m) kT / 2 of E[v^T M v / 2] for Langevin systems.
    pub kinetic_target: Option<f64>,
}

/// Work to do with whatever system a scene builds: the scene's system type is known only at
/// run time, so the work is generic over it.
pub trait SceneRunner {
    /// What the work returns.
    type Output;
    /// Does the work with the scene's system.
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: CurvedSystem + Clone + Send + Sync + 'static;
}

impl Scene {
    /// The scene as TOML text (reads back to an equal scene).
    pub fn to_toml(&self) -> Result<String, StudyError> {
        toml::to_string(self).map_err(|e| StudyError::Format {
            file: self.name.clone(),
            message: e.to_string(),
        })
    }

    /// Whether the study computes `output`.
    pub fn wants(&self, output: Output) -> bool {
        self.outputs.contains(&output)
    }

    /// A scene error of this scene saying `message`.
    pub(crate) fn invalid(&self, message: impl Into<String>) -> StudyError {
        StudyError::Invalid {
            scene: self.name.clone(),
            message: message.into(),
        }
    }

    /// The number of coordinates of the scene's system (`None` for a system built in code).
    pub fn coordinates(&self) -> Option<usize> {
        struct Coordinates;
        impl SystemVisitor for Coordinates {
            type Output = usize;
            fn visit<K: SceneSystem>(self, kind: &K) -> usize {
                kind.coordinates()
            }
        }
        self.system.visit(Coordinates).ok()
    }

    /// The system, initial state (checked to lie on the tangent bundle) and constants of a
    /// system built in code, for the studies' `*_on` functions. No C_g (seed eq. 2.2) is known
    /// for such a system, so the theory variant of the half-explicit scheme does not apply
    /// (reported as skipped); the practical and untruncated variants use the scene's C_eta.
    pub fn prepare_custom<S>(
        &self, system: S, position: Vec<f64>, velocity: Vec<f64>,
    ) -> Result<Prepared<S>, StudyError>
    where
        S: CurvedSystem,
    {
        let scene = Scene {
            initial: InitialSpec {
                velocity: Some(velocity),
                ..InitialSpec::default()
            },
            ..self.clone()
        };
        scene.prepare(system, position, None, None)
    }

    /// Builds the scene's system, initial state and scheme constants and drops them: a
    /// parameter the system refuses (a NaN mass, a negative length) is found before any study
    /// runs. A system built in code has nothing to build here.
    pub fn check_system(&self) -> Result<(), StudyError> {
        struct Build;
        impl SceneRunner for Build {
            type Output = ();
            fn run<S>(self, _: &Scene, _: Prepared<S>)
            where
                S: CurvedSystem + Clone + Send + Sync + 'static,
            {
            }
        }
        match self.system {
            SystemSpec::Custom(_) => Ok(()),
            _ => self.run(Build),
        }
    }

    /// Builds the system (through the registry, [`SystemSpec::visit`]), the initial state and
    /// the scheme constants, and hands them to `runner`.
    pub fn run<R: SceneRunner>(&self, runner: R) -> Result<R::Output, StudyError> {
        struct Run<'a, R> {
            scene: &'a Scene,
            runner: R,
        }
        impl<R: SceneRunner> SystemVisitor for Run<'_, R> {
            type Output = Result<R::Output, StudyError>;
            fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
                kind.build_into(self.scene, self)?
            }
        }
        impl<R: SceneRunner> BuiltRunner for Run<'_, R> {
            type Output = Result<R::Output, StudyError>;
            fn run<S>(self, built: Built<S>) -> Self::Output
            where
                S: CurvedSystem + Clone + Send + Sync + 'static,
            {
                let mut prepared =
                    self.scene
                        .prepare(built.system, built.rest, built.velocity, built.theory)?;
                prepared.kinetic_target = built.kinetic_target;
                Ok(self.runner.run(self.scene, prepared))
            }
        }
        let run = Run {
            scene: self,
            runner,
        };
        self.system.visit(run).unwrap_or_else(|name| {
            Err(self.invalid(format!(
                "system '{name}' is built in code: run it with Scene::prepare_custom and the studies' *_on functions"
            )))
        })
    }

    /// The positions of the initial shape, if one is named, else `default`.
    pub(crate) fn shaped(
        &self, chain: &BeadChain, default: Vec<f64>,
    ) -> Result<Vec<f64>, StudyError> {
        match self.initial.shape {
            None => Ok(default),
            Some(Shape::Straight) => chain
                .straight([0.0, 0.0, -1.0])
                .map_err(|e| self.invalid(format!("initial.shape: {e}"))),
            Some(Shape::Zigzag(angle)) if angle.is_finite() => Ok(chain.zigzag(angle)),
            Some(Shape::Zigzag(angle)) => Err(self.invalid(format!(
                "initial.shape.zigzag = {angle}: the angle must be finite"
            ))),
        }
    }

    /// The initial state (checked or projected) and the constants for `system`: the scene's
    /// `[initial]` values, else `rest` and the system's own initial velocity `own_velocity`
    /// (default: at rest).
    fn prepare<S>(
        &self, system: S, rest: Vec<f64>, own_velocity: Option<Vec<f64>>,
        theory: Option<(f64, f64)>,
    ) -> Result<Prepared<S>, StudyError>
    where
        S: CurvedSystem,
    {
        let n = rest.len();
        let mut position = self.initial.position.clone().unwrap_or(rest);
        let mut velocity = self
            .initial
            .velocity
            .clone()
            .or(own_velocity)
            .unwrap_or_else(|| vec![0.0; n]);
        for (name, x) in [("position", &position), ("velocity", &velocity)] {
            if x.len() != n {
                return Err(self.invalid(format!(
                    "initial.{name} has {} entries, the system has {n} coordinates",
                    x.len()
                )));
            }
        }
        let (constraint, mass) = (system.constraint(), system.mass());
        if self.initial.project {
            project_state(constraint, mass, &mut position, &mut velocity)
                .map_err(|e| self.invalid(format!("initial state: {e}")))?;
        }
        check_state(constraint, &position, &velocity, INITIAL_STATE_TOLERANCE).map_err(|e| {
            self.invalid(format!(
                "initial state: {e} (set initial.project = true to project it)"
            ))
        })?;
        let constants = SchemeConstants {
            theory,
            practical_c_eta: self.scheme.practical_c_eta,
            c_kappa: self.scheme.c_kappa.unwrap_or(f64::INFINITY),
            local_c_eta: self.scheme.local_c_eta,
            geodesic_substeps: self.scheme.geodesic_substeps,
            projection_tolerance: self.scheme.projection_tolerance,
        };
        Ok(Prepared {
            system,
            position,
            velocity,
            constants,
            kinetic_target: None,
        })
    }
}
