//! A scene dict as the library reads it. The dict is written as JSON text, one value a line,
//! with the dotted key of each line (`system.pendulum.length`, `outputs[0]`), so that a value
//! the scene's reader refuses is named by its key. Numpy scalars and arrays are taken as the
//! numbers and lists they hold; NaN and infinity, which JSON cannot hold, are refused by key,
//! as are values no scene file holds (sets, objects).

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyMapping, PyString, PyTuple};
use sdae_study::scene::Scene;

use crate::errors::to_py;

/// Tables and lists nested deeper than this are refused (a dict that holds itself).
const MAX_DEPTH: usize = 32;

/// The scene of `table`, a dict with the keys of a scene file; a value refused as the scene
/// is read is named by its dotted key.
pub fn scene_of_dict(table: &Bound<'_, PyDict>) -> PyResult<Scene> {
    let py = table.py();
    let mut json = Json {
        lines: Vec::new(),
        keys: Vec::new(),
        numpy_scalar: py.import("numpy")?.getattr("generic")?,
    };
    json.value("", String::new(), table.as_any(), 0)?;
    let text = json.lines.join("\n");
    if let Err(e) = serde_json::from_str::<Scene>(&text) {
        return Err(PyValueError::new_err(json.refusal(&e)));
    }
    Scene::from_json(&text).map_err(to_py)
}

/// JSON text being written, one value a line, and the dotted key of each line.
struct Json<'py> {
    lines: Vec<String>,
    keys: Vec<String>,
    /// `numpy.generic`, the type of numpy's scalars.
    numpy_scalar: Bound<'py, PyAny>,
}

impl<'py> Json<'py> {
    /// Writes `ob`, the value of `key`, after `head` (`"length": ` in a table, nothing in a
    /// list), its members and entries on lines of their own.
    fn value(
        &mut self, key: &str, head: String, ob: &Bound<'py, PyAny>, depth: usize,
    ) -> PyResult<()> {
        if depth > MAX_DEPTH {
            let outer = key.split(['.', '[']).next().unwrap_or(key);
            return Err(PyValueError::new_err(format!(
                "{outer}: tables and lists nested more than {MAX_DEPTH} deep (a table that holds \
                 itself?)"
            )));
        }
        if let Some(plain) = self.numpy_value(ob)? {
            return self.value(key, head, &plain, depth + 1);
        }
        if let Some(table) = as_table(ob)? {
            self.push(key, format!("{head}{{"));
            let members = table.len();
            for (k, (name, member)) in table.iter().enumerate() {
                let name = name.cast::<PyString>().map_err(|_| {
                    PyTypeError::new_err(format!(
                        "{}: a key is a string, not {}",
                        shown_key(key),
                        type_name(&name)
                    ))
                })?;
                let name = name.to_cow()?;
                let head = format!("{}: ", json_string(&name));
                self.value(&member_key(key, &name), head, &member, depth + 1)?;
                self.comma(k + 1 < members);
            }
            self.push(key, "}".into());
        } else if let Some(entries) = as_list(ob) {
            self.push(key, format!("{head}["));
            for (i, entry) in entries.iter().enumerate() {
                self.value(&format!("{key}[{i}]"), String::new(), entry, depth + 1)?;
                self.comma(i + 1 < entries.len());
            }
            self.push(key, "]".into());
        } else {
            let scalar = scalar(key, ob)?;
            self.push(key, format!("{head}{scalar}"));
        }
        Ok(())
    }

