//! Speed of systems written as expressions (`sdae_expr_system::ExpressionSystem`: tapes
//! interpreted over lanes) against the same built-in systems, per path-step in SIMD lanes,
//! random numbers included:
//!
//! - `expr_system_pendulum`: the seed's pendulum (`built_in`: `sdae_systems::pendulum`)
//!   against the same system as expressions (`expressions`: one equation, the scalar Gram
//!   storage, the kappa root in closed form), [`PENDULUM_PATHS`] paths;
//! - `expr_system_chain`: the 10-atom chain molecule with its bond-angle potential (torsion
//!   off) against the same as expressions with the tridiagonal Gram storage the bonds' pattern
//!   allows (`ExpressionSystem::visit_shape`), [`CHAIN_PATHS`] paths;
//! - `expr_system_call`: one evaluation of Dg(x) u of the pendulum's constraint over lanes,
//!   through the constraint (`constraint`: registers found by the system) and through the
//!   compiled program with registers held by the caller (`program`: the interpretation alone).
//!
//! The expression constraints take their composite forms (g with the Gram matrix, the kappa
//! coefficients) as one compiled program each, for the unit mass here.
//!
//! The half-explicit stepper with the practical C_eta = 1 steps every path; each group's
//! systems step the same Brownian paths, and every path restarts from its initial state every
//! 1000 steps. The throughput is in paths, so criterion's "elem/s" is path-steps per second.
//! Run with `cargo bench -p sdae-bench --bench expr_system`, or `cargo xtask bench`.

use std::collections::BTreeMap;
use std::hint::black_box;
use std::time::Duration;

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use pulp::{Simd, WithSimd};
use sdae_expr::{Graph, Program, SymbolTable, Var};
use sdae_expr_system::{
    ExpressionConstraint, ExpressionSpec, ExpressionSystem, MassSpec, NoiseSpec, ShapeVisitor,
};
use sdae_lanes::{LaneWidth, Lanes};
use sdae_manifold::{Equations, GramShape, Scalar};
use sdae_model::System;
use sdae_scheme::StepperConfig;
use sdae_systems::{AngleParams, ChainMoleculeParams, Masses, PendulumParams};
use sdae_systems::{chain_molecule, pendulum};

// The systems here evaluate their own drift and noise in lanes: `PathByPath` is not needed.
#[allow(dead_code)]
mod common;
use common::EnsembleBench;

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Paths of the pendulum's ensembles.
const PENDULUM_PATHS: usize = 512;

/// Paths of the chain's ensembles.
const CHAIN_PATHS: usize = 64;

/// Atoms of the chain.
const ATOMS: usize = 10;

/// Step size.
const H: f64 = 1e-3;

/// The pendulum's constraint, as text.
const CIRCLE: &str = "(1 - (x1^2 + y1^2)) / 2";

/// A group of few samples, as the other ensemble benches keep the run short.
fn group<'a>(c: &'a mut Criterion, name: &str, paths: usize) -> BenchmarkGroup<'a, WallTime> {
    let mut group = c.benchmark_group(name);
    group
        .sample_size(20)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(paths as u64));
    group
}

/// Steps `system` in `group` as benchmark `id`.
fn bench_system<S: System>(
    group: &mut BenchmarkGroup<'_, WallTime>, id: &str, system: S, config: StepperConfig,
    paths: usize, state: (Vec<f64>, Vec<f64>),
) {
    let mut bench = EnsembleBench::new(system, config, paths, state, H);
    group.bench_function(id, |b| b.iter(|| black_box(bench.step())));
    bench.report(&format!("{id} of {paths} paths"));
}

/// A spec of `particles` particles in `dimension` dimensions of unit mass at rest at
/// `position`, with `constraints`, the potential and parameters, no noise.
fn spec(
    particles: usize, dimension: usize, constraints: Vec<String>, potential: String,
    parameters: &[(&str, f64)], position: Vec<f64>,
) -> ExpressionSpec {
    ExpressionSpec {
        coordinates: None,
        particles: Some(particles),
        dimension: Some(dimension),
        mass: MassSpec::One(1.0),
        parameters: parameters.iter().map(|&(k, v)| (k.into(), v)).collect(),
        constraints,
        potential: Some(potential),
        forces: None,
        friction: None,
        kt: None,
        noise: None,
        observables: BTreeMap::new(),
        position,
        velocity: None,
        project: false,
    }
}

