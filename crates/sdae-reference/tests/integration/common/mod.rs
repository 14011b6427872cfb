//! Helpers shared by the integration tests of the reference solvers.

use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_systems::{Pendulum, PendulumParams, pendulum};

/// The planar unit pendulum with gravity c_g, unit noise, no friction.
pub fn planar(gravity: f64, noise: f64) -> Pendulum {
    pendulum(PendulumParams {
        gravity,
        noise,
        friction: 0.0,
        ..PendulumParams::default()
    })
    .unwrap()
}

/// `steps` Brownian increments of dimension `dim` on [0, t_end], path `index` of seed `seed`.
pub fn brownian_path(seed: u64, index: u64, dim: usize, t_end: f64, steps: usize) -> Vec<f64> {
    let mut source = GaussianIncrements::for_path(seed, index, dim);
    let mut data = vec![0.0; dim * steps];
    let h = t_end / steps as f64;
    for chunk in data.chunks_exact_mut(dim) {
        source.next_increment(h, chunk);
    }
    data
}

/// sqrt(|r1 - r2|^2 + |v1 - v2|^2).
pub fn state_distance(r1: &[f64], v1: &[f64], r2: &[f64], v2: &[f64]) -> f64 {
    let d = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    (d(r1, r2) + d(v1, v2)).sqrt()
}

/// Least-squares slope of log(error) against log(h): the observed order.
pub fn observed_order(hs: &[f64], errors: &[f64]) -> f64 {
    let x: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let y: Vec<f64> = errors.iter().map(|e| e.ln()).collect();
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// The numbers in scientific notation with 3 decimals, for test output.
pub fn show(values: &[f64]) -> String {
    let parts: Vec<String> = values.iter().map(|e| format!("{e:.3e}")).collect();
    format!("[{}]", parts.join(", "))
}
