//! The ensemble engine's Newton lanes on bead chains (the chain molecule, the fiber, a chain
//! under gravity) and on rigid bonds (the rigid triatomic, a tetrahedron under gravity): each
//! lane's step is the scalar stepper's, bit for bit (state, mu, diagnostics, and the failure
//! of a path that stops), at W = 1, 4 and 8, with the drift and noise of a system without lane
//! forms evaluated path by path and those of one with lane forms in lanes.

use crate::common::lane_configs;
use sdae_lanes::{LaneWidth, Real};
use sdae_manifold::{
    BeadChain, Constraint, DiagonalMass, IdentityMass, Mass, RigidBonds, TheoryBound,
};
use sdae_model::{
    AdditiveNoise, Drift, MechanicalSystem, PathEnsemble, PathState, Scheme, StepFailure, System,
};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};
use sdae_systems::{
    ChainMoleculeParams, Fiber, FiberParams, RigidTriatomicParams, chain_molecule, rigid_triatomic,
};

const PATHS: usize = 11;
const STEPS: usize = 150;

/// The last path's alternating bead speed ([`start`]).
const KICK: f64 = 60.0;

/// Gravity (0, 0, -1) on every bead, with a lane form of any size.
#[derive(Debug, Clone, Copy)]
struct Gravity;

impl Drift for Gravity {
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (k, o) in out.iter_mut().enumerate() {
            *o = v[0].splat_like(if k % 3 == 2 { -1.0 } else { 0.0 });
        }
        true
    }
}

/// Gravity as a closure: no lane form, evaluated path by path.
fn closure_gravity(_r: &[f64], _v: &[f64], out: &mut [f64]) {
    Gravity.drift(_r, _v, out);
}

/// Each path's final (r, v, mu) as bits, its diagnostics' counts and its failure.
#[derive(Debug, PartialEq)]
struct Outcome {
    bits: Vec<u64>,
    steps: usize,
    newton_iterations: usize,
    truncated: usize,
    contraction: u64,
    clock_lag: u64,
    failure: Option<StepFailure>,
}

/// The paths' initial velocities: v0 plus the rigid translation (0, 0.2 p, 0.1 p) per bead;
/// the last path's beads also move up and down in turn at speed [`KICK`], so fast that an
/// untruncated step's Newton iteration for kappa fails.
fn start(v0: &[f64], p: usize) -> Vec<f64> {
    let mut v = v0.to_vec();
    for (j, bead) in v.chunks_exact_mut(3).enumerate() {
        bead[1] += 0.2 * p as f64;
        bead[2] += 0.1 * p as f64;
        if p == PATHS - 1 {
            bead[2] += if j % 2 == 0 { KICK } else { -KICK };
        }
    }
    v
}

/// Path p's increment of step k, the same for the ensemble and the scalar stepper.
fn increments(l: usize, h: f64) -> Vec<Vec<f64>> {
    let mut sources: Vec<_> = (0..PATHS)
        .map(|p| GaussianIncrements::for_path(5, p as u64, l))
        .collect();
    let mut all = vec![vec![0.0; l * PATHS]; STEPS];
    for step in &mut all {
        for (p, source) in sources.iter_mut().enumerate() {
            source.next_increment(h, &mut step[p * l..(p + 1) * l]);
        }
    }
    all
}

