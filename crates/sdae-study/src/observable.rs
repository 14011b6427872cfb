//! Observables: scalar functions f(r, v) of a path's state whose expectations E[f(X_t)] the weak
//! study measures.
//!
//! A scene names its observables in its `[weak]` table; each system kind has built-in ones
//! ([`names_for`]), built by [`built_in`] from the scene and its prepared system. A user's own
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

use std::fmt;
use std::sync::Arc;

use sdae_manifold::Mass;
use sdae_model::System;

use crate::error::StudyError;
use crate::scene::{Output, Prepared, Scene, SceneSystem, SystemSpec, SystemVisitor};

/// The function of an observable: f(r, v).
type Function = dyn Fn(&[f64], &[f64]) -> f64 + Send + Sync;

/// A named scalar function f(r, v) of the state.
#[derive(Clone)]
pub struct Observable {
    name: String,
    function: Arc<Function>,
}

impl Observable {
    /// The observable `name` computing `f(r, v)`.
    pub fn new(
        name: impl Into<String>, f: impl Fn(&[f64], &[f64]) -> f64 + Send + Sync + 'static,
    ) -> Self {
        Self {
            name: name.into(),
            function: Arc::new(f),
        }
    }

    /// Its name (as in a scene's `[weak]` table and the reports).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// f(r, v).
    pub fn value(&self, r: &[f64], v: &[f64]) -> f64 {
        (self.function)(r, v)
    }
}

impl fmt::Debug for Observable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Observable({})", self.name)
    }
}

/// Observables are equal when their names are (a closure cannot be compared).
impl PartialEq for Observable {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// The built-in observables of the pendulums: the cosine of the angle from the downward vertical
/// -r_d / rho, the height r_d, the energy |v|^2 / 2 + c_g r_d (unit mass), the cosine of the
/// angle turned since the start r . r_0 / rho^2, and the kinetic energy |v|^2 / 2.
pub const PENDULUM: [&str; 5] = [
    "cos_angle",
    "height",
    "energy",
    "cos_turn",
    "kinetic_energy",
];

/// The built-in observables of molecules (chain molecule, triatomic): the end-to-end distance
/// |r_last - r_first|, the cosine of the bond angle at atom 1 and the kinetic energy
/// v^T M v / 2.
pub const MOLECULE: [&str; 3] = ["end_to_end", "cos_bond_angle", "kinetic_energy"];

/// The built-in observables of the rigid triatomic: those of [`MOLECULE`] and the squared
/// distance |X - c|^2 of the mean X of the atoms' positions from the trap's centre c.
pub const TRIATOMIC: [&str; 4] = [
    "end_to_end",
    "cos_bond_angle",
    "kinetic_energy",
    "centroid_distance_squared",
];

/// The built-in observables of the fiber: the coordinates of its last bead (the tip), the
/// end-to-end distance, the mean squared curvature over the inner beads
/// (1 / (K - 2)) sum_i |u_i - u_(i-1)|^2 / ds_i^2 (u_i the unit tangent of segment i, ds_i the
/// mean length of the two segments at bead i) and the kinetic energy v^T M v / 2.
pub const FIBER: [&str; 6] = [
    "tip_x",
    "tip_y",
    "tip_z",
    "end_to_end",
    "mean_squared_curvature",
    "kinetic_energy",
];

/// The built-in observables of a system kind (none for a system built in code: its observables
/// are the user's closures).
pub fn names_for(system: &SystemSpec) -> &'static [&'static str] {
    struct Names;
    impl SystemVisitor for Names {
        type Output = &'static [&'static str];
        fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
            kind.observables()
        }
    }
    system.visit(Names).unwrap_or(&[])
}

/// The outputs a built-in observable reads: the position, the velocity or both.
pub fn needs(name: &str) -> &'static [Output] {
    match name {
        "energy" => &[Output::Position, Output::Velocity],
        "kinetic_energy" => &[Output::Velocity],
        _ => &[Output::Position],
    }
}

