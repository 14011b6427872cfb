//! Integration tests of the built-in systems, as one test binary: the parameter structs as they
//! come from scene files. (The systems under the schemes, the tangent bundle, equipartition and
//! the fiber's mechanics, are checked in the workspace's `tests/` package, which depends on the
//! schemes: this crate's tests depend on no scheme.)

mod params;
