//! The studies from Python: convergence, weak, stability and MLMC runs with the command line's
//! options ([`sdae_study::options`]), and the expectation helper (the estimator a pilot predicts
//! cheapest); each returns a [`PyReport`].
//!
//! A keyword left at None keeps the scene's value, as an option not typed on the command line
//! does. A setting the library refuses is a `ValueError` named by its keyword when the caller
//! gave it, else by its key in the scene file.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use sdae_mlmc::expectation::{CostMeasure, Method};
use sdae_mlmc::{MlmcError, RunControl};
use sdae_study::StudyError;
use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::integrator::SchemeKind;
use sdae_study::mlmc::{
    ExpectRequest, MlmcSettings, QmcSettings, caused_by_input, run_mlmc, scene_expectation_with,
    study_error,
};
use sdae_study::options::{
    ConvergenceOptions, EnsembleOptions, MlmcOptions, WeakOptions, option_of,
};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;
use sdae_study::scene_load::key_in_table;
use sdae_study::stability::{StabilityReport, StabilityScene};

use crate::args::{scheme_kind, thread_count, whole};
use crate::errors::to_py;
use crate::interrupt::{Meter, Run, run_interruptible};
use crate::report::{PyReport, Study};
use crate::scene::PyScene;

/// A refused setting named by the keyword `given` holds for it, else by its key in the scene
/// table `table` with "(the scene's value)"; any other error as [`to_py`] maps it.
fn named(e: StudyError, given: &[&str], table: &str) -> PyErr {
    match e {
        StudyError::Setting { key, value, rule } => match option_of(key) {
            Some(option) if given.contains(&option) => {
                PyValueError::new_err(format!("{option} = {value}: {rule}"))
            }
            _ => PyValueError::new_err(format!(
                "{} = {value}: {rule} (the scene's value)",
                key_in_table(table, key)
            )),
        },
        e => to_py(e),
    }
}

/// An MLMC error as a Python exception: refused input a `ValueError` ([`named`]), the rest a
/// `RuntimeError`.
fn mlmc_error(e: MlmcError, given: &[&str]) -> PyErr {
    if let Some(study) = study_error(&e) {
        return named(study.clone(), given, "mlmc");
    }
    match e {
        MlmcError::Setting { key, value, rule } => {
            named(StudyError::Setting { key, value, rule }, given, "mlmc")
        }
        e if caused_by_input(&e) => PyValueError::new_err(e.to_string()),
        e => PyRuntimeError::new_err(e.to_string()),
    }
}

/// The keywords of `pairs` whose value was given (not None).
fn given<'a>(pairs: &[(&'a str, bool)]) -> Vec<&'a str> {
    pairs.iter().filter(|(_, g)| *g).map(|(k, _)| *k).collect()
}

/// The progress line of a run of `total` `unit` of `scene`'s `study`, drawn after `after`
/// seconds (None: no line).
fn meter(
    scene: &Scene, study: &str, total: Option<u64>, unit: &'static str, after: Option<f64>,
) -> Option<Meter> {
    Meter::after(after, format!("{} {study}", scene.name), total, unit)
}

/// The paths of `settings` on `scene`, checked first, with a progress line of paths.
fn run_paths(
    py: Python<'_>, scene: &Scene, settings: &ConvergenceSettings, study: &str, given: &[&str],
    table: &str, progress: Option<f64>,
) -> PyResult<sdae_study::convergence::ConvergenceRun> {
    settings
        .validate_for(scene)
        .map_err(|e| named(e, given, table))?;
    let meter = meter(scene, study, Some(settings.paths as u64), "paths", progress);
    run_interruptible(py, meter, |run: &Run| {
        let tick = |_| run.advance(1);
        let control = Control {
            progress: Some(&tick),
            stop: Some(run.flag()),
            ..Control::default()
        };
        run_convergence(scene, settings, (0, 1), control)
    })?
    .map_err(|e| named(e, given, table))
}

/// Paths, seed, threads and quick as the library's options.
fn ensemble(
    paths: Option<i128>, seed: Option<i128>, threads: Option<i128>, quick: bool,
) -> PyResult<EnsembleOptions> {
    Ok(EnsembleOptions {
        paths: paths.map(|n| whole("paths", n)).transpose()?,
        seed: seed.map(|s| whole("seed", s)).transpose()?,
        threads: threads.map(thread_count).transpose()?,
        quick,
    })
}

