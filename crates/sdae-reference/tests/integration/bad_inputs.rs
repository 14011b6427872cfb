//! Every user-caused failure gives its typed error, never a panic or a silent NaN.

use crate::common::planar;
use sdae_ift::{IftError, SolverSettings};
use sdae_manifold::{DenseMass, ManifoldError, Sphere};
use sdae_model::{
    AdditiveNoise, MechanicalSystem, ModelError, NoObserver, PathDiagnostics, PathFailure, Scheme,
    StepFailure, TimeGrid, run_path,
};
use sdae_noise::{GaussianIncrements, RecordedIncrements};
use sdae_reference::{
    EulerMaruyama, InherentSde, ProjectedEulerMaruyama, ReferenceError, StochasticHeun,
    TruncatedEulerMaruyama,
};
use sdae_systems::PendulumDrift;

const R: [f64; 2] = [1.0, 0.0];
const V: [f64; 2] = [0.0, 0.5];

fn step_errors<S: Scheme>(name: &str, solver: &mut S) {
    let dw = [0.1, -0.2];
    let step = |solver: &mut S, r: &[f64], v: &[f64], h: f64, dw: &[f64]| {
        let (mut r1, mut v1) = (r.to_vec(), v.to_vec());
        let result = solver.step(&mut r1, &mut v1, h, dw);
        if result.is_err() {
            let bits = |x: &[f64]| x.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&r1), bits(r), "{name}: failed step changed r");
            assert_eq!(bits(&v1), bits(v), "{name}: failed step changed v");
        }
        result
    };
    // Whether a step failed on its input `what` of size `found` where `expected` was needed.
    let mismatch = |e: &StepFailure, what: &str, sizes: (usize, usize)| {
        matches!(
            e,
            StepFailure::Input(ModelError::DimensionMismatch {
                what: w,
                expected,
                found
            }) if *w == what && (*expected, *found) == sizes
        )
    };
    let e = step(solver, &[1.0, 0.0, 0.0], &V, 0.1, &dw).unwrap_err();
    assert!(mismatch(&e, "position r", (2, 3)), "{name}: {e}");
    let e = step(solver, &R, &[0.0], 0.1, &dw).unwrap_err();
    assert!(
        matches!(
            e,
            StepFailure::Input(ModelError::DimensionMismatch {
                what: "velocity v",
                ..
            })
        ),
        "{name}: {e}"
    );
    let e = step(solver, &R, &V, 0.1, &[0.1]).unwrap_err();
    assert!(mismatch(&e, "Brownian increment dw", (2, 1)), "{name}: {e}");
    for h in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        let e = step(solver, &R, &V, h, &dw).unwrap_err();
        assert!(
            matches!(
                e,
                StepFailure::Input(ModelError::InvalidSetting { name: "h", .. })
            ),
            "{name}: h = {h}: {e}"
        );
    }
    let e = step(solver, &[f64::NAN, 0.0], &V, 0.1, &dw).unwrap_err();
    assert!(
        matches!(
            e,
            StepFailure::Input(ModelError::Manifold(ManifoldError::NonFinite { .. }))
        ),
        "{name}: {e}"
    );
    // r = 0: G_M(r) = |r|^2 = 0.
    let e = step(solver, &[0.0, 0.0], &V, 0.1, &dw).unwrap_err();
    assert!(matches!(e, StepFailure::Singular { .. }), "{name}: {e}");
    // A good step works.
    step(solver, &R, &V, 0.1, &dw).unwrap();
}

#[test]
fn step_inputs_are_checked_by_every_solver() {
    step_errors("EM", &mut EulerMaruyama::new(planar(1.0, 1.0)).unwrap());
    step_errors(
        "truncated EM",
        &mut TruncatedEulerMaruyama::new(planar(1.0, 1.0)).unwrap(),
    );
    step_errors(
        "projected EM",
        &mut ProjectedEulerMaruyama::new(planar(1.0, 1.0)).unwrap(),
    );
    step_errors("Heun", &mut StochasticHeun::new(planar(1.0, 1.0)).unwrap());
}

