//! Keyword values as the library takes them: counts and seeds from Python integers of any
//! size, schemes by name; a value out of range is a `ValueError` naming its keyword.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use sdae_study::convergence::MAX_THREADS;
use sdae_study::integrator::SchemeKind;

/// The names of the built-in schemes.
#[pyfunction]
pub fn schemes() -> Vec<&'static str> {
    SchemeKind::ALL.iter().map(|k| k.name()).collect()
}

/// `value` as a count or seed, or a `ValueError` naming `name` where it is negative or too
/// large for the setting.
pub fn whole<T: TryFrom<i128>>(name: &str, value: i128) -> PyResult<T> {
    T::try_from(value).map_err(|_| {
        let largest = match std::any::type_name::<T>() {
            "u32" => u64::from(u32::MAX),
            _ => u64::MAX,
        };
        PyValueError::new_err(format!(
            "{name} = {value}: must be a whole number from 0 to {largest}"
        ))
    })
}

/// `value` as worker threads asked for: 1 to [`MAX_THREADS`], as the command line's `--threads`
/// takes them, or a `ValueError` naming `threads` (how many start is the run's business).
pub fn thread_count(value: i128) -> PyResult<usize> {
    match whole("threads", value)? {
        n @ 1..=MAX_THREADS => Ok(n),
        n => Err(PyValueError::new_err(format!(
            "threads = {n}: must be in 1..={MAX_THREADS}"
        ))),
    }
}

/// The built-in scheme `name`, or a `ValueError` naming the keyword `keyword`.
pub fn scheme_kind(keyword: &str, name: &str) -> PyResult<SchemeKind> {
    SchemeKind::from_name(name).ok_or_else(|| {
        PyValueError::new_err(format!(
            "{keyword} = {name:?}: not a built-in scheme (one of {})",
            schemes().join(", ")
        ))
    })
}