/// The convergence study of `scene`: strong errors against a fine reference, orders and run
/// time, as `sdae-study convergence` runs it with the same options.
#[pyfunction]
#[pyo3(signature = (scene, *, schemes=None, reference_scheme=None, levels=None, ref_level=None,
    t_end=None, p=None, paths=None, seed=None, threads=None, quick=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn convergence(
    py: Python<'_>, scene: &PyScene, schemes: Option<Vec<String>>,
    reference_scheme: Option<String>, levels: Option<(i128, i128)>, ref_level: Option<i128>,
    t_end: Option<f64>, p: Option<f64>, paths: Option<i128>, seed: Option<i128>,
    threads: Option<i128>, quick: bool, progress: Option<f64>,
) -> PyResult<PyReport> {
    let scene = &scene.scene;
    let levels = levels
        .map(|(a, b)| -> PyResult<(u32, u32)> {
            let (a, b) = (whole("levels", a)?, whole("levels", b)?);
            if a > b {
                return Err(PyValueError::new_err(format!(
                    "levels = ({a}, {b}): the first must not exceed the second"
                )));
            }
            Ok((a, b))
        })
        .transpose()?;
    let options = ConvergenceOptions {
        ensemble: ensemble(paths, seed, threads, quick)?,
        schemes: schemes
            .unwrap_or_default()
            .iter()
            .map(|s| scheme_kind("schemes", s))
            .collect::<PyResult<Vec<SchemeKind>>>()?,
        reference_scheme: reference_scheme
            .map(|s| scheme_kind("reference_scheme", &s))
            .transpose()?,
        levels,
        ref_level: ref_level.map(|r| whole("ref_level", r)).transpose()?,
        t_end,
        p,
    };
    let given = given(&[
        ("paths", paths.is_some()),
        ("seed", seed.is_some()),
        ("threads", threads.is_some()),
        ("levels", levels.is_some()),
        ("ref_level", ref_level.is_some()),
        ("t_end", t_end.is_some()),
        ("p", p.is_some()),
        ("schemes", !options.schemes.is_empty()),
    ]);
    let settings = options.settings(scene);
    let run = run_paths(
        py,
        scene,
        &settings,
        "convergence",
        &given,
        "study",
        progress,
    )?;
    PyReport::new(Study::Convergence(Box::new(build_report(run))))
}

/// The weak-error study of `scene` (its `[weak]` table), as `sdae-study weak` runs it.
#[pyfunction]
#[pyo3(signature = (scene, *, randomizations=None, paths=None, seed=None, threads=None,
    quick=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn weak(
    py: Python<'_>, scene: &PyScene, randomizations: Option<i128>, paths: Option<i128>,
    seed: Option<i128>, threads: Option<i128>, quick: bool, progress: Option<f64>,
) -> PyResult<PyReport> {
    let scene = &scene.scene;
    let options = WeakOptions {
        ensemble: ensemble(paths, seed, threads, quick)?,
        randomizations: randomizations
            .map(|r| whole("randomizations", r))
            .transpose()?,
    };
    let given = given(&[
        ("paths", paths.is_some()),
        ("seed", seed.is_some()),
        ("threads", threads.is_some()),
        ("randomizations", randomizations.is_some()),
    ]);
    let settings = options.settings(scene).map_err(to_py)?;
    let run = run_paths(py, scene, &settings, "weak", &given, "weak", progress)?;
    let report = sdae_study::weak::build_weak_report(run).map_err(to_py)?;
    PyReport::new(Study::Weak(Box::new(report)))
}

