//! Every bad input a user can give yields its typed error, naming what, where and how far off.

use sdae_manifold::{BeadChain, DenseMass, DiagonalMass, IdentityMass, ManifoldError, Sphere};
use sdae_scheme::{
    AdditiveNoise, GaussianIncrements, MechanicalSystem, NoObserver, PendulumParams,
    RecordedIncrements, SchemeError, StepFailure, Stepper, StepperConfig, TimeGrid, ZeroDrift,
    pendulum, run_path,
};

fn stepper() -> Stepper<sdae_scheme::Pendulum> {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    Stepper::new(system, config).unwrap()
}

#[test]
fn dimension_mismatches() {
    let mut s = stepper();
    let (mut r, mut v) = (vec![1.0, 0.0, 0.0], vec![0.0, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[0.0, 0.0]),
        Err(StepFailure::Input(SchemeError::DimensionMismatch {
            what: "position r",
            expected: 2,
            found: 3
        }))
    ));
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[0.0]),
        Err(StepFailure::Input(SchemeError::DimensionMismatch {
            expected: 2,
            found: 1,
            ..
        }))
    ));
    // Mass of the wrong order.
    let e = MechanicalSystem::new(
        Sphere::unit_circle(),
        DiagonalMass::new(vec![1.0; 3]).unwrap(),
        ZeroDrift,
        AdditiveNoise::new(1.0, 2).unwrap(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            SchemeError::Manifold(ManifoldError::DimensionMismatch {
                expected: 2,
                found: 3,
                ..
            })
        ),
        "{e}"
    );
    // Increment source of the wrong dimension.
    let mut noise = GaussianIncrements::for_path(1, 0, 3);
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap_err();
    assert_eq!(err.error.step, 0);
    assert!(matches!(
        err.error.failure,
        StepFailure::Input(SchemeError::DimensionMismatch {
            expected: 2,
            found: 3,
            ..
        })
    ));
    // Too few recorded increments.
    let data = vec![0.0; 2 * 5];
    let mut recorded = RecordedIncrements::new(&data, 2);
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut recorded, &mut NoObserver).unwrap_err();
    assert!(matches!(
        err.error.failure,
        StepFailure::Input(SchemeError::DimensionMismatch {
            expected: 10,
            found: 5,
            ..
        })
    ));
}

#[test]
fn bad_step_sizes_and_grids() {
    let mut s = stepper();
    for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
        assert!(
            matches!(
                s.step(&mut r, &mut v, h, &[0.0, 0.0]),
                Err(StepFailure::Input(SchemeError::InvalidSetting {
                    name: "h",
                    ..
                }))
            ),
            "h = {h}"
        );
    }
    assert!(matches!(
        TimeGrid::new(1.0, 0),
        Err(SchemeError::InvalidSetting { name: "N", .. })
    ));
    assert!(matches!(
        TimeGrid::new(0.0, 10),
        Err(SchemeError::InvalidSetting { name: "T", .. })
    ));
    assert!(matches!(
        TimeGrid::new(f64::NAN, 10),
        Err(SchemeError::InvalidSetting { name: "T", .. })
    ));
}

#[test]
fn non_finite_states() {
    let mut s = stepper();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![f64::NAN, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[0.0, 0.0]),
        Err(StepFailure::NonFiniteVelocity { .. })
    ));
    let (mut r, mut v) = (vec![f64::INFINITY, 0.0], vec![0.0, 1.0]);
    assert!(s.step(&mut r, &mut v, 0.01, &[0.0, 0.0]).is_err());
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let mut noise = GaussianIncrements::for_path(1, 0, 2);
    let (mut r, mut v) = (vec![1.0, f64::NAN], vec![0.0, 1.0]);
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap_err();
    assert!(matches!(
        err.error.failure,
        StepFailure::Input(SchemeError::Manifold(ManifoldError::NonFinite {
            what: "position r",
            index: 1
        }))
    ));
    // A drift that returns NaN.
    let system = MechanicalSystem::new(
        Sphere::unit_circle(),
        IdentityMass,
        |_r: &[f64], _v: &[f64], a: &mut [f64]| a.fill(f64::NAN),
        AdditiveNoise::new(0.0, 2).unwrap(),
    )
    .unwrap();
    let mut s = Stepper::new(system, StepperConfig::new(1.0, 1.0).unwrap()).unwrap();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[]),
        Err(StepFailure::NonFiniteDrift { index: 0 })
    ));
}

#[test]
fn states_off_the_manifold() {
    let mut s = stepper();
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let mut noise = GaussianIncrements::for_path(1, 0, 2);
    let (mut r, mut v) = (vec![1.1, 0.0], vec![0.0, 1.0]);
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap_err();
    match err.error.failure {
        StepFailure::Input(SchemeError::Manifold(ManifoldError::OffManifold {
            residual,
            index: 0,
            ..
        })) => {
            assert!((residual - 0.5 * (1.1f64 * 1.1 - 1.0)).abs() < 1e-15);
        }
        other => panic!("{other:?}"),
    }
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.3, 1.0]);
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap_err();
    match err.error.failure {
        StepFailure::Input(SchemeError::Manifold(ManifoldError::OffTangent {
            residual, ..
        })) => {
            assert!((residual - 0.3).abs() < 1e-15);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("not tangent"), "{err}");
}

#[test]
fn bad_masses_and_parameters() {
    assert!(matches!(
        DenseMass::new(2, vec![1.0, 3.0, 3.0, 1.0]),
        Err(ManifoldError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        DenseMass::new(2, vec![1.0, 0.1, 0.2, 1.0]),
        Err(ManifoldError::NotSymmetric { .. })
    ));
    assert!(matches!(
        DiagonalMass::new(vec![1.0, 0.0]),
        Err(ManifoldError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        DiagonalMass::new(vec![1.0, f64::NAN]),
        Err(ManifoldError::NonFinite { index: 1, .. })
    ));
    assert!(BeadChain::new(1, 1.0).is_err());
    assert!(BeadChain::new(3, -1.0).is_err());
    assert!(
        pendulum(PendulumParams {
            dim: 4,
            ..PendulumParams::default()
        })
        .is_err()
    );
    assert!(
        pendulum(PendulumParams {
            friction: -1.0,
            ..PendulumParams::default()
        })
        .is_err()
    );
    assert!(
        pendulum(PendulumParams {
            noise: f64::NAN,
            ..PendulumParams::default()
        })
        .is_err()
    );
    assert!(StepperConfig::new(0.0, 1.0).is_err());
    assert!(StepperConfig::new(1.0, -1.0).is_err());
    assert!(StepperConfig::theory(0.5).is_err());
    let system = pendulum(PendulumParams::default()).unwrap();
    let mut config = StepperConfig::for_system(&system).unwrap();
    config.c_eta = Some(f64::NAN);
    assert!(matches!(
        Stepper::new(system, config),
        Err(SchemeError::InvalidSetting { name: "C_eta", .. })
    ));
}
