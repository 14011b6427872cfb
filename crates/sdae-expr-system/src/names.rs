//! The names of a specification: coordinates (given or generated from particles and
//! dimension), their velocities `v_<name>`, the parameters, and the symbol table the
//! expressions are bound to; the masses per coordinate.

use std::collections::HashSet;

use sdae_expr::{CONSTANTS, ExprError, FUNCTIONS, SymbolTable, Var, is_identifier};
use sdae_manifold::DiagonalMass;

use crate::error::{SpecError, SpecErrorKind};
use crate::spec::{ExpressionSpec, MassSpec};

/// The most coordinates n of a system.
pub const MAX_COORDINATES: usize = 1024;

/// The most observables of a specification.
pub const MAX_OBSERVABLES: usize = 256;

/// The input slots of every expression and program: coordinates q, velocities v, the
/// directions u and w of Jacobian products and second derivatives, the multipliers z of the
/// transpose product.
pub(crate) const Q: u16 = 0;
/// Velocities.
pub(crate) const V: u16 = 1;
/// Direction u.
pub(crate) const U: u16 = 2;
/// Direction w.
pub(crate) const W: u16 = 3;
/// Multipliers z.
pub(crate) const Z: u16 = 4;

/// The names expressions cannot use for coordinates or parameters, with the reason.
const RESERVED: &str = "is reserved (time `t` is not available in expressions)";

/// The coordinates' names and the number of particles, if given that way.
pub(crate) fn coordinates(
    spec: &ExpressionSpec,
) -> Result<(Vec<String>, Option<usize>), SpecError> {
    match (&spec.coordinates, spec.particles, spec.dimension) {
        (Some(names), None, None) => {
            check_count("coordinates", names.len())?;
            Ok((names.clone(), None))
        }
        (None, Some(particles), Some(dimension)) => {
            if !(1..=3).contains(&dimension) {
                return Err(SpecError::new(
                    "dimension",
                    SpecErrorKind::Value {
                        value: dimension as f64,
                        index: 0,
                        rule: "the space dimension is 1, 2 or 3",
                    },
                ));
            }
            check_count("particles", particles.saturating_mul(dimension))?;
            let axes = &["x", "y", "z"][..dimension];
            let names = (1..=particles)
                .flat_map(|p| axes.iter().map(move |a| format!("{a}{p}")))
                .collect();
            Ok((names, Some(particles)))
        }
        (Some(_), _, _) => Err(SpecError::conflict(
            "coordinates",
            "give either `coordinates` or `particles` and `dimension`, not both",
        )),
        (None, _, _) => Err(SpecError::conflict(
            "coordinates",
            "missing: give `coordinates` (names) or `particles` and `dimension`",
        )),
    }
}

/// Refuses n = 0 and n beyond [`MAX_COORDINATES`].
fn check_count(key: &str, n: usize) -> Result<(), SpecError> {
    if n == 0 {
        return Err(SpecError::conflict(
            key,
            "a system needs at least two coordinates",
        ));
    }
    if n > MAX_COORDINATES {
        return Err(SpecError::new(
            key,
            SpecErrorKind::Limit {
                what: "coordinates",
                found: n,
                limit: MAX_COORDINATES,
            },
        ));
    }
    Ok(())
}

/// The symbol table: coordinates (slot [`Q`]), velocities `v_<name>` (slot [`V`]), the
/// parameters, then the unnamed slots [`U`], [`W`] (n each) and [`Z`] (m).
pub(crate) fn symbol_table(
    spec: &ExpressionSpec, names: &[String], m: usize,
) -> Result<SymbolTable, SpecError> {
    for (i, name) in names.iter().enumerate() {
        check_reserved(&format!("coordinates[{i}]"), name)?;
    }
    let velocities: Vec<String> = names.iter().map(|name| format!("v_{name}")).collect();
    let mut table = SymbolTable::new();
    add_slot(&mut table, names, |i| format!("coordinates[{i}]"))?;
    add_slot(&mut table, &velocities, |i| format!("coordinates[{i}]"))?;
    for (name, &value) in &spec.parameters {
        let key = format!("parameters.{name}");
        check_reserved(&key, name)?;
        table
            .add_parameter(name, value)
            .map_err(|error| symbol_error(&key, error))?;
    }
    let n = names.len();
    for len in [n, n, m] {
        table
            .add_unnamed_inputs(len)
            .map_err(|error| symbol_error("coordinates", error))?;
    }
    Ok(table)
}

