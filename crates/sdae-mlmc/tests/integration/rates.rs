//! The rates alpha and beta of Euler-Maruyama on scalar linear SDEs with known means against
//! their closed forms, and the adaptive estimate of geometric Brownian motion against its mean.

use sdae_mlmc::RunControl;
use sdae_mlmc::algorithm::{AdaptiveSettings, adaptive, run_plan};
use sdae_mlmc::fit::fit_rates;
use sdae_mlmc::sampler::level_stats;

use crate::linear::Linear;

/// Geometric Brownian motion dX = X / 2 dt + X / 2 dW from level 0 on 2 steps, T = 1.
fn gbm(seed: u64) -> Linear {
    Linear {
        a: 0.5,
        b: 0.5,
        multiplicative: true,
        t_end: 1.0,
        coarsest: 1,
        seed,
    }
}

/// The convergence test's rates on levels 0..=8 with 20 000 samples each, fitted from l = 2.
fn rates_of(model: &Linear) -> sdae_mlmc::Rates {
    let control = RunControl::new(2).unwrap();
    let sums = run_plan(model, &control, &[20_000; 9]).unwrap();
    let stats = level_stats(&sums, model);
    fit_rates(&stats, 2)
}

/// The fitted alpha and beta cover the exact slopes of the closed forms over the levels they
/// were fitted on (levels 2..=8 less those left out as pre-asymptotic or unresolved), and those
/// are near the asymptotic rates.
fn check_rates(model: &Linear, alpha_limit: f64, beta_limit: f64) {
    let rates = rates_of(model);
    let (alpha, beta) = (rates.alpha.unwrap(), rates.beta.unwrap());
    let kept = |out: &[&Vec<u32>]| -> Vec<u32> {
        (2..=8)
            .filter(|l| out.iter().all(|o| !o.contains(l)))
            .collect()
    };
    let (exact_alpha, exact_beta) = model.exact_rates(
        &kept(&[&rates.alpha_pre_asymptotic, &rates.unresolved]),
        &kept(&[&rates.beta_pre_asymptotic]),
    );
    assert!((exact_alpha - alpha_limit).abs() < 0.05, "{exact_alpha}");
    assert!((exact_beta - beta_limit).abs() < 0.05, "{exact_beta}");
    assert!(
        alpha.contains(exact_alpha),
        "alpha {alpha:?}, exact {exact_alpha}"
    );
    assert!(
        beta.contains(exact_beta),
        "beta {beta:?}, exact {exact_beta}"
    );
    assert!(
        beta.ci_high - beta.ci_low < 0.3,
        "beta {beta:?} is not resolved"
    );
    // gamma is the work per sample's: 1.5 2^(k0 + l) steps, exactly 1.
    let gamma = rates.gamma.unwrap();
    assert!(
        [gamma.estimate, gamma.ci_low, gamma.ci_high]
            .iter()
            .all(|g| (g - 1.0).abs() < 1e-12),
        "{gamma:?}"
    );
}

#[test]
fn euler_maruyama_has_alpha_1_and_beta_1_on_geometric_brownian_motion() {
    let gbm = gbm(11);
    check_rates(&gbm, 1.0, 1.0);
}

#[test]
fn euler_maruyama_has_alpha_1_and_beta_2_on_additive_noise() {
    let ou = Linear::ou(12);
    check_rates(&ou, 1.0, 2.0);
}

#[test]
fn the_adaptive_estimate_of_geometric_brownian_motion_covers_its_mean() {
    let gbm = gbm(13);
    let control = RunControl::new(2).unwrap();
    let run = adaptive(
        &gbm,
        &control,
        &AdaptiveSettings {
            eps: 2e-3,
            initial_samples: 1000,
            min_levels: 2,
            max_level: 12,
        },
    )
    .unwrap();
    assert!(run.converged);
    assert!(run.estimate.contains(0.5f64.exp()), "{:?}", run.estimate);
    // The sampling error is within its share eps^2 / 2 of the mean square error.
    let half = run.estimate.ci_high - run.estimate.estimate;
    assert!(half / 1.96 <= 2e-3 / 2f64.sqrt() * 1.01, "{half}");
}