/// The stability study of `scene` (its `[stability]` table), as `sdae-study stability` runs
/// it for that scene.
#[pyfunction]
#[pyo3(signature = (scene, *, paths=None, seed=None, threads=None, quick=false, progress=None))]
pub fn stability(
    py: Python<'_>, scene: &PyScene, paths: Option<i128>, seed: Option<i128>,
    threads: Option<i128>, quick: bool, progress: Option<f64>,
) -> PyResult<PyReport> {
    let scene = &scene.scene;
    let options = ensemble(paths, seed, threads, quick)?;
    let given = given(&[
        ("paths", paths.is_some()),
        ("seed", seed.is_some()),
        ("threads", threads.is_some()),
    ]);
    let settings = options.stability_settings(scene).map_err(to_py)?;
    let run = run_paths(
        py,
        scene,
        &settings,
        "stability",
        &given,
        "stability",
        progress,
    )?;
    let case = scene
        .stability
        .as_ref()
        .map(|s| s.case.clone())
        .unwrap_or_default();
    let report = StabilityReport {
        scenes: vec![StabilityScene {
            case,
            report: build_report(run),
        }],
    };
    PyReport::new(Study::Stability(Box::new(report)))
}

/// The MLMC options shared by the study and the expectation helper, with the keywords given.
struct MlmcKeywords {
    options: MlmcOptions,
    given: Vec<&'static str>,
}

impl MlmcKeywords {
    /// The settings of `scene`, checked.
    fn settings(&self, scene: &Scene) -> PyResult<MlmcSettings> {
        let settings = self.options.settings(scene);
        settings
            .validate_for(scene)
            .map_err(|e| mlmc_error(e, &self.given))?;
        Ok(settings)
    }

