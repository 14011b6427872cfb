//! Speed of compiled expressions (`sdae_expr::Program`, a tape interpreted over lanes) against
//! the same formulas written by hand over lanes, on [`PATHS`] paths W at a time:
//!
//! - `expr_pendulum_gradient`: grad g of the pendulum's constraint g = x^2 + y^2 - L^2
//!   (`tape`: differentiated and compiled from the text; `hand`: 2 x, 2 y);
//! - `expr_chain_jacobian_vector`: Dg(q) w of the 9 bond constraints
//!   |r_{i+1} - r_i|^2 - l^2 of a chain of 10 beads in space (`tape`: the Jacobian's 54
//!   structurally nonzero entries differentiated, multiplied by w and compiled; `hand`:
//!   2 (r_{i+1} - r_i) . (w_{i+1} - w_i)).
//!
//! Each iteration loads every path's inputs into lanes, evaluates and stores the outputs; the
//! throughput is in paths. The interpretation overhead per operation is the difference of the
//! two times divided by the tape's operations (printed before the runs). Run with
//! `cargo bench -p sdae-bench --bench expr`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use pulp::{Simd, WithSimd};
use sdae_expr::{ExprId, Graph, Program, SymbolTable, Var};
use sdae_lanes::{LaneWidth, Lanes};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Paths evaluated per iteration.
const PATHS: usize = 1024;

/// Beads of the chain.
const BEADS: usize = 10;

/// A formula over lanes: outputs from the coordinates q and a vector w.
trait Kernel {
    fn run<S: Simd>(
        &self, q: &[Lanes<S>], w: &[Lanes<S>], out: &mut [Lanes<S>], scratch: &mut Vec<Lanes<S>>,
    );
}

/// A compiled program of inputs q (slot 0) and w (slot 1).
struct Tape(Program);

impl Kernel for Tape {
    #[inline(always)]
    fn run<S: Simd>(
        &self, q: &[Lanes<S>], w: &[Lanes<S>], out: &mut [Lanes<S>], scratch: &mut Vec<Lanes<S>>,
    ) {
        self.0.eval(&[q, w], out, scratch);
    }
}

/// grad (x^2 + y^2 - L^2) by hand.
struct PendulumGradient;

impl Kernel for PendulumGradient {
    #[inline(always)]
    fn run<S: Simd>(
        &self, q: &[Lanes<S>], _: &[Lanes<S>], out: &mut [Lanes<S>], _: &mut Vec<Lanes<S>>,
    ) {
        out[0] = q[0] * 2.0;
        out[1] = q[1] * 2.0;
    }
}

/// The chain's Dg(q) w by hand.
struct ChainJacobianVector;

impl Kernel for ChainJacobianVector {
    #[inline(always)]
    fn run<S: Simd>(
        &self, q: &[Lanes<S>], w: &[Lanes<S>], out: &mut [Lanes<S>], _: &mut Vec<Lanes<S>>,
    ) {
        for (i, o) in out.iter_mut().enumerate() {
            let (a, b) = (3 * i, 3 * i + 3);
            let dot = (q[b] - q[a]) * (w[b] - w[a])
                + (q[b + 1] - q[a + 1]) * (w[b + 1] - w[a + 1])
                + (q[b + 2] - q[a + 2]) * (w[b + 2] - w[a + 2]);
            *o = dot * 2.0;
        }
    }
}

/// Every path of `q` and `w` (value j of path p at `j * PATHS + p`) through `kernel`, W paths
/// at a time, into `out` (laid out likewise).
struct Sweep<'a, K> {
    kernel: &'a K,
    q: &'a [f64],
    w: &'a [f64],
    out: &'a mut [f64],
}

