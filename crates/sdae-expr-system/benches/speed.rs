//! Time per path-step of systems written as expressions against the built-in ones, in SIMD
//! lanes (the processor's widest), and the cost of the registers' pool per program call.
//!
//! - `pendulum`: the seed's pendulum (sdae_systems::pendulum) against the same system as
//!   expressions with the scalar Gram storage (m = 1, the kappa root in closed form) and with
//!   the dense one;
//! - `chain`: the 10-atom chain molecule with its angle potential (torsion off) against the
//!   same as expressions with the tridiagonal Gram storage and with the dense one;
//! - `registers`: Dg u of the pendulum's constraint over lanes, through the thread's pool of
//!   registers (what the system does) and with registers the caller holds (the floor).
//!
//! The half-explicit stepper with practical C_eta = 1 steps every path on increments drawn
//! beforehand; the runs of the systems alternate, [`ROUNDS`] times, and the medians are
//! printed. Run with `cargo bench -p sdae-expr-system --bench speed` (about 30 s).

use std::collections::BTreeMap;
use std::hint::black_box;
use std::time::Instant;

use pulp::{Simd, WithSimd};
use sdae_expr::{Graph, Program, SymbolTable, Var};
use sdae_expr_system::{ExpressionSpec, ExpressionSystem, MassSpec};
use sdae_lanes::{LaneWidth, Lanes};
use sdae_manifold::{Equations, Scalar, Tridiagonal};
use sdae_model::{PathEnsemble, System};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{
    AngleParams, ChainMoleculeParams, Masses, PendulumParams, chain_molecule, pendulum,
};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Paths of each ensemble.
const PATHS: usize = 512;
/// Alternated rounds of runs.
const ROUNDS: usize = 7;
/// Step size.
const H: f64 = 1e-3;
/// Increments drawn beforehand (cycled).
const DRAWN: usize = 16;

/// Deterministic standard normals (Box-Muller on a 64-bit LCG), scaled by sqrt(H).
fn increments(len: usize, seed: u64) -> Vec<f64> {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..len)
        .map(|_| {
            let (a, b) = (uniform(), uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos() * H.sqrt()
        })
        .collect()
}

/// A stepping ensemble and its increments.
struct Run {
    name: &'static str,
    step: Box<dyn FnMut(usize) -> usize>,
    times: Vec<f64>,
}

/// A run of `system` from (r0, v0) with `config`.
fn run<S: System + 'static>(
    name: &'static str, system: S, config: StepperConfig, r0: &[f64], v0: &[f64],
) -> Run {
    let stepper = Stepper::new(system, config).expect("stepper");
    let mut ensemble = Ensemble::new(stepper, PATHS, r0, v0).expect("ensemble");
    let l = ensemble.system().noise_dim();
    let drawn: Vec<Vec<f64>> = (0..DRAWN)
        .map(|k| increments(l * ensemble.stride(), k as u64))
        .collect();
    let (r0, v0) = (r0.to_vec(), v0.to_vec());
    let step = move |k: usize| {
        if k.is_multiple_of(1000) {
            ensemble.restart(&r0, &v0).expect("restart");
        }
        let stepped = ensemble.step(H, &drawn[k % DRAWN]).expect("step");
        if ensemble.failed_paths() > 0 {
            let p = (0..PATHS)
                .find(|&p| matches!(ensemble.failure(p), Ok(Some(_))))
                .unwrap_or(0);
            panic!("{name}: path {p} failed: {:?}", ensemble.failure(p));
        }
        assert_eq!(ensemble.scalar_steps(), 0, "{name}: a step left the lanes");
        stepped
    };
    Run {
        name,
        step: Box::new(step),
        times: Vec::new(),
    }
}

/// Alternates the runs, `steps` steps each per round, and prints the median ns per
/// path-step with the ratio to the first run.
fn alternate(group: &str, runs: &mut [Run], steps: usize) {
    for round in 0..ROUNDS {
        for run in runs.iter_mut() {
            let start = Instant::now();
            for k in 0..steps {
                black_box((run.step)(round * steps + k));
            }
            run.times
                .push(start.elapsed().as_secs_f64() * 1e9 / (steps * PATHS) as f64);
        }
    }
    let median = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let base = median(&mut runs[0].times);
    for run in runs.iter_mut() {
        let m = median(&mut run.times);
        println!(
            "{group}/{}: {m:.1} ns per path-step ({:.2}x)",
            run.name,
            m / base
        );
    }
}

