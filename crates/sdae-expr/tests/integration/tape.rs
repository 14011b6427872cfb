//! Compiled programs: W lanes compute bit for bit what f64 computes path by path, common
//! subexpressions are computed once, integer powers are repeated products.

use pulp::{Simd, WithSimd};
use sdae_expr::{CompileOptions, Graph, Program, Var, powi};
use sdae_lanes::{LaneWidth, Lanes};

use crate::{table, values};

/// Paths evaluated.
const PATHS: usize = 24;

/// The program's outputs for every path, W paths at a time: `inputs[slot]` holds value j of
/// path p at `j * PATHS + p`, the outputs likewise.
struct Run<'a> {
    program: &'a Program,
    inputs: &'a [Vec<f64>],
}

impl WithSimd for Run<'_> {
    type Output = Vec<f64>;
    fn with_simd<S: Simd>(self, simd: S) -> Vec<f64> {
        let w = Lanes::<S>::WIDTH;
        let outputs = self.program.outputs();
        let mut result = vec![0.0; outputs * PATHS];
        let mut scratch = Vec::new();
        for start in (0..PATHS).step_by(w) {
            let lanes: Vec<Vec<Lanes<S>>> = self
                .inputs
                .iter()
                .map(|slot| {
                    (0..slot.len() / PATHS)
                        .map(|j| Lanes::load(simd, &slot[j * PATHS + start..]))
                        .collect()
                })
                .collect();
            let refs: Vec<&[Lanes<S>]> = lanes.iter().map(Vec::as_slice).collect();
            let mut out = vec![Lanes::splat(simd, 0.0); outputs];
            self.program.eval(&refs, &mut out, &mut scratch);
            for (i, o) in out.iter().enumerate() {
                o.store(&mut result[i * PATHS + start..]);
            }
        }
        result
    }
}

/// The outputs path by path in f64, laid out as [`Run`]'s.
fn path_by_path(program: &Program, inputs: &[Vec<f64>]) -> Vec<f64> {
    let outputs = program.outputs();
    let mut result = vec![0.0; outputs * PATHS];
    let mut scratch = Vec::new();
    for p in 0..PATHS {
        let per_path: Vec<Vec<f64>> = inputs
            .iter()
            .map(|slot| {
                (0..slot.len() / PATHS)
                    .map(|j| slot[j * PATHS + p])
                    .collect()
            })
            .collect();
        let refs: Vec<&[f64]> = per_path.iter().map(Vec::as_slice).collect();
        let mut out = vec![0.0; outputs];
        program.eval(&refs, &mut out, &mut scratch);
        for (i, o) in out.into_iter().enumerate() {
            result[i * PATHS + p] = o;
        }
    }
    result
}

fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn lanes_compute_what_f64_computes_path_by_path() {
    let mut table = table(&["x", "y", "z"], &[("k", 0.75)]);
    let w_vars = Var::slot(table.add_unnamed_inputs(3).unwrap(), 3);
    let mut graph = Graph::new();
    let texts = [
        "x^3*y - 2*x*y^2 + k",
        "sin(x)*cos(y) + tan(z/3) - tanh(x*z)",
        "exp(x*y) - log(1 + z^2) + log(x)",
        "atan2(y, x) + sqrt(abs(z)) + sqrt(x)",
        "x^-2 + y^2.5 + x^y + x^7 + z^(1/3)",
        "(sqrt(x^2 + y^2) - 2)^2 + z^2 - 0.25",
    ];
    let e: Vec<_> = texts
        .iter()
        .map(|t| graph.parse(t, &table).unwrap())
        .collect();
    let vars = table.slot_vars(0);
    let jacobian = graph.jacobian(&e, &vars).unwrap();
    let mut outputs = e.clone();
    outputs.extend(graph.jacobian_vector(&jacobian, &w_vars).unwrap());
    outputs.extend(
        graph
            .second_directional(&jacobian, &vars, &w_vars, &w_vars)
            .unwrap(),
    );
    let program = Program::compile(&graph, &outputs).unwrap();
    // Values of either sign, zeros, and a NaN and an infinity among them.
    let mut q: Vec<f64> = (0..3 * PATHS)
        .map(|k| ((k * 7919 % 101) as f64 - 40.0) / 13.0)
        .collect();
    q[5] = 0.0;
    q[PATHS + 3] = -0.0;
    q[2 * PATHS + 9] = f64::NAN;
    q[11] = f64::INFINITY;
    let w: Vec<f64> = (0..3 * PATHS).map(|k| (k as f64 * 0.61).cos()).collect();
    let inputs = [q, w];
    let expected = path_by_path(&program, &inputs);
    let run = || Run {
        program: &program,
        inputs: &inputs,
    };
    let results = [
        ("scalar", Simd::vectorize(pulp::Scalar, run())),
        ("4 emulated", Simd::vectorize(pulp::Scalar256b, run())),
        ("8 emulated", Simd::vectorize(pulp::Scalar512b, run())),
        ("One", LaneWidth::One.dispatch(run())),
        ("Four", LaneWidth::Four.dispatch(run())),
        ("Eight", LaneWidth::Eight.dispatch(run())),
    ];
    for (width, got) in results {
        for (k, (a, b)) in got.iter().zip(&expected).enumerate() {
            assert!(
                same_bits(*a, *b),
                "{width}: output {} path {}: {a} vs {b}",
                k / PATHS,
                k % PATHS
            );
        }
    }
    // The program computes what the expressions say.
    let x: f64 = inputs[0][1];
    let (y, z) = (inputs[0][PATHS + 1], inputs[0][2 * PATHS + 1]);
    let first = x.powi(3) * y - 2.0 * x * y * y + 0.75;
    assert!((expected[1] - first).abs() <= 1e-12 * (1.0 + first.abs()));
    let torus = ((x * x + y * y).sqrt() - 2.0).powi(2) + z * z - 0.25;
    assert!((expected[5 * PATHS + 1] - torus).abs() <= 1e-12 * (1.0 + torus.abs()));
}

