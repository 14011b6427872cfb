//! Equipartition on the thermal pendulum (kT = 1, one degree of freedom: E[|v|^2 / 2] = 1/2):
//! at a small step the half-explicit scheme's kinetic energy is within its 95% interval of the
//! target, while at a coarse step the same check detects the heating of the explicit rotation
//! (design notes, Section 6), so the check has power.

use sdae_stats::Interval;
use sdae_study::convergence::{ConvergenceSettings, build_report, run_convergence};
use sdae_study::integrator::SchemeKind;
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

fn kinetic_energy(level: u32) -> (Interval, f64) {
    let mut scene = Scene::built_in("thermal-pendulum").unwrap();
    scene.t_end = 32.0;
    let settings = ConvergenceSettings {
        paths: 200,
        coarsest: level,
        finest: level,
        reference: None,
        kinetic_after: Some(8.0),
        schemes: vec![SchemeKind::HalfExplicitPractical],
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    let level = &report.schemes[0].levels[0];
    assert_eq!(level.failures, 0);
    (
        level.kinetic_energy.unwrap(),
        report.kinetic_target.unwrap(),
    )
}

#[test]
fn small_steps_give_the_set_temperature_and_coarse_steps_do_not() {
    // h = 32 / 2^15 ~ 1e-3: O(h) bias well below the standard error of 200 paths.
    let (fine, target) = kinetic_energy(15);
    assert_eq!(target, 0.5);
    assert!(
        fine.ci_low <= target && target <= fine.ci_high,
        "h = 1/1024: {fine:?} misses {target}"
    );
    // A 95% interval is about 4 standard errors wide: it must not be uselessly wide.
    assert!(fine.ci_high - fine.ci_low < 0.15 * target, "{fine:?}");
    // h = 1/16: the rotation heats the pendulum by about a third.
    let (coarse, _) = kinetic_energy(9);
    assert!(
        coarse.ci_low > target,
        "h = 1/16: {coarse:?} does not show the heating"
    );
}
