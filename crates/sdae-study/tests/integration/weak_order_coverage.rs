//! The weak order's bootstrap interval covers the true order on a model whose weak error is
//! known exactly at every step size: Euler-Maruyama on geometric Brownian motion
//! dX = a X dt + b X dW has E[X_N] = X_0 (1 + a h)^N, against E[X_T] = X_0 e^(aT), so
//! e(h) = X_0 ((1 + a h)^(T/h) - e^(aT)) = -X_0 e^(aT) a^2 T h / 2 + O(h^2): weak order 1.
//!
//! Each replication runs its own paths at every level on shared Brownian increments, fits the
//! order with [`weak_order`] against the exact E[X_T] (exact basis: per-path X_N - E[X_T]) and
//! asks whether the interval covers the slope of the exact errors over the levels it fitted
//! (the quantity the estimator estimates; over these step sizes it lies within 0.1 of 1).
//! Nominal coverage 95%; over 200 replications the binomial standard error at 95% is
//! sqrt(0.95 * 0.05 / 200) = 0.015, so a coverage below 90% (more than 3 standard errors
//! short) fails.

use rand::RngExt;
use sdae_noise::path_rng;
use sdae_study::weak::weak_order;

const A: f64 = 0.5;
const B: f64 = 0.05;
const X0: f64 = 1.0;
const T: f64 = 1.0;
/// Levels N = 2^1 .. 2^5.
const LEVELS: [u32; 5] = [1, 2, 3, 4, 5];
const PATHS: usize = 4000;
const REPLICATIONS: u64 = 200;

/// The exact weak error of Euler-Maruyama at N steps.
fn exact_error(n: usize) -> f64 {
    let h = T / n as f64;
    X0 * ((1.0 + A * h).powi(n as i32) - (A * T).exp())
}

/// The least-squares slope of log |e| against log h over `levels`.
fn slope(h: &[f64], e: &[f64], levels: &[usize]) -> f64 {
    let x: Vec<f64> = levels.iter().map(|&j| h[j].ln()).collect();
    let y: Vec<f64> = levels.iter().map(|&j| e[j].abs().ln()).collect();
    let (mx, my) = (
        x.iter().sum::<f64>() / x.len() as f64,
        y.iter().sum::<f64>() / y.len() as f64,
    );
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// One replication: per level, per path X_N - E[X_T] (Euler-Maruyama on increments summed from
/// the finest level's).
fn replication(seed: u64) -> Vec<Vec<f64>> {
    let finest = 1usize << LEVELS[LEVELS.len() - 1];
    let h_fine = T / finest as f64;
    let exact = X0 * (A * T).exp();
    let mut rng = path_rng(2026, seed);
    let mut diffs = vec![Vec::with_capacity(PATHS); LEVELS.len()];
    let mut dw = vec![0.0; finest];
    for _ in 0..PATHS {
        for pair in dw.chunks_exact_mut(2) {
            // Box-Muller: two standard normals from two uniforms in (0, 1].
            let (u, v): (f64, f64) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
            let radius = (-2.0 * u.ln()).sqrt() * h_fine.sqrt();
            let angle = std::f64::consts::TAU * v;
            pair[0] = radius * angle.cos();
            pair[1] = radius * angle.sin();
        }
        for (j, &k) in LEVELS.iter().enumerate() {
            let (n, per) = (1usize << k, finest >> k);
            let h = T / n as f64;
            let mut x = X0;
            for step in dw.chunks_exact(per) {
                x *= 1.0 + A * h + B * step.iter().sum::<f64>();
            }
            diffs[j].push(x - exact);
        }
    }
    diffs
}

#[test]
fn weak_order_interval_covers_the_exact_order_of_euler_on_gbm() {
    let h: Vec<f64> = LEVELS.iter().map(|&k| T / (1u64 << k) as f64).collect();
    let exact: Vec<f64> = LEVELS.iter().map(|&k| exact_error(1 << k)).collect();
    let mut covered = 0;
    let mut fitted_levels = 0;
    for r in 0..REPLICATIONS {
        let fit = weak_order(&h, &replication(r)).expect("resolved levels");
        let truth = slope(&h, &exact, &fit.fitted);
        assert!((truth - 1.0).abs() < 0.1, "exact slope {truth}");
        covered += usize::from(fit.order.is_some_and(|o| o.contains(truth)));
        fitted_levels += fit.fitted.len();
    }
    let coverage = covered as f64 / REPLICATIONS as f64;
    let se = (0.95 * 0.05 / REPLICATIONS as f64).sqrt();
    println!(
        "coverage {coverage:.3} over {REPLICATIONS} replications (binomial se {se:.3}), {:.1} levels fitted on average",
        fitted_levels as f64 / REPLICATIONS as f64
    );
    assert!(
        coverage >= 0.90,
        "coverage {coverage} < 0.90 (nominal 0.95, binomial se {se:.3})"
    );
}
