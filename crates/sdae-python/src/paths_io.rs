//! Recorded paths to and from a file and a pickle. Both go through one state: a dict of the
//! numpy arrays (`times`, `positions`, `velocities`, `multipliers` and `diagnostics.<name>`)
//! and `meta`, a JSON text with what the arrays do not hold (the format and its version, the
//! scheme, h, the seed, the steps, the recording stride, the scene as TOML and the failures).
//! `Paths.save` writes the state as a `.npz` file (`numpy.savez`, no pickled objects), and
//! pickling a `Paths` pickles the state. Reading a state back checks every entry, so that a
//! file of something else is a `ValueError` naming what is wrong, not a crash.

use std::path::Path;

use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use sdae_model::PathDiagnostics;
use sdae_study::integrator::SchemeKind;
use sdae_study::scene::Scene;
use sdae_study::simulate::{SimulateSettings, SimulatedPaths};
use serde_json::{Value, json};

/// The `format` of a state's `meta`.
const FORMAT: &str = "sdae-paths";

/// The version of the state written; a state of another version is refused.
const VERSION: u64 = 1;

/// The first bytes of a `.npz` file: a zip archive's local file header.
const ZIP: &[u8] = b"PK\x03\x04";

/// What a run was, beyond its arrays: the scene, the seed, the steps and the recording stride.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// The scene the paths were simulated on.
    pub scene: Scene,
    /// Path i drew from the stream (seed, i).
    pub seed: u64,
    /// N: the step was h = T / N.
    pub steps: usize,
    /// k: t_0, every k-th step and t_N were recorded.
    pub every: usize,
}

/// How one column of the diagnostics reads a path's value and sets it.
enum Column {
    /// A count, kept as uint64.
    Count(
        fn(&PathDiagnostics) -> usize,
        fn(&mut PathDiagnostics, usize),
    ),
    /// A real number, kept as float64.
    Real(fn(&PathDiagnostics) -> f64, fn(&mut PathDiagnostics, f64)),
}

/// The diagnostics a `Paths` shows, by name.
const COLUMNS: [(&str, Column); 10] = [
    ("steps", Column::Count(|d| d.steps, |d, x| d.steps = x)),
    (
        "truncated_steps",
        Column::Count(|d| d.truncated_steps, |d, x| d.truncated_steps = x),
    ),
    ("min_eta", Column::Real(|d| d.min_eta, |d, x| d.min_eta = x)),
    (
        "newton_iterations",
        Column::Count(|d| d.newton_iterations, |d, x| d.newton_iterations = x),
    ),
    (
        "max_position_residual",
        Column::Real(
            |d| d.max_position_residual,
            |d, x| d.max_position_residual = x,
        ),
    ),
    (
        "max_velocity_residual",
        Column::Real(
            |d| d.max_velocity_residual,
            |d, x| d.max_velocity_residual = x,
        ),
    ),
    (
        "homotopy_steps",
        Column::Count(|d| d.homotopy_steps, |d, x| d.homotopy_steps = x),
    ),
    (
        "max_kappa_ratio",
        Column::Real(|d| d.max_kappa_ratio, |d, x| d.max_kappa_ratio = x),
    ),
    (
        "clock_lag",
        Column::Real(|d| d.clock_lag, |d, x| d.clock_lag = x),
    ),
    (
        "rounding_certified_steps",
        Column::Count(
            |d| d.rounding_certified_steps,
            |d, x| d.rounding_certified_steps = x,
        ),
    ),
];

/// Each path's diagnostics as arrays of length P, by column name.
pub fn diagnostics<'py>(
    py: Python<'py>, diagnostics: &[PathDiagnostics],
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (name, column) in &COLUMNS {
        let array = match column {
            Column::Count(get, _) => {
                let values: Vec<u64> = diagnostics.iter().map(|d| get(d) as u64).collect();
                values.into_pyarray(py).into_any()
            }
            Column::Real(get, _) => {
                let values: Vec<f64> = diagnostics.iter().map(get).collect();
                values.into_pyarray(py).into_any()
            }
        };
        dict.set_item(*name, array)?;
    }
    Ok(dict)
}

/// The `meta` text of a state.
pub fn meta(
    scheme: &str, h: f64, record: &Record, failures: &[Option<String>],
) -> PyResult<String> {
    let scene = record.scene.to_toml().map_err(crate::errors::to_py)?;
    Ok(json!({
        "format": FORMAT,
        "version": VERSION,
        "scheme": scheme,
        "h": h,
        "seed": record.seed,
        "steps": record.steps,
        "every": record.every,
        "scene": scene,
        "failures": failures,
    })
    .to_string())
}

/// A refusal of a state: what is wrong with which entry.
fn refused(entry: &str, why: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{entry}: {why}"))
}

