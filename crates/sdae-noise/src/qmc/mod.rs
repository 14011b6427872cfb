//! Randomized quasi-Monte Carlo Brownian paths: path i of randomization r of a study is the
//! image of point i of scrambled Sobol' points under the inverse normal distribution function,
//! ordered by a Brownian bridge per component.
//!
//! - [`SobolPoints`]: Sobol' points with the Joe and Kuo direction numbers (new-joe-kuo-6.21201,
//!   up to [`MAX_SOBOL_DIMS`] dimensions), point i and coordinate j computed directly, plain or
//!   randomized by Matousek's linear matrix scrambling plus a digital shift
//!   ([`SobolPoints::scrambled`]); [`unit_interval`] turns a coordinate into a double in (0, 1).
//!   The Joe and Kuo parameters come from the `sobol` crate (its dependencies are lighter
//!   than those of its fork `sobol-qmc`); the direction numbers are computed here in 64 bits.
//! - [`inverse_normal_cdf`]: Wichura's AS 241, a monotone map to standard normals.
//! - [`BrownianBridge`]: the bridge construction of a path on N steps, N any positive integer.
//! - [`QuasiBrownian`]: one randomization's paths (dimension m, N steps), padded with the
//!   path's pseudo-random normals beyond the Sobol' dimensions; its paths as an
//!   [`IncrementSource`](crate::IncrementSource), [`QuasiIncrements`], or many at once in the
//!   ensembles' layout, [`QuasiEnsembleIncrements`], made W paths at a time in SIMD lanes
//!   ([`QuasiBrownian::unit_ensemble`]) with the same numbers bit for bit.

mod bridge;
mod inverse_normal;
mod joe_kuo;
mod quasi_brownian;
mod quasi_ensemble;
mod quasi_increments;
mod quasi_lanes;
mod scramble;
mod seeds;
mod sobol;

pub use bridge::BrownianBridge;
pub use inverse_normal::inverse_normal_cdf;
pub use joe_kuo::MAX_SOBOL_DIMS;
pub use quasi_brownian::QuasiBrownian;
pub use quasi_ensemble::QuasiEnsembleIncrements;
pub use quasi_increments::QuasiIncrements;
pub use sobol::{SobolPoints, unit_interval};
