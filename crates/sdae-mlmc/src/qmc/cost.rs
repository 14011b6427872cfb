//! The cost exponent of a method from runs at several accuracies: work ~ K eps^-c.
//!
//! MLMC with beta > gamma costs eps^-2; MLQMC with scrambled Sobol' points on smooth payoffs
//! has been reported between about eps^-1.1 and eps^-2 (Giles and Waterhouse 2009).

use sdae_stats::Interval;

use super::MlqmcEstimate;
use crate::fit::fit_slope;

/// The cost exponent c of work ~ K eps^-c from `(eps, work)` pairs: the least-squares slope of
/// ln work against ln(1 / eps), with the 95% t interval of the regression (n - 2 degrees of
/// freedom from the residuals; unbounded with two runs). `None` with fewer than two runs or an
/// eps or a work that is not finite and > 0.
pub fn cost_exponent(runs: &[(f64, f64)]) -> Option<Interval> {
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if runs
        .iter()
        .any(|&(eps, work)| !(positive(eps) && positive(work)))
    {
        return None;
    }
    let x: Vec<f64> = runs.iter().map(|(eps, _)| -eps.ln()).collect();
    let y: Vec<f64> = runs.iter().map(|(_, work)| work.ln()).collect();
    fit_slope(&x, &y, None)
}

/// [`cost_exponent`] of MLQMC runs: their eps and work.
pub fn cost_exponent_of(runs: &[MlqmcEstimate]) -> Option<Interval> {
    let pairs: Vec<(f64, f64)> = runs.iter().map(|r| (r.eps, r.work)).collect();
    cost_exponent(&pairs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exponent_of_an_exact_power_law_is_recovered() {
        let runs: Vec<(f64, f64)> = [1e-1, 3e-2, 1e-2, 3e-3]
            .iter()
            .map(|&e: &f64| (e, 7.0 * e.powf(-1.5)))
            .collect();
        let c = cost_exponent(&runs).unwrap();
        assert!((c.estimate - 1.5).abs() < 1e-12, "{c:?}");
        assert!(c.ci_high - c.ci_low < 1e-9, "{c:?}");
        assert!(cost_exponent(&runs[..1]).is_none());
        assert!(cost_exponent(&[(1e-2, 1.0), (0.0, 2.0)]).is_none());
    }
}
