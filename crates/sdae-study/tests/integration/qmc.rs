//! Randomized quasi-Monte Carlo paths in the MLMC study, checks that can fail: multilevel QMC
//! on the circle with friction against the closed form of E[cos(phi_T - phi_0)] (coverage of
//! its interval and RMSE over seeded runs), results independent of the thread count, the
//! report's QMC part, and bad settings.

use sdae_mlmc::qmc::{MlqmcEstimate, QuasiSampler, QuasiSettings, mlqmc};
use sdae_mlmc::{LevelSampler, MlmcError, RunControl};
use sdae_study::mlmc::QmcSettings;
use sdae_study::mlmc::study::{SamplerTask, run_mlmc, with_sampler};

use crate::mlmc::{UNIT_CIRCLE, circle, circle_settings};

/// Runs multilevel QMC on a scene's sampler.
pub(crate) struct Quasi<'a, 'b> {
    pub(crate) control: &'a RunControl<'b>,
    pub(crate) settings: QuasiSettings,
}

impl SamplerTask for Quasi<'_, '_> {
    type Output = MlqmcEstimate;
    fn run<L: LevelSampler + QuasiSampler>(self, sampler: &L) -> Result<MlqmcEstimate, MlmcError> {
        mlqmc(sampler, self.control, &self.settings)
    }
}

/// MLQMC on the unit circle at accuracy `eps` with R = 16 randomizations of n_0 = 32 points.
fn circle_run(seed: u64, eps: f64, control: &RunControl<'_>) -> MlqmcEstimate {
    let (scene, _) = circle(UNIT_CIRCLE);
    let settings = circle_settings(&scene, seed, control.threads());
    let task = Quasi {
        control,
        settings: QuasiSettings {
            randomizations: 16,
            initial_points: 32,
            max_level: 10,
            ..QuasiSettings::new(eps)
        },
    };
    with_sampler(&scene, &settings, task).unwrap()
}

/// 100 seeded runs at eps = 5e-3: the 95% t interval over the randomizations covers the
/// closed form in about 95 of them if the bias is small against the interval; fewer than 90
/// (2.3 binomial standard deviations below 95) means the bias or the interval is off. The
/// root mean square error over the runs, bias included, must be below eps.
#[test]
fn mlqmc_on_the_circle_covers_the_closed_form_and_meets_its_accuracy() {
    let (_, exact) = circle(UNIT_CIRCLE);
    let eps = 5e-3;
    let control = RunControl::new(2).unwrap();
    let runs: Vec<MlqmcEstimate> = (0..100)
        .map(|seed| circle_run(3000 + seed, eps, &control))
        .collect();
    let covered = runs.iter().filter(|r| r.estimate.contains(exact)).count();
    let mse = runs
        .iter()
        .map(|r| (r.estimate.estimate - exact).powi(2))
        .sum::<f64>()
        / runs.len() as f64;
    assert!(covered >= 90, "{covered} of 100 intervals cover {exact}");
    assert!(mse.sqrt() < eps, "RMSE {} against eps {eps}", mse.sqrt());
    for r in &runs {
        assert!(r.converged && r.variance <= eps * eps / 2.0, "{r:?}");
        assert!(
            r.levels
                .iter()
                .all(|q| q.failed == 0 && q.points.is_power_of_two())
        );
    }
}

/// The same run on one thread and on two: the same bits.
#[test]
fn mlqmc_results_do_not_depend_on_the_thread_count() {
    let one = circle_run(7, 2e-3, &RunControl::new(1).unwrap());
    let two = circle_run(7, 2e-3, &RunControl::new(2).unwrap());
    assert_eq!(one.totals.len(), 16);
    for (a, b) in one.totals.iter().zip(&two.totals) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    assert_eq!(
        one.estimate.estimate.to_bits(),
        two.estimate.estimate.to_bits()
    );
    for (a, b) in one.levels.iter().zip(&two.levels) {
        assert!(a.same_samples(b), "{a:?}\n{b:?}");
    }
}

