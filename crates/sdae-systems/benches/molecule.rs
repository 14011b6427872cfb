//! Speed of the half-explicit scheme on the chain molecule of seed Section 5.2 (the defaults:
//! 8 atoms, 7 rigid bonds, bond angles and threefold torsions, Langevin friction and noise at
//! kT = 1), per path-step, random numbers included:
//!
//! - `molecule_step`: one path, the scalar stepper (24 Gaussian numbers per step);
//! - `molecule_ensemble`: [`PATHS`] paths stepped together by the ensemble engine
//!   (`sdae_scheme::Ensemble`, W paths in SIMD lanes), the forces from the molecule's lane forms
//!   (the sines and arc tangents of the angle and torsion terms lane by lane);
//! - `molecule_ensemble_path_by_path`: the same with the forces evaluated path by path inside
//!   the lanes (a system without lane forms, as a user's system is), for comparison.
//!
//! Every path restarts from the zigzag at rest every 1000 steps. Run with
//! `cargo bench -p sdae-systems --bench molecule`, or `cargo xtask bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sdae_model::{GaussianIncrements, IncrementSource, Scheme, System};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{ChainMolecule, ChainMoleculeParams, chain_molecule};

mod common;
use common::{EnsembleBench, PathByPath};

/// Paths of the ensembles.
const PATHS: usize = 64;

/// Step size (reduced units: the fastest bond-angle vibration has a period of about 1).
const H: f64 = 1e-3;

fn molecule() -> (ChainMolecule, StepperConfig) {
    let molecule = chain_molecule(&ChainMoleculeParams::default()).expect("molecule parameters");
    let config = StepperConfig::for_system(&molecule)
        .and_then(|c| c.with_c_eta(1.0))
        .and_then(|c| c.with_c_kappa(f64::INFINITY))
        .expect("stepper config");
    (molecule, config)
}

fn bench_step(c: &mut Criterion) {
    let (molecule, config) = molecule();
    let (r0, v0) = molecule.initial_state();
    let mut noise = GaussianIncrements::for_path(2025, 0, molecule.noise_dim());
    let mut dw = vec![0.0; molecule.noise_dim()];
    let mut stepper = Stepper::new(molecule, config).expect("stepper");
    let (mut r, mut v) = (r0.clone(), v0.clone());
    let mut steps = 0u64;
    c.bench_function("molecule_step", |b| {
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

fn bench_ensemble<S: System>(c: &mut Criterion, name: &str, system: impl Fn(ChainMolecule) -> S) {
    let (molecule, config) = molecule();
    let state = molecule.initial_state();
    let mut bench = EnsembleBench::new(system(molecule), config, PATHS, state, H);
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(PATHS as u64));
    group.bench_function("default", |b| b.iter(|| black_box(bench.step())));
    group.finish();
    bench.report(name);
}

fn bench_molecule_ensemble(c: &mut Criterion) {
    bench_ensemble(c, "molecule_ensemble", |molecule| molecule);
    bench_ensemble(c, "molecule_ensemble_path_by_path", PathByPath);
}

criterion_group!(benches, bench_step, bench_molecule_ensemble);
criterion_main!(benches);
