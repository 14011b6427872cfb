//! What the systems' ensemble benchmarks share: an ensemble stepped with fresh increments, and
//! a system seen through its scalar functions only.

use sdae_lanes::Real;
use sdae_model::{PathEnsemble, System};
use sdae_noise::EnsembleIncrements;
use sdae_scheme::{Ensemble, Stepper, StepperConfig};

/// Steps between restarts of every path from the initial state.
const RESTART_EVERY: u64 = 1000;

/// Seed of the paths' streams.
const SEED: u64 = 2025;

/// A system with its scalar drift and noise only: an ensemble evaluates them path by path
/// inside its lanes, as it does a user's system without lane forms.
#[derive(Debug, Clone)]
pub struct PathByPath<S>(pub S);

impl<S: System> System for PathByPath<S> {
    type Constraint = S::Constraint;
    type Mass = S::Mass;
    fn constraint(&self) -> &S::Constraint {
        self.0.constraint()
    }
    fn mass(&self) -> &S::Mass {
        self.0.mass()
    }
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        T::each_path([r, v], out, |[r, v], out| {
            self.0.drift(r, v, out);
        })
    }
    fn noise_dim(&self) -> usize {
        self.0.noise_dim()
    }
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        T::each_path([r, v, dw], out, |[r, v, dw], out| {
            self.0.add_noise(r, v, dw, out);
        })
    }
}

/// Paths of one system stepped together, each path's increments from its own stream.
pub struct EnsembleBench<S: System> {
    ensemble: Ensemble<S>,
    r0: Vec<f64>,
    v0: Vec<f64>,
    h: f64,
    noise: EnsembleIncrements,
    dw: Vec<f64>,
    steps: u64,
}

impl<S: System> EnsembleBench<S> {
    /// `paths` paths of `system` from (r0, v0), stepped with step size `h`.
    pub fn new(
        system: S, config: StepperConfig, paths: usize, (r0, v0): (Vec<f64>, Vec<f64>), h: f64,
    ) -> Self {
        let l = system.noise_dim();
        let stepper = Stepper::new(system, config).expect("stepper");
        let ensemble = Ensemble::new(stepper, paths, &r0, &v0).expect("ensemble");
        let indices: Vec<u64> = (0..paths as u64).collect();
        let dw = vec![0.0; l * ensemble.stride()];
        Self {
            ensemble,
            r0,
            v0,
            h,
            noise: EnsembleIncrements::for_paths(SEED, &indices, l),
            dw,
            steps: 0,
        }
    }

    /// Draws every path's increment and steps every path (all restarted every RESTART_EVERY
    /// steps). Returns the number of failed paths.
    pub fn step(&mut self) -> usize {
        if self.steps.is_multiple_of(RESTART_EVERY) {
            self.ensemble.restart(&self.r0, &self.v0).expect("restart");
        }
        self.steps += 1;
        self.noise.fill(self.h, &mut self.dw).expect("increments");
        self.ensemble.step(self.h, &self.dw).expect("step input")
    }

    /// Panics if a path failed; prints how many path-steps the scalar stepper took (nothing
    /// when a filter left the benchmark out).
    pub fn report(&self, name: &str) {
        assert_eq!(self.ensemble.failed_paths(), 0, "{name}: a path failed");
        if self.steps == 0 {
            return;
        }
        println!(
            "{name}: {} of {} path-steps through the scalar stepper",
            self.ensemble.scalar_steps(),
            self.steps as usize * self.ensemble.paths()
        );
    }
}
