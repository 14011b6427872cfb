//! The compiler's rewrites against the graph evaluated node by node: the same bits for every
//! input, signed zeros, infinities, subnormals and overflow included.

use std::collections::HashMap;

use crate::func::{atan2, powf, powi};
use crate::graph::{ExprId, Graph, Node};
use crate::symbols::SymbolTable;
use crate::tape::{Op, Program};

/// Node by node in f64, as written (no rewrite): an independent reader of the graph.
fn evaluate(graph: &Graph, e: ExprId, x: &[f64], memo: &mut HashMap<ExprId, f64>) -> f64 {
    if let Some(&v) = memo.get(&e) {
        return v;
    }
    let mut at = |a: ExprId| evaluate(graph, a, x, memo);
    let value = match graph.node(e) {
        Node::Const(c) => c,
        Node::Input(var) => x[var.index as usize],
        Node::Neg(a) => -at(a),
        Node::Add(a, b) => at(a) + at(b),
        Node::Sub(a, b) => at(a) - at(b),
        Node::Mul(a, b) => at(a) * at(b),
        Node::Div(a, b) => at(a) / at(b),
        Node::PowI(a, n) => powi(at(a), n),
        Node::Pow(a, b) => powf(at(a), at(b)),
        Node::Func(f, a) => f.apply(at(a)),
        Node::Atan2(y, x) => atan2(at(y), at(x)),
    };
    memo.insert(e, value);
    value
}

/// Expressions where the rewrites apply, and where they must not.
const TEXTS: [&str; 18] = [
    "-x + y",
    "x - -y",
    "-x - y",
    "-x + -y",
    "-(x*y) + -(y*z)",
    "(-x)/2 + y/0.5 - z/-4",
    "-x*-y - -z",
    "abs(-x) + sign(-y) * 3",
    "-x^3 + (-y)^2 - (-z)^-3",
    "x^-3 / 8 - y / 3",
    "sin(-x) * -2 + exp(-y)",
    "atan2(-y, -x) - -z / 2",
    "-(x + y) + (x + y)",
    "x / 4.5 + y / 2^-1022 - z / 2^1023",
    "(1 - (x^2 + y^2)) / 2",
    "-(-x / y) * -(z - x)",
    "(-x)^y + -z",
    "x / -0.25 - (-y) / z",
];

/// Inputs of every kind: zeros of both signs, infinities, NaN, the extremes.
const POINTS: [f64; 12] = [
    0.0,
    -0.0,
    1.0,
    -2.5,
    0.3,
    1e308,
    -1e308,
    5e-324,
    -1e-310,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
];

#[test]
fn rewrites_keep_every_bit() {
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&["x", "y", "z"]).unwrap();
    let mut graph = Graph::new();
    let mut outputs: Vec<ExprId> = TEXTS
        .iter()
        .map(|t| graph.parse(t, &table).unwrap())
        .collect();
    // Derivatives bring negations and constant factors of their own.
    for &e in &outputs.clone() {
        outputs.extend(graph.gradient(e, &table.slot_vars(q)).unwrap());
    }
    let program = Program::compile(&graph, &outputs).unwrap();
    let mut out = vec![0.0; outputs.len()];
    let mut scratch = Vec::new();
    for &a in &POINTS {
        for &b in &POINTS {
            for &c in &POINTS {
                let x = [a, b, c];
                program.eval(&[&x[..]], &mut out, &mut scratch);
                let mut memo = HashMap::new();
                for (i, (&e, got)) in outputs.iter().zip(&out).enumerate() {
                    let expected = evaluate(&graph, e, &x, &mut memo);
                    let same =
                        got.to_bits() == expected.to_bits() || got.is_nan() && expected.is_nan();
                    assert!(
                        same,
                        "output {i} at {x:?}: {got:?}, node by node {expected:?}"
                    );
                }
            }
        }
    }
}

/// The operations of `text` compiled alone.
fn ops_of(text: &str) -> Vec<Op> {
    let mut table = SymbolTable::new();
    table.add_inputs(&["x", "y"]).unwrap();
    let mut graph = Graph::new();
    let e = graph.parse(text, &table).unwrap();
    Program::compile(&graph, &[e]).unwrap().ops().to_vec()
}

/// The count of operations of `text` that `kind` matches.
fn count(text: &str, kind: fn(&Op) -> bool) -> usize {
    ops_of(text).iter().filter(|op| kind(op)).count()
}

#[test]
fn negations_fold_and_powers_of_two_multiply() {
    let neg = |op: &Op| matches!(op, Op::Neg(_));
    let div = |op: &Op| matches!(op, Op::Div(..));
    assert_eq!(count("-x + y", neg), 0);
    assert_eq!(count("x - -y", neg), 0);
    assert_eq!(count("(-x) * (-y)", neg), 0);
    assert_eq!(count("abs(-x)", neg), 0);
    // -(x + y) would change the sign of a zero sum: one negation stays.
    assert_eq!(count("-x - y", neg), 1);
    assert_eq!(count("-(x * y)", neg), 1);
    assert_eq!(count("x / 2 + y / -0.125", div), 0);
    // 3 has no exact reciprocal, 2^1023's is subnormal.
    assert_eq!(count("x / 3 + y / 2^1023", div), 2);
    // The loads come first; the pooled constant 2 that only divided is gone.
    let ops = ops_of("(1 - (x^2 + y^2)) / 2");
    assert!(matches!(ops[..2], [Op::Load { .. }, Op::Load { .. }]));
    let mut table = SymbolTable::new();
    table.add_inputs(&["x"]).unwrap();
    let mut graph = Graph::new();
    let e = graph.parse("x / 2", &table).unwrap();
    assert_eq!(Program::compile(&graph, &[e]).unwrap().constants(), [0.5]);
}