/// The run and its record that a state holds (each array copied), or a `ValueError` naming the
/// entry that is missing, of the wrong kind or of the wrong shape.
pub fn from_state(state: &Bound<'_, PyDict>) -> PyResult<(SimulatedPaths, Record)> {
    let meta = meta_of(&entry(state, "meta")?)?;
    let text = |key: &str| -> PyResult<String> {
        meta.get(key)
            .and_then(Value::as_str)
            .map(str::to_owned)
            .ok_or_else(|| refused("meta", format!("no text `{key}`")))
    };
    let whole = |key: &str| -> PyResult<u64> {
        meta.get(key)
            .and_then(Value::as_u64)
            .ok_or_else(|| refused("meta", format!("no whole number `{key}`")))
    };
    let count = |key: &str| -> PyResult<usize> {
        usize::try_from(whole(key)?).map_err(|_| refused("meta", format!("`{key}` too large")))
    };
    if meta.get("format").and_then(Value::as_str) != Some(FORMAT) {
        return Err(refused("meta", format!("format is not {FORMAT:?}")));
    }
    match whole("version")? {
        VERSION => {}
        v => {
            return Err(refused(
                "meta",
                format!("version {v}: this sdae reads version {VERSION}"),
            ));
        }
    }
    let scheme = text("scheme")?;
    let kind = SchemeKind::from_name(&scheme).ok_or_else(|| {
        refused(
            "meta",
            format!("scheme {scheme:?} is not a built-in scheme"),
        )
    })?;
    let h = meta
        .get("h")
        .and_then(Value::as_f64)
        .filter(|h| h.is_finite() && *h > 0.0)
        .ok_or_else(|| refused("meta", "no positive step `h`"))?;
    let scene = Scene::from_toml(&text("scene")?)
        .and_then(|scene| scene.check_system().map(|()| scene))
        .map_err(|e| refused("meta.scene", e))?;
    let record = Record {
        scene,
        seed: whole("seed")?,
        steps: count("steps")?,
        every: count("every")?,
    };
    let failures = failures_of(&meta)?;
    let run = arrays_of(state, scheme, h, failures)?;
    let settings = SimulateSettings::new(kind, run.failures.len(), record.steps, record.seed)
        .and_then(|s| s.every(record.every))
        .map_err(|e| refused("meta", e))?;
    if settings.records() != run.times.len() {
        return Err(refused(
            "times",
            format!(
                "{} times, but {} steps recorded every {} make {}",
                run.times.len(),
                record.steps,
                record.every,
                settings.records()
            ),
        ));
    }
    Ok((run, record))
}

/// The entry `key` of a state, or a refusal naming it.
fn entry<'py>(state: &Bound<'py, PyDict>, key: &str) -> PyResult<Bound<'py, PyAny>> {
    state.get_item(key)?.ok_or_else(|| refused(key, "missing"))
}

/// The JSON of `meta`: a str, or the 0-d array of text `numpy.load` gives back.
fn meta_of(value: &Bound<'_, PyAny>) -> PyResult<Value> {
    let text: String = match value.extract::<String>() {
        Ok(text) => text,
        Err(_) => value
            .cast::<numpy::PyUntypedArray>()
            .ok()
            .filter(|a| a.ndim() == 0)
            .and_then(|a| a.call_method0("item").ok())
            .and_then(|item| item.extract::<String>().ok())
            .ok_or_else(|| refused("meta", "not a text"))?,
    };
    serde_json::from_str(&text).map_err(|e| refused("meta", e))
}

/// The failures of `meta`: one message or null per path.
fn failures_of(meta: &Value) -> PyResult<Vec<Option<String>>> {
    let list = meta
        .get("failures")
        .and_then(Value::as_array)
        .ok_or_else(|| refused("meta", "no list `failures`"))?;
    list.iter()
        .map(|failure| match failure {
            Value::Null => Ok(None),
            Value::String(message) => Ok(Some(message.clone())),
            other => Err(refused(
                "meta",
                format!("failure {other}: not a text or null"),
            )),
        })
        .collect()
}

/// The arrays of a state, checked against each other and the `failures`' P.
fn arrays_of(
    state: &Bound<'_, PyDict>, scheme: String, h: f64, failures: Vec<Option<String>>,
) -> PyResult<SimulatedPaths> {
    let p = failures.len();
    let (times, shape) = real_array(state, "times", 1)?;
    let t = shape[0];
    let (positions, shape) = real_array(state, "positions", 3)?;
    let n = shape[2];
    expect_shape("positions", &shape, [p, t, n])?;
    let (velocities, shape) = real_array(state, "velocities", 3)?;
    expect_shape("velocities", &shape, [p, t, n])?;
    let (multipliers, shape) = real_array(state, "multipliers", 3)?;
    let m = shape[2];
    expect_shape("multipliers", &shape, [p, t, m])?;
    Ok(SimulatedPaths {
        scheme,
        n,
        m,
        h,
        times,
        positions,
        velocities,
        multipliers,
        diagnostics: diagnostics_of(state, p)?,
        failures,
    })
}

/// A refusal unless `shape` is `expected` (P and T of the other arrays).
fn expect_shape(key: &str, shape: &[usize], expected: [usize; 3]) -> PyResult<()> {
    if shape == expected {
        return Ok(());
    }
    Err(refused(
        key,
        format!("shape {shape:?}, expected {expected:?} (paths, times, coordinates)"),
    ))
}

