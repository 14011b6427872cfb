//! The invariant-measure bias of the splitting schemes on the Gibbs pendulum (planar, kT = 1,
//! gravity 4: <cos phi> = I1(4) / I0(4) in closed form), through the equipartition study's
//! bias analysis on 1024 paths (thoroughly, the study's 4096) over T = 204.8 at h = 0.4 .. 0.05:
//!
//! - BAOAB's configurational bias is of order 2: the 95% bootstrap interval of the fitted order
//!   contains 2 and excludes 1; so are both schemes' kinetic-energy biases;
//! - g-BAOAB's configurational bias is below the resolution at every h (the closed form lies in
//!   each 95% interval), while BAOAB's at h = 0.4 is resolved: the geodesic substeps remove
//!   most of it;
//! - the half-explicit scheme's bias at the smallest step is larger than BAOAB's at the
//!   largest (first order against second).

use sdae_study::convergence::run_convergence;
use sdae_study::equipartition::{BiasStudy, ReferenceKind, collect, variants};
use sdae_study::gibbs::bessel_i;
use sdae_study::integrator::SchemeKind;
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;

fn scheme<'a>(study: &'a BiasStudy, name: &str) -> &'a sdae_study::equipartition::BiasScheme {
    study.schemes.iter().find(|s| s.scheme == name).unwrap()
}

#[test]
fn splitting_schemes_have_second_order_invariant_measure_bias() {
    check_biases(1024);
}

/// The thorough variant, on the study's 4096 paths (about a minute in the test profile):
/// `cargo test -p sdae-study --test integration -- --ignored`.
#[test]
#[ignore]
fn splitting_schemes_have_second_order_invariant_measure_bias_thoroughly() {
    check_biases(4096);
}

/// The checks above on `paths` paths.
fn check_biases(paths: usize) {
    let scene = Scene::built_in("gibbs-pendulum").unwrap();
    let mut settings = variants(&scene, false).unwrap()[0].settings.clone();
    assert_eq!(settings.paths, 4096);
    settings.schemes = vec![
        SchemeKind::BaoabRattle,
        SchemeKind::GBaoab,
        SchemeKind::HalfExplicitPractical,
    ];
    settings.threads = 2;
    settings.paths = paths;
    let run = run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap();
    let result = collect(&[run]).unwrap();

    let configurational = result.configurational.as_ref().unwrap();
    assert_eq!(configurational.reference_kind, ReferenceKind::ClosedForm);
    let exact = bessel_i(1, 4.0) / bessel_i(0, 4.0);
    assert!((configurational.reference - exact).abs() < 1e-15);

    let baoab = scheme(configurational, "baoab-rattle");
    let order = baoab
        .order
        .expect("BAOAB's configurational order is resolved");
    assert!(order.contains(2.0) && !order.contains(1.0), "{order:?}");

    let kinetic = result.kinetic.as_ref().unwrap();
    for name in ["baoab-rattle", "g-baoab"] {
        let order = scheme(kinetic, name).order.unwrap();
        assert!(
            order.contains(2.0) && !order.contains(1.0),
            "{name}: {order:?}"
        );
    }

    let g_baoab = scheme(configurational, "g-baoab");
    for level in &g_baoab.levels {
        let bias = level.bias.unwrap();
        assert!(bias.contains(0.0), "g-baoab at h = {}: {bias:?}", level.h);
    }
    let coarse = baoab.levels[0].bias.unwrap();
    assert!(!coarse.contains(0.0), "BAOAB at h = 0.4: {coarse:?}");

    let half_explicit = scheme(configurational, "half-explicit C_eta = 1");
    let finest = half_explicit.levels.last().unwrap().bias.unwrap();
    assert!(
        finest.ci_high.abs().min(finest.ci_low.abs())
            > coarse.ci_high.abs().max(coarse.ci_low.abs()),
        "half-explicit at h = 0.05: {finest:?}, BAOAB at h = 0.4: {coarse:?}"
    );
}
