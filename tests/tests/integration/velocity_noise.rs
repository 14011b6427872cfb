//! Noise that depends on the velocity: the free unit rotor with B(r, v) dw = sigma v dw. Its
//! angular velocity omega = r x v obeys the Ito SDE d omega = sigma omega dW (the noise is
//! tangent and the constraint forces are normal to it), so E omega(T) = omega0 and
//! E omega(T)^2 = omega0^2 e^{sigma^2 T}; the Stratonovich solution would have
//! E omega(T) = omega0 e^{sigma^2 T / 2} and E omega(T)^2 = omega0^2 e^{2 sigma^2 T}.
//! Stochastic Heun evaluates the diffusion at the left point, so it is an Ito scheme here too
//! and belongs in studies of such systems (the fiber scenes); it and the half-explicit scheme
//! must give the Ito moments, within 4.5 standard errors of the estimators.

use sdae_manifold::{IdentityMass, Sphere};
use sdae_model::{MechanicalSystem, NoObserver, Scheme, TimeGrid, run_path};
use sdae_noise::GaussianIncrements;
use sdae_reference::StochasticHeun;
use sdae_scheme::{Stepper, StepperConfig};

const SIGMA: f64 = 0.5;
const T: f64 = 1.0;
const PATHS: u64 = 4000;
const STEPS: usize = 128;

fn no_drift(_r: &[f64], _v: &[f64], a: &mut [f64]) {
    a.fill(0.0);
}

fn along_velocity(_r: &[f64], v: &[f64], dw: &[f64], out: &mut [f64]) {
    for (o, vi) in out.iter_mut().zip(v) {
        *o += SIGMA * vi * dw[0];
    }
}

type Rotor = MechanicalSystem<
    Sphere,
    IdentityMass,
    fn(&[f64], &[f64], &mut [f64]),
    sdae_model::ClosureNoise<fn(&[f64], &[f64], &[f64], &mut [f64])>,
>;

fn rotor() -> Rotor {
    let noise =
        sdae_model::ClosureNoise::new(1, along_velocity as fn(&[f64], &[f64], &[f64], &mut [f64]));
    MechanicalSystem::new(
        Sphere::new(2, 1.0).unwrap(),
        IdentityMass,
        no_drift as fn(&[f64], &[f64], &mut [f64]),
        noise,
    )
    .unwrap()
}

/// Sample mean and standard error of the mean.
fn mean_and_error(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// omega(T) on every path, starting from r = (1, 0), v = (0, 1) (omega0 = 1).
fn final_omegas(scheme: &mut dyn Scheme<System = Rotor>, seed: u64) -> Vec<f64> {
    let grid = TimeGrid::new(T, STEPS).unwrap();
    (0..PATHS)
        .map(|i| {
            let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
            let mut noise = GaussianIncrements::for_path(seed, i, 1);
            run_path(scheme, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap();
            (r[0] * v[1] - r[1] * v[0]) / (r[0] * r[0] + r[1] * r[1])
        })
        .collect()
}

fn assert_ito_moments(name: &str, omegas: &[f64]) {
    let (m1, e1) = mean_and_error(omegas);
    let squares: Vec<f64> = omegas.iter().map(|w| w * w).collect();
    let (m2, e2) = mean_and_error(&squares);
    let ito = (1.0, (SIGMA * SIGMA * T).exp());
    let stratonovich = (
        (SIGMA * SIGMA * T / 2.0).exp(),
        (2.0 * SIGMA * SIGMA * T).exp(),
    );
    println!("{name}: E omega {m1:.4} +- {e1:.4}, E omega^2 {m2:.4} +- {e2:.4}");
    assert!(
        (m1 - ito.0).abs() < 4.5 * e1,
        "{name}: E omega = {m1} +- {e1}, Ito {}",
        ito.0
    );
    assert!(
        (m2 - ito.1).abs() < 4.5 * e2,
        "{name}: E omega^2 = {m2} +- {e2}, Ito {}",
        ito.1
    );
    // The test tells the two calculi apart.
    assert!((m1 - stratonovich.0).abs() > 4.5 * e1 && (m2 - stratonovich.1).abs() > 4.5 * e2);
}

#[test]
fn stochastic_heun_gives_the_ito_solution_when_the_noise_depends_on_v() {
    let mut heun = StochasticHeun::new(rotor()).unwrap();
    assert_ito_moments("stochastic Heun", &final_omegas(&mut heun, 31));
}

#[test]
fn the_half_explicit_scheme_agrees() {
    let system = rotor();
    let config = StepperConfig::new(10.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    assert_ito_moments("half-explicit", &final_omegas(&mut stepper, 32));
}
