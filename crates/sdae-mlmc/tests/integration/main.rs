//! Multilevel Monte Carlo against closed forms: the rates of Euler-Maruyama on scalar linear SDEs and
//! the adaptive estimate of geometric Brownian motion; plans run in shards; the expectation
//! helper's choice of estimator against the exact variances.
//!
//! One test binary for the crate: each file below is a module of it.

mod expectation;
mod linear;
mod pick;
mod qmc;
mod rates;
mod shard;
mod uniform;
