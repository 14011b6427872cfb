//! Builders shared by the integration tests.

use sdae_manifold::{BeadChain, IdentityMass, TheoryBound};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem, System};
use sdae_scheme::StepperConfig;
use sdae_systems::{Pendulum, PendulumParams, pendulum};

/// Gravity -c e_z on every bead.
#[derive(Debug, Clone, Copy)]
pub struct Gravity(pub f64);

impl Drift for Gravity {
    fn drift(&self, _r: &[f64], _v: &[f64], out: &mut [f64]) {
        for bead in out.chunks_exact_mut(3) {
            bead[0] = 0.0;
            bead[1] = 0.0;
            bead[2] = -self.0;
        }
    }
}

/// A chain of `beads` beads of total length 1 under gravity with additive noise.
pub fn chain_system(
    beads: usize, noise: f64,
) -> MechanicalSystem<BeadChain, IdentityMass, Gravity, AdditiveNoise> {
    let chain = BeadChain::new(beads, 1.0 / (beads - 1) as f64).unwrap();
    MechanicalSystem::new(
        chain,
        IdentityMass,
        Gravity(1.0),
        AdditiveNoise::new(noise, 3 * beads).unwrap(),
    )
    .unwrap()
}

/// max |x_i|.
pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |s, v| s.max(v.abs()))
}

/// A pendulum of length 1.5 in `dim` dimensions with strong noise and friction: fast enough
/// that C_eta = 0.05 truncates often.
pub fn noisy_pendulum(dim: usize) -> Pendulum {
    pendulum(PendulumParams {
        dim,
        length: 1.5,
        gravity: 1.0,
        noise: 3.0,
        friction: 0.5,
    })
    .unwrap()
}

/// The lane tests' configurations: "practical" (C_eta = 0.05, truncated often enough that
/// both branches of eta are taken, no ball), the same with rescaled noise and with the
/// constraint's local measure of the motion, and the theory's constants (a finite ball).
pub fn lane_configs<S: System>(system: &S) -> Vec<(&'static str, StepperConfig)>
where
    S::Constraint: TheoryBound,
{
    let practical = StepperConfig::for_system(system)
        .unwrap()
        .with_c_eta(0.05)
        .unwrap()
        .with_c_kappa(f64::INFINITY)
        .unwrap();
    vec![
        ("practical", practical),
        ("rescaled", practical.rescaled()),
        ("local", practical.local()),
        ("theory", StepperConfig::for_system(system).unwrap()),
    ]
}