/// The float64 array `key` of `ndim` dimensions, copied in C order, and its shape.
fn real_array(
    state: &Bound<'_, PyDict>, key: &str, ndim: usize,
) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let value = entry(state, key)?;
    let array = value
        .cast::<PyArrayDyn<f64>>()
        .map_err(|_| refused(key, format!("not a float64 array ({})", kind_of(&value))))?;
    if array.ndim() != ndim {
        return Err(refused(
            key,
            format!("{} dimensions, expected {ndim}", array.ndim()),
        ));
    }
    let shape = array.shape().to_vec();
    let values = array.readonly().as_array().iter().copied().collect();
    Ok((values, shape))
}

/// The diagnostics columns of a state, each of length `p`.
fn diagnostics_of(state: &Bound<'_, PyDict>, p: usize) -> PyResult<Vec<PathDiagnostics>> {
    let mut diagnostics = vec![PathDiagnostics::default(); p];
    for (name, column) in &COLUMNS {
        let key = format!("diagnostics.{name}");
        let value = entry(state, &key)?;
        let wrong = |what: &str| {
            refused(
                &key,
                format!("not a 1-D {what} array of length {p} ({})", kind_of(&value)),
            )
        };
        match column {
            Column::Count(_, set) => {
                let array = value
                    .cast::<PyArrayDyn<u64>>()
                    .map_err(|_| wrong("uint64"))?;
                if array.shape() != [p] {
                    return Err(wrong("uint64"));
                }
                for (d, x) in diagnostics
                    .iter_mut()
                    .zip(array.readonly().as_array().iter())
                {
                    set(d, usize::try_from(*x).map_err(|_| wrong("uint64"))?);
                }
            }
            Column::Real(_, set) => {
                let array = value
                    .cast::<PyArrayDyn<f64>>()
                    .map_err(|_| wrong("float64"))?;
                if array.shape() != [p] {
                    return Err(wrong("float64"));
                }
                for (d, x) in diagnostics
                    .iter_mut()
                    .zip(array.readonly().as_array().iter())
                {
                    set(d, *x);
                }
            }
        }
    }
    Ok(diagnostics)
}

/// What a value is, for a refusal: an array's dtype and shape, or the value's type.
fn kind_of(value: &Bound<'_, PyAny>) -> String {
    match value.cast::<numpy::PyUntypedArray>() {
        Ok(array) => {
            let dtype = array
                .dtype()
                .str()
                .map(|s| s.to_string())
                .unwrap_or_default();
            format!("{dtype} of shape {:?}", array.shape())
        }
        Err(_) => value
            .get_type()
            .name()
            .map(|n| format!("a {n}"))
            .unwrap_or_else(|_| "an object".into()),
    }
}

/// Writes `state` to `path` as a `.npz` file (the name as given, `.npz` not appended); an
/// `OSError` naming the file if it cannot be written.
pub fn save(py: Python<'_>, state: &Bound<'_, PyDict>, path: &Path) -> PyResult<()> {
    let file = py.import("builtins")?.call_method1("open", (path, "wb"))?;
    let written = py
        .import("numpy")?
        .call_method("savez", (&file,), Some(state));
    let closed = file.call_method0("close");
    written?;
    closed?;
    Ok(())
}

/// The run and record of the `.npz` file at `path`: an `OSError` if it cannot be opened, a
/// `ValueError` naming the file and what is wrong if it is not paths written by `Paths.save`
/// (no pickled objects are read).
pub fn load(py: Python<'_>, path: &Path) -> PyResult<(SimulatedPaths, Record)> {
    let file = py.import("builtins")?.call_method1("open", (path, "rb"))?;
    let read = read_npz(py, &file);
    let closed = file.call_method0("close");
    let loaded = read.and_then(|state| from_state(&state)).map_err(|e| {
        PyValueError::new_err(format!(
            "{}: not paths written by Paths.save: {}",
            path.display(),
            e.value(py)
        ))
    })?;
    closed?;
    Ok(loaded)
}

/// Every entry of the `.npz` file open as `file`, read into memory.
fn read_npz<'py>(py: Python<'py>, file: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let keywords = PyDict::new(py);
    keywords.set_item("allow_pickle", false)?;
    let start = file.call_method1("read", (ZIP.len(),))?;
    let start = start.cast::<PyBytes>()?.as_bytes();
    if start != ZIP {
        return Err(PyValueError::new_err(format!(
            "not a .npz archive (a zip file, starting with \"PK\\x03\\x04\"): it starts with {:?}",
            String::from_utf8_lossy(start)
        )));
    }
    file.call_method1("seek", (0,))?;
    let npz = py
        .import("numpy")?
        .call_method("load", (file,), Some(&keywords))?;
    let state = PyDict::new(py);
    for key in npz.getattr("files")?.try_iter()? {
        let key = key?;
        state.set_item(&key, npz.get_item(&key)?)?;
    }
    npz.call_method0("close")?;
    Ok(state)
}