fn pendulum_runs() {
    let params = PendulumParams::default();
    let built_in = pendulum(params).expect("pendulum");
    let config = StepperConfig::for_system(&built_in)
        .and_then(|c| c.with_c_eta(1.0))
        .expect("config");
    let spec = ExpressionSpec {
        coordinates: None,
        particles: Some(1),
        dimension: Some(2),
        mass: MassSpec::One(1.0),
        parameters: BTreeMap::from([("c".into(), params.gravity)]),
        constraints: vec!["(1 - (x1^2 + y1^2)) / 2".into()],
        potential: Some("c * y1".into()),
        forces: None,
        friction: None,
        kt: None,
        noise: Some(sdae_expr_system::NoiseSpec::Intensity(params.noise)),
        observables: BTreeMap::new(),
        position: vec![1.0, 0.0],
        velocity: Some(vec![0.0, 1.0]),
        project: false,
    };
    let dense = ExpressionSystem::compile(&spec).expect("expression pendulum");
    let scalar = dense.with_shape::<Scalar>().expect("one equation");
    let (r0, v0) = ([1.0, 0.0], [0.0, 1.0]);
    let mut runs = [
        run("built-in", built_in, config, &r0, &v0),
        run("expressions (scalar)", scalar, config, &r0, &v0),
        run("expressions (dense)", dense, config, &r0, &v0),
    ];
    alternate("pendulum", &mut runs, 2000);
}

/// The angle potential k/2 (theta - theta0)^2 at inner atom b of atoms a, b, c.
fn angle_term(a: usize, b: usize, c: usize) -> String {
    let d = |i: usize, j: usize, x: &str| format!("({x}{i} - {x}{j})");
    let (ux, uy, uz) = (d(a, b, "x"), d(a, b, "y"), d(a, b, "z"));
    let (wx, wy, wz) = (d(c, b, "x"), d(c, b, "y"), d(c, b, "z"));
    let cross = format!(
        "sqrt(({uy}*{wz} - {uz}*{wy})^2 + ({uz}*{wx} - {ux}*{wz})^2 + ({ux}*{wy} - {uy}*{wx})^2)"
    );
    let dot = format!("{ux}*{wx} + {uy}*{wy} + {uz}*{wz}");
    format!("k / 2 * (atan2({cross}, {dot}) - theta0)^2")
}

fn chain_runs() {
    const ATOMS: usize = 10;
    let angle = AngleParams {
        stiffness: 20.0,
        ..AngleParams::default()
    };
    let params = ChainMoleculeParams {
        atoms: ATOMS,
        bond_length: 1.0,
        masses: Masses::Uniform(1.0),
        friction: 1.0,
        temperature: 1.0,
        angle,
        torsion: Default::default(),
    };
    let built_in = chain_molecule(&params).expect("chain");
    // C_eta = 1 without the ball's radius (c_kappa infinite), as the molecule benches of
    // sdae-bench: the theory's radius refuses a rare step of a chain at kT = 1.
    let config = StepperConfig::new(1.0, f64::INFINITY).expect("config");
    let bond = |i: usize| {
        let j = i + 1;
        format!("1/2 - ((x{j} - x{i})^2 + (y{j} - y{i})^2 + (z{j} - z{i})^2) / 2")
    };
    let potential: Vec<String> = (2..ATOMS).map(|b| angle_term(b - 1, b, b + 1)).collect();
    let (dx, dy) = ((2.0f64 / 3.0).sqrt(), (1.0f64 / 3.0).sqrt());
    let r0: Vec<f64> = (0..ATOMS)
        .flat_map(|i| [i as f64 * dx, if i % 2 == 1 { dy } else { 0.0 }, 0.0])
        .collect();
    let spec = ExpressionSpec {
        coordinates: None,
        particles: Some(ATOMS),
        dimension: Some(3),
        mass: MassSpec::One(1.0),
        parameters: BTreeMap::from([
            ("k".into(), angle.stiffness),
            ("theta0".into(), angle.equilibrium),
        ]),
        constraints: (1..ATOMS).map(bond).collect(),
        potential: Some(potential.join(" + ")),
        forces: None,
        friction: Some(1.0),
        kt: Some(1.0),
        noise: None,
        observables: BTreeMap::new(),
        position: r0.clone(),
        velocity: None,
        project: false,
    };
    let expressions = ExpressionSystem::compile(&spec).expect("expression chain");
    let tridiagonal = expressions
        .with_shape::<Tridiagonal>()
        .expect("a chain of bonds");
    let v0 = vec![0.0; 3 * ATOMS];
    let mut runs = [
        run("built-in", built_in, config, &r0, &v0),
        run("expressions (tridiagonal)", tridiagonal, config, &r0, &v0),
        run("expressions (dense)", expressions, config, &r0, &v0),
    ];
    alternate("chain", &mut runs, 300);
}

