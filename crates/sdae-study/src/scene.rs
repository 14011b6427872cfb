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
//! # Ok::<(), sdae_study::scene::SceneError>(())
//! ```

use sdae_manifold::{BeadChain, TheoryBound, check_state};
use sdae_reference::CurvedSystem;
use sdae_scheme::{
    INITIAL_STATE_TOLERANCE, PendulumParams, StepperConfig, System, pendulum, project_state,
};
use sdae_systems::{
    ChainMoleculeParams, Fiber, FiberParams, RigidTriatomicParams, chain_molecule, rigid_triatomic,
};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::integrator::SchemeConstants;

/// Why a scene cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SceneError {
    /// The file is not valid TOML or does not fit the scene format (the message names the key).
    #[error("scene file {file}: {message}")]
    Format {
        /// The file (or "<inline>").
        file: String,
        /// What is wrong, naming the key.
        message: String,
    },
    /// The file cannot be read.
    #[error("cannot read scene file {file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A value is out of range or the parts do not fit together.
    #[error("scene {scene}: {message}")]
    Invalid {
        /// The scene's name.
        scene: String,
        /// What is wrong.
        message: String,
    },
    /// No built-in scene of that name.
    #[error("no built-in scene '{0}' (built-in: {list})", list = BUILT_IN.map(|(n, _)| n).join(", "))]
    Unknown(String),
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

/// The seed's stochastic pendulum (Section 5.1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PendulumSpec {
    /// Space dimension: 2 (planar) or 3 (spherical).
    pub dim: usize,
    /// Length rho.
    pub length: f64,
    /// Gravity c_g.
    pub gravity: f64,
    /// Noise amplitude sigma.
    pub noise: f64,
    /// Friction gamma.
    pub friction: f64,
}

impl From<PendulumSpec> for PendulumParams {
    fn from(s: PendulumSpec) -> Self {
        PendulumParams {
            dim: s.dim,
            length: s.length,
            gravity: s.gravity,
            noise: s.noise,
            friction: s.friction,
        }
    }
}

/// The system of a scene, by kind: a table `[system.<kind>]` with the kind's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SystemSpec {
    /// The stochastic pendulum (seed 5.1).
    Pendulum(PendulumSpec),
    /// A chain molecule with rigid bonds under Langevin dynamics (seed 5.2).
    ChainMolecule(ChainMoleculeParams),
    /// A rigid triatomic molecule in a harmonic trap under Langevin dynamics (seed 5.2).
    Triatomic(RigidTriatomicParams),
    /// An inextensible fiber in turbulent air (seed 5.3).
    Fiber(FiberParams),
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
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c_kappa: Option<f64>,
}

impl Default for SchemeSpec {
    fn default() -> Self {
        Self {
            practical_c_eta: 1.0,
            c_kappa: None,
        }
    }
}

/// Default study settings of the scene (the command line overrides them).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyDefaults {
    /// Monte Carlo paths.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paths: Option<usize>,
    /// Level exponents [A, B]: N = 2^A .. 2^B.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<[u32; 2]>,
    /// Reference level R (2^R steps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<u32>,
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
    pub levels: [u32; 2],
    /// Reference level R (2^R steps), where a reference is affordable and trustworthy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<u32>,
    /// |g(r)| or |Dg(r) v| above this counts as constraint drift (default 1e-2).
    #[serde(default = "default_drift_tolerance")]
    pub drift_tolerance: f64,
    /// |r_i| or |v_i| above this counts as a blow-up (default 1e8).
    #[serde(default = "default_blow_up")]
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
    pub levels: [u32; 2],
    /// The kinetic energy is averaged over t >= burn_in.
    pub burn_in: f64,
    /// The values of C_eta of the half-explicit scheme to compare.
    pub c_eta: Vec<f64>,
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
}

