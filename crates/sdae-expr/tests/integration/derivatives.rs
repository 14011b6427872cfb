//! Derivatives against central finite differences, Jacobian sparsity, directional second
//! derivatives, and the detection of constant second derivatives.
//!
//! Central differences with the step h = 1e-6 max(1, |x|): the error of
//! (f(x + h) - f(x - h)) / 2h is h^2 |f'''| / 6 (truncation, at most 2e-13 |f'''|) plus about
//! eps |f| / h from rounding (eps = 2.2e-16, so at most 2.2e-10 |f|, a few times that with the
//! rounding of x + h). At the test points |f| and |f'''| stay below 1e3, so an error of
//! 1e-7 (1 + |f| + |f'|) bounds both with a margin of 100; a wrong rule (a sign, a factor, a
//! missing chain term) errs by O(|f'|) and fails it.

use sdae_expr::{ExprId, Graph, Program, SymbolTable, Var};

use crate::{table, values};

const STEP: f64 = 1e-6;

/// The error bound of a central difference (module docs).
fn tolerance(f: f64, derivative: f64) -> f64 {
    1e-7 * (1.0 + f.abs() + derivative.abs())
}

/// The value of the compiled `program` (one output) at `point`.
fn at(program: &Program, point: &[f64]) -> f64 {
    let mut out = [0.0];
    program.eval(&[point], &mut out, &mut Vec::new());
    out[0]
}

/// Checks d e / d vars[j] (symbolic) against central differences of `e` at `point`.
fn check_gradient(
    graph: &mut Graph, e: ExprId, vars: &[Var], point: &[f64], what: &str,
) -> Vec<ExprId> {
    let gradient = graph.gradient(e, vars).expect("gradient");
    let f = Program::compile(graph, &[e]).unwrap();
    let symbolic = values(graph, &gradient, &[point]);
    for (j, &d) in symbolic.iter().enumerate() {
        let h = STEP * point[j].abs().max(1.0);
        let (mut plus, mut minus) = (point.to_vec(), point.to_vec());
        plus[j] += h;
        minus[j] -= h;
        let difference = (at(&f, &plus) - at(&f, &minus)) / (plus[j] - minus[j]);
        let fx = at(&f, point);
        assert!(
            (d - difference).abs() <= tolerance(fx, d),
            "{what}: d/d{j} = {d}, finite difference {difference} at {point:?}"
        );
    }
    gradient
}

const EXPRESSIONS: [&str; 14] = [
    "x^3*y - 2*x*y^2 + 5",
    "sin(x)*cos(y) + tan(z/3)",
    "exp(x*y) - log(1 + z^2)",
    "atan2(y, x) + atan2(x*z, 1 + y^2)",
    "sqrt(x^2 + y^2 + z^2)",
    "tanh(x - y)*abs(z - 2)",
    "x^-2 + y^2.5 + x^y",
    "(1 + x^2)^1.5 / (2 + sin(y*z))",
    "exp(sin(x*cos(y)))^2 / sqrt(1 + z^4)",
    "x/y/z - (x - y)/(y + 2)",
    "-x^2 + 2^x - z^-3",
    "abs(x - 1.5)^3 + log(x*y*z)",
    "(sqrt(x^2 + y^2) - 2)^2 + z^2 - 0.25",
    "x^70 + y^(1/3)",
];

const POINTS: [[f64; 3]; 3] = [[0.7, 1.3, 0.4], [1.1, 0.6, 1.7], [0.45, 0.9, 1.25]];

#[test]
fn first_and_second_derivatives_match_central_differences() {
    let table = table(&["x", "y", "z"], &[]);
    let vars = table.slot_vars(0);
    for text in EXPRESSIONS {
        let mut graph = Graph::new();
        let e = graph.parse(text, &table).unwrap();
        for point in POINTS {
            let gradient = check_gradient(&mut graph, e, &vars, &point, text);
            for (j, &dj) in gradient.iter().enumerate() {
                check_gradient(&mut graph, dj, &vars, &point, &format!("d/d{j} of {text}"));
            }
        }
    }
}