fn bench_pendulum(c: &mut Criterion) {
    let params = PendulumParams::default();
    let built_in = pendulum(params).expect("pendulum");
    let config = StepperConfig::for_system(&built_in)
        .and_then(|c| c.with_c_eta(1.0))
        .expect("config");
    let mut written = spec(
        1,
        2,
        vec![CIRCLE.into()],
        "c * y1".into(),
        &[("c", params.gravity)],
        vec![1.0, 0.0],
    );
    written.noise = Some(NoiseSpec::Intensity(params.noise));
    written.velocity = Some(vec![0.0, 1.0]);
    let expressions = ExpressionSystem::compile(&written)
        .expect("expression pendulum")
        .with_shape::<Scalar>()
        .expect("one equation");
    let state = || (vec![1.0, 0.0], vec![0.0, 1.0]);
    let mut group = group(c, "expr_system_pendulum", PENDULUM_PATHS);
    bench_system(
        &mut group,
        "built_in",
        built_in,
        config,
        PENDULUM_PATHS,
        state(),
    );
    bench_system(
        &mut group,
        "expressions",
        expressions,
        config,
        PENDULUM_PATHS,
        state(),
    );
    group.finish();
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

/// Steps the expression chain with the Gram structure its pattern allows.
struct ChainVisitor<'g, 'c> {
    group: &'g mut BenchmarkGroup<'c, WallTime>,
    config: StepperConfig,
    state: (Vec<f64>, Vec<f64>),
}

impl ShapeVisitor for ChainVisitor<'_, '_> {
    type Output = ();
    fn visit<Sh: GramShape>(self, system: ExpressionSystem<Sh>) {
        assert_eq!(Sh::STRUCTURE, sdae_manifold::GramStructure::Tridiagonal);
        let (config, state) = (self.config, self.state);
        bench_system(
            self.group,
            "expressions",
            system,
            config,
            CHAIN_PATHS,
            state,
        );
    }
}

fn bench_chain(c: &mut Criterion) {
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
    // C_eta = 1 without the ball's radius, as the molecule benches.
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
    let mut written = spec(
        ATOMS,
        3,
        (1..ATOMS).map(bond).collect(),
        potential.join(" + "),
        &[("k", angle.stiffness), ("theta0", angle.equilibrium)],
        r0.clone(),
    );
    (written.friction, written.kt) = (Some(1.0), Some(1.0));
    let expressions = ExpressionSystem::compile(&written).expect("expression chain");
    let state = || (r0.clone(), vec![0.0; 3 * ATOMS]);
    let mut group = group(c, "expr_system_chain", CHAIN_PATHS);
    bench_system(
        &mut group,
        "built_in",
        built_in,
        config,
        CHAIN_PATHS,
        state(),
    );
    let visitor = ChainVisitor {
        group: &mut group,
        config,
        state: state(),
    };
    expressions.visit_shape(visitor);
    group.finish();
}

/// Evaluations of Dg(x) u over lanes: through the constraint, or the program with registers
/// held here.
struct Products<'a> {
    constraint: &'a ExpressionConstraint<Scalar>,
    program: &'a Program,
    through_constraint: bool,
    calls: u64,
}

impl WithSimd for Products<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let x = [Lanes::splat(simd, 0.6), Lanes::splat(simd, -0.8)];
        let u = [Lanes::splat(simd, 0.3), Lanes::splat(simd, 0.1)];
        let mut out = [Lanes::splat(simd, 0.0)];
        let mut registers = Vec::new();
        for _ in 0..self.calls {
            let x = black_box(&x);
            if self.through_constraint {
                Equations::jacobian_mul(self.constraint, &x[..], &u, &mut out);
            } else {
                self.program
                    .eval(&[&x[..], &[], &u[..]], &mut out, &mut registers);
            }
            black_box(&mut out);
        }
    }
}

fn bench_call(c: &mut Criterion) {
    let mut written = spec(1, 2, vec![CIRCLE.into()], "0".into(), &[], vec![1.0, 0.0]);
    written.potential = None;
    let system = ExpressionSystem::compile(&written)
        .expect("circle")
        .with_shape::<Scalar>()
        .expect("one equation");
    // The same Dg u compiled here, its inputs in the system's slots (q, v, u).
    let mut table = SymbolTable::new();
    let q = table.add_inputs(&["x1", "y1"]).expect("names");
    table.add_inputs(&["v_x1", "v_y1"]).expect("names");
    let u = Var::slot(table.add_unnamed_inputs(2).expect("slot"), 2);
    let mut graph = Graph::new();
    let g = graph.parse(CIRCLE, &table).expect("g");
    let jacobian = graph.jacobian(&[g], &table.slot_vars(q)).expect("Dg");
    let products = graph.jacobian_vector(&jacobian, &u).expect("Dg u");
    let program = Program::compile(&graph, &products).expect("program");
    let mut group = c.benchmark_group("expr_system_call");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(2));
    for (id, through_constraint) in [("constraint", true), ("program", false)] {
        group.bench_function(id, |b| {
            b.iter_custom(|calls| {
                let start = std::time::Instant::now();
                LaneWidth::Best.dispatch(Products {
                    constraint: system.expression_constraint(),
                    program: &program,
                    through_constraint,
                    calls,
                });
                start.elapsed()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_pendulum, bench_chain, bench_call);
criterion_main!(benches);
