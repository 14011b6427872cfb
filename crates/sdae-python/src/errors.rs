//! The library's errors as Python exceptions: a refused setting or scene is a `ValueError`, a
//! file that cannot be read an `OSError`, anything else a `RuntimeError`; each with the
//! library's message.

use pyo3::PyErr;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use sdae_study::StudyError;

/// The Python exception of a library error.
pub fn to_py(error: StudyError) -> PyErr {
    let message = error.to_string();
    match error {
        StudyError::Format { .. }
        | StudyError::Invalid { .. }
        | StudyError::Unknown(_)
        | StudyError::Setting { .. }
        | StudyError::SchemeNotApplicable { .. }
        | StudyError::UnknownObservable { .. }
        | StudyError::ObservableNeedsOutput { .. }
        | StudyError::Model(_) => PyValueError::new_err(message),
        StudyError::Io { .. } | StudyError::Read { .. } | StudyError::Write { .. } => {
            PyOSError::new_err(message)
        }
        _ => PyRuntimeError::new_err(message),
    }
}
