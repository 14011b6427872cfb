//! Reference solvers for the inherent SDE (seed eq. 2.4) and the multiplier formula (eq. 2.3):
//! Euler-Maruyama, truncated Euler-Maruyama (Remark 3.3), projected Euler-Maruyama and a
//! higher-order method for additive noise. Not yet implemented: this crate is reserved for them.
