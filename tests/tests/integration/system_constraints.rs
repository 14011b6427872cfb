//! Every built-in system stays on the tangent bundle under the half-explicit scheme, and runs
//! with the inherent-SDE reference solvers, which agree with the scheme on the same Brownian
//! path.

use sdae_manifold::{StateResiduals, state_residuals};
use sdae_model::{Scheme, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_reference::{CurvedSystem, TruncatedEulerMaruyama};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{
    AirFlow, ChainMoleculeParams, Fiber, FiberParams, RigidTriatomicParams, chain_molecule,
    rigid_triatomic,
};

const SEED: u64 = 77;

/// Runs `steps` steps of size h from `state` and returns the largest |g| and |Dg v| seen
/// after any step, measured independently of the stepper's own report.
fn max_residuals<S>(system: S, state: (Vec<f64>, Vec<f64>), h: f64, steps: usize) -> StateResiduals
where
    S: System + Clone,
{
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let (mut r, mut v) = state;
    let mut noise = GaussianIncrements::for_path(SEED, 0, system.noise_dim());
    let mut dw = vec![0.0; system.noise_dim()];
    let (mut position, mut velocity) = (0.0_f64, 0.0_f64);
    for k in 0..steps {
        noise.next_increment(h, &mut dw);
        stepper
            .step(&mut r, &mut v, h, &dw)
            .unwrap_or_else(|e| panic!("step {k}: {e}"));
        let (residuals, _, _) = state_residuals(system.constraint(), &r, &v).unwrap();
        position = position.max(residuals.position);
        velocity = velocity.max(residuals.velocity);
    }
    assert!(r.iter().chain(&v).all(|x| x.is_finite()));
    StateResiduals { position, velocity }
}

fn assert_on_tangent_bundle(name: &str, residuals: StateResiduals) {
    let StateResiduals { position, velocity } = residuals;
    eprintln!("{name}: max |g| = {position:e}, max |Dg v| = {velocity:e}");
    assert!(position < 1e-12, "{name}: |g| = {position:e}");
    assert!(velocity < 1e-12, "{name}: |Dg v| = {velocity:e}");
}

fn shear_fiber() -> Fiber {
    Fiber::new(&FiberParams {
        air: AirFlow {
            wind: [1.0, 0.0, 0.2],
            shear: [[0.0, 0.0, 0.5], [0.0; 3], [0.0; 3]],
        },
        ..FiberParams::default()
    })
    .unwrap()
}

#[test]
fn chain_molecule_stays_on_the_tangent_bundle() {
    let system = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let state = system.initial_state();
    assert_on_tangent_bundle("chain molecule", max_residuals(system, state, 1e-3, 4000));
}

#[test]
fn rigid_triatomic_stays_on_the_tangent_bundle() {
    let system = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let state = system.initial_state();
    assert_on_tangent_bundle("rigid triatomic", max_residuals(system, state, 1e-3, 4000));
}

#[test]
fn fiber_stays_on_the_tangent_bundle() {
    let fiber = shear_fiber();
    for (name, state) in [
        ("hanging fiber", fiber.hanging()),
        ("zigzag fiber", fiber.zigzag(0.3)),
    ] {
        assert_on_tangent_bundle(name, max_residuals(fiber.clone(), state, 2e-4, 3000));
    }
}

/// Largest distance between the scheme's path and truncated Euler-Maruyama on the inherent SDE,
/// both with step h for `steps` steps, the reference driven by the Brownian path `reference_path`
/// (the scheme always by path 0).
fn distance_to_reference<S>(
    system: &S, state: &(Vec<f64>, Vec<f64>), h: f64, steps: usize, reference_path: u64,
) -> f64
where
    S: CurvedSystem + Clone,
{
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let mut reference = TruncatedEulerMaruyama::new(system.clone()).unwrap();
    let l = system.noise_dim();
    let mut noise = GaussianIncrements::for_path(SEED, 0, l);
    let mut other = GaussianIncrements::for_path(SEED, reference_path, l);
    let (mut dw, mut dw_ref) = (vec![0.0; l], vec![0.0; l]);
    let (mut r, mut v) = state.clone();
    let (mut rr, mut vr) = state.clone();
    let mut distance = 0.0_f64;
    for _ in 0..steps {
        noise.next_increment(h, &mut dw);
        other.next_increment(h, &mut dw_ref);
        let dw_ref = if reference_path == 0 { &dw } else { &dw_ref };
        stepper.step(&mut r, &mut v, h, &dw).unwrap();
        reference.step(&mut rr, &mut vr, h, dw_ref).unwrap();
        let d = r
            .iter()
            .zip(&rr)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        distance = distance.max(d);
    }
    distance
}

/// On the same Brownian path the two solvers stay close; on independent paths they do not
/// (which shows that the closeness is not a matter of the time being short).
fn assert_agrees_with_reference<S>(name: &str, system: &S, state: &(Vec<f64>, Vec<f64>), h: f64)
where
    S: CurvedSystem + Clone,
{
    let steps = (0.5 / h) as usize;
    let same = distance_to_reference(system, state, h, steps, 0);
    let independent = distance_to_reference(system, state, h, steps, 1);
    eprintln!("{name}: same path {same:e}, independent paths {independent:e}");
    assert!(
        same < 0.05 * independent,
        "{name}: {same:e} vs {independent:e}"
    );
}

#[test]
fn reference_solver_agrees_on_the_same_brownian_path() {
    let chain = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    assert_agrees_with_reference("chain molecule", &chain, &chain.initial_state(), 1e-4);
    let triatomic = rigid_triatomic(&RigidTriatomicParams {
        masses: sdae_systems::Masses::Uniform(1.0),
        ..RigidTriatomicParams::default()
    })
    .unwrap();
    assert_agrees_with_reference(
        "rigid triatomic",
        &triatomic,
        &triatomic.initial_state(),
        1e-4,
    );
    let fiber = Fiber::new(&FiberParams::default()).unwrap();
    assert_agrees_with_reference("fiber", &fiber, &fiber.zigzag(0.2), 1e-4);
}