impl<K: Kernel> WithSimd for Sweep<'_, K> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let width = Lanes::<S>::WIDTH;
        let zero = Lanes::splat(simd, 0.0);
        let (n, m) = (self.q.len() / PATHS, self.out.len() / PATHS);
        let (mut q, mut w, mut out) = (
            vec![zero; n],
            vec![zero; self.w.len() / PATHS],
            vec![zero; m],
        );
        let mut scratch = Vec::new();
        for start in (0..PATHS).step_by(width) {
            for (j, x) in q.iter_mut().enumerate() {
                *x = Lanes::load(simd, &self.q[j * PATHS + start..]);
            }
            for (j, x) in w.iter_mut().enumerate() {
                *x = Lanes::load(simd, &self.w[j * PATHS + start..]);
            }
            self.kernel.run(&q, &w, &mut out, &mut scratch);
            for (i, x) in out.iter().enumerate() {
                x.store(&mut self.out[i * PATHS + start..]);
            }
        }
    }
}

/// `kernel` over every path.
fn sweep<K: Kernel>(kernel: &K, q: &[f64], w: &[f64], out: &mut [f64]) {
    LaneWidth::Best.dispatch(Sweep { kernel, q, w, out });
}

/// The pendulum's gradient, compiled.
fn pendulum_tape() -> Program {
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&["x", "y"]).expect("names");
    table.add_parameter("L", 1.0).expect("parameter");
    let mut graph = Graph::new();
    let g = graph.parse("x^2 + y^2 - L^2", &table).expect("constraint");
    let gradient = graph.gradient(g, &table.slot_vars(q)).expect("gradient");
    Program::compile(&graph, &gradient).expect("program")
}

/// The chain's Dg(q) w, compiled.
fn chain_tape() -> Program {
    let names: Vec<String> = (0..BEADS)
        .flat_map(|i| ["x", "y", "z"].map(|c| format!("{c}{i}")))
        .collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&refs).expect("names");
    table.add_parameter("l", 1.0).expect("parameter");
    let w = Var::slot(
        table.add_unnamed_inputs(3 * BEADS).expect("slot"),
        3 * BEADS,
    );
    let mut graph = Graph::new();
    let bonds: Vec<ExprId> = (1..BEADS)
        .map(|i| {
            let j = i - 1;
            let text = format!("(x{i}-x{j})^2 + (y{i}-y{j})^2 + (z{i}-z{j})^2 - l^2");
            graph.parse(&text, &table).expect("bond")
        })
        .collect();
    let jacobian = graph
        .jacobian(&bonds, &table.slot_vars(q))
        .expect("jacobian");
    let products = graph.jacobian_vector(&jacobian, &w).expect("products");
    Program::compile(&graph, &products).expect("program")
}

/// `n` values per path.
fn inputs(n: usize, phase: f64) -> Vec<f64> {
    (0..n * PATHS)
        .map(|k| (k as f64 * 0.37 + phase).sin() + (k / PATHS) as f64)
        .collect()
}

/// Benchmarks `tape` against `hand` after checking that they agree.
fn compare<H: Kernel>(c: &mut Criterion, name: &str, tape: Program, hand: H, n: usize) {
    let (q, w) = (inputs(n, 0.0), inputs(n, 1.0));
    let m = tape.outputs();
    let tape = Tape(tape);
    let (mut a, mut b) = (vec![0.0; m * PATHS], vec![0.0; m * PATHS]);
    sweep(&tape, &q, &w, &mut a);
    sweep(&hand, &q, &w, &mut b);
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (x - y).abs() <= 1e-12 * (1.0 + y.abs()),
            "{name}: tape {x}, by hand {y}"
        );
    }
    println!(
        "{name}: {} tape operations ({} constants), {m} outputs, W = {}",
        tape.0.op_count(),
        tape.0.constants().len(),
        LaneWidth::Best.lanes()
    );
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(PATHS as u64));
    group.bench_function("tape", |bencher| {
        bencher.iter(|| sweep(&tape, black_box(&q), black_box(&w), &mut a))
    });
    group.bench_function("hand", |bencher| {
        bencher.iter(|| sweep(&hand, black_box(&q), black_box(&w), &mut b))
    });
    group.finish();
}

fn bench_expr(c: &mut Criterion) {
    compare(
        c,
        "expr_pendulum_gradient",
        pendulum_tape(),
        PendulumGradient,
        2,
    );
    compare(
        c,
        "expr_chain_jacobian_vector",
        chain_tape(),
        ChainJacobianVector,
        3 * BEADS,
    );
}

criterion_group!(benches, bench_expr);
criterion_main!(benches);