    /// The Python value a numpy array (`tolist()`) or scalar (`item()`) holds, or `None` for
    /// anything else.
    fn numpy_value(&self, ob: &Bound<'py, PyAny>) -> PyResult<Option<Bound<'py, PyAny>>> {
        if ob.cast::<numpy::PyUntypedArray>().is_ok() {
            return ob.call_method0("tolist").map(Some);
        }
        if ob.is_instance(&self.numpy_scalar)? {
            return ob.call_method0("item").map(Some);
        }
        Ok(None)
    }

    /// A line of `key`.
    fn push(&mut self, key: &str, line: String) {
        self.lines.push(line);
        self.keys.push(key.to_string());
    }

    /// Ends the last line with a comma when more members or entries follow.
    fn comma(&mut self, more: bool) {
        if let (true, Some(line)) = (more, self.lines.last_mut()) {
            line.push(',');
        }
    }

    /// The reader's refusal `e` of the text, named by the key of the line it points at.
    fn refusal(&self, e: &serde_json::Error) -> String {
        let full = e.to_string();
        let position = format!(" at line {} column {}", e.line(), e.column());
        let message = full.strip_suffix(&position).unwrap_or(&full);
        match self.keys.get(e.line().wrapping_sub(1)) {
            Some(key) if !key.is_empty() => format!("{key}: {message}"),
            _ => format!("scene dict: {message}"),
        }
    }
}

/// `ob` as a dict when it is a mapping (a dict made of another mapping).
fn as_table<'py>(ob: &Bound<'py, PyAny>) -> PyResult<Option<Bound<'py, PyDict>>> {
    if let Ok(dict) = ob.cast::<PyDict>() {
        return Ok(Some(dict.clone()));
    }
    if ob.cast::<PyMapping>().is_ok() {
        let dict = ob.py().get_type::<PyDict>().call1((ob,))?;
        return Ok(Some(dict.cast_into::<PyDict>()?));
    }
    Ok(None)
}

/// The entries of `ob` when it is a list or a tuple.
fn as_list<'py>(ob: &Bound<'py, PyAny>) -> Option<Vec<Bound<'py, PyAny>>> {
    if let Ok(list) = ob.cast::<PyList>() {
        return Some(list.iter().collect());
    }
    ob.cast::<PyTuple>().ok().map(|t| t.iter().collect())
}

/// `ob`, the value of `key`, as a JSON scalar: None, a bool, a string, a whole number within
/// 64 bits or a finite float.
fn scalar(key: &str, ob: &Bound<'_, PyAny>) -> PyResult<String> {
    if ob.is_none() {
        return Ok("null".into());
    }
    if let Ok(b) = ob.cast::<PyBool>() {
        return Ok(b.is_true().to_string());
    }
    if let Ok(s) = ob.cast::<PyString>() {
        return Ok(json_string(&s.to_cow()?));
    }
    if ob.cast::<PyInt>().is_ok() {
        return whole(key, ob);
    }
    if let Ok(f) = ob.cast::<PyFloat>() {
        return finite(key, f.value());
    }
    Err(PyTypeError::new_err(format!(
        "{} = {}: a scene holds numbers, strings, booleans, lists and tables, not {}",
        shown_key(key),
        ob.repr()?,
        type_name(ob)
    )))
}

/// A Python int as JSON, or a `ValueError` naming `key` beyond 64 bits.
fn whole(key: &str, ob: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(n) = ob.extract::<i64>() {
        return Ok(n.to_string());
    }
    ob.extract::<u64>().map(|n| n.to_string()).map_err(|_| {
        PyValueError::new_err(format!(
            "{} = {}: must be from -2^63 to 2^64 - 1",
            shown_key(key),
            ob.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        ))
    })
}

/// A float as JSON, or a `ValueError` naming `key` for NaN and infinity.
fn finite(key: &str, x: f64) -> PyResult<String> {
    serde_json::Number::from_f64(x)
        .map(|n| n.to_string())
        .ok_or_else(|| {
            let shown = if x.is_nan() {
                "nan"
            } else if x > 0.0 {
                "inf"
            } else {
                "-inf"
            };
            PyValueError::new_err(format!(
                "{} = {shown}: must be finite (a scene holds no NaN or infinity)",
                shown_key(key)
            ))
        })
}

/// `text` as a JSON string.
fn json_string(text: &str) -> String {
    serde_json::Value::from(text).to_string()
}

/// The dotted key of member `name` of the table at `key`.
fn member_key(key: &str, name: &str) -> String {
    if key.is_empty() {
        name.to_string()
    } else {
        format!("{key}.{name}")
    }
}

/// `key` as a message names it: the whole dict where it is the top level.
fn shown_key(key: &str) -> &str {
    if key.is_empty() { "scene dict" } else { key }
}

/// The name of `ob`'s type.
fn type_name(ob: &Bound<'_, PyAny>) -> String {
    ob.get_type()
        .name()
        .map_or_else(|_| "?".into(), |n| n.to_string())
}
