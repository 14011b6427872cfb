//! The statistics of the studies and of multilevel Monte Carlo, with intervals that hold their
//! 95% where the sample allows it:
//!
//! - [`Interval`]: an estimate with its 95% confidence interval, and [`t975`], the Student t
//!   quantile its t intervals are built with;
//! - [`mean_interval`]: the mean of independent samples with its t interval;
//! - [`lp_error`]: the L^p norm over paths of per-path errors, with a studentized bootstrap
//!   interval on the log scale, scaled by the largest error so that no p underflows
//!   ([`lp_estimate`]: the same estimate without its interval);
//! - [`fit_order`]: the observed order of convergence from the per-path errors of all levels
//!   of one set of paths, with its interval from the paired bootstrap of whole paths
//!   ([`bootstrap`]) and the local slopes with theirs, so that curvature is flagged as
//!   pre-asymptotic rather than hidden in an interval;
//! - [`weak_order`]: weak orders from signed weak errors, over the asymptotic levels only,
//!   with intervals widened by the model error the levels show;
//! - [`json_f64`]: `f64` fields that survive JSON whatever their value (NaN and infinities as
//!   strings), for reports and shards that other tools read back;
//! - [`memory`]: the memory a run may take, so that settings needing more are refused before
//!   anything is allocated.
//!
//! ```
//! use sdae_stats::{Interval, t975};
//!
//! // The mean of four samples with its t interval: mean +- t_{0.975, 3} s / sqrt(4).
//! let x = [1.0, 2.0, 3.0, 4.0];
//! let mean = x.iter().sum::<f64>() / 4.0;
//! let s = (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / 3.0).sqrt();
//! let half = t975(3) * s / 2.0;
//! let interval = Interval { estimate: mean, ci_low: mean - half, ci_high: mean + half };
//! assert!((t975(3) - 3.182446).abs() < 1e-6);
//! assert!(interval.contains(2.5) && !interval.contains(5.0));
//! ```

pub mod bootstrap;
mod estimates;
mod interval;
pub mod json_f64;
pub mod memory;
pub mod weak_order;

pub use estimates::{
    INDICATIVE_BELOW, LocalSlope, OrderFit, PathErrors, effective_paths, fit_order,
    fit_order_and_errors, lp_error, lp_estimate, mean_interval,
};
pub use interval::{Interval, t975};

/// A coarse level is pre-asymptotic when its local slope departs from the finer levels' beyond
/// the Monte Carlo error and by more than this (the strong and weak orders' fits and the MLMC
/// rates alike).
pub const PRE_ASYMPTOTIC_TOLERANCE: f64 = 0.05;
