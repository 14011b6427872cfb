//! The coverage of the intervals the studies print, on laws with known answers (normal, skewed and
//! heavy-tailed samples), and the verdicts of the order fits on errors of known order.
//!
//! One test binary for the crate: each file below is a module of it.

mod coverage;