/// Dg u over lanes, `calls` times: through the constraint (the pool) or the program itself
/// with registers held here.
struct Products<'a> {
    constraint: &'a sdae_expr_system::ExpressionConstraint,
    program: &'a Program,
    pooled: bool,
    calls: usize,
}

impl WithSimd for Products<'_> {
    type Output = f64;
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> f64 {
        let x = [Lanes::splat(simd, 0.6), Lanes::splat(simd, -0.8)];
        let u = [Lanes::splat(simd, 0.3), Lanes::splat(simd, 0.1)];
        let mut out = [Lanes::splat(simd, 0.0)];
        let mut registers = Vec::new();
        let start = Instant::now();
        for _ in 0..self.calls {
            let x = black_box(&x);
            if self.pooled {
                Equations::jacobian_mul(self.constraint, &x[..], &u, &mut out);
            } else {
                self.program
                    .eval(&[&x[..], &[], &u[..]], &mut out, &mut registers);
            }
            black_box(&mut out);
        }
        start.elapsed().as_secs_f64() * 1e9 / self.calls as f64
    }
}

fn register_runs() {
    let spec = ExpressionSpec {
        coordinates: Some(vec!["x".into(), "y".into()]),
        particles: None,
        dimension: None,
        mass: MassSpec::One(1.0),
        parameters: BTreeMap::new(),
        constraints: vec!["(1 - (x^2 + y^2)) / 2".into()],
        potential: None,
        forces: None,
        friction: None,
        kt: None,
        noise: None,
        observables: BTreeMap::new(),
        position: vec![1.0, 0.0],
        velocity: None,
        project: false,
    };
    let system = ExpressionSystem::compile(&spec).expect("circle");
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&["x", "y"]).expect("names");
    table.add_inputs(&["v_x", "v_y"]).expect("names");
    let u = Var::slot(table.add_unnamed_inputs(2).expect("slot"), 2);
    let mut graph = Graph::new();
    let g = graph.parse("(1 - (x^2 + y^2)) / 2", &table).expect("g");
    let jacobian = graph.jacobian(&[g], &table.slot_vars(q)).expect("Dg");
    let products = graph.jacobian_vector(&jacobian, &u).expect("Dg u");
    let program = Program::compile(&graph, &products).expect("program");
    let calls = 2_000_000;
    let mut times = [Vec::new(), Vec::new()];
    for _ in 0..ROUNDS {
        for (pooled, t) in [false, true].into_iter().zip(times.iter_mut()) {
            let constraint = system.expression_constraint();
            t.push(LaneWidth::Best.dispatch(Products {
                constraint,
                program: &program,
                pooled,
                calls,
            }));
        }
    }
    for (name, t) in ["registers held by the caller", "registers from the pool"]
        .iter()
        .zip(&mut times)
    {
        t.sort_by(f64::total_cmp);
        println!(
            "registers/{name}: {:.1} ns per call of Dg u ({} ops, {} lanes)",
            t[ROUNDS / 2],
            program.op_count(),
            LaneWidth::Best.lanes()
        );
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    if !std::env::args().any(|a| a == "chain") {
        register_runs();
        pendulum_runs();
    }
    chain_runs();
}
