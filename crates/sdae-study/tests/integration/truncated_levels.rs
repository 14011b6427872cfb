//! A level where more than half of the steps are truncated measures the truncation (a step of
//! eta h), not the order of the step: the order is fitted over the other levels only, and the
//! report names the truncation-dominated ones.

use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::integrator::SchemeKind;
use sdae_study::output::markdown;
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

#[test]
fn truncation_dominated_levels_are_not_fitted() {
    let mut scene = Scene::built_in("pendulum").unwrap();
    // eta = min(1, C_eta / (max(|v|, |v|^2, |a|) h)) with |v|, |a| ~ 1: C_eta = 0.05 truncates
    // nearly every step at h >= 1/16 and none at h <= 1/64.
    scene.scheme.practical_c_eta = 0.05;
    let settings = ConvergenceSettings {
        paths: 40,
        coarsest: 3,
        finest: 8,
        reference: Some(12),
        schemes: vec![SchemeKind::HalfExplicitPractical],
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    let scheme = &report.schemes[0];
    let dominated: Vec<usize> = (0..scheme.levels.len())
        .filter(|&j| scheme.levels[j].stable_but_biased)
        .collect();
    assert!(
        !dominated.is_empty() && dominated.len() + 3 <= scheme.levels.len(),
        "the test needs truncation-dominated coarse levels and three others: {dominated:?}"
    );
    assert_eq!(scheme.not_fitted_truncated, dominated);
    assert!(scheme.not_fitted_for_failures.is_empty());
    let fit = scheme.observed_order.r.as_ref().unwrap();
    let considered: Vec<usize> = fit
        .fitted
        .iter()
        .chain(&fit.pre_asymptotic)
        .copied()
        .collect();
    assert!(considered.iter().all(|j| !dominated.contains(j)));
    // Every level that is not truncation-dominated is fitted or flagged as pre-asymptotic.
    assert_eq!(considered.len() + dominated.len(), scheme.levels.len());
    let text = markdown(&report);
    let steps: Vec<String> = dominated
        .iter()
        .map(|&j| scheme.levels[j].n_steps.to_string())
        .collect();
    assert!(
        text.contains(&format!(
            "Not fitted, truncation-dominated (stable but biased): half-explicit-practical at N = {}.",
            steps.join(", ")
        )),
        "{text}"
    );
}