/// The first `paths` paths in an ensemble of that many.
fn run_ensemble<S: System>(
    stepper: &Stepper<S>, width: LaneWidth, paths: usize, r0: &[f64], v0: &[f64], h: f64,
) -> (Vec<Outcome>, usize)
where
    Stepper<S>: Clone,
{
    let mut ensemble = Ensemble::new(stepper.clone(), paths, r0, v0)
        .unwrap()
        .with_width(width);
    for p in 0..paths {
        ensemble.set_state(p, r0, &start(v0, p)).unwrap();
    }
    let (n, l, stride) = (r0.len(), stepper.system().noise_dim(), ensemble.stride());
    let mut dw = vec![0.0; l * stride];
    for step in increments(l, h) {
        for p in 0..paths {
            for j in 0..l {
                dw[j * stride + p] = step[p * l + j];
            }
        }
        ensemble.step(h, &dw).unwrap();
    }
    let m = stepper.system().constraint().n_constraints();
    let outcomes = (0..paths)
        .map(|p| {
            let (mut r, mut v, mut mu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
            ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
            let d = ensemble.diagnostics(p).unwrap();
            Outcome {
                bits: r.iter().chain(&v).chain(&mu).map(|x| x.to_bits()).collect(),
                steps: d.steps,
                newton_iterations: d.newton_iterations,
                truncated: d.truncated_steps,
                contraction: d.max_contraction.to_bits(),
                clock_lag: d.clock_lag.to_bits(),
                failure: ensemble.failure(p).unwrap().cloned(),
            }
        })
        .collect();
    (outcomes, ensemble.scalar_steps())
}

/// The first `paths` paths, each through the scalar stepper.
fn run_scalar<S: System>(
    stepper: &Stepper<S>, paths: usize, r0: &[f64], v0: &[f64], h: f64,
) -> Vec<Outcome>
where
    Stepper<S>: Clone,
{
    let l = stepper.system().noise_dim();
    let m = stepper.system().constraint().n_constraints();
    let all = increments(l, h);
    (0..paths)
        .map(|p| {
            let mut scheme = stepper.clone();
            let (mut r, mut v) = (r0.to_vec(), start(v0, p));
            let mut path = PathState::new(m, true, false);
            let mut failure = None;
            for step in &all {
                if let Err(e) = path.step(&mut scheme, &mut r, &mut v, h, &step[p * l..(p + 1) * l])
                {
                    failure = Some(e);
                    break;
                }
            }
            let d = path.diagnostics;
            Outcome {
                bits: r
                    .iter()
                    .chain(&v)
                    .chain(&path.mu)
                    .map(|x| x.to_bits())
                    .collect(),
                steps: d.steps,
                newton_iterations: d.newton_iterations,
                truncated: d.truncated_steps,
                contraction: d.max_contraction.to_bits(),
                clock_lag: d.clock_lag.to_bits(),
                failure,
            }
        })
        .collect()
}

/// Every width against the scalar stepper; returns (truncated steps, failed paths, steps the
/// lanes left to the scalar stepper) of the widest.
fn check<S: System>(
    what: &str, stepper: &Stepper<S>, state: (&[f64], &[f64]), h: f64,
) -> (usize, usize, usize)
where
    Stepper<S>: Clone,
{
    let (r0, v0) = state;
    let scalar = run_scalar(stepper, PATHS, r0, v0, h);
    let mut summary = (0, 0, 0);
    for width in LaneWidth::ALL {
        let (lanes, scalar_steps) = run_ensemble(stepper, width, PATHS, r0, v0, h);
        for (p, (a, b)) in scalar.iter().zip(&lanes).enumerate() {
            assert_eq!(a, b, "{what}, {width:?}, path {p}");
        }
        summary = (
            lanes.iter().map(|o| o.truncated).sum(),
            lanes.iter().filter(|o| o.failure.is_some()).count(),
            scalar_steps,
        );
    }
    summary
}

/// The lane tests' four ([`lane_configs`]), a finite ball with the practical C_eta, and no
/// truncation.
fn configs<S: System>(system: &S) -> Vec<(&'static str, StepperConfig)>
where
    S::Constraint: sdae_manifold::TheoryBound,
{
    let mut configs = lane_configs(system);
    let practical = configs[0].1;
    configs.push(("finite ball", practical.with_c_kappa(0.05).unwrap()));
    configs.push(("untruncated", practical.untruncated()));
    configs
}

/// Every configuration of a system under [`Gravity`] with additive noise, with its lane form
/// and as a closure, against the scalar stepper. The practical configuration truncates, loses
/// no path and leaves fewer than 1% of the path-steps to the scalar stepper. Returns the paths
/// the untruncated configuration loses.
fn check_under_gravity<C, M>(constraint: C, mass: M, r0: &[f64], h: f64) -> usize
where
    C: TheoryBound + Clone,
    M: Mass + Clone,
{
    let v0 = vec![0.0; r0.len()];
    let noise = AdditiveNoise::new(0.3, r0.len()).unwrap();
    let lanes = MechanicalSystem::new(constraint.clone(), mass.clone(), Gravity, noise).unwrap();
    let closure = MechanicalSystem::new(constraint, mass, closure_gravity, noise).unwrap();
    let mut untruncated_failures = 0;
    for (name, config) in configs(&lanes) {
        let (truncated, failed, scalar_steps) = check(
            name,
            &Stepper::new(lanes.clone(), config).unwrap(),
            (r0, &v0),
            h,
        );
        if name == "practical" {
            assert!(truncated > 0, "eta < 1 untested");
            assert_eq!(failed, 0);
            assert!(scalar_steps < PATHS * STEPS / 100, "{scalar_steps}");
        }
        if name == "untruncated" {
            untruncated_failures = failed;
        }
        check(
            name,
            &Stepper::new(closure.clone(), config).unwrap(),
            (r0, &v0),
            h,
        );
    }
    untruncated_failures
}

#[test]
fn a_gravity_chain_steps_in_lanes_with_the_scalar_numbers() {
    let chain = BeadChain::new(12, 1.0 / 11.0).unwrap();
    let failed = check_under_gravity(chain, IdentityMass, &chain.zigzag(0.3), 2e-3);
    // The kicked path stops with the scalar failure; the others go on in lanes.
    assert_eq!(failed, 1, "the kicked path");
}

#[test]
fn the_chain_molecule_and_the_fiber_step_in_lanes_with_the_scalar_numbers() {
    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let (r0, v0) = molecule.initial_state();
    for (name, config) in configs(&molecule) {
        let stepper = Stepper::new(molecule.clone(), config).unwrap();
        let (_, _, scalar_steps) = check(name, &stepper, (&r0, &v0), 5e-3);
        if name == "practical" {
            assert!(scalar_steps < PATHS * STEPS / 100, "{scalar_steps}");
        }
    }
    let params = FiberParams::default();
    let fiber = Fiber::new(&params).unwrap();
    let r0 = BeadChain::new(params.beads, params.segment)
        .unwrap()
        .zigzag(0.2);
    let v0 = vec![0.0; r0.len()];
    for (name, config) in configs(&fiber) {
        let stepper = Stepper::new(fiber.clone(), config).unwrap();
        check(name, &stepper, (&r0, &v0), 1e-3);
    }
}

#[test]
fn the_rigid_triatomic_steps_in_lanes_with_the_scalar_numbers() {
    let molecule = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let (r0, v0) = molecule.initial_state();
    for (name, config) in configs(&molecule) {
        let stepper = Stepper::new(molecule.clone(), config).unwrap();
        let (truncated, failed, scalar_steps) = check(name, &stepper, (&r0, &v0), 5e-3);
        if name == "practical" {
            assert!(truncated > 0, "eta < 1 untested");
            assert_eq!(failed, 0);
            assert!(scalar_steps < PATHS * STEPS / 100, "{scalar_steps}");
        }
    }
}

#[test]
fn a_tetrahedron_under_gravity_steps_in_lanes_with_the_scalar_numbers() {
    // Six bonds of different lengths between four atoms of different masses: a 6 x 6 dense
    // Newton matrix.
    let r0: Vec<f64> = vec![0.0, 0.0, 0.0, 1.1, 0.0, 0.0, 0.3, 0.9, 0.0, 0.4, 0.3, 0.8];
    let pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    let bonds: Vec<(usize, usize, f64)> = pairs
        .iter()
        .map(|&(i, j)| {
            let d2: f64 = (0..3)
                .map(|c| (r0[3 * j + c] - r0[3 * i + c]).powi(2))
                .sum();
            (i, j, d2.sqrt())
        })
        .collect();
    let tetrahedron = RigidBonds::new(4, &bonds).unwrap();
    let mass = DiagonalMass::per_particle(&[1.0, 2.0, 0.5, 1.5], 3).unwrap();
    check_under_gravity(tetrahedron, mass, &r0, 2e-3);
}

#[test]
fn one_group_of_paths_reads_its_increments_where_they_lie() {
    // Eight paths at W = 8: the increments' rows are read where they lie, without a copy.
    // Four lanes from the same rows copy them (two groups). Both give the scalar numbers.
    let chain = BeadChain::new(12, 1.0 / 11.0).unwrap();
    let r0 = chain.zigzag(0.3);
    let v0 = vec![0.0; r0.len()];
    let noise = AdditiveNoise::new(0.3, r0.len()).unwrap();
    let system = MechanicalSystem::new(chain, IdentityMass, Gravity, noise).unwrap();
    let stepper = Stepper::new(system.clone(), lane_configs(&system)[0].1).unwrap();
    let paths = 8;
    let scalar = run_scalar(&stepper, paths, &r0, &v0, 2e-3);
    for width in [LaneWidth::Eight, LaneWidth::Four, LaneWidth::Best] {
        let (lanes, _) = run_ensemble(&stepper, width, paths, &r0, &v0, 2e-3);
        assert_eq!(lanes.len(), paths);
        for (p, (a, b)) in scalar.iter().zip(&lanes).enumerate() {
            assert_eq!(a, b, "{width:?}, path {p}");
        }
    }
}
