//! Brownian increments for constrained stochastic mechanical systems (seed eq. 1.1):
//!
//! ```text
//! dr = v dt,   M dv = a(r, v) dt + B(r, v) dw + grad g(r) dmu,   g(r) = 0
//! ```
//!
//! A scheme steps from t_k to t_{k+1} = t_k + h with the increment dw_k = w(t_{k+1}) - w(t_k)
//! of the l-dimensional Brownian motion w, which is sqrt(h) N(0, I_l). This crate draws them:
//!
//! - each path's own streams: [`PathStreams`], whose main stream is [`path_rng`]`(seed, i)` for
//!   path i of a study, so a path's numbers do not depend on the thread count, on sharding or
//!   on which paths run together;
//! - standard normals from them ([`StandardNormals`]), a ziggurat of 2048 layers that reads one
//!   word of the main stream per number and finishes the 0.23% of draws its fast path rejects
//!   from a side stream;
//! - the increments of one path, [`IncrementSource`]: [`GaussianIncrements`] (sqrt(h) z with z
//!   standard normals), [`Coarsened`] (the sum of `factor` consecutive fine increments, so
//!   several step sizes run on the same Brownian path) and [`RecordedIncrements`] (a stored
//!   path);
//! - the increments of P paths at once, [`EnsembleIncrements`]: the same numbers bit for bit,
//!   drawn W paths at a time in the lanes of a SIMD register (the lanes and their layout are
//!   those of [`sdae_lanes`]);
//! - randomized quasi-Monte Carlo paths: path i of
//!   randomization r is point i of scrambled Sobol' points ([`SobolPoints`]) mapped to normals
//!   by [`inverse_normal_cdf`] and ordered by a [`BrownianBridge`] per component, one path as an
//!   [`IncrementSource`] ([`QuasiIncrements`]) or P at once in the ensembles' layout
//!   ([`QuasiEnsembleIncrements`]), made W paths at a time in SIMD lanes with the same numbers,
//!   both from a [`QuasiBrownian`].
//!
//! The schemes and the path driver that consume these increments are in `sdae-model` and the
//! crates above it; this crate depends on none of them.
//!
//! The same seed and path give the same numbers, and their variance is h:
//!
//! ```
//! use sdae_noise::{GaussianIncrements, IncrementSource};
//!
//! // Path 3 of a study with seed 42, increments of dimension l = 2 over steps of h = 0.01.
//! let (h, steps) = (0.01, 5000);
//! let mut noise = GaussianIncrements::for_path(42, 3, 2);
//! let mut dw = [0.0; 2];
//! let mut path = Vec::with_capacity(2 * steps);
//! for _ in 0..steps {
//!     noise.next_increment(h, &mut dw);
//!     path.extend_from_slice(&dw);
//! }
//! assert_eq!(path.len(), 2 * steps);
//! // The sample variance of the 10 000 entries is h within a few standard errors.
//! let variance = path.iter().map(|x| x * x).sum::<f64>() / path.len() as f64;
//! assert!((variance / h - 1.0).abs() < 5.0 * (2.0 / path.len() as f64).sqrt());
//!
//! // Drawn again, path 3 gives the same bits; path 4 other numbers.
//! let mut again = GaussianIncrements::for_path(42, 3, 2);
//! again.next_increment(h, &mut dw);
//! assert_eq!(dw.map(f64::to_bits), [path[0].to_bits(), path[1].to_bits()]);
//! GaussianIncrements::for_path(42, 4, 2).next_increment(h, &mut dw);
//! assert_ne!(dw[0], path[0]);
//! ```

mod ensemble_noise;
mod error;
mod increments;
mod normals;
mod path_streams;
mod qmc;
mod seeding;
mod ziggurat;

pub use ensemble_noise::EnsembleNoise;
pub use error::NoiseError;
pub use increments::{Coarsened, GaussianIncrements, IncrementSource, RecordedIncrements};
pub use normals::EnsembleIncrements;
pub use path_streams::{PathStreams, StandardNormals};
pub use qmc::{
    BrownianBridge, MAX_SOBOL_DIMS, QuasiBrownian, QuasiEnsembleIncrements, QuasiIncrements,
    SobolPoints, inverse_normal_cdf, unit_interval,
};
pub use seeding::path_rng;
