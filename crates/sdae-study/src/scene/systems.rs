//! The registry of the systems a scene file can name. Each `[system.<kind>]` table's
//! parameters build their system, its rest position, the theory's constants and the
//! equipartition value here ([`SceneSystem`]), and name its observables, their functions and
//! their closed-form averages at equilibrium; [`SystemSpec::visit`] is the one place that lists
//! the kinds: adding a system is a variant of [`SystemSpec`], its arm in `visit` and its
//! [`SceneSystem`] implementation. The built-in kinds are here, the system written as
//! expressions in `scene/expressions.rs`.

use sdae_manifold::TheoryBound;
use sdae_model::System;
use sdae_reference::CurvedSystem;
use sdae_scheme::StepperConfig;
use sdae_systems::{
    ChainMolecule, ChainMoleculeParams, Fiber, FiberParams, Pendulum, PendulumParams,
    RigidTriatomic, RigidTriatomicParams, chain_molecule, pendulum, rigid_triatomic,
};

use super::{Output, Scene, SystemSpec};
use crate::error::StudyError;
use crate::gibbs;
use crate::observable::kinds::{
    self as observable, FIBER, Function, MOLECULE, PENDULUM, TRIATOMIC,
};

/// A system built from a scene's `[system.<kind>]` table, before the initial state is taken.
#[derive(Debug, Clone)]
pub struct Built<S> {
    /// The system.
    pub system: S,
    /// Its rest position (the initial position where the scene names none).
    pub rest: Vec<f64>,
    /// Its own initial velocity (where the scene names none; `None`: at rest).
    pub velocity: Option<Vec<f64>>,
    /// The theory's (C_eta, C_kappa) (Thm 3.4) where the constraint bounds C_g.
    pub theory: Option<(f64, f64)>,
    /// The equipartition value (n - m) kT / 2 of E[v^T M v / 2] for Langevin systems.
    pub kinetic_target: Option<f64>,
}

impl<S> Built<S> {
    /// The system, and the rest without it.
    pub(crate) fn take(self) -> (S, Built<()>) {
        let Built {
            system,
            rest,
            velocity,
            theory,
            kinetic_target,
        } = self;
        let others = Built {
            system: (),
            rest,
            velocity,
            theory,
            kinetic_target,
        };
        (system, others)
    }
}

impl Built<()> {
    /// The rest with `system`.
    pub(crate) fn with<S>(self, system: S) -> Built<S> {
        Built {
            system,
            rest: self.rest,
            velocity: self.velocity,
            theory: self.theory,
            kinetic_target: self.kinetic_target,
        }
    }
}

/// The parameters of a system kind (built in, or written as expressions), as a scene file gives
/// them.
pub trait SceneSystem {
    /// The system they build.
    type System: CurvedSystem + Clone + Send + Sync + 'static;
    /// The number of coordinates of the system they build (saturating).
    fn coordinates(&self) -> usize;
    /// The names of the system's observables: a built-in kind's built-in ones, an expression
    /// system's own (and the kinetic energy).
    fn observables(&self) -> Vec<String>;
    /// The outputs the observable `name` reads (the position, the velocity or both).
    fn observable_needs(&self, name: &str) -> &'static [Output] {
        built_in_needs(name)
    }
    /// Whether `text`, none of [`SceneSystem::observables`], is an observable of the system as
    /// an expression of its coordinates and velocities: `None` for a kind whose observables
    /// are names only, else `Ok` or the compiler's refusal.
    fn observable_expression(&self, _text: &str) -> Option<Result<(), String>> {
        None
    }
    /// The function f(r, v) of the built-in observable `name`, given the path's initial
    /// position `r0`; None for a name the system does not have and for the kinetic energy
    /// v^T M v / 2, which every system computes from its mass matrix.
    fn observable(&self, name: &str, r0: &[f64]) -> Option<Box<Function>>;
    /// The closed form of the time average of the built-in observable `name` at equilibrium,
    /// where the system has one ([`crate::gibbs`]).
    fn exact_average(&self, _name: &str) -> Option<f64> {
        None
    }
    /// For a chain of beads (to which a named initial shape applies), the scene key of its
    /// number of beads and that number.
    fn chain(&self) -> Option<(&'static str, usize)> {
        None
    }
    /// Builds the system (a parameter it refuses is an error of `scene`), with its rest
    /// position in the scene's initial shape.
    fn build(&self, scene: &Scene) -> Result<Built<Self::System>, StudyError>;
    /// Builds the system and hands it to `runner`: the system of [`SceneSystem::build`], or,
    /// for a kind whose system's type is known only once it is built (the Gram structure of a
    /// system written as expressions), that type.
    fn build_into<R: BuiltRunner>(
        &self, scene: &Scene, runner: R,
    ) -> Result<R::Output, StudyError> {
        Ok(runner.run(self.build(scene)?))
    }
}

