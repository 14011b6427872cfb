//! Observables: scalar functions f(r, v) of a path's state whose expectations E[f(X_t)] the weak
//! study measures.
//!
//! A scene names its observables in its `[weak]` table; each system kind has built-in ones, and
//! a system written as expressions (`[system.expressions]`) has those its spec names as
//! expressions f(q, v) ([`names_for`]), and any other expression of its coordinates and
//! velocities named in a study (`x1^2 + y1^2`, `v_x1 * y2`): a name that is none of the spec's
//! is compiled as one ([`check_known`]); [`built_in`] builds them from the scene and its
//! prepared system. A user's own
//! observable is a closure of (r, v) ([`Observable::new`]), passed to the studies' `*_on`
//! functions beside a user's own system and schemes. Only the observables a study is given are
//! evaluated, at the grid points of its coarsest level (see
//! [`Observing`](crate::lockstep::Observing)).
//!
//! ```
//! use sdae_study::observable::Observable;
//! // The angle of a planar pendulum from the downward vertical, as a user's closure.
//! let angle = Observable::new("angle", |r, _v| r[0].atan2(-r[1]));
//! assert_eq!(angle.name(), "angle");
//! assert!((angle.value(&[1.0, 0.0], &[0.0, 0.0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
//! ```

use sdae_manifold::Mass;
use sdae_model::System;

use crate::error::StudyError;
use crate::scene::{Output, Prepared, Scene, SceneSystem, SystemSpec, SystemVisitor};

pub(crate) mod kinds;

use kinds::Function;
pub use kinds::{FIBER, MOLECULE, PENDULUM, TRIATOMIC};
pub use sdae_lockstep::Observable;

/// The observables of a system kind: a built-in kind's built-in ones, an expression system's
/// own by name and the kinetic energy (none for a system built in code: its observables are the
/// user's closures).
pub fn names_for(system: &SystemSpec) -> Vec<String> {
    struct Names;
    impl SystemVisitor for Names {
        type Output = Vec<String>;
        fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
            kind.observables()
        }
    }
    system.visit(Names).unwrap_or_default()
}

/// The outputs the observable `name` of the scene's system reads (a built-in one those its
/// formula reads; an expression observable the velocity where it names one, `v_<coordinate>`;
/// a user's closure on a system built in code may read both).
pub fn needs_in(system: &SystemSpec, name: &str) -> &'static [Output] {
    struct Needs<'a>(&'a str);
    impl SystemVisitor for Needs<'_> {
        type Output = &'static [Output];
        fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
            kind.observable_needs(self.0)
        }
    }
    system
        .visit(Needs(name))
        .unwrap_or(&[Output::Position, Output::Velocity])
}

