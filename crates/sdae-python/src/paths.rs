//! Simulated paths from Python: P paths of a scene with a named scheme, recorded every k-th
//! step, as numpy arrays (the library's [`sdae_study::simulate`]).

use numpy::npyffi::NPY_ORDER;
use numpy::{IntoPyArray, PyArray1, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sdae_model::PathDiagnostics;
use sdae_study::options::started_threads;
use sdae_study::simulate::{SimulateSettings, SimulatedPaths, simulate_with_progress};

use crate::args::{scheme_kind, thread_count, whole};
use crate::errors::to_py;
use crate::interrupt::{Meter, run_interruptible};
use crate::scene::PyScene;

/// Simulates `paths` paths of `scene` with `scheme` over `steps` steps of h = T / steps from
/// the scene's initial state; path i draws from the stream (seed, i). Records t_0, every
/// `every`-th step and t_N. Releases the interpreter's lock; Ctrl-C raises KeyboardInterrupt.
/// With `progress`, a progress line is drawn on stderr after that many seconds.
/// The counts and the seed come as Python integers of any size: a negative one is a
/// `ValueError` naming it, as is any setting the library refuses. `threads` is refused outside
/// 1..=[`MAX_THREADS`](sdae_study::convergence::MAX_THREADS) as on the command line, and as
/// there at most one thread per path and 4 per available core are started
/// ([`started_threads`]).
#[pyfunction]
#[pyo3(signature = (scene, scheme, paths, steps, seed, every, threads, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>, scene: &PyScene, scheme: &str, paths: i128, steps: i128, seed: i128,
    every: i128, threads: i128, progress: Option<f64>,
) -> PyResult<PyPaths> {
    let (paths, steps, every, threads) = (
        whole("paths", paths)?,
        whole("steps", steps)?,
        whole("every", every)?,
        thread_count(threads)?,
    );
    let seed = whole("seed", seed)?;
    let kind = scheme_kind("scheme", scheme)?;
    let settings = SimulateSettings::new(kind, paths, steps, seed)
        .and_then(|s| s.every(every))
        .and_then(|s| s.threads(started_threads(threads, paths)))
        .map_err(to_py)?;
    let scene = &scene.scene;
    let label = format!("{} {}", scene.name, kind.name());
    let meter = Meter::after(progress, label, Some(paths as u64), "paths");
    let simulated = run_interruptible(py, meter, |run| {
        simulate_with_progress(scene, &settings, &|| run.stopped(), &|n| {
            run.advance(n as u64)
        })
    })?;
    PyPaths::new(py, simulated.map_err(to_py)?)
}

/// P recorded paths: `times` (T,), `positions` and `velocities` (P, T, n), `multipliers`
/// (P, T, m), `failures` (one message or None per path) and `diagnostics` (a dict of arrays
/// of length P). A failed path holds NaN after its last completed step. The arrays are made
/// once, without copying the run's numbers, and each property returns the same array.
#[pyclass(name = "Paths", module = "sdae._sdae", frozen)]
pub struct PyPaths {
    scheme: String,
    h: f64,
    paths: usize,
    records: usize,
    dims: (usize, usize),
    times: Py<PyArray1<f64>>,
    /// r, v and mu.
    states: [Py<PyArray3<f64>>; 3],
    failures: Vec<Option<String>>,
    diagnostics: Py<PyDict>,
}

impl PyPaths {
    /// The run's numbers as numpy arrays (moved, not copied).
    fn new(py: Python<'_>, run: SimulatedPaths) -> PyResult<Self> {
        let (p, t) = (run.failures.len(), run.times.len());
        let shaped = |values: Vec<f64>, width: usize| -> PyResult<Py<PyArray3<f64>>> {
            let array = values
                .into_pyarray(py)
                .reshape_with_order([p, t, width], NPY_ORDER::NPY_CORDER)?;
            read_only(array.as_any())?;
            Ok(array.unbind())
        };
        Ok(Self {
            scheme: run.scheme,
            h: run.h,
            paths: p,
            records: t,
            dims: (run.n, run.m),
            states: [
                shaped(run.positions, run.n)?,
                shaped(run.velocities, run.n)?,
                shaped(run.multipliers, run.m)?,
            ],
            times: {
                let times = run.times.into_pyarray(py);
                read_only(times.as_any())?;
                times.unbind()
            },
            diagnostics: diagnostics(py, &run.diagnostics)?.unbind(),
            failures: run.failures,
        })
    }
}