/// Adds a slot of inputs, naming the entry of a refused name by `key(i)`: each name is checked
/// first as the table would check it (a name, not a function's or constant's, not taken).
fn add_slot(
    table: &mut SymbolTable, names: &[String], key: impl Fn(usize) -> String,
) -> Result<(), SpecError> {
    let mut seen = HashSet::new();
    for (i, name) in names.iter().enumerate() {
        let reason = if !is_identifier(name) {
            "is not a name (a letter or `_`, then letters, digits or `_`)"
        } else if FUNCTIONS.contains(&name.as_str()) || CONSTANTS.iter().any(|(c, _)| c == name) {
            "is the name of a function or constant of the grammar"
        } else if table.get(name).is_some() || !seen.insert(name.as_str()) {
            "is given twice"
        } else {
            continue;
        };
        return Err(SpecError::new(
            key(i),
            SpecErrorKind::Name {
                name: name.clone(),
                reason: reason.to_string(),
            },
        ));
    }
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    table
        .add_inputs(&refs)
        .map_err(|error| symbol_error(&key(0), error))?;
    Ok(())
}

/// Refuses `t` and names beginning with `v_` (the velocities'), as coordinates or parameters.
fn check_reserved(key: &str, name: &str) -> Result<(), SpecError> {
    let reason = if name == "t" {
        RESERVED
    } else if name.starts_with("v_") {
        "is reserved: names beginning with `v_` are the velocities'"
    } else {
        return Ok(());
    };
    Err(SpecError::new(
        key,
        SpecErrorKind::Name {
            name: name.to_string(),
            reason: reason.to_string(),
        },
    ))
}

/// A refusal of the symbol table, at entry `key`.
fn symbol_error(key: &str, error: ExprError) -> SpecError {
    let kind = match error {
        ExprError::BadSymbol { name, reason } => SpecErrorKind::Name { name, reason },
        ExprError::NonFiniteParameter { value, .. } => SpecErrorKind::Value {
            value,
            index: 0,
            rule: "a parameter must be finite",
        },
        ExprError::Limit {
            what, found, limit, ..
        } => SpecErrorKind::Limit { what, found, limit },
        other => SpecErrorKind::Conflict(other.to_string()),
    };
    SpecError::new(key, kind)
}

/// The diagonal mass: one for all, one per coordinate, or one per particle.
pub(crate) fn masses(
    spec: &MassSpec, n: usize, particles: Option<usize>,
) -> Result<DiagonalMass, SpecError> {
    let diagonal = match spec {
        MassSpec::One(m) => vec![*m; n],
        MassSpec::Each(list) if list.len() == n => list.clone(),
        MassSpec::Each(list) if Some(list.len()) == particles => {
            let dimension = n / list.len();
            list.iter()
                .flat_map(|&m| std::iter::repeat_n(m, dimension))
                .collect()
        }
        MassSpec::Each(list) => {
            let what = match particles {
                Some(p) => format!("one mass, one per coordinate ({n}) or one per particle ({p})"),
                None => format!("one mass or one per coordinate ({n})"),
            };
            return Err(SpecError::length("mass", what, n, list.len()));
        }
    };
    if let Some(index) = diagonal.iter().position(|m| !(m.is_finite() && *m > 0.0)) {
        let index = match spec {
            MassSpec::One(_) => 0,
            MassSpec::Each(list) if list.len() == n => index,
            MassSpec::Each(list) => index / (n / list.len()),
        };
        return Err(SpecError::new(
            "mass",
            SpecErrorKind::Value {
                value: diagonal_value(spec, index),
                index,
                rule: "a mass must be finite and > 0",
            },
        ));
    }
    DiagonalMass::new(diagonal).map_err(|e| SpecError::conflict("mass", e.to_string()))
}

/// Entry `index` of the masses as given.
fn diagonal_value(spec: &MassSpec, index: usize) -> f64 {
    match spec {
        MassSpec::One(m) => *m,
        MassSpec::Each(list) => list[index],
    }
}

/// The inputs of slot `slot` of length `len`.
pub(crate) fn slot(slot: u16, len: usize) -> Vec<Var> {
    Var::slot(slot, len)
}
