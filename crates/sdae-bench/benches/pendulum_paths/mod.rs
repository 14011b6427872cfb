//! What the pendulum ensemble benchmarks share: the paths, their initial state and step size,
//! and increments drawn beforehand.

use sdae_noise::EnsembleIncrements;

/// Paths of the ensemble: 16 KiB of state, in the first-level cache.
pub const PATHS: usize = 512;

/// Steps between resets of the states.
pub const RESET_EVERY: usize = 1000;

/// Increments drawn beforehand for the steps alone (cycled).
pub const DRAWN_STEPS: usize = 64;

/// Step size, as `pendulum_step` in benches/step.rs.
pub const H: f64 = 1e-3;

/// Seed of the paths' streams.
pub const SEED: u64 = 2024;

/// Initial position of every path.
pub const R0: [f64; 2] = [1.0, 0.0];

/// Initial velocity of every path.
pub const V0: [f64; 2] = [0.0, 1.0];

/// The next [`DRAWN_STEPS`] increments of step size [`H`] from `noise`, each in the layout of
/// an ensemble of `stride` (two noise components).
pub fn drawn_increments(noise: &mut EnsembleIncrements, stride: usize) -> Vec<Vec<f64>> {
    (0..DRAWN_STEPS)
        .map(|_| {
            let mut dw = vec![0.0; 2 * stride];
            noise.fill(H, &mut dw).expect("increments buffer");
            dw
        })
        .collect()
}