/// Work with a system built from a scene's table, whatever its type.
pub trait BuiltRunner {
    /// What the work returns.
    type Output;
    /// Does the work with `built`.
    fn run<S>(self, built: Built<S>) -> Self::Output
    where
        S: CurvedSystem + Clone + Send + Sync + 'static;
}

/// Work with the parameters of whichever system kind a scene names.
pub trait SystemVisitor {
    /// What the work returns.
    type Output;
    /// Does the work with the parameters `kind`.
    fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output;
}

impl SystemSpec {
    /// Hands the parameters of the scene's system kind to `visitor`, or returns the name of a
    /// system built in code. The one list of the kinds.
    pub fn visit<V: SystemVisitor>(&self, visitor: V) -> Result<V::Output, &str> {
        match self {
            SystemSpec::Pendulum(p) => Ok(visitor.visit(p)),
            SystemSpec::ChainMolecule(p) => Ok(visitor.visit(p)),
            SystemSpec::Triatomic(p) => Ok(visitor.visit(p)),
            SystemSpec::Fiber(p) => Ok(visitor.visit(p)),
            SystemSpec::Expressions(spec) => Ok(visitor.visit(&**spec)),
            SystemSpec::Custom(name) => Err(name),
        }
    }

    /// The closed form of the time average of the built-in observable `name` at equilibrium,
    /// where the system has one ([`SceneSystem::exact_average`]); None otherwise (no closed
    /// form, no temperature, or a system built in code).
    pub fn exact_average(&self, name: &str) -> Option<f64> {
        struct Average<'a>(&'a str);
        impl SystemVisitor for Average<'_> {
            type Output = Option<f64>;
            fn visit<K: SceneSystem>(self, kind: &K) -> Option<f64> {
                kind.exact_average(self.0)
            }
        }
        self.visit(Average(name)).ok().flatten()
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

/// The outputs a built-in observable reads: the position, the velocity or both.
pub(super) fn built_in_needs(name: &str) -> &'static [Output] {
    match name {
        "energy" => &[Output::Position, Output::Velocity],
        "kinetic_energy" => &[Output::Velocity],
        _ => &[Output::Position],
    }
}

/// Names as owned strings.
fn owned(names: &[&str]) -> Vec<String> {
    names.iter().map(|n| n.to_string()).collect()
}

/// A system's refusal of its parameters, as an error of `scene`.
fn refused(scene: &Scene, e: impl std::fmt::Display) -> StudyError {
    scene.invalid(format!("system: {e}"))
}

