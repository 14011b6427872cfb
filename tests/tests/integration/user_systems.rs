//! Systems assembled by a user: a constraint from closures, dense and diagonal masses, the
//! spherical pendulum, and the projection of an initial state.

use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use sdae_manifold::{
    ClosureConstraint, Constraint, DenseMass, DiagonalMass, IdentityMass, Mass, Sphere, check_state,
};
use sdae_model::{AdditiveNoise, MechanicalSystem, Scheme, project_state};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

fn gravity(_r: &[f64], _v: &[f64], a: &mut [f64]) {
    a.fill(0.0);
    a[1] = -1.0;
}

/// The unit circle written by hand: g = (1 - |x|^2)/2.
fn circle_from_closures() -> impl Constraint<Gram = sdae_manifold::DenseGram> + Clone {
    ClosureConstraint::new(
        2,
        1,
        |x: &[f64], g: &mut [f64]| g[0] = 0.5 * (1.0 - x[0] * x[0] - x[1] * x[1]),
        |x: &[f64], u: &[f64], out: &mut [f64]| out[0] = -(x[0] * u[0] + x[1] * u[1]),
        |x: &[f64], z: &[f64], out: &mut [f64]| {
            out[0] = -x[0] * z[0];
            out[1] = -x[1] * z[0];
        },
    )
    .unwrap()
}

fn run<C, M>(constraint: C, mass: M, steps: usize) -> (Vec<f64>, Vec<f64>)
where
    C: Constraint,
    M: Mass,
{
    let system = MechanicalSystem::new(
        constraint,
        mass,
        gravity,
        AdditiveNoise::new(0.5, 2).unwrap(),
    )
    .unwrap();
    let mut stepper = Stepper::new(system, StepperConfig::new(1.0, 0.5).unwrap()).unwrap();
    let (mut r, mut v) = (vec![0.6, -0.8], vec![0.8, 0.6]);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    for _ in 0..steps {
        let dw = [rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5].map(|x| 0.1 * x);
        stepper.step(&mut r, &mut v, 0.01, &dw).unwrap();
    }
    (r, v)
}

fn assert_close(a: &[f64], b: &[f64], tol: f64) {
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{a:?} vs {b:?}");
    }
}

#[test]
fn closure_constraint_and_dense_mass_reproduce_the_built_in_circle() {
    let (r_ref, v_ref) = run(Sphere::unit_circle(), IdentityMass, 500);
    let (r, v) = run(circle_from_closures(), IdentityMass, 500);
    assert_close(&r, &r_ref, 1e-12);
    assert_close(&v, &v_ref, 1e-12);
    let dense_identity = DenseMass::new(2, vec![1.0, 0.0, 0.0, 1.0]).unwrap();
    let (r, v) = run(circle_from_closures(), dense_identity, 500);
    assert_close(&r, &r_ref, 1e-12);
    assert_close(&v, &v_ref, 1e-12);
}

#[test]
fn diagonal_and_dense_masses_agree() {
    let diagonal = DiagonalMass::new(vec![2.0, 3.0]).unwrap();
    let dense = DenseMass::new(2, vec![2.0, 0.0, 0.0, 3.0]).unwrap();
    let (r1, v1) = run(Sphere::unit_circle(), diagonal, 300);
    let (r2, v2) = run(circle_from_closures(), dense, 300);
    assert_close(&r1, &r2, 1e-12);
    assert_close(&v1, &v2, 1e-12);
    check_state(&Sphere::unit_circle(), &r1, &v1, 1e-12).unwrap();
}

#[test]
fn spherical_pendulum_step_matches_the_closed_form() {
    // In R^3 as in R^2: for v tangent, r' = (1 - kappa) r + h v, kappa = 1 - sqrt(1 - h^2 |v|^2).
    let system = pendulum(PendulumParams {
        dim: 3,
        gravity: 0.0,
        noise: 0.0,
        ..PendulumParams::default()
    })
    .unwrap();
    let mut stepper = Stepper::new(system, StepperConfig::new(1.0, 1.0).unwrap()).unwrap();
    let r0 = [0.0, 0.6, 0.8];
    let v0 = [1.5, 0.8, -0.6];
    let h = 0.2;
    let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
    stepper.step(&mut r, &mut v, h, &[]).unwrap();
    let speed2: f64 = v0.iter().map(|x| x * x).sum();
    let kappa = 1.0 - (1.0 - h * h * speed2).sqrt();
    assert!((stepper.kappa()[0] - kappa).abs() < 1e-14);
    let expected: Vec<f64> = (0..3).map(|i| (1.0 - kappa) * r0[i] + h * v0[i]).collect();
    assert_close(&r, &expected, 1e-14);
    check_state(&Sphere::new(3, 1.0).unwrap(), &r, &v, 1e-13).unwrap();
}

#[test]
fn projection_puts_a_perturbed_state_on_the_tangent_bundle() {
    let chain = sdae_manifold::BeadChain::new(8, 0.5).unwrap();
    let mass = DiagonalMass::per_particle(&[1.0, 2.0, 1.0, 3.0, 1.0, 2.0, 1.0, 1.5], 3).unwrap();
    let mut r = chain.zigzag(0.7);
    let mut v: Vec<f64> = (0..24).map(|k| (k as f64 * 0.3).sin()).collect();
    for (k, x) in r.iter_mut().enumerate() {
        *x += 1e-3 * (k as f64).cos();
    }
    assert!(check_state(&chain, &r, &v, 1e-6).is_err());
    let moved = project_state(&chain, &mass, &mut r, &mut v).unwrap();
    assert!(moved > 0.0 && moved < 1e-2, "{moved}");
    check_state(&chain, &r, &v, 1e-12).unwrap();
}
