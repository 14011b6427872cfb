//! Built-in constrained stochastic mechanical systems (seed Section 5): constrained Langevin
//! molecules (5.2) and inextensible fibers in turbulent air (5.3).
