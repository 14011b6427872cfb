//! Integration tests of the built-in systems, as one test binary: the tangent bundle under the
//! half-explicit scheme and the reference solvers, equipartition of the Langevin systems, the
//! fiber's mechanics without noise, and the parameter structs as they come from scene files.

mod constraints;
mod equipartition;
mod fiber_dynamics;
mod params;