/// The stochastic pendulum (seed 5.1): rest at the bottom, r = (0, ..., 0, -length).
impl SceneSystem for PendulumParams {
    type System = Pendulum;
    fn coordinates(&self) -> usize {
        self.dim
    }
    fn observables(&self) -> Vec<String> {
        owned(&PENDULUM)
    }
    fn observable(&self, name: &str, r0: &[f64]) -> Option<Box<Function>> {
        observable::pendulum(self, name, r0)
    }
    fn exact_average(&self, name: &str) -> Option<f64> {
        (name == "cos_angle").then(|| gibbs::pendulum_cos_angle(self))?
    }
    fn build(&self, scene: &Scene) -> Result<Built<Pendulum>, StudyError> {
        let system = pendulum(*self).map_err(|e| refused(scene, e))?;
        let mut rest = vec![0.0; self.dim];
        rest[self.dim - 1] = -self.length;
        Ok(Built {
            theory: theory_constants(&system),
            system,
            rest,
            velocity: None,
            // Langevin: kT = sigma^2 / (2 gamma), d - 1 degrees of freedom.
            kinetic_target: (self.friction > 0.0)
                .then(|| (self.dim - 1) as f64 * self.noise * self.noise / (4.0 * self.friction)),
        })
    }
}

/// A chain molecule with rigid bonds under Langevin dynamics (seed 5.2).
impl SceneSystem for ChainMoleculeParams {
    type System = ChainMolecule;
    fn coordinates(&self) -> usize {
        self.atoms.saturating_mul(3)
    }
    fn observables(&self) -> Vec<String> {
        owned(&MOLECULE)
    }
    fn observable(&self, name: &str, _r0: &[f64]) -> Option<Box<Function>> {
        observable::chain(name)
    }
    fn exact_average(&self, name: &str) -> Option<f64> {
        (name == "cos_bond_angle").then(|| gibbs::trimer_cos_bond_angle(self))?
    }
    fn chain(&self) -> Option<(&'static str, usize)> {
        Some(("chain-molecule.atoms", self.atoms))
    }
    fn build(&self, scene: &Scene) -> Result<Built<ChainMolecule>, StudyError> {
        let system = chain_molecule(self).map_err(|e| refused(scene, e))?;
        let rest = scene.shaped(system.constraint(), system.initial_state().0)?;
        Ok(Built {
            theory: theory_constants(&system),
            kinetic_target: Some(system.equipartition_energy()),
            system,
            rest,
            velocity: None,
        })
    }
}

/// A rigid triatomic molecule in a harmonic trap under Langevin dynamics (seed 5.2).
impl SceneSystem for RigidTriatomicParams {
    type System = RigidTriatomic;
    fn coordinates(&self) -> usize {
        9
    }
    fn observables(&self) -> Vec<String> {
        owned(&TRIATOMIC)
    }
    fn observable(&self, name: &str, _r0: &[f64]) -> Option<Box<Function>> {
        observable::triatomic(self, name)
    }
    fn exact_average(&self, name: &str) -> Option<f64> {
        (name == "centroid_distance_squared").then(|| gibbs::triatomic_centroid_distance(self))?
    }
    fn build(&self, scene: &Scene) -> Result<Built<RigidTriatomic>, StudyError> {
        let system = rigid_triatomic(self).map_err(|e| refused(scene, e))?;
        Ok(Built {
            theory: theory_constants(&system),
            kinetic_target: Some(system.equipartition_energy()),
            rest: system.initial_state().0,
            velocity: None,
            system,
        })
    }
}

/// An inextensible fiber in turbulent air (seed 5.3), hanging at rest.
impl SceneSystem for FiberParams {
    type System = Fiber;
    fn coordinates(&self) -> usize {
        self.beads.saturating_mul(3)
    }
    fn observables(&self) -> Vec<String> {
        owned(&FIBER)
    }
    fn observable(&self, name: &str, _r0: &[f64]) -> Option<Box<Function>> {
        observable::fiber(name)
    }
    fn chain(&self) -> Option<(&'static str, usize)> {
        Some(("fiber.beads", self.beads))
    }
    fn build(&self, scene: &Scene) -> Result<Built<Fiber>, StudyError> {
        let system = Fiber::new(self).map_err(|e| refused(scene, e))?;
        let rest = scene.shaped(system.constraint(), system.hanging().0)?;
        Ok(Built {
            theory: theory_constants(&system),
            kinetic_target: None,
            system,
            rest,
            velocity: None,
        })
    }
}