#[test]
fn integer_powers_are_the_same_products_everywhere() {
    let table = table(&["x"], &[]);
    let mut graph = Graph::new();
    let e: Vec<_> = [
        "x^2", "x^3", "x^5", "x^-3", "x^64", "x^65", "x^2.0", "x^(1+1)",
    ]
    .iter()
    .map(|t| graph.parse(t, &table).unwrap())
    .collect();
    for x in [1.1f64, -0.7, 3.3e-2, 1.0 + f64::EPSILON] {
        let got = values(&graph, &e, &[&[x]]);
        let expected = [
            x * x,
            x * x * x,
            (x * x) * (x * x) * x,
            1.0 / (x * x * x),
            powi(x, 64),
            x.powf(65.0),
            x * x,
            x * x,
        ];
        for (g, e) in got.iter().zip(expected) {
            assert_eq!(g.to_bits(), e.to_bits(), "x = {x}");
        }
    }
}

#[test]
fn common_subexpressions_are_computed_once() {
    let table = table(&["x", "y"], &[("a", 2.0)]);
    let mut graph = Graph::new();
    let e = graph
        .parse("sin(x*y) + sin(y*x)^2 + cos(x*y)*a + a*x*y", &table)
        .unwrap();
    let vars = table.slot_vars(0);
    let mut outputs = vec![e];
    outputs.extend(graph.gradient(e, &vars).unwrap());
    let with = Program::compile(&graph, &outputs).unwrap();
    let without = Program::compile_with(&graph, &outputs, CompileOptions { cse: false }).unwrap();
    assert!(
        3 * with.op_count() <= 2 * without.op_count(),
        "CSE: {} ops, without: {}",
        with.op_count(),
        without.op_count()
    );
    // x*y once: one load of each input, one product, one sine and one cosine of it.
    let ops = with.ops();
    let count = |f: &dyn Fn(&sdae_expr::Op) -> bool| ops.iter().filter(|op| f(op)).count();
    assert_eq!(count(&|op| matches!(op, sdae_expr::Op::Load { .. })), 2);
    assert_eq!(
        count(&|op| matches!(op, sdae_expr::Op::Func(sdae_expr::Func::Sin, _))),
        1
    );
    assert_eq!(
        count(&|op| matches!(op, sdae_expr::Op::Func(sdae_expr::Func::Cos, _))),
        1
    );
    // Constants pooled: each value once.
    let mut constants = with.constants().to_vec();
    constants.sort_by(f64::total_cmp);
    constants.dedup();
    assert_eq!(constants.len(), with.constants().len());
    let (mut a, mut b) = (vec![0.0; outputs.len()], vec![0.0; outputs.len()]);
    with.eval(&[&[0.3, -1.2]], &mut a, &mut Vec::new());
    without.eval(&[&[0.3, -1.2]], &mut b, &mut Vec::new());
    assert_eq!(a, b);
}

#[test]
fn programs_refuse_foreign_expressions() {
    let table = table(&["x"], &[]);
    let mut small = Graph::new();
    let mut large = Graph::new();
    small.parse("x", &table).unwrap();
    let e = large.parse("x + sin(x) * 2", &table).unwrap();
    assert!(matches!(
        Program::compile(&small, &[e]),
        Err(sdae_expr::ExprError::ForeignExpression { .. })
    ));
    assert!(small.diff(e, Var::new(0, 0)).is_err());
}
