//! Each scene computes only what it asks for: a system without noise draws no random numbers,
//! mu is accumulated only when an output needs it, and D^2 g is evaluated only by the solvers of
//! the inherent SDE, never by the half-explicit scheme.

use std::cell::Cell;
use std::convert::Infallible;

use rand_core::TryRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::SeedableRng;
use sdae_manifold::{Constraint, Curvature, Mass, ScalarGram, Sphere};
use sdae_model::{MechanicalSystem, NoObserver, Recorder, Scheme, System, TimeGrid, run_path};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_reference::EulerMaruyama;
use sdae_scheme::{Stepper, StepperConfig};
use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;
use sdae_systems::{PendulumDrift, PendulumParams, pendulum};

/// A random-number generator that counts the words it hands out.
struct CountingRng<'a> {
    inner: Xoshiro256PlusPlus,
    words: &'a Cell<usize>,
}

impl TryRng for CountingRng<'_> {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        self.words.set(self.words.get() + 1);
        self.inner.try_next_u32()
    }
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        self.words.set(self.words.get() + 1);
        self.inner.try_next_u64()
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        self.words.set(self.words.get() + dst.len().div_ceil(8));
        self.inner.try_fill_bytes(dst)
    }
}

fn words_drawn(noise: f64) -> usize {
    let system = pendulum(PendulumParams {
        noise,
        ..PendulumParams::default()
    })
    .unwrap();
    let words = Cell::new(0);
    let rng = CountingRng {
        inner: Xoshiro256PlusPlus::seed_from_u64(1),
        words: &words,
    };
    let mut increments = GaussianIncrements::new(rng, system.noise_dim());
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    let grid = TimeGrid::new(1.0, 100).unwrap();
    run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut increments,
        &mut NoObserver,
    )
    .unwrap();
    assert_eq!(increments.dim(), if noise == 0.0 { 0 } else { 2 });
    words.get()
}

#[test]
fn a_system_without_noise_draws_no_random_numbers() {
    assert_eq!(words_drawn(0.0), 0);
    // The same count with noise shows that the counter sees the draws.
    assert!(words_drawn(1.0) >= 200);
}

/// The unit circle, counting the evaluations of D^2 g.
struct CountingCircle<'a> {
    sphere: Sphere,
    curvature_calls: &'a Cell<usize>,
}

impl Constraint for CountingCircle<'_> {
    type Gram = ScalarGram;
    fn dim(&self) -> usize {
        self.sphere.dim()
    }
    fn n_constraints(&self) -> usize {
        1
    }
    fn value(&self, x: &[f64], out: &mut [f64]) {
        self.sphere.value(x, out)
    }
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        self.sphere.jacobian_mul(x, u, out)
    }
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        self.sphere.jacobian_transpose_mul(x, z, out)
    }
    fn new_gram(&self) -> ScalarGram {
        self.sphere.new_gram()
    }
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut ScalarGram,
    ) {
        self.sphere.cross_gram(x1, x2, mass, scratch, out)
    }
}

impl Curvature for CountingCircle<'_> {
    fn second_derivative(&self, x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        self.curvature_calls.set(self.curvature_calls.get() + 1);
        self.sphere.second_derivative(x, u, w, out)
    }
}

#[test]
fn only_the_inherent_sde_solvers_evaluate_the_second_derivative() {
    let calls = Cell::new(0);
    let system = || {
        MechanicalSystem::new(
            CountingCircle {
                sphere: Sphere::new(2, 1.0).unwrap(),
                curvature_calls: &calls,
            },
            sdae_manifold::IdentityMass,
            PendulumDrift {
                gravity: 1.0,
                friction: 0.0,
            },
            sdae_model::NoNoise,
        )
        .unwrap()
    };
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system(), config).unwrap();
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    for _ in 0..50 {
        stepper.step(&mut r, &mut v, 0.01, &[]).unwrap();
    }
    assert_eq!(calls.get(), 0, "the half-explicit scheme evaluated D^2 g");
    let mut euler = EulerMaruyama::new(system()).unwrap();
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    for _ in 0..50 {
        euler.step(&mut r, &mut v, 0.01, &[]).unwrap();
    }
    assert!(
        calls.get() >= 50,
        "Euler-Maruyama needs D^2 g at every step"
    );
}

#[test]
fn mu_is_accumulated_only_when_an_output_needs_it() {
    // The path driver: a recorder that does not ask for mu gets none.
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let grid = TimeGrid::new(1.0, 64).unwrap();
    let mut without = Recorder::every(1);
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.0, 0.0]);
    let mut noise = GaussianIncrements::for_path(3, 0, 2);
    run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut without).unwrap();
    assert!(without.multiplier(64).is_empty());
    // A study of a scene whose outputs leave out the multiplier reports no mu error.
    let text = sdae_study::scene::BUILT_IN[0].1.replace(
        r#"outputs = ["position", "velocity", "multiplier"]"#,
        r#"outputs = ["position"]"#,
    );
    // Without its [weak] table, whose energy observable reads the velocity.
    let text = text.split("\n[weak]").next().unwrap_or(&text);
    let scene = Scene::from_toml(text).unwrap();
    let settings = ConvergenceSettings {
        paths: 4,
        coarsest: 2,
        finest: 3,
        reference: Some(6),
        threads: 1,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    for scheme in &report.schemes {
        for level in &scheme.levels {
            assert!(level.error.r.is_some() && level.error.v.is_none() && level.error.mu.is_none());
        }
    }
}