#[test]
fn grid_and_truncation_settings_are_checked() {
    for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = TimeGrid::new(t, 10).unwrap_err();
        assert!(
            matches!(e, ModelError::InvalidSetting { name: "T", .. }),
            "{e}"
        );
    }
    let e = TimeGrid::new(1.0, 0).unwrap_err();
    assert!(
        matches!(e, ModelError::InvalidSetting { name: "N", .. }),
        "{e}"
    );
    // Truncation scale.
    for c in [0.0, -1.0, f64::NAN] {
        let e = TruncatedEulerMaruyama::new(planar(1.0, 1.0))
            .unwrap()
            .with_scale(c)
            .unwrap_err();
        assert!(
            matches!(e, ReferenceError::Model(ModelError::InvalidSetting { .. })),
            "{e}"
        );
    }
}

/// The input error of a path's failure, which must be at step 0.
fn input(e: &PathFailure) -> ModelError {
    match &e.error.failure {
        StepFailure::Input(m) => {
            assert_eq!(e.error.step, 0);
            m.clone()
        }
        other => panic!("not an input error: {other}"),
    }
}

#[test]
fn path_states_and_noise_dimensions_are_checked() {
    let mut solver = TruncatedEulerMaruyama::new(planar(1.0, 1.0)).unwrap();
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let mut run = |r: &[f64], v: &[f64], dim: usize| {
        let (mut r, mut v) = (r.to_vec(), v.to_vec());
        let mut noise = GaussianIncrements::for_path(1, 0, dim);
        run_path(
            &mut solver,
            &mut r,
            &mut v,
            grid,
            &mut noise,
            &mut NoObserver,
        )
        .map(|_| ())
        .unwrap_err()
    };
    let e = run(&[1.1, 0.0], &V, 2);
    assert!(
        matches!(
            input(&e),
            ModelError::Manifold(ManifoldError::OffManifold { .. })
        ),
        "{e}"
    );
    let e = run(&R, &[0.3, 0.5], 2);
    assert!(
        matches!(
            input(&e),
            ModelError::Manifold(ManifoldError::OffTangent { .. })
        ),
        "{e}"
    );
    let e = run(&R, &V, 3);
    assert!(
        matches!(
            input(&e),
            ModelError::DimensionMismatch {
                what: "increment source dimension",
                ..
            }
        ),
        "{e}"
    );
    let e = run(&R, &[0.0], 2);
    assert!(
        matches!(
            input(&e),
            ModelError::Manifold(ManifoldError::DimensionMismatch { .. })
        ),
        "{e}"
    );
}

