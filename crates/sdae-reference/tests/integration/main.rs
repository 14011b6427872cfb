//! Integration tests of the reference solvers, as one test binary: the coefficients of the
//! inherent SDE against closed forms, agreement with the half-explicit scheme on the same
//! Brownian paths, the observed orders of stochastic Heun, and the typed errors of bad inputs.

mod common;

mod agreement;
mod bad_inputs;
mod closed_form;
mod heun_order;
