//! Simulated paths from Python: P paths of a scene with a named scheme, recorded every k-th
//! step, as numpy arrays (the library's [`sdae_study::simulate`]).

use std::path::PathBuf;

use numpy::npyffi::NPY_ORDER;
use numpy::{IntoPyArray, PyArray1, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sdae_study::options::started_threads;
use sdae_study::simulate::{SimulateSettings, SimulatedPaths, simulate_with_progress};
use sdae_study::trajectory::{TrajectoryFormat, write_paths};

use crate::args::{scheme_kind, thread_count, whole};
use crate::errors::to_py;
use crate::interrupt::{Meter, run_interruptible};
use crate::paths_io::{self, Record};
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
    let record = Record {
        scene: scene.scene.clone(),
        seed,
        steps,
        every,
    };
    let scene = &scene.scene;
    let label = format!("{} {}", scene.name, kind.name());
    let meter = Meter::after(progress, label, Some(paths as u64), "paths");
    let simulated = run_interruptible(py, meter, |run| {
        simulate_with_progress(scene, &settings, &|| run.stopped(), &|n| {
            run.advance(n as u64)
        })
    })?;
    PyPaths::new(py, simulated.map_err(to_py)?, record)
}

/// P recorded paths: `times` (T,), `positions` and `velocities` (P, T, n), `multipliers`
/// (P, T, m), `failures` (one message or None per path) and `diagnostics` (a dict of arrays
/// of length P). A failed path holds NaN after its last completed step. The arrays are made
/// once, without copying the run's numbers, and each property returns the same array. The
/// paths keep their scene, seed, steps and stride: they are saved to and loaded from `.npz`
/// files and pickled through one state (`paths_io`), and written as XYZ and VTK trajectories
/// by the library's writers.
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
    record: Record,
}

impl PyPaths {
    /// The run's numbers as numpy arrays (moved, not copied).
    fn new(py: Python<'_>, run: SimulatedPaths, record: Record) -> PyResult<Self> {
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
            diagnostics: {
                let columns = paths_io::diagnostics(py, &run.diagnostics)?;
                for (_, column) in columns.iter() {
                    read_only(&column)?;
                }
                columns.unbind()
            },
            failures: run.failures,
            record,
        })
    }

    /// Writes the paths as `format` into `folder` with the library's writers, the
    /// interpreter's lock released.
    fn write(
        &self, py: Python<'_>, format: TrajectoryFormat, folder: PathBuf,
    ) -> PyResult<Vec<PathBuf>> {
        let (run, record) = paths_io::from_state(&self.state(py)?)?;
        py.detach(|| write_paths(&run, &record.scene, format, &folder))
            .map_err(to_py)
    }

    /// The state that `save` writes and a pickle holds: the arrays themselves (not copies) and
    /// `meta` (`paths_io`).
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let state = PyDict::new(py);
        state.set_item(
            "meta",
            paths_io::meta(&self.scheme, self.h, &self.record, &self.failures)?,
        )?;
        state.set_item("times", &self.times)?;
        for (key, array) in ["positions", "velocities", "multipliers"]
            .into_iter()
            .zip(&self.states)
        {
            state.set_item(key, array)?;
        }
        for (name, column) in self.diagnostics.bind(py).iter() {
            state.set_item(format!("diagnostics.{name}"), column)?;
        }
        Ok(state)
    }
}