/// A chain of `beads` beads in space (x0 y0 z0 x1 ...), its bonds of length 1.
fn chain(beads: usize) -> (SymbolTable, Vec<String>) {
    let names: Vec<String> = (0..beads)
        .flat_map(|i| ["x", "y", "z"].map(|c| format!("{c}{i}")))
        .collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let table = table(&refs, &[("l", 1.0)]);
    let bonds = (1..beads)
        .map(|i| {
            let j = i - 1;
            format!("(x{i}-x{j})^2 + (y{i}-y{j})^2 + (z{i}-z{j})^2 - l^2")
        })
        .collect();
    (table, bonds)
}

#[test]
fn jacobians_have_the_pattern_of_their_constraints() {
    let (table, bonds) = chain(10);
    let vars = table.slot_vars(0);
    let mut graph = Graph::new();
    let g: Vec<ExprId> = bonds
        .iter()
        .map(|b| graph.parse(b, &table).unwrap())
        .collect();
    let jacobian = graph.jacobian(&g, &vars).unwrap();
    assert_eq!((jacobian.rows(), jacobian.cols()), (9, 30));
    let expected: Vec<(usize, usize)> = (0..9)
        .flat_map(|i| (3 * i..3 * i + 6).map(move |j| (i, j)))
        .collect();
    assert_eq!(jacobian.pattern(), expected);
    assert_eq!(jacobian.get(0, 7), None);
    // Each entry against the row's gradient, checked by differences.
    let point: Vec<f64> = (0..30)
        .map(|k| (k as f64 * 0.37).sin() + k as f64 / 3.0)
        .collect();
    for (i, &gi) in g.iter().enumerate() {
        let gradient = check_gradient(&mut graph, gi, &vars, &point, &bonds[i]);
        for entry in jacobian.row(i) {
            let (a, b) = (
                values(&graph, &[entry.expr], &[&point])[0],
                values(&graph, &[gradient[entry.col]], &[&point])[0],
            );
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
    // A variable the row mentions but that cancels is structurally zero.
    let e = graph.parse("x0 - x0 + y0*y1", &table).unwrap();
    assert_eq!(
        graph.jacobian(&[e], &vars).unwrap().pattern(),
        [(0, 1), (0, 4)]
    );
}

/// D^2 g(q)(u, w) of `constraints` against (Dg(q + h u) w - Dg(q - h u) w) / 2h.
fn check_second_directional(names: &[&str], constraints: &[&str], q: &[f64], u: &[f64], w: &[f64]) {
    let mut table = table(names, &[("R", 2.0), ("r", 0.5), ("L1", 1.0), ("L2", 0.7)]);
    let n = names.len();
    let vars = table.slot_vars(0);
    let u_vars = Var::slot(table.add_unnamed_inputs(n).unwrap(), n);
    let w_vars = Var::slot(table.add_unnamed_inputs(n).unwrap(), n);
    let mut graph = Graph::new();
    let g: Vec<ExprId> = constraints
        .iter()
        .map(|c| graph.parse(c, &table).unwrap())
        .collect();
    let jacobian = graph.jacobian(&g, &vars).unwrap();
    let second = graph
        .second_directional(&jacobian, &vars, &u_vars, &w_vars)
        .unwrap();
    let swapped = graph
        .second_directional(&jacobian, &vars, &w_vars, &u_vars)
        .unwrap();
    let dg_w = graph.jacobian_vector(&jacobian, &w_vars).unwrap();
    let (second, swapped) = (
        values(&graph, &second, &[q, u, w]),
        values(&graph, &swapped, &[q, u, w]),
    );
    let h = STEP;
    let shifted = |sign: f64| {
        let point: Vec<f64> = q.iter().zip(u).map(|(q, u)| q + sign * h * u).collect();
        values(&graph, &dg_w, &[&point, u, w])
    };
    let (plus, minus, at_q) = (
        shifted(1.0),
        shifted(-1.0),
        values(&graph, &dg_w, &[q, u, w]),
    );
    for i in 0..g.len() {
        let difference = (plus[i] - minus[i]) / (2.0 * h);
        assert!(
            (second[i] - difference).abs() <= tolerance(at_q[i], second[i]),
            "{}: D2g(u, w) = {}, difference {difference}",
            constraints[i],
            second[i]
        );
        assert!((second[i] - swapped[i]).abs() <= 1e-12 * (1.0 + second[i].abs()));
    }
}

#[test]
fn directional_second_derivatives_match_differences_of_the_jacobian() {
    check_second_directional(
        &["x1", "y1", "x2", "y2"],
        &["x1^2 + y1^2 - L1^2", "(x2-x1)^2 + (y2-y1)^2 - L2^2"],
        &[0.6, -0.8, 1.1, -1.3],
        &[0.3, -0.7, 1.2, 0.4],
        &[-0.5, 0.2, 0.9, -1.1],
    );
    check_second_directional(
        &["x", "y", "z"],
        &[
            "(sqrt(x^2 + y^2) - R)^2 + z^2 - r^2",
            "x^2/4 + y^2 + z^2/9 - 1",
            "sin(x)*y + exp(y*z) - atan2(z, x)",
        ],
        &[1.9, 0.4, 0.3],
        &[0.3, -0.7, 1.2],
        &[-0.5, 0.2, 0.9],
    );
}

#[test]
fn quadratic_constraints_are_found() {
    let table = table(
        &["x", "y", "z", "x2", "y2", "z2"],
        &[("R", 2.0), ("r", 0.5)],
    );
    let vars = table.slot_vars(0);
    let mut graph = Graph::new();
    let mut quadratic = |text: &str| {
        let e = graph.parse(text, &table).unwrap();
        graph.constant_hessian(e, &vars).unwrap()
    };
    let sphere = quadratic("x^2 + y^2 + z^2 - R^2").expect("a sphere is quadratic");
    let mut identity2 = vec![0.0; 36];
    for k in 0..3 {
        identity2[k * 7] = 2.0;
    }
    assert_eq!(sphere, identity2);
    let bond = quadratic("(x2-x)^2 + (y2-y)^2 + (z2-z)^2 - r^2").expect("a bond is quadratic");
    assert_eq!(
        (bond[0], bond[3], bond[3 * 6], bond[3 * 6 + 3]),
        (2.0, -2.0, -2.0, 2.0)
    );
    assert!(quadratic("x^2/4 + y^2 + z^2/9 - 1").is_some());
    assert!(quadratic("x*y - 1").is_some());
    assert!(quadratic("3*x - y + 2").is_some());
    assert!(
        quadratic("(sqrt(x^2 + y^2) - R)^2 + z^2 - r^2").is_none(),
        "a torus is not"
    );
    assert!(quadratic("x^3 - y").is_none());
    assert!(quadratic("sin(x) + y^2").is_none());
}

#[test]
fn substituted_expressions_evaluate_as_the_original_at_the_replacements() {
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&["x", "y"]).unwrap();
    let r = Var::slot(table.add_unnamed_inputs(2).unwrap(), 2);
    let mut graph = Graph::new();
    let texts = [
        "x^2 * sin(y) - x / 3",
        "atan2(y, x) + exp(-x * y)",
        "y^3 - 2",
    ];
    let exprs: Vec<ExprId> = texts
        .iter()
        .map(|t| graph.parse(t, &table).unwrap())
        .collect();
    let (x, y) = (table.slot_vars(q)[0], table.slot_vars(q)[1]);
    // x -> r0 + r1 (an expression), y -> r1 (an input of another slot).
    let (r0, r1) = (graph.input(r[0]), graph.input(r[1]));
    let sum = graph.add(r0, r1);
    let replace = |var: Var| match var {
        v if v == x => Some(sum),
        v if v == y => Some(r1),
        _ => None,
    };
    let substituted = graph.substitute(&exprs, &replace).unwrap();
    let original = Program::compile(&graph, &exprs).unwrap();
    let image = Program::compile(&graph, &substituted).unwrap();
    for (a, b) in [(0.3, -1.7), (2.5, 0.25), (-1e3, 7.0)] {
        let (mut expected, mut found) = ([0.0; 3], [0.0; 3]);
        original.eval(&[&[a + b, b][..], &[]], &mut expected, &mut Vec::new());
        image.eval(&[&[][..], &[a, b]], &mut found, &mut Vec::new());
        let same = expected
            .iter()
            .zip(&found)
            .all(|(e, f)| e.to_bits() == f.to_bits());
        assert!(same, "at ({a}, {b}): {expected:?} against {found:?}");
    }
    // Nothing replaced: the same nodes.
    let none = graph.substitute(&exprs, &|_| None).unwrap();
    assert_eq!(none, exprs);
}
