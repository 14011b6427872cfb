//! A study's report as Python sees it: the JSON, CSV and Markdown the command line writes, and
//! the files themselves on request. The package's `Report` class (python/sdae/report.py) reads
//! the JSON into plain numbers, lists and numpy arrays, and the CSV into rows.

use std::fmt::Write as _;
use std::path::PathBuf;

use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use sdae_study::StudyError;
use sdae_study::convergence::ConvergenceReport;
use sdae_study::files::{write_atomically, write_json};
use sdae_study::mlmc::expect_report;
use sdae_study::mlmc::{MlmcReport, SceneExpectation};
use sdae_study::stability::StabilityReport;
use sdae_study::weak::WeakReport;

use crate::errors::to_py;

/// A finished study.
pub enum Study {
    /// Strong errors, orders and run time.
    Convergence(Box<ConvergenceReport>),
    /// Weak errors and orders.
    Weak(Box<WeakReport>),
    /// Failures and residuals on stiff and extreme scenes.
    Stability(Box<StabilityReport>),
    /// Multilevel Monte Carlo's test, rates and complexity.
    Mlmc(Box<MlmcReport>),
    /// E[f(X_T)] to a requested accuracy.
    Expectation(Box<SceneExpectation>),
}

impl Study {
    /// The study's name.
    fn kind(&self) -> &'static str {
        match self {
            Study::Convergence(_) => "convergence",
            Study::Weak(_) => "weak",
            Study::Stability(_) => "stability",
            Study::Mlmc(_) => "mlmc",
            Study::Expectation(_) => "expectation",
        }
    }

    /// The report as the JSON file the command line writes.
    fn json(&self) -> Result<String, serde_json::Error> {
        match self {
            Study::Convergence(r) => serde_json::to_string(r),
            Study::Weak(r) => serde_json::to_string(r),
            Study::Stability(r) => serde_json::to_string(r),
            Study::Mlmc(r) => serde_json::to_string(r),
            Study::Expectation(r) => serde_json::to_string(r),
        }
    }

    /// The report's CSV tables (blank lines between tables): the command line's file, for
    /// stability each scene's convergence table with the scene's name in front.
    fn csv(&self) -> String {
        match self {
            Study::Convergence(r) => sdae_study::output::csv(r),
            Study::Weak(r) => sdae_study::weak::report::csv(r),
            Study::Stability(r) => stability_csv(r),
            Study::Mlmc(r) => sdae_study::mlmc::report::csv(r),
            Study::Expectation(r) => expect_report::csv(r),
        }
    }

    /// The report in Markdown, as in the command line's `.md` file.
    fn markdown(&self) -> String {
        match self {
            Study::Convergence(r) => sdae_study::output::markdown(r),
            Study::Weak(r) => sdae_study::weak::report::markdown(r),
            Study::Stability(r) => sdae_study::stability::markdown(r),
            Study::Mlmc(r) => sdae_study::mlmc::report::markdown(r),
            Study::Expectation(r) => expect_report::markdown(r),
        }
    }

    /// Writes the files the command line writes for this study into `dir`, made if missing;
    /// an `OSError` naming the folder, or the file, that cannot be written and why.
    fn write(&self, dir: &std::path::Path) -> PyResult<()> {
        std::fs::create_dir_all(dir).map_err(|e| {
            PyOSError::new_err(format!(
                "cannot write the report to the folder {}: {e}",
                dir.display()
            ))
        })?;
        self.write_files(dir).map_err(to_py)
    }

    /// Writes the study's files into the folder `dir`.
    fn write_files(&self, dir: &std::path::Path) -> Result<(), StudyError> {
        match self {
            Study::Convergence(r) => sdae_study::output::write_report(r, dir),
            Study::Weak(r) => sdae_study::weak::report::write_report(r, dir),
            Study::Stability(r) => sdae_study::stability::write_report(r, dir),
            Study::Mlmc(r) => sdae_study::mlmc::report::write_report(r, dir),
            Study::Expectation(r) => {
                write_json(&dir.join("expectation.json"), r)?;
                write_atomically(&dir.join("expectation.csv"), &expect_report::csv(r))
            }
        }
    }
}

/// Each stability scene's convergence table, a `scene` column in front.
fn stability_csv(report: &StabilityReport) -> String {
    let mut out = String::new();
    for scene in &report.scenes {
        let table = sdae_study::output::csv(&scene.report);
        let mut lines = table.lines();
        if out.is_empty() {
            if let Some(header) = lines.next() {
                let _ = writeln!(out, "scene,{header}");
            }
        } else {
            lines.next();
        }
        for line in lines {
            let _ = writeln!(out, "{},{line}", scene.report.scene);
        }
    }
    out
}

/// A study's report: `kind`, its JSON (`to_json`), CSV tables (`csv`) and Markdown
/// (`markdown`), and `write(folder)` for the command line's files.
#[pyclass(name = "Report", module = "sdae._sdae", frozen)]
pub struct PyReport {
    study: Study,
    json: String,
}

impl PyReport {
    /// The report of a finished study.
    pub fn new(study: Study) -> PyResult<Self> {
        let json = study
            .json()
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        Ok(Self { study, json })
    }
}

#[pymethods]
impl PyReport {
    /// The study: "convergence", "weak", "stability", "mlmc" or "expectation".
    #[getter]
    fn kind(&self) -> &'static str {
        self.study.kind()
    }

    /// The report as the command line's JSON file.
    fn to_json(&self) -> &str {
        &self.json
    }

    /// The report's CSV tables, a blank line between two tables.
    #[getter]
    fn csv(&self) -> String {
        self.study.csv()
    }

    /// The report in Markdown.
    #[getter]
    fn markdown(&self) -> String {
        self.study.markdown()
    }

    /// Writes the command line's files of this study (JSON, CSV, Markdown, SVG plots) into
    /// `folder`, made if missing; an `OSError` naming the folder, or the file, that cannot be
    /// written, and why.
    fn write(&self, folder: PathBuf) -> PyResult<()> {
        self.study.write(&folder)
    }

    fn __repr__(&self) -> String {
        format!(
            "Report({:?}, {} bytes of JSON)",
            self.study.kind(),
            self.json.len()
        )
    }
}