/// Marks a numpy array read-only: a property hands out the same array each time.
fn read_only(array: &Bound<'_, PyAny>) -> PyResult<()> {
    let flags = PyDict::new(array.py());
    flags.set_item("write", false)?;
    array.call_method("setflags", (), Some(&flags))?;
    Ok(())
}

/// Each path's diagnostics as arrays of length P.
fn diagnostics<'py>(
    py: Python<'py>, diagnostics: &[PathDiagnostics],
) -> PyResult<Bound<'py, PyDict>> {
    let column =
        |f: fn(&PathDiagnostics) -> f64| -> Vec<f64> { diagnostics.iter().map(f).collect() };
    let count = |f: fn(&PathDiagnostics) -> usize| -> Vec<u64> {
        diagnostics.iter().map(|d| f(d) as u64).collect()
    };
    let dict = PyDict::new(py);
    dict.set_item("steps", count(|d| d.steps).into_pyarray(py))?;
    dict.set_item(
        "truncated_steps",
        count(|d| d.truncated_steps).into_pyarray(py),
    )?;
    dict.set_item("min_eta", column(|d| d.min_eta).into_pyarray(py))?;
    dict.set_item(
        "newton_iterations",
        count(|d| d.newton_iterations).into_pyarray(py),
    )?;
    dict.set_item(
        "max_position_residual",
        column(|d| d.max_position_residual).into_pyarray(py),
    )?;
    dict.set_item(
        "max_velocity_residual",
        column(|d| d.max_velocity_residual).into_pyarray(py),
    )?;
    dict.set_item(
        "homotopy_steps",
        count(|d| d.homotopy_steps).into_pyarray(py),
    )?;
    dict.set_item(
        "max_kappa_ratio",
        column(|d| d.max_kappa_ratio).into_pyarray(py),
    )?;
    dict.set_item("clock_lag", column(|d| d.clock_lag).into_pyarray(py))?;
    dict.set_item(
        "rounding_certified_steps",
        count(|d| d.rounding_certified_steps).into_pyarray(py),
    )?;
    for (_, column) in dict.iter() {
        read_only(&column)?;
    }
    Ok(dict)
}

#[pymethods]
impl PyPaths {
    /// The scheme's name.
    #[getter]
    fn scheme(&self) -> &str {
        &self.scheme
    }

    /// The step size h = T / N.
    #[getter]
    fn h(&self) -> f64 {
        self.h
    }

    /// The recorded times, shape (T,).
    #[getter]
    fn times(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.times.clone_ref(py)
    }

    /// r at the recorded times, shape (P, T, n).
    #[getter]
    fn positions(&self, py: Python<'_>) -> Py<PyArray3<f64>> {
        self.states[0].clone_ref(py)
    }

    /// v at the recorded times, shape (P, T, n).
    #[getter]
    fn velocities(&self, py: Python<'_>) -> Py<PyArray3<f64>> {
        self.states[1].clone_ref(py)
    }

    /// mu at the recorded times (mu_0 = 0), shape (P, T, m).
    #[getter]
    fn multipliers(&self, py: Python<'_>) -> Py<PyArray3<f64>> {
        self.states[2].clone_ref(py)
    }

    /// Why each path stopped, or None.
    #[getter]
    fn failures(&self) -> Vec<Option<String>> {
        self.failures.clone()
    }

    /// Each path's diagnostics as arrays of length P: `steps`, `truncated_steps`, `min_eta`,
    /// `newton_iterations`, `max_position_residual`, `max_velocity_residual`, `homotopy_steps`,
    /// `max_kappa_ratio`, `clock_lag` (grid time minus the path's own clock, for the
    /// time-changed scheme) and `rounding_certified_steps`.
    #[getter]
    fn diagnostics(&self, py: Python<'_>) -> Py<PyDict> {
        self.diagnostics.clone_ref(py)
    }

    fn __repr__(&self) -> String {
        let (n, m) = self.dims;
        let failed = self.failures.iter().filter(|f| f.is_some()).count();
        format!(
            "Paths({} paths x {} times, n = {n}, m = {m}, scheme {:?}, {failed} failed)",
            self.paths, self.records, self.scheme,
        )
    }
}
