//! Builders shared by the integration tests.
#![allow(dead_code)]

use sdae_manifold::{BeadChain, IdentityMass};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem};

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
    beads: usize,
    noise: f64,
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