    /// Runs `work` with a run control of the settings' threads, a progress line of samples and
    /// the stop flag.
    fn run<T: Send>(
        &self, py: Python<'_>, scene: &Scene, settings: &MlmcSettings, study: &str,
        progress: Option<f64>, work: impl FnOnce(&RunControl<'_>) -> Result<T, MlmcError> + Send,
    ) -> PyResult<T> {
        let meter = meter(scene, study, None, "samples", progress);
        run_interruptible(py, meter, |run: &Run| {
            let tick = |n| run.advance(n);
            let mut control = RunControl::new(settings.threads)?;
            control.progress = Some(&tick);
            control.stop = Some(run.flag());
            work(&control)
        })?
        .map_err(|e| mlmc_error(e, &self.given))
    }
}

/// The MLMC study of `scene`'s E[f(X_T)], as `sdae-study mlmc` runs it with the same options.
#[pyfunction]
#[pyo3(signature = (scene, *, observable=None, scheme=None, eps=None, antithetic=false,
    coarsest=None, max_level=None, test_levels=None, test_samples=None, t_end=None, seed=2026,
    threads=None, quick=false, standard=true, randomizations=None, initial_points=None,
    progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn mlmc(
    py: Python<'_>, scene: &PyScene, observable: Option<String>, scheme: Option<String>,
    eps: Option<Vec<f64>>, antithetic: bool, coarsest: Option<i128>, max_level: Option<i128>,
    test_levels: Option<i128>, test_samples: Option<i128>, t_end: Option<f64>, seed: i128,
    threads: Option<i128>, quick: bool, standard: bool, randomizations: Option<i128>,
    initial_points: Option<i128>, progress: Option<f64>,
) -> PyResult<PyReport> {
    let scene = &scene.scene;
    let qmc = match (randomizations, initial_points) {
        (None, None) => None,
        (r, n) => Some(quasi_design(r, n)?),
    };
    let mut keywords = mlmc_keywords(
        observable,
        scheme,
        antithetic,
        [coarsest, max_level, test_levels, test_samples],
        t_end,
        seed,
        threads,
    )?;
    keywords.options.eps = eps.clone().unwrap_or_default();
    keywords.options.quick = quick;
    keywords.options.standard_run = standard;
    keywords.options.qmc = qmc;
    for (name, set) in [
        ("eps", eps.is_some()),
        ("randomizations", randomizations.is_some()),
        ("initial_points", initial_points.is_some()),
    ] {
        if set {
            keywords.given.push(name);
        }
    }
    let settings = keywords.settings(scene)?;
    let report = keywords.run(py, scene, &settings, "mlmc", progress, |control| {
        run_mlmc(scene, &settings, control)
    })?;
    PyReport::new(Study::Mlmc(Box::new(report)))
}

/// The MLMC options every MLMC call takes; `levels` are the coarsest level, the finest level,
/// the test's levels and the test's samples.
fn mlmc_keywords(
    observable: Option<String>, scheme: Option<String>, antithetic: bool,
    levels: [Option<i128>; 4], t_end: Option<f64>, seed: i128, threads: Option<i128>,
) -> PyResult<MlmcKeywords> {
    let [coarsest, max_level, test_levels, test_samples] = levels;
    let options = MlmcOptions {
        observable,
        scheme,
        antithetic,
        coarsest: coarsest.map(|k| whole("coarsest", k)).transpose()?,
        max_level: max_level.map(|l| whole("max_level", l)).transpose()?,
        test_levels: test_levels.map(|l| whole("test_levels", l)).transpose()?,
        test_samples: test_samples.map(|n| whole("test_samples", n)).transpose()?,
        t_end,
        seed: whole("seed", seed)?,
        threads: threads.map(thread_count).transpose()?,
        ..MlmcOptions::default()
    };
    let given = given(&[
        ("observable", options.observable.is_some()),
        ("scheme", options.scheme.is_some()),
        ("coarsest", coarsest.is_some()),
        ("max_level", max_level.is_some()),
        ("test_levels", test_levels.is_some()),
        ("test_samples", test_samples.is_some()),
        ("t_end", t_end.is_some()),
        ("threads", threads.is_some()),
    ]);
    Ok(MlmcKeywords { options, given })
}

/// E[f(X_T)] of `scene`'s observable to root mean square accuracy `eps`, by whichever of
/// standard Monte Carlo, randomized QMC, MLMC and multilevel QMC a short pilot predicts
/// cheapest by `pick_by` ("work" or "seconds"), or by `method` ("mlmc", "mlqmc", "standard",
/// "rqmc") whatever the prediction; `randomizations` and `initial_points` are the QMC design.
#[pyfunction]
#[pyo3(signature = (scene, *, eps, observable=None, scheme=None, antithetic=false,
    coarsest=None, max_level=None, test_levels=None, test_samples=None, t_end=None, seed=2026,
    threads=None, method=None, pick_by=None, randomizations=None, initial_points=None,
    progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn expectation(
    py: Python<'_>, scene: &PyScene, eps: f64, observable: Option<String>, scheme: Option<String>,
    antithetic: bool, coarsest: Option<i128>, max_level: Option<i128>, test_levels: Option<i128>,
    test_samples: Option<i128>, t_end: Option<f64>, seed: i128, threads: Option<i128>,
    method: Option<String>, pick_by: Option<String>, randomizations: Option<i128>,
    initial_points: Option<i128>, progress: Option<f64>,
) -> PyResult<PyReport> {
    let scene = &scene.scene;
    let mut keywords = mlmc_keywords(
        observable,
        scheme,
        antithetic,
        [coarsest, max_level, test_levels, test_samples],
        t_end,
        seed,
        threads,
    )?;
    keywords.options.qmc = Some(quasi_design(randomizations, initial_points)?);
    keywords.given.push("eps");
    for (name, set) in [
        ("randomizations", randomizations.is_some()),
        ("initial_points", initial_points.is_some()),
    ] {
        if set {
            keywords.given.push(name);
        }
    }
    let request = ExpectRequest {
        eps,
        by: pick_by.map_or(Ok(CostMeasure::Work), |b| {
            b.parse()
                .map_err(|e| PyValueError::new_err(format!("pick_by = {b:?}: {e}")))
        })?,
        method: method
            .map(|m| {
                m.parse::<Method>()
                    .map_err(|e| PyValueError::new_err(format!("method = {m:?}: {e}")))
            })
            .transpose()?,
    };
    let settings = keywords.settings(scene)?;
    let found = keywords.run(py, scene, &settings, "expectation", progress, |control| {
        scene_expectation_with(scene, &settings, &request, control)
    })?;
    PyReport::new(Study::Expectation(Box::new(found)))
}

/// The QMC design of R randomizations of n_0 points, the command line's defaults for those
/// not given.
fn quasi_design(
    randomizations: Option<i128>, initial_points: Option<i128>,
) -> PyResult<QmcSettings> {
    Ok(QmcSettings {
        randomizations: randomizations
            .map_or(Ok(sdae_study::options::MLQMC_RANDOMIZATIONS), |r| {
                whole("randomizations", r)
            })?,
        initial_points: initial_points
            .map_or(Ok(sdae_study::options::MLQMC_INITIAL_POINTS), |n| {
                whole("initial_points", n)
            })?,
    })
}
