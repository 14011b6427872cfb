//! A system written as expressions, `[system.expressions]`: the table's keys are those of
//! [`ExpressionSpec`], compiled by [`ExpressionSystem::compile`] (symbolic derivatives, tapes
//! over lanes). The spec gives the initial state itself (`position`, `velocity`, `project`), so
//! a scene with an expression system takes no `[initial]` table: two initial states would
//! leave one of them silently unused. Every refusal of the spec names its key as
//! `system.expressions.<key>` with the compiler's message (and the caret line of a parse error).
//!
//! Its observables are the spec's `observables` by name, the kinetic energy v^T M v / 2
//! that every system has (so a spec may not define one of that name), and any other expression
//! of the coordinates and velocities a study names, compiled by
//! [`ExpressionSystem::compile_observable`]. With friction and kT it
//! is a Langevin system: the equipartition value (n - m) kT / 2 applies, and so do BAOAB and
//! g-BAOAB.

use sdae_expr_system::{ExpressionSpec, ExpressionSystem, ShapeVisitor, SpecError};
use sdae_manifold::GramShape;

use super::systems::{Built, BuiltRunner, SceneSystem, built_in_needs};
use super::{InitialSpec, Output, Scene};
use crate::error::StudyError;
use crate::observable::kinds::Function;

/// The observable every system has, computed from its mass matrix.
const KINETIC_ENERGY: &str = "kinetic_energy";

/// The scene key of the table.
const TABLE: &str = "system.expressions";

/// The refusal `e` of the spec as an error of `scene`, naming `system.expressions.<key>` with
/// the compiler's message (which begins with the key; an expression's text and caret line
/// follow on lines of their own).
pub(crate) fn refusal(scene: &Scene, e: &SpecError) -> StudyError {
    scene.invalid(format!("{TABLE}.{e}"))
}

/// The spec compiled, or its refusal as an error of `scene`, after the checks of the scene
/// around it: no `[initial]` table, no observable named like the kinetic energy.
pub(crate) fn compiled(
    spec: &ExpressionSpec, scene: &Scene,
) -> Result<ExpressionSystem, StudyError> {
    if scene.initial != InitialSpec::default() {
        return Err(scene.invalid(format!(
            "initial: {TABLE} gives the initial state itself (position, velocity, project): \
             leave the [initial] table out"
        )));
    }
    if spec.observables.contains_key(KINETIC_ENERGY) {
        return Err(scene.invalid(format!(
            "{TABLE}.observables.{KINETIC_ENERGY}: the name is taken by v^T M v / 2, which \
             every system has; give the observable another name"
        )));
    }
    ExpressionSystem::compile(spec).map_err(|e| refusal(scene, &e))
}

impl Scene {
    /// Compiles the scene's expression system, if it has one, and drops it: a refusal of the
    /// spec is found when the scene is read, before any study runs.
    pub(crate) fn check_expressions(&self) -> Result<(), StudyError> {
        match &self.system {
            super::SystemSpec::Expressions(spec) => compiled(spec, self).map(drop),
            _ => Ok(()),
        }
    }
}

/// Whether the expression `text` reads a velocity (a name `v_<coordinate>`: names beginning
/// with `v_` are the velocities'). A text that does not parse reads none: the compiler refuses
/// it by its key.
fn reads_velocity(text: &str) -> bool {
    sdae_expr::Syntax::parse(text).is_ok_and(|syntax| {
        syntax
            .names()
            .iter()
            .any(|(name, _)| name.starts_with("v_"))
    })
}

impl SceneSystem for ExpressionSpec {
    type System = ExpressionSystem;

    fn coordinates(&self) -> usize {
        match (&self.coordinates, self.particles, self.dimension) {
            (Some(names), _, _) => names.len(),
            (None, Some(particles), Some(dimension)) => particles.saturating_mul(dimension),
            _ => self.position.len(),
        }
    }

    fn observables(&self) -> Vec<String> {
        let own = self.observables.keys().cloned();
        own.chain([KINETIC_ENERGY.to_string()]).collect()
    }

    /// An observable of the spec reads what its text names, the kinetic energy the velocity,
    /// and any other name is read as an expression.
    fn observable_needs(&self, name: &str) -> &'static [Output] {
        let text = match self.observables.get(name) {
            Some(text) => text,
            None if name == KINETIC_ENERGY => return built_in_needs(name),
            None => name,
        };
        if reads_velocity(text) {
            &[Output::Position, Output::Velocity]
        } else {
            &[Output::Position]
        }
    }

    fn observable_expression(&self, text: &str) -> Option<Result<(), String>> {
        let verdict = match ExpressionSystem::compile(self) {
            Ok(system) => system
                .compile_observable(text)
                .map(drop)
                .map_err(|e| e.kind.to_string()),
            Err(e) => Err(format!("{TABLE}.{e}")),
        };
        Some(verdict)
    }

    /// The spec's observable `name`, or `name` compiled as an expression.
    fn observable(&self, name: &str, _r0: &[f64]) -> Option<Box<Function>> {
        let system = ExpressionSystem::compile(self).ok()?;
        let f = match system.observable(name) {
            Some(f) => f,
            None => system.compile_observable(name).ok()?,
        };
        Some(Box::new(move |r, v| f.value(r, v)))
    }

    fn build(&self, scene: &Scene) -> Result<Built<ExpressionSystem>, StudyError> {
        let system = compiled(self, scene)?;
        let (position, velocity) = system.initial_state();
        let (rest, velocity) = (position.to_vec(), velocity.to_vec());
        let (n, m) = (system.coordinates().len(), self.constraints.len());
        let kinetic_target = match (self.friction, self.kt) {
            (Some(gamma), Some(kt)) if gamma > 0.0 => Some(n.saturating_sub(m) as f64 * kt / 2.0),
            _ => None,
        };
        Ok(Built {
            system,
            rest,
            velocity: Some(velocity),
            theory: None,
            kinetic_target,
        })
    }

    /// The system with the narrowest Gram structure its Jacobian's pattern allows (scalar for
    /// one equation, tridiagonal for a chain of bonds written in order, dense otherwise).
    fn build_into<R: BuiltRunner>(
        &self, scene: &Scene, runner: R,
    ) -> Result<R::Output, StudyError> {
        struct Shaped<R> {
            runner: R,
            built: Built<()>,
        }
        impl<R: BuiltRunner> ShapeVisitor for Shaped<R> {
            type Output = R::Output;
            fn visit<Sh: GramShape>(self, system: ExpressionSystem<Sh>) -> R::Output {
                self.runner.run(self.built.with(system))
            }
        }
        let (system, built) = self.build(scene)?.take();
        Ok(system.visit_shape(Shaped { runner, built }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocities_are_found_among_the_names_an_observable_reads() {
        assert!(reads_velocity("x1 * v_y1"));
        assert!(!reads_velocity("x1 * y1 + w_z1"));
        assert!(!reads_velocity("x1 + * v_y1"));
    }
}
