//! Scenes from Python: a built-in one by name, a TOML file or text, or a dict with the keys of
//! a scene file; checked as the command line checks them before a study, system and initial
//! state included, so that what a run would refuse is refused when the scene is made.

use std::path::{Path, PathBuf};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sdae_study::scene::{BUILT_IN, Scene, SystemSpec};

use crate::errors::to_py;
use crate::scene_dict::scene_of_dict;

/// The names of the built-in scenes.
#[pyfunction]
pub fn built_in_scenes() -> Vec<&'static str> {
    BUILT_IN.iter().map(|(name, _)| *name).collect()
}

/// A scene: a system, its parameters, the initial state, T and the study defaults.
#[pyclass(name = "Scene", module = "sdae._sdae", frozen)]
#[derive(Clone)]
pub struct PyScene {
    pub scene: Scene,
}

#[pymethods]
impl PyScene {
    /// The built-in scene `name` (see `built_in_scenes()`).
    #[staticmethod]
    fn built_in(name: &str) -> PyResult<Self> {
        Self::checked(Scene::built_in(name).map_err(to_py)?, None)
    }

    /// The scene written as TOML text, in the format of a scene file.
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        Self::checked(Scene::from_toml(text).map_err(to_py)?, None)
    }

    /// The scene of a scene file.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        Self::checked(Scene::from_file(&path).map_err(to_py)?, Some(&path))
    }

    /// The scene of a dict with the keys of a scene file (nested dicts for its tables, numpy
    /// scalars and 1-D arrays taken as numbers and lists); a refused value is named by its
    /// dotted key (`system.pendulum.length`), NaN and infinity included.
    #[staticmethod]
    fn from_dict(table: &Bound<'_, PyDict>) -> PyResult<Self> {
        Self::checked(scene_of_dict(table)?, None)
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> &str {
        &self.scene.name
    }

    /// One line on what the scene shows.
    #[getter]
    fn description(&self) -> &str {
        &self.scene.description
    }

    /// The final time T.
    #[getter]
    fn t_end(&self) -> f64 {
        self.scene.t_end
    }

    /// The scene as TOML text (reads back to an equal scene).
    fn to_toml(&self) -> PyResult<String> {
        self.scene.to_toml().map_err(to_py)
    }

    /// The scene as a dict with the keys of a scene file.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let json = serde_json::to_string(&self.scene)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        py.import("json")?.call_method1("loads", (json,))
    }

    fn __repr__(&self) -> String {
        format!("Scene({:?}, T={})", self.scene.name, self.scene.t_end)
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.scene == other.scene
    }

    /// Pickles as its TOML text, so that scenes go to `multiprocessing` workers.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let rebuild = py.get_type::<PyScene>().getattr("from_toml")?;
        Ok((rebuild, (self.to_toml()?,)))
    }
}

impl PyScene {
    /// `scene` once its system is built and its initial state checked
    /// ([`Scene::check_system`]), as the command line checks a scene before a study; a refusal
    /// of a scene read from `file` names the file, as there. A system built in code is refused
    /// here: from Python no code can build it.
    fn checked(scene: Scene, file: Option<&Path>) -> PyResult<Self> {
        if let SystemSpec::Custom(name) = &scene.system {
            return Err(PyValueError::new_err(format!(
                "system.custom = {name:?}: a system built in code runs from Rust only \
                 (Scene::prepare_custom); from Python, write the system as expressions in \
                 system.expressions (docs/custom-systems.md)"
            )));
        }
        scene.check_system().map_err(|e| match file {
            Some(file) => to_py(e.in_scene_file(&file.display().to_string())),
            None => to_py(e),
        })?;
        Ok(Self { scene })
    }
}
