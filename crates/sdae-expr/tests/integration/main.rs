//! Integration tests of the expression engine, as one test binary: parsing and its refusals,
//! derivatives against finite differences, and compiled programs over lanes against f64.

mod derivatives;
mod parse;
mod tape;

use sdae_expr::{ExprId, Graph, Program, SymbolTable};

/// A table of the inputs `names` (slot 0) and the parameters `parameters`.
pub fn table(names: &[&str], parameters: &[(&str, f64)]) -> SymbolTable {
    let mut table = SymbolTable::new();
    table.add_inputs(names).expect("input names");
    for (name, value) in parameters {
        table.add_parameter(name, *value).expect("parameter");
    }
    table
}

/// The values of `exprs` of `graph` at the inputs `inputs`, compiled once.
pub fn values(graph: &Graph, exprs: &[ExprId], inputs: &[&[f64]]) -> Vec<f64> {
    let program = Program::compile(graph, exprs).expect("compiles");
    let mut out = vec![0.0; exprs.len()];
    program.eval(inputs, &mut out, &mut Vec::new());
    out
}
