//! Observables f(q, v) written as expressions.

use std::collections::BTreeMap;
use std::sync::Arc;

use sdae_expr::{Graph, Program, SymbolTable};
use sdae_lanes::Real;

use crate::constraint::{Reads, parse};
use crate::error::compile;
use crate::error::{SpecError, SpecErrorKind};
use crate::names::MAX_OBSERVABLES;
use crate::scratch;

/// An observable f(r, v) compiled from its expression: cheap to clone, shared by threads.
#[derive(Debug, Clone)]
pub struct ExpressionObservable {
    program: Arc<Program>,
}

impl ExpressionObservable {
    /// Compiles `text` (entry `key` in refusals) against `table`.
    pub(crate) fn compile(table: &SymbolTable, key: &str, text: &str) -> Result<Self, SpecError> {
        let mut graph = Graph::new();
        let f = parse(&mut graph, table, key, text, Reads::Velocities)?;
        Ok(Self {
            program: Arc::new(compile(&graph, &[f], key)?),
        })
    }

    /// f(r, v) for one path.
    pub fn value(&self, r: &[f64], v: &[f64]) -> f64 {
        self.evaluate(r, v)
    }

    /// f(r, v) for one path (`f64`) or W paths at once (lanes), lane k computing exactly what
    /// one path computes.
    #[inline(always)]
    pub fn evaluate<T: Real>(&self, r: &[T], v: &[T]) -> T {
        let mut out = [r[0].splat_like(0.0)];
        scratch::eval(&self.program, &[r, v], &mut out);
        out[0]
    }
}

/// The observables of a spec, by name.
pub(crate) fn compile_all(
    table: &SymbolTable, texts: &BTreeMap<String, String>,
) -> Result<BTreeMap<String, ExpressionObservable>, SpecError> {
    if texts.len() > MAX_OBSERVABLES {
        return Err(SpecError::new(
            "observables",
            SpecErrorKind::Limit {
                what: "observables",
                found: texts.len(),
                limit: MAX_OBSERVABLES,
            },
        ));
    }
    texts
        .iter()
        .map(|(name, text)| {
            let key = format!("observables.{name}");
            Ok((
                name.clone(),
                ExpressionObservable::compile(table, &key, text)?,
            ))
        })
        .collect()
}
