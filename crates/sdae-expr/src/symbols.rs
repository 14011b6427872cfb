//! The names an expression may use: inputs (coordinates, velocities, ... in slots, one slice
//! of values each at evaluation) and parameters (constants folded in when bound).

use std::collections::HashMap;

use crate::ExprError;
use crate::func::{CONSTANTS, FUNCTIONS};

/// The most symbols (inputs and parameters together) a table holds.
pub const MAX_SYMBOLS: usize = 4096;

/// The most input slots a table or a program has.
pub const MAX_SLOTS: usize = 64;

/// An input of an expression: value `index` of the slice `slot` given at evaluation (slot 0
/// the coordinates, slot 1 the velocities, ..., as the table was built).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Var {
    /// Which slice.
    pub slot: u16,
    /// Which value of it.
    pub index: u32,
}

impl Var {
    /// Value `index` of slot `slot`.
    pub fn new(slot: u16, index: u32) -> Self {
        Var { slot, index }
    }

    /// Values `0..len` of slot `slot`.
    pub fn slot(slot: u16, len: usize) -> Vec<Var> {
        (0..len as u32).map(|i| Var::new(slot, i)).collect()
    }
}

/// What a name stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Symbol {
    /// An input, read at evaluation.
    Input(Var),
    /// A parameter: a constant folded into the expressions that use it.
    Parameter(f64),
}

/// Names and what they stand for.
///
/// ```
/// use sdae_expr::{Symbol, SymbolTable, Var};
///
/// let mut table = SymbolTable::new();
/// let q = table.add_inputs(&["x", "y"])?;
/// table.add_parameter("L", 1.5)?;
/// assert_eq!(table.get("y"), Some(Symbol::Input(Var::new(q, 1))));
/// assert!(table.add_parameter("sin", 1.0).is_err());
/// # Ok::<(), sdae_expr::ExprError>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct SymbolTable {
    names: HashMap<String, Symbol>,
    slots: Vec<usize>,
}

impl SymbolTable {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// A new slot of inputs named `names` (value i of the slot's slice is `names[i]`);
    /// returns the slot's number. Refuses a name that is not an identifier, is a function's
    /// or constant's, or is already taken, and a table beyond [`MAX_SYMBOLS`] or
    /// [`MAX_SLOTS`].
    pub fn add_inputs(&mut self, names: &[&str]) -> Result<u16, ExprError> {
        let slot = self.add_unnamed_inputs(0)?;
        for (index, name) in names.iter().enumerate() {
            self.insert(name, Symbol::Input(Var::new(slot, index as u32)))?;
            self.slots[slot as usize] += 1;
        }
        Ok(slot)
    }

    /// A new slot of `len` inputs without names (such as the directions u and w of a second
    /// derivative); returns the slot's number.
    pub fn add_unnamed_inputs(&mut self, len: usize) -> Result<u16, ExprError> {
        if self.slots.len() >= MAX_SLOTS {
            return Err(ExprError::Limit {
                what: "input slots",
                found: self.slots.len() + 1,
                limit: MAX_SLOTS,
                position: None,
            });
        }
        self.slots.push(len);
        Ok((self.slots.len() - 1) as u16)
    }

    /// A parameter: `name` stands for `value` (finite) in every expression bound to the table.
    pub fn add_parameter(&mut self, name: &str, value: f64) -> Result<(), ExprError> {
        if !value.is_finite() {
            return Err(ExprError::NonFiniteParameter {
                name: name.to_string(),
                value,
            });
        }
        self.insert(name, Symbol::Parameter(value))
    }

    /// What `name` stands for.
    pub fn get(&self, name: &str) -> Option<Symbol> {
        self.names.get(name).copied()
    }

    /// The number of slots.
    pub fn slots(&self) -> usize {
        self.slots.len()
    }

    /// The inputs of slot `slot` (empty for a slot the table does not have).
    pub fn slot_vars(&self, slot: u16) -> Vec<Var> {
        Var::slot(slot, self.slots.get(slot as usize).copied().unwrap_or(0))
    }

    /// The known name nearest to `name` by edit distance, if one is close (at most a third of
    /// the name's length, at least one edit).
    pub fn nearest(&self, name: &str) -> Option<&str> {
        let budget = (name.chars().count() / 3).max(1);
        self.names
            .keys()
            .map(|known| (edit_distance(name, known), known.as_str()))
            .filter(|(d, _)| *d <= budget)
            .min()
            .map(|(_, known)| known)
    }

    fn insert(&mut self, name: &str, symbol: Symbol) -> Result<(), ExprError> {
        let bad = |reason: &str| {
            Err(ExprError::BadSymbol {
                name: name.to_string(),
                reason: reason.to_string(),
            })
        };
        if !is_identifier(name) {
            return bad("not a name (a letter or `_`, then letters, digits or `_`)");
        }
        if FUNCTIONS.contains(&name) || CONSTANTS.iter().any(|(c, _)| *c == name) {
            return bad("the name of a function or constant of the grammar");
        }
        if self.names.contains_key(name) {
            return bad("given twice");
        }
        if self.names.len() >= MAX_SYMBOLS {
            return Err(ExprError::Limit {
                what: "symbols",
                found: self.names.len() + 1,
                limit: MAX_SYMBOLS,
                position: None,
            });
        }
        self.names.insert(name.to_string(), symbol);
        Ok(())
    }
}

/// Whether `name` is an identifier of the grammar: an ASCII letter or `_`, then ASCII letters,
/// digits or `_`.
pub fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The Levenshtein distance of two names: the fewest insertions, deletions and substitutions
/// of characters that turn `a` into `b`.
///
/// ```
/// assert_eq!(sdae_expr::edit_distance("kitten", "sitting"), 3);
/// ```
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != *cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_names_by_edit_distance() {
        assert_eq!(edit_distance("x1", "x2"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        let mut table = SymbolTable::new();
        table.add_inputs(&["theta", "omega"]).unwrap();
        assert_eq!(table.nearest("thetq"), Some("theta"));
        assert_eq!(table.nearest("zzz"), None);
    }
}