/// The candidate closest to `name` in edit distance, if it is close enough to be a slip (at
/// most a third of the name's length, and at least 2, edits away).
pub fn nearest<'a>(name: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(2);
    candidates
        .iter()
        .map(|c| (sdae_expr::edit_distance(name, c), *c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// Checks that `name` is an observable of the scene's system ([`names_for`]) and that the scene
/// computes the outputs it reads (a system built in code takes any name: its observables come
/// as closures).
pub fn check(scene: &Scene, name: &str) -> Result<(), StudyError> {
    check_known(scene, name)?;
    if let Some(output) = needs_in(&scene.system, name)
        .iter()
        .find(|o| !scene.wants(**o) && !matches!(scene.system, SystemSpec::Custom(_)))
    {
        return Err(StudyError::ObservableNeedsOutput {
            scene: scene.name.clone(),
            observable: name.to_string(),
            output: output_key(*output),
        });
    }
    Ok(())
}

/// Checks that `name` is an observable of the scene's system (any name for a system built in
/// code), whatever outputs the scene computes: a time average reads the state as the
/// paths go, not a recorded output. For a system written as expressions, a name that is none
/// of its observables is compiled as an expression of the coordinates and velocities; a text
/// that does not compile is refused as an unknown name with the compiler's message below it
/// (`StudyError::UnknownObservable` with its `refusal`).
pub fn check_known(scene: &Scene, name: &str) -> Result<(), StudyError> {
    if matches!(scene.system, SystemSpec::Custom(_)) {
        return Ok(());
    }
    let known = names_for(&scene.system);
    if known.iter().any(|k| k == name) {
        return Ok(());
    }
    struct Expression<'a>(&'a str);
    impl SystemVisitor for Expression<'_> {
        type Output = Option<Result<(), String>>;
        fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
            kind.observable_expression(self.0)
        }
    }
    let compiled = scene.system.visit(Expression(name)).ok().flatten();
    let candidates: Vec<&str> = known.iter().map(String::as_str).collect();
    let unknown = |refusal: Option<String>| StudyError::UnknownObservable {
        scene: scene.name.clone(),
        nearest: nearest(name, &candidates).map(str::to_string),
        name: name.to_string(),
        known: known.join(", "),
        refusal,
    };
    match compiled {
        Some(Ok(())) => Ok(()),
        Some(Err(refusal)) => Err(unknown(Some(refusal))),
        None => Err(unknown(None)),
    }
}

/// An output as a scene file spells it.
fn output_key(output: Output) -> &'static str {
    match output {
        Output::Position => "position",
        Output::Velocity => "velocity",
        Output::Multiplier => "multiplier",
        Output::KineticEnergy => "kinetic-energy",
    }
}

/// The observables `names` of the scene's system (checked with [`check`]).
pub fn built_in_all<S>(
    scene: &Scene, prepared: &Prepared<S>, names: &[String],
) -> Result<Vec<Observable>, StudyError>
where
    S: System + Clone + Send + Sync + 'static,
{
    names
        .iter()
        .map(|name| built_in(scene, prepared, name))
        .collect()
}

/// The observable `name` of the scene's system, from its parameters and initial state
/// (checked with [`check`]: the scene computes the outputs it reads).
pub fn built_in<S>(
    scene: &Scene, prepared: &Prepared<S>, name: &str,
) -> Result<Observable, StudyError>
where
    S: System + Clone + Send + Sync + 'static,
{
    check(scene, name)?;
    build(scene, prepared, name)
}

/// The observable `name`, known to be one of the scene's system ([`check_known`]; a time
/// average reads the state as the paths go, whatever outputs the scene records).
pub(crate) fn build<S>(
    scene: &Scene, prepared: &Prepared<S>, name: &str,
) -> Result<Observable, StudyError>
where
    S: System + Clone + Send + Sync + 'static,
{
    if name == "kinetic_energy" {
        let system = prepared.system.clone();
        return Ok(Observable::new(name, move |_r, v| {
            let mut mv = vec![0.0; v.len()];
            system.mass().apply(v, &mut mv);
            0.5 * v.iter().zip(&mv).map(|(a, b)| a * b).sum::<f64>()
        }));
    }
    struct Built<'a>(&'a str, &'a [f64]);
    impl SystemVisitor for Built<'_> {
        type Output = Option<Box<Function>>;
        fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
            kind.observable(self.0, self.1)
        }
    }
    let f = scene
        .system
        .visit(Built(name, &prepared.position))
        .ok()
        .flatten()
        .ok_or_else(|| StudyError::UnknownObservable {
            scene: scene.name.clone(),
            name: name.to_string(),
            nearest: None,
            known: names_for(&scene.system).join(", "),
            refusal: None,
        })?;
    Ok(Observable::from_boxed(name, f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_names_are_suggested() {
        assert_eq!(nearest("cos_angel", &PENDULUM), Some("cos_angle"));
        assert_eq!(nearest("hight", &PENDULUM), Some("height"));
        assert_eq!(nearest("temperature", &PENDULUM), None);
    }
}