/// Marks a numpy array read-only: a property hands out the same array each time.
fn read_only(array: &Bound<'_, PyAny>) -> PyResult<()> {
    let flags = PyDict::new(array.py());
    flags.set_item("write", false)?;
    array.call_method("setflags", (), Some(&flags))?;
    Ok(())
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

    /// The scene the paths were simulated on.
    #[getter]
    fn scene(&self) -> PyScene {
        PyScene {
            scene: self.record.scene.clone(),
        }
    }

    /// The seed: path i drew from the stream (seed, i).
    #[getter]
    fn seed(&self) -> u64 {
        self.record.seed
    }

    /// N, the number of steps of h = T / N.
    #[getter]
    fn steps(&self) -> usize {
        self.record.steps
    }

    /// k: t_0, every k-th step and t_N were recorded.
    #[getter]
    fn every(&self) -> usize {
        self.record.every
    }

    /// Writes the paths to `path` as a `.npz` file (the name as given): every array, the
    /// failures, the scene, the scheme, the seed, the steps and the stride. `Paths.load` reads
    /// it back to an equal `Paths`; `numpy.load` reads it without pickled objects.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        paths_io::save(py, &self.state(py)?, &path)
    }

    /// The paths of a `.npz` file written by `save`: `OSError` if it cannot be read,
    /// `ValueError` naming the file and what is wrong if it holds something else.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let (run, record) = paths_io::load(py, &path)?;
        Self::new(py, run, record)
    }

    /// The paths of a state (`__reduce__`); `ValueError` naming the entry that is wrong.
    #[staticmethod]
    fn _from_state(state: &Bound<'_, PyDict>) -> PyResult<Self> {
        let (run, record) = paths_io::from_state(state)?;
        Self::new(state.py(), run, record)
    }

    /// Writes the paths as extended XYZ files into the folder `folder` (made if missing), one
    /// file per path, `<scene>.path-<p>.xyz`, one frame per recorded time (VMD, OVITO, ASE);
    /// returns the files written. A failed path's NaN states are left out. `OSError` naming the
    /// file that cannot be written; `ValueError` for a scene whose coordinates are not points.
    fn to_xyz(&self, py: Python<'_>, folder: PathBuf) -> PyResult<Vec<PathBuf>> {
        self.write(py, TrajectoryFormat::Xyz, folder)
    }

    /// Writes the paths as VTK files into the folder `folder` (made if missing): one XML
    /// unstructured grid per recorded time, `<scene>.<j>.vtu`, each path's chain of beads a
    /// polyline, and the collection `<scene>.pvd` that ParaView opens as one time series;
    /// returns the files written, the collection first. `ValueError` for a scene that is not a
    /// chain of beads in 3-D (a fiber, a chain molecule); `OSError` as `to_xyz`.
    fn to_vtk(&self, py: Python<'_>, folder: PathBuf) -> PyResult<Vec<PathBuf>> {
        self.write(py, TrajectoryFormat::Vtk, folder)
    }

    /// Pickles as the state `save` writes, so that paths go to and from `multiprocessing`
    /// workers and files.
    fn __reduce__<'py>(
        &self, py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyDict>,))> {
        let rebuild = py.get_type::<PyPaths>().getattr("_from_state")?;
        Ok((rebuild, (self.state(py)?,)))
    }

    /// Equal paths: the same scheme, h, scene, seed, steps, stride, failures, and arrays equal
    /// element by element (NaN equal to NaN).
    fn __eq__(&self, py: Python<'_>, other: &Self) -> PyResult<bool> {
        if (&self.scheme, self.h, &self.record, &self.failures)
            != (&other.scheme, other.h, &other.record, &other.failures)
        {
            return Ok(false);
        }
        let (mine, theirs) = (self.state(py)?, other.state(py)?);
        if mine.len() != theirs.len() {
            return Ok(false);
        }
        let numpy = py.import("numpy")?;
        let keywords = PyDict::new(py);
        for (key, array) in mine.iter() {
            let Some(other_array) = theirs.get_item(&key)? else {
                return Ok(false);
            };
            if key.extract::<String>()? == "meta" {
                continue;
            }
            let real = array
                .getattr("dtype")?
                .getattr("kind")?
                .extract::<String>()?
                == "f";
            keywords.set_item("equal_nan", real)?;
            let same = numpy.call_method("array_equal", (&array, &other_array), Some(&keywords))?;
            if !same.is_truthy()? {
                return Ok(false);
            }
        }
        Ok(true)
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