#[test]
fn too_few_recorded_increments_are_refused() {
    let mut solver = TruncatedEulerMaruyama::new(planar(1.0, 1.0)).unwrap();
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let data = vec![0.0; 2 * 5];
    let (mut r, mut v) = (R.to_vec(), V.to_vec());
    let e = run_path(
        &mut solver,
        &mut r,
        &mut v,
        grid,
        &mut RecordedIncrements::new(&data, 2),
        &mut NoObserver,
    )
    .unwrap_err();
    assert!(
        matches!(
            input(&e),
            ModelError::DimensionMismatch {
                expected: 10,
                found: 5,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn one_shot_evaluations_check_their_inputs() {
    let mut sde = InherentSde::new(planar(1.0, 1.0)).unwrap();
    let (mut out, mut mu) = ([0.0; 2], [0.0; 1]);
    let mismatch = |e: &ReferenceError| {
        matches!(
            e,
            ReferenceError::Model(ModelError::DimensionMismatch { .. })
        )
    };
    let e = sde.drift(&R, &V, &mut [0.0; 3], &mut mu).unwrap_err();
    assert!(mismatch(&e), "{e}");
    let e = sde.drift(&R, &V, &mut out, &mut [0.0; 2]).unwrap_err();
    assert!(mismatch(&e), "{e}");
    let e = sde.diffusion(&R, &V, &[1.0], &mut out).unwrap_err();
    assert!(mismatch(&e), "{e}");
    let e = sde.drift(&[0.0, 0.0], &V, &mut out, &mut mu).unwrap_err();
    assert!(matches!(e, ReferenceError::SingularGram { .. }), "{e}");
    let e = sde
        .multiplier_increment(&R, &V, -1.0, &[0.0, 0.0], &mut out, &mut mu)
        .unwrap_err();
    assert!(
        matches!(
            e,
            ReferenceError::Model(ModelError::InvalidSetting { name: "h", .. })
        ),
        "{e}"
    );
    let e = sde
        .drift(&R, &[f64::INFINITY, 0.0], &mut out, &mut mu)
        .unwrap_err();
    assert!(
        matches!(
            e,
            ReferenceError::Model(ModelError::Manifold(ManifoldError::NonFinite { .. }))
        ),
        "{e}"
    );
}

#[test]
fn projection_failure_is_typed() {
    // One Newton iteration without homotopy cannot bring an EM step of size 0.2 back to 1e-15.
    // A dense mass (here the identity) has no closed-form projection, so Newton runs.
    let pendulum = MechanicalSystem::new(
        Sphere::new(2, 1.0).unwrap(),
        DenseMass::new(2, vec![1.0, 0.0, 0.0, 1.0]).unwrap(),
        PendulumDrift {
            gravity: 1.0,
            friction: 0.0,
        },
        AdditiveNoise::new(1.0, 2).unwrap(),
    )
    .unwrap();
    let settings = SolverSettings {
        tolerance: 1e-15,
        stagnation_tolerance: 1e-15,
        max_iterations: 1,
        homotopy: false,
        ..SolverSettings::default()
    };
    let mut solver = ProjectedEulerMaruyama::with_settings(pendulum, settings).unwrap();
    let (mut r, mut v) = (R.to_vec(), vec![0.0, 2.0]);
    let e = solver.step(&mut r, &mut v, 0.2, &[0.0, 0.0]).unwrap_err();
    assert!(
        matches!(
            e,
            StepFailure::Root {
                source: IftError::NoConvergence { .. },
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(
        (r.as_slice(), v.as_slice()),
        (&R[..], &[0.0, 2.0][..]),
        "state changed"
    );
}

/// Large steps on the pendulum (T = 400, N = 200, v_0 = 3): the drift -|v|^2 r / |r|^2 is not
/// one-sided Lipschitz. Returns the result and the final state.
fn large_steps<S: Scheme>(
    solver: &mut S,
) -> (Result<PathDiagnostics, PathFailure>, Vec<f64>, Vec<f64>) {
    let (mut r, mut v) = (R.to_vec(), vec![0.0, 3.0]);
    let mut noise = GaussianIncrements::for_path(5, 0, 2);
    let grid = TimeGrid::new(400.0, 200).unwrap();
    let result = run_path(solver, &mut r, &mut v, grid, &mut noise, &mut NoObserver);
    (result, r, v)
}

fn blow_up_step<S: Scheme>(solver: &mut S) -> usize {
    let (result, r, v) = large_steps(solver);
    let e = result.unwrap_err();
    assert!(
        matches!(e.error.failure, StepFailure::NonFinite { .. }),
        "{e}"
    );
    assert!(e.error.step > 0, "{e}");
    assert!(
        r.iter().chain(&v).all(|x| x.is_finite()),
        "NaN left in the state"
    );
    e.error.step
}

#[test]
fn euler_maruyama_blow_up_is_a_typed_error_and_truncation_prevents_it() {
    let em_step = blow_up_step(&mut EulerMaruyama::new(planar(1.0, 1.0)).unwrap());
    let heun_step = blow_up_step(&mut StochasticHeun::new(planar(1.0, 1.0)).unwrap());
    println!("EM blows up at step {em_step}, Heun at step {heun_step}");
    let (result, r, v) = large_steps(&mut TruncatedEulerMaruyama::new(planar(1.0, 1.0)).unwrap());
    let d = result.unwrap();
    assert!(r.iter().chain(&v).all(|x| x.is_finite()));
    assert!(d.truncated_steps > 0 && d.min_eta < 1.0, "{d:?}");
    println!("truncated EM: {d:?}");
}
