//! Convergence-study harness: Brownian paths at several resolutions, Monte Carlo over paths,
//! strong-error estimators with confidence intervals, order fits and work-precision reports.
//! Not yet implemented: this crate is reserved for them.
