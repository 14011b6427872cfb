//! Speed of the half-explicit scheme on the Langevin molecules of seed Section 5.2, per
//! path-step, random numbers included:
//!
//! - the chain molecule (the defaults: 8 atoms, 7 rigid bonds, bond angles and threefold
//!   torsions, Langevin friction and noise at kT = 1; a bead chain, tridiagonal Newton matrix);
//! - the rigid triatomic (the defaults: a water-like triangle of 3 atoms and 3 rigid bonds in a
//!   harmonic trap; rigid bonds, dense 3 x 3 Newton matrix).
//!
//! For each, `<molecule>_step`: one path, the scalar stepper; `<molecule>_ensemble`: [`PATHS`]
//! paths stepped together by the ensemble engine (`sdae_scheme::Ensemble`, W paths in SIMD
//! lanes), the forces from the molecule's lane forms (the chain molecule's sines and arc
//! tangents of the angle and torsion terms lane by lane); `<molecule>_ensemble_path_by_path`:
//! the same with the forces evaluated path by path inside the lanes (a system without lane
//! forms, as a user's system is), for comparison.
//!
//! Every path restarts from its initial state every 1000 steps. Run with
//! `cargo bench -p sdae-bench --bench molecule`, or `cargo xtask bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sdae_manifold::TheoryBound;
use sdae_model::{Scheme, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{
    ChainMolecule, ChainMoleculeParams, RigidTriatomic, RigidTriatomicParams, chain_molecule,
    rigid_triatomic,
};

mod common;
use common::{EnsembleBench, PathByPath};

/// Lane buffers start on cache lines, as in the command line and the Python package.
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

/// Paths of the ensembles.
const PATHS: usize = 64;

/// Step size (reduced units: the fastest bond-angle vibration has a period of about 1).
const H: f64 = 1e-3;

/// A molecule of the benchmarks: its name, its initial state and the stepper's settings (the
/// practical C_eta = 1, no ball).
trait Molecule: System<Constraint: TheoryBound> + Clone {
    const NAME: &'static str;
    fn build() -> Self;
    fn initial_state(&self) -> (Vec<f64>, Vec<f64>);
    fn config(&self) -> StepperConfig {
        StepperConfig::for_system(self)
            .and_then(|c| c.with_c_eta(1.0))
            .and_then(|c| c.with_c_kappa(f64::INFINITY))
            .expect("stepper config")
    }
}

impl Molecule for ChainMolecule {
    const NAME: &'static str = "molecule";
    fn build() -> Self {
        chain_molecule(&ChainMoleculeParams::default()).expect("molecule parameters")
    }
    fn initial_state(&self) -> (Vec<f64>, Vec<f64>) {
        ChainMolecule::initial_state(self)
    }
}

impl Molecule for RigidTriatomic {
    const NAME: &'static str = "triatomic";
    fn build() -> Self {
        rigid_triatomic(&RigidTriatomicParams::default()).expect("triatomic parameters")
    }
    fn initial_state(&self) -> (Vec<f64>, Vec<f64>) {
        RigidTriatomic::initial_state(self)
    }
}

fn bench_step<M: Molecule>(c: &mut Criterion) {
    let molecule = M::build();
    let config = molecule.config();
    let (r0, v0) = molecule.initial_state();
    let mut noise = GaussianIncrements::for_path(2025, 0, molecule.noise_dim());
    let mut dw = vec![0.0; molecule.noise_dim()];
    let mut stepper = Stepper::new(molecule, config).expect("stepper");
    let (mut r, mut v) = (r0.clone(), v0.clone());
    let mut steps = 0u64;
    c.bench_function(&format!("{}_step", M::NAME), |b| {
        b.iter(|| {
            if steps.is_multiple_of(1000) {
                r.copy_from_slice(&r0);
                v.copy_from_slice(&v0);
            }
            steps += 1;
            noise.next_increment(H, &mut dw);
            match stepper.step(&mut r, &mut v, H, &dw) {
                Ok(report) => black_box(report.newton_iterations),
                Err(e) => panic!("step {steps} failed: {e}"),
            }
        })
    });
}

fn bench_ensemble<M: Molecule, S: System>(c: &mut Criterion, name: &str, system: impl Fn(M) -> S) {
    let molecule = M::build();
    let config = molecule.config();
    let state = molecule.initial_state();
    let mut bench = EnsembleBench::new(system(molecule), config, PATHS, state, H);
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(PATHS as u64));
    group.bench_function("default", |b| b.iter(|| black_box(bench.step())));
    group.finish();
    bench.report(name);
}

fn bench_molecule<M: Molecule>(c: &mut Criterion) {
    bench_step::<M>(c);
    bench_ensemble(c, &format!("{}_ensemble", M::NAME), |molecule: M| molecule);
    bench_ensemble(
        c,
        &format!("{}_ensemble_path_by_path", M::NAME),
        PathByPath::<M>,
    );
}

fn bench_molecules(c: &mut Criterion) {
    bench_molecule::<ChainMolecule>(c);
    bench_molecule::<RigidTriatomic>(c);
}

criterion_group!(benches, bench_molecules);
criterion_main!(benches);