/// `--qmc` adds MLQMC at every eps, the cost exponents and the single-level run to the report
/// (JSON, Markdown), and its single-level run needs fewer steps than standard Monte Carlo for
/// its accuracy on this smooth observable; without it the report has no QMC part.
#[test]
fn the_study_reports_its_quasi_monte_carlo_part() {
    let (scene, exact) = circle(UNIT_CIRCLE);
    let mut settings = circle_settings(&scene, 2026, 2).quick();
    settings.spec.eps = vec![1e-2, 5e-3, 2.5e-3];
    let control = RunControl::new(2).unwrap();
    let plain = run_mlmc(&scene, &settings, &control).unwrap();
    assert!(plain.qmc.is_none());
    assert!(!serde_json::to_string(&plain).unwrap().contains("\"qmc\""));
    settings.qmc = Some(QmcSettings::default());
    let report = run_mlmc(&scene, &settings, &control).unwrap();
    let qmc = report.qmc.as_ref().unwrap();
    assert_eq!(qmc.runs.len(), 3);
    for row in &qmc.runs {
        let half = row.run.estimate.ci_high - row.run.estimate.estimate;
        assert!(
            (row.run.estimate.estimate - exact).abs() < 2.0 * half + row.run.eps,
            "{row:?}"
        );
    }
    assert!(qmc.cost_exponent.is_some() && qmc.mlmc_cost_exponent.is_some());
    let single = qmc.standard.as_ref().unwrap();
    assert!(single.savings > 1.0, "{single:?}");
    assert!(single.level.points.is_power_of_two());
    // The circle's planar noise has 2 components: l 2^(k0 + level) coordinates, all quasi-random.
    assert!(!qmc.coordinates.is_empty());
    for c in &qmc.coordinates {
        assert_eq!(
            c.coordinates,
            2 << (settings.spec.coarsest + c.level),
            "{c:?}"
        );
        assert_eq!(c.quasi, c.coordinates);
    }
    let markdown = sdae_study::mlmc::report::markdown(&report);
    assert!(
        markdown.contains("Every coordinate of every path is quasi-random"),
        "{markdown}"
    );
    assert!(
        markdown.contains("## Multilevel quasi-Monte Carlo"),
        "{markdown}"
    );
    assert!(
        markdown.contains("Direct single-level randomized QMC"),
        "{markdown}"
    );
    assert!(sdae_study::mlmc::report::csv(&report).contains("mlqmc_eps,"));
}

/// Fewer than 2 randomizations, or points that are not a power of two, are refused before
/// anything runs, naming the setting.
#[test]
fn bad_qmc_settings_are_named_errors() {
    let (scene, _) = circle(UNIT_CIRCLE);
    let control = RunControl::new(1).unwrap();
    let mut settings = circle_settings(&scene, 1, 1).quick();
    for (qmc, key) in [
        (
            QmcSettings {
                randomizations: 1,
                initial_points: 32,
            },
            "mlqmc.randomizations",
        ),
        (
            QmcSettings {
                randomizations: 16,
                initial_points: 24,
            },
            "mlqmc.initial_points",
        ),
    ] {
        settings.qmc = Some(qmc);
        match run_mlmc(&scene, &settings, &control) {
            Err(MlmcError::Setting { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{key}: {other:?}"),
        }
    }
}

/// At T = 1e-100 every path ends where it started: no variance at all. Standard Monte Carlo's
/// work beside the single-level QMC run is two paths' (it was NaN steps), and no ratio of the
/// unmeasurably short runs prints as NaN or 0.0x.
#[test]
fn a_run_without_variance_prints_no_nan() {
    let (scene, _) = circle(UNIT_CIRCLE);
    let mut settings = circle_settings(&scene, 1, 2).quick();
    settings.t_end = 1e-100;
    settings.qmc = Some(QmcSettings {
        randomizations: 4,
        initial_points: 32,
    });
    let control = RunControl::new(2).unwrap();
    let report = run_mlmc(&scene, &settings, &control).unwrap();
    let single = report.qmc.as_ref().unwrap().standard.as_ref().unwrap();
    assert!(
        single.standard_work.is_finite() && single.standard_work > 0.0,
        "{single:?}"
    );
    for row in &report.complexity {
        assert!(row.savings.is_finite() && row.savings > 0.0, "{row:?}");
    }
    let lines = [
        sdae_study::mlmc::quasi_report::standard_line(single),
        sdae_study::mlmc::report::standard_line(report.standard.as_ref().unwrap()),
    ];
    for line in lines {
        assert!(!line.contains("NaN") && !line.contains(" 0.0x"), "{line}");
    }
}