/// The built-in scenes: (name, file contents).
pub const BUILT_IN: [(&str, &str); 13] = [
    ("pendulum", include_str!("../scenes/pendulum.toml")),
    (
        "spherical-pendulum",
        include_str!("../scenes/spherical-pendulum.toml"),
    ),
    (
        "fast-pendulum",
        include_str!("../scenes/fast-pendulum.toml"),
    ),
    (
        "noisy-pendulum",
        include_str!("../scenes/noisy-pendulum.toml"),
    ),
    (
        "long-pendulum",
        include_str!("../scenes/long-pendulum.toml"),
    ),
    (
        "thermal-pendulum",
        include_str!("../scenes/thermal-pendulum.toml"),
    ),
    (
        "chain-molecule",
        include_str!("../scenes/chain-molecule.toml"),
    ),
    ("triatomic", include_str!("../scenes/triatomic.toml")),
    ("fiber", include_str!("../scenes/fiber.toml")),
    ("stiff-fiber", include_str!("../scenes/stiff-fiber.toml")),
    (
        "straight-fiber",
        include_str!("../scenes/straight-fiber.toml"),
    ),
    ("drag-fiber", include_str!("../scenes/drag-fiber.toml")),
    ("long-fiber", include_str!("../scenes/long-fiber.toml")),
];

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
    /// Whether the noise depends on r only (stochastic Heun then converges to the Ito
    /// solution; with noise depending on v it would converge to the Stratonovich one).
    pub noise_independent_of_velocity: bool,
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
    /// Reads a scene from TOML text.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        Self::parse(text, "<inline>")
    }

    fn parse(text: &str, file: &str) -> Result<Self, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| SceneError::Format {
            file: file.to_string(),
            message: e.to_string(),
        })?;
        scene.validate()?;
        Ok(scene)
    }

    /// Reads a scene file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        Self::parse(&text, &file)
    }

    /// A built-in scene by name.
    pub fn built_in(name: &str) -> Result<Self, SceneError> {
        let (_, text) = BUILT_IN
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| SceneError::Unknown(name.to_string()))?;
        Self::parse(text, &format!("scenes/{name}.toml"))
    }

    /// The scene as TOML text (reads back to an equal scene).
    pub fn to_toml(&self) -> Result<String, SceneError> {
        toml::to_string(self).map_err(|e| SceneError::Format {
            file: self.name.clone(),
            message: e.to_string(),
        })
    }

    /// Whether the study computes `output`.
    pub fn wants(&self, output: Output) -> bool {
        self.outputs.contains(&output)
    }

    fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            scene: self.name.clone(),
            message: message.into(),
        }
    }

    /// Checks what the types cannot: ranges and consistency.
    fn validate(&self) -> Result<(), SceneError> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(self.invalid(format!(
                "name = '{}': use letters, digits, '-' and '_' (it names the report's files)",
                self.name
            )));
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return Err(self.invalid(format!("T = {}: must be finite and > 0", self.t_end)));
        }
        if self.initial.shape.is_some() && self.initial.position.is_some() {
            return Err(self.invalid("initial: give either shape or position, not both"));
        }
        let chain_like = matches!(
            self.system,
            SystemSpec::ChainMolecule(_) | SystemSpec::Fiber(_)
        );
        if self.initial.shape.is_some() && !chain_like {
            return Err(self
                .invalid("initial.shape applies to chains of beads (chain-molecule, fiber) only"));
        }
        if self.outputs.is_empty() {
            return Err(self.invalid("outputs is empty: name at least one output"));
        }
        let c_eta = self.scheme.practical_c_eta;
        if !(c_eta.is_finite() && c_eta > 0.0) {
            return Err(self.invalid(format!(
                "scheme.practical_c_eta = {c_eta}: must be finite and > 0"
            )));
        }
        if let Some(c) = self.scheme.c_kappa {
            if c.is_nan() || c <= 0.0 {
                return Err(self.invalid(format!("scheme.c_kappa = {c}: must be > 0")));
            }
        }
        if let Some([a, b]) = self.study.levels {
            if a > b {
                return Err(self.invalid(format!("study.levels = [{a}, {b}] is empty")));
            }
        }
        if let Some(st) = &self.stability {
            let [a, b] = st.levels;
            if a > b {
                return Err(self.invalid(format!("stability.levels = [{a}, {b}] is empty")));
            }
            for (name, x) in [
                ("drift_tolerance", st.drift_tolerance),
                ("blow_up", st.blow_up),
            ] {
                if x.is_nan() || x <= 0.0 {
                    return Err(self.invalid(format!("stability.{name} = {x}: must be > 0")));
                }
            }
        }
        if let Some(eq) = &self.equipartition {
            if !self.wants(Output::KineticEnergy) {
                return Err(
                    self.invalid("an [equipartition] table needs \"kinetic-energy\" in outputs")
                );
            }
            let [a, b] = eq.levels;
            if a > b {
                return Err(self.invalid(format!("equipartition.levels = [{a}, {b}] is empty")));
            }
            if !(eq.burn_in >= 0.0 && eq.burn_in < eq.t_end) {
                return Err(self.invalid(format!(
                    "equipartition.burn_in = {}: must be in [0, equipartition.T = {})",
                    eq.burn_in, eq.t_end
                )));
            }
            if let Some(c) = eq.c_eta.iter().find(|c| !(c.is_finite() && **c > 0.0)) {
                return Err(self.invalid(format!(
                    "equipartition.c_eta contains {c}: each must be finite and > 0"
                )));
            }
        }
        Ok(())
    }

    /// Builds the system, the initial state and the scheme constants, and hands them to
    /// `runner`.
    pub fn run<R: SceneRunner>(&self, runner: R) -> Result<R::Output, SceneError> {
        match &self.system {
            SystemSpec::ChainMolecule(params) => {
                let system =
                    chain_molecule(params).map_err(|e| self.invalid(format!("system: {e}")))?;
                let rest = self.shaped(system.constraint(), system.initial_state().0)?;
                let theory = theory_constants(&system);
                let mut prepared = self.prepare(system, rest, true, theory)?;
                prepared.kinetic_target = Some(prepared.system.equipartition_energy());
                Ok(runner.run(self, prepared))
            }
            SystemSpec::Triatomic(params) => {
                let system =
                    rigid_triatomic(params).map_err(|e| self.invalid(format!("system: {e}")))?;
                let rest = system.initial_state().0;
                let theory = theory_constants(&system);
                let mut prepared = self.prepare(system, rest, true, theory)?;
                prepared.kinetic_target = Some(prepared.system.equipartition_energy());
                Ok(runner.run(self, prepared))
            }
            SystemSpec::Fiber(params) => {
                let system =
                    Fiber::new(params).map_err(|e| self.invalid(format!("system: {e}")))?;
                let rest = self.shaped(system.constraint(), system.hanging().0)?;
                let theory = theory_constants(&system);
                // sigma_j = sigma_0 (1 + alpha |v_j - u(x_j)|) depends on v unless alpha = 0.
                let independent = params.turbulence_gain == 0.0;
                let prepared = self.prepare(system, rest, independent, theory)?;
                Ok(runner.run(self, prepared))
            }
            SystemSpec::Pendulum(spec) => {
                let system =
                    pendulum((*spec).into()).map_err(|e| self.invalid(format!("system: {e}")))?;
                let mut rest = vec![0.0; spec.dim];
                rest[spec.dim - 1] = -spec.length;
                let theory = theory_constants(&system);
                let mut prepared = self.prepare(system, rest, true, theory)?;
                // Langevin: kT = sigma^2 / (2 gamma), d - 1 degrees of freedom.
                prepared.kinetic_target = (spec.friction > 0.0).then(|| {
                    (spec.dim - 1) as f64 * spec.noise * spec.noise / (4.0 * spec.friction)
                });
                Ok(runner.run(self, prepared))
            }
        }
    }

    /// The positions of the initial shape, if one is named, else `default`.
    fn shaped(&self, chain: &BeadChain, default: Vec<f64>) -> Result<Vec<f64>, SceneError> {
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

    /// The initial state (checked or projected) and the constants for `system`.
    fn prepare<S>(
        &self,
        system: S,
        rest: Vec<f64>,
        noise_independent_of_velocity: bool,
        theory: Option<(f64, f64)>,
    ) -> Result<Prepared<S>, SceneError>
    where
        S: CurvedSystem,
    {
        let n = rest.len();
        let mut position = self.initial.position.clone().unwrap_or(rest);
        let mut velocity = self
            .initial
            .velocity
            .clone()
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
        };
        Ok(Prepared {
            system,
            position,
            velocity,
            constants,
            noise_independent_of_velocity,
            kinetic_target: None,
        })
    }
}

/// The theory's (C_eta, C_kappa) (Thm 3.4) where the constraint bounds C_g.
fn theory_constants<S>(system: &S) -> Option<(f64, f64)>
where
    S: System,
    S::Constraint: TheoryBound,
{
    StepperConfig::for_system(system)
        .ok()
        .and_then(|c| c.c_eta.map(|c_eta| (c_eta, c.c_kappa)))
}
