//! What a user writes: the system as a table of expressions ([`ExpressionSpec`]), as a scene
//! file's `[system.expressions]` or a Python dict gives it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// A constrained stochastic mechanical system written as expressions (crate docs): coordinates,
/// masses, parameters, constraints g_i(q) = 0, a potential V(q) and forces a(q, v), friction
/// with a temperature or a noise, observables f(q, v) and the initial state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpressionSpec {
    /// Named generalized coordinates, e.g. ["x1", "y1", "x2", "y2"]. Either this or
    /// (particles, dimension), which names them x1, y1, z1, x2, ... (dimension <= 3).
    #[serde(default)]
    pub coordinates: Option<Vec<String>>,
    /// The number of particles (with `dimension`, instead of `coordinates`).
    #[serde(default)]
    pub particles: Option<usize>,
    /// The space dimension of the particles: 1, 2 or 3.
    #[serde(default)]
    pub dimension: Option<usize>,
    /// One mass for all coordinates, or one per coordinate, or one per particle.
    pub mass: MassSpec,
    /// Named constants the expressions may use.
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
    /// g_i(q) = 0, any number m >= 1 of equations (m < n).
    pub constraints: Vec<String>,
    /// V(q): the force is -grad V.
    #[serde(default)]
    pub potential: Option<String>,
    /// Extra force expressions a_i(q, v), one per coordinate.
    #[serde(default)]
    pub forces: Option<Vec<String>>,
    /// gamma >= 0 makes a Langevin system (drift -gamma v, noise sqrt(2 gamma kT) I); needs
    /// `kT`.
    #[serde(default)]
    pub friction: Option<f64>,
    /// The temperature kT >= 0 of a Langevin system (with `friction`).
    #[serde(default, rename = "kT")]
    pub kt: Option<f64>,
    /// Without friction: B = sigma I (a number), diag(sigma_i) (numbers), or diag(b_i(q, v))
    /// (expression strings: multiplicative). With friction and kT it is derived (giving both
    /// is refused).
    #[serde(default)]
    pub noise: Option<NoiseSpec>,
    /// Named observables f(q, v).
    #[serde(default)]
    pub observables: BTreeMap<String, String>,
    /// Initial position (length n).
    pub position: Vec<f64>,
    /// Initial velocity (length n; default 0).
    #[serde(default)]
    pub velocity: Option<Vec<f64>>,
    /// Project (r0, v0) onto the manifold / tangent space instead of refusing it.
    #[serde(default)]
    pub project: bool,
}

/// The masses: one for every coordinate, or a list (one per coordinate, or one per particle
/// when the coordinates come from `particles` and `dimension`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MassSpec {
    /// The same mass for every coordinate.
    One(f64),
    /// One mass per coordinate, or per particle.
    Each(Vec<f64>),
}

/// The noise B(q, v) dw without friction: additive (one intensity or one per coordinate) or
/// multiplicative (one expression b_i(q, v) per coordinate, B = diag(b)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NoiseSpec {
    /// B = sigma I.
    Intensity(f64),
    /// B = diag(sigma_1, ..., sigma_n).
    Intensities(Vec<f64>),
    /// B = diag(b_1(q, v), ..., b_n(q, v)).
    Expressions(Vec<String>),
}
