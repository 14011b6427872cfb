//! The weak study on randomized quasi-Monte Carlo paths (`weak --qmc`): on the rotor, whose
//! E[cos(angle turned)] has a closed form, the reference's estimate from R = 16 randomizations
//! of n = 64 scrambled Sobol' points agrees with it and its interval is much narrower than that
//! of as many pseudo-random paths; the design is checked (named setting errors) and the numbers
//! do not depend on the thread count.

use sdae_study::StudyError;
use sdae_study::convergence::{ConvergenceRun, ConvergenceSettings};
use sdae_study::integrator::SchemeKind;
use sdae_study::observable::built_in_all;
use sdae_study::scene::{Prepared, Scene, SceneRunner};
use sdae_study::weak::{Basis, WeakReport, build_weak_report, weak_settings};

use crate::weak_run::run_whole;

/// The run of a weak study with `settings` (its observables the scene's built-in ones).
struct Run<'a> {
    settings: &'a ConvergenceSettings,
}

impl SceneRunner for Run<'_> {
    type Output = Result<ConvergenceRun, StudyError>;
    fn run<S>(self, scene: &Scene, prepared: Prepared<S>) -> Self::Output
    where
        S: sdae_reference::CurvedSystem + Clone + Send + Sync + 'static,
    {
        let observables = built_in_all(scene, &prepared, &self.settings.observables)?;
        run_whole(scene, &prepared, &observables, self.settings)
    }
}

fn run(scene: &Scene, settings: &ConvergenceSettings) -> Result<ConvergenceRun, StudyError> {
    scene.run(Run { settings }).expect("the rotor builds")
}

/// The rotor's quick weak settings for cos_turn, with one scheme beside the reference (BAOAB
/// with RATTLE at 2^8 steps, paired at 2^7), 1024 paths on 2 threads; QMC with `randomizations`.
fn rotor(randomizations: Option<usize>) -> (Scene, ConvergenceSettings) {
    let scene = Scene::built_in("rotor").unwrap();
    let settings = ConvergenceSettings {
        paths: 1024,
        threads: 2,
        seed: 11,
        observables: vec!["cos_turn".into()],
        schemes: vec![SchemeKind::HalfExplicitPractical],
        randomizations,
        ..weak_settings(&scene, true).unwrap()
    };
    (scene, settings)
}

/// The reference's estimate of E[cos_turn] (extrapolated from its two finest levels): its
/// interval's half-width, its distance to the exact value and the bias bound.
fn reference(report: &WeakReport) -> (f64, f64, f64) {
    let o = &report.observables[0];
    let Basis::Exact(exact) = o.basis else {
        panic!("the rotor gives the exact value of cos_turn");
    };
    assert_eq!(exact, 0.7417415778265619);
    let value = o.reference_value.unwrap();
    let bound = o.reference_bias.as_ref().unwrap().bound;
    let half = 0.5 * (value.ci_high - value.ci_low);
    (half, (value.estimate - exact).abs(), bound)
}

/// 16 randomizations of 64 points: the reference's estimate is within its half-width plus its
/// bias bound of the exact value, and its half-width (a t interval over the 16 randomization
/// means) is at most 0.4 times that of 1024 pseudo-random paths (measured: 0.169; with n
/// = 64 stratified points per randomization the variance of a randomization's mean falls
/// faster than 1 / n, which a pseudo-random interval over the same paths cannot do).
#[test]
fn rotor_qmc_reference_agrees_with_the_closed_form_and_narrows_the_interval() {
    let (scene, settings) = rotor(Some(16));
    let quasi = build_weak_report(run(&scene, &settings).unwrap()).unwrap();
    let qmc = quasi.qmc.as_ref().unwrap();
    assert_eq!((qmc.randomizations, qmc.points, qmc.samples), (16, 64, 16));
    assert!(qmc.left_out.is_empty());
    // The statistics rest on the 16 samples, and the report says so.
    assert!(quasi.observables[0].schemes.iter().all(|s| s.paths == 16));
    let md = sdae_study::weak::report::markdown(&quasi);
    assert!(
        md.contains("R = 16 randomizations") && md.contains("n = 64 points"),
        "{md}"
    );
    assert!(md.contains("rests on the 16 samples"), "{md}");

    let (half_q, off_q, bound_q) = reference(&quasi);
    assert!(
        off_q <= half_q + bound_q,
        "QMC: |estimate - exact| = {off_q:e} above {half_q:e} + {bound_q:e}"
    );

    let (scene, settings) = rotor(None);
    let pseudo = build_weak_report(run(&scene, &settings).unwrap()).unwrap();
    assert!(pseudo.qmc.is_none());
    let (half_p, off_p, bound_p) = reference(&pseudo);
    assert!(
        off_p <= half_p + bound_p,
        "pseudo-random: {off_p:e} above {half_p:e} + {bound_p:e}"
    );
    let ratio = half_q / half_p;
    eprintln!("half-widths: QMC {half_q:e}, pseudo-random {half_p:e}, ratio {ratio:.3}");
    assert!(
        ratio < 0.4,
        "QMC half-width {half_q:e} against {half_p:e} (ratio {ratio})"
    );
}

/// paths = R n with n a power of two and R >= 2, or a named setting error before any path runs.
#[test]
fn qmc_designs_that_do_not_hold_are_refused_by_name() {
    let (scene, settings) = rotor(Some(16));
    let refused = |paths: usize, randomizations: usize| {
        let settings = ConvergenceSettings {
            paths,
            randomizations: Some(randomizations),
            ..settings.clone()
        };
        match run(&scene, &settings) {
            Err(StudyError::Setting { key, .. }) => key,
            other => panic!(
                "paths {paths}, R = {randomizations}: {:?}",
                other.map(|_| ())
            ),
        }
    };
    // Not a multiple of R.
    assert_eq!(refused(1000, 16), "study.paths");
    // n = 48 is not a power of two.
    assert_eq!(refused(16 * 48, 16), "study.paths");
    // One randomization gives no interval.
    assert_eq!(refused(64, 1), "weak.randomizations");
}

/// A QMC run's per-path values are the same bit for bit on 1 and 2 threads (16 randomizations
/// of 8 points: blocks of 32 paths on one thread, 16 on two, each spanning several
/// randomizations; path p is point p % n of randomization p / n whatever block it runs in).
#[test]
fn qmc_paths_do_not_depend_on_the_threads() {
    let (scene, settings) = rotor(Some(16));
    let settings = ConvergenceSettings {
        paths: 16 * 8,
        ..settings
    };
    let values = |threads: usize| {
        let settings = ConvergenceSettings {
            threads,
            ..settings.clone()
        };
        let mut run = run(&scene, &settings).unwrap();
        run.records.sort_by_key(|r| r.index);
        run.records
            .iter()
            .map(|r| {
                let tracks: Vec<Vec<f64>> = r.tracks.iter().map(|t| t.observed.clone()).collect();
                (
                    r.index,
                    r.reference_observed.clone(),
                    r.reference_coarse_observed.clone(),
                    tracks,
                )
            })
            .collect::<Vec<_>>()
    };
    let (one, two) = (values(1), values(2));
    assert_eq!(one.len(), 128);
    assert!(one == two, "the values differ between 1 and 2 threads");
    // And they are not those of the pseudo-random paths.
    let pseudo = ConvergenceSettings {
        randomizations: None,
        threads: 1,
        ..settings.clone()
    };
    let mut run_p = run(&scene, &pseudo).unwrap();
    run_p.records.sort_by_key(|r| r.index);
    assert_ne!(run_p.records[0].reference_observed, one[0].1);
}