/// The candidate closest to `name` in edit distance, if it is close enough to be a slip (at
/// most a third of the name's length, and at least 2, edits away).
pub fn nearest<'a>(name: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(2);
    candidates
        .iter()
        .map(|c| (edit_distance(name, c), *c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// The Levenshtein distance: insertions, deletions and substitutions of characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// Checks that `name` is a built-in observable of the scene's system and that the scene computes
/// the outputs it reads (a system built in code takes any name: its observables come as
/// closures).
pub fn check(scene: &Scene, name: &str) -> Result<(), StudyError> {
    check_known(scene, name)?;
    if let Some(output) = needs(name)
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

/// Checks that `name` is a built-in observable of the scene's system (any name for a system
/// built in code), whatever outputs the scene computes: a time average reads the state as the
/// paths go, not a recorded output.
pub fn check_known(scene: &Scene, name: &str) -> Result<(), StudyError> {
    if matches!(scene.system, SystemSpec::Custom(_)) {
        return Ok(());
    }
    let known = names_for(&scene.system);
    if !known.contains(&name) {
        return Err(StudyError::UnknownObservable {
            scene: scene.name.clone(),
            name: name.to_string(),
            nearest: nearest(name, known).map(str::to_string),
            known: known.join(", "),
        });
    }
    Ok(())
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

/// The built-in observables `names` of the scene's system (checked with [`check`]).
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

/// The built-in observable `name` of the scene's system, from its parameters and initial state
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
    let f: Box<Function> = match (&scene.system, name) {
        (SystemSpec::Pendulum(p), "cos_angle") => {
            let (d, rho) = (p.dim, p.length);
            Box::new(move |r, _| -r[d - 1] / rho)
        }
        (SystemSpec::Pendulum(p), "height") => {
            let d = p.dim;
            Box::new(move |r, _| r[d - 1])
        }
        (SystemSpec::Pendulum(p), "energy") => {
            let (d, g) = (p.dim, p.gravity);
            Box::new(move |r, v| 0.5 * dot(v, v) + g * r[d - 1])
        }
        (SystemSpec::Pendulum(p), "cos_turn") => {
            let (r0, rho2) = (prepared.position.clone(), p.length * p.length);
            Box::new(move |r, _| dot(r, &r0) / rho2)
        }
        (SystemSpec::Triatomic(p), "centroid_distance_squared") => {
            let centre = p.trap.center;
            Box::new(move |r, _| {
                let atoms = r.len() / 3;
                (0..3)
                    .map(|i| {
                        let mean = (0..atoms).map(|a| r[3 * a + i]).sum::<f64>() / atoms as f64;
                        (mean - centre[i]) * (mean - centre[i])
                    })
                    .sum()
            })
        }
        (_, "end_to_end") => Box::new(|r, _| {
            let beads = r.len() / 3;
            distance(bead(r, 0), bead(r, beads - 1))
        }),
        (_, "cos_bond_angle") => Box::new(|r, _| {
            let (a, b) = (
                difference(bead(r, 0), bead(r, 1)),
                difference(bead(r, 2), bead(r, 1)),
            );
            dot(&a, &b) / (dot(&a, &a) * dot(&b, &b)).sqrt()
        }),
        (SystemSpec::Fiber(_), "tip_x" | "tip_y" | "tip_z") => {
            let axis = usize::from(name == "tip_y") + 2 * usize::from(name == "tip_z");
            Box::new(move |r, _| r[r.len() - 3 + axis])
        }
        (SystemSpec::Fiber(_), "mean_squared_curvature") => Box::new(|r, _| curvature(r)),
        _ => unreachable!("check() admits only the names handled here"),
    };
    Ok(Observable {
        name: name.to_string(),
        function: Arc::from(f),
    })
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Bead i of a chain (coordinates 3i..3i+3).
fn bead(r: &[f64], i: usize) -> &[f64] {
    &r[3 * i..3 * i + 3]
}

/// a - b.
fn difference(a: &[f64], b: &[f64]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// |a - b|.
fn distance(a: &[f64], b: &[f64]) -> f64 {
    let d = difference(a, b);
    dot(&d, &d).sqrt()
}

/// (1 / (K - 2)) sum over the inner beads i of |u_i - u_(i-1)|^2 / ds_i^2, with u_i the unit
/// tangent of segment i (bead i to i + 1) and ds_i the mean length of segments i - 1 and i
/// (0 for fewer than 3 beads).
fn curvature(r: &[f64]) -> f64 {
    let beads = r.len() / 3;
    if beads < 3 {
        return 0.0;
    }
    let segment = |i: usize| {
        let d = difference(bead(r, i + 1), bead(r, i));
        let length = dot(&d, &d).sqrt();
        (d.map(|x| x / length), length)
    };
    let mut sum = 0.0;
    let mut before = segment(0);
    for i in 1..beads - 1 {
        let after = segment(i);
        let turn = difference(&after.0, &before.0);
        let ds = 0.5 * (before.1 + after.1);
        sum += dot(&turn, &turn) / (ds * ds);
        before = after;
    }
    sum / (beads - 2) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_names_are_suggested() {
        assert_eq!(nearest("cos_angel", &PENDULUM), Some("cos_angle"));
        assert_eq!(nearest("hight", &PENDULUM), Some("height"));
        assert_eq!(nearest("temperature", &PENDULUM), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }

    #[test]
    fn curvature_of_a_circle_is_one_over_radius_squared() {
        // Beads on a circle of radius 2, 1 degree apart: |u_i - u_(i-1)| / ds -> 1 / R.
        let (radius, step) = (2.0, 1f64.to_radians());
        let r: Vec<f64> = (0..30)
            .flat_map(|i| {
                let a = i as f64 * step;
                [radius * a.cos(), radius * a.sin(), 0.0]
            })
            .collect();
        let k2 = curvature(&r);
        assert!((k2 - 0.25).abs() < 1e-4, "{k2}");
        // A straight chain has none.
        let straight: Vec<f64> = (0..5).flat_map(|i| [0.0, 0.0, -(i as f64)]).collect();
        assert_eq!(curvature(&straight), 0.0);
    }
}
