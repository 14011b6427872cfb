//! The Python package `sdae`: scenes, simulated paths and the studies of the library, numpy
//! arrays in and out. Its native module `sdae._sdae` is built by maturin (`pip install crates/sdae-python`);
//! the package's Python files (`python/sdae`) re-export it with docstrings and type stubs.
//!
//! Every run releases the interpreter's lock and checks for signals between blocks of work
//! (`interrupt.rs`), so that Ctrl-C raises `KeyboardInterrupt` within a second. A setting or a
//! scene the library refuses raises `ValueError` with the library's message, the one the
//! command line prints.

use pyo3::prelude::*;

/// Lane buffers start on cache lines, as in the command line (docs/performance.md).
#[global_allocator]
static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;

mod args;
mod errors;
mod interrupt;
mod paths;
mod paths_io;
mod report;
mod scene;
mod scene_dict;
mod studies;

/// The native module `sdae._sdae`.
#[pymodule]
fn _sdae(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add_class::<scene::PyScene>()?;
    module.add_class::<paths::PyPaths>()?;
    module.add_class::<report::PyReport>()?;
    module.add_function(wrap_pyfunction!(scene::built_in_scenes, module)?)?;
    module.add_function(wrap_pyfunction!(args::schemes, module)?)?;
    module.add_function(wrap_pyfunction!(paths::simulate, module)?)?;
    module.add_function(wrap_pyfunction!(studies::convergence, module)?)?;
    module.add_function(wrap_pyfunction!(studies::weak, module)?)?;
    module.add_function(wrap_pyfunction!(studies::stability, module)?)?;
    module.add_function(wrap_pyfunction!(studies::mlmc, module)?)?;
    module.add_function(wrap_pyfunction!(studies::expectation, module)?)?;
    module.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
