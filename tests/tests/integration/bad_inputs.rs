//! Every bad input a user can give yields its typed error, naming what, where and how far off.

use sdae_manifold::{BeadChain, DenseMass, DiagonalMass, IdentityMass, ManifoldError, Sphere};
use sdae_model::{
    AdditiveNoise, MechanicalSystem, ModelError, NoObserver, Scheme, StepFailure, TimeGrid,
    ZeroDrift, run_path,
};
use sdae_noise::{GaussianIncrements, RecordedIncrements};
use sdae_scheme::{SchemeError, Stepper, StepperConfig};
use sdae_systems::{Pendulum, PendulumParams, pendulum};

fn stepper() -> Stepper<Pendulum> {
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
        Err(StepFailure::Input(ModelError::DimensionMismatch {
            what: "position r",
            expected: 2,
            found: 3
        }))
    ));
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[0.0]),
        Err(StepFailure::Input(ModelError::DimensionMismatch {
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
            ModelError::Manifold(ManifoldError::DimensionMismatch {
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
        StepFailure::Input(ModelError::DimensionMismatch {
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
        StepFailure::Input(ModelError::DimensionMismatch {
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
                Err(StepFailure::Input(ModelError::InvalidSetting {
                    name: "h",
                    ..
                }))
            ),
            "h = {h}"
        );
    }
    assert!(matches!(
        TimeGrid::new(1.0, 0),
        Err(ModelError::InvalidSetting { name: "N", .. })
    ));
    assert!(matches!(
        TimeGrid::new(0.0, 10),
        Err(ModelError::InvalidSetting { name: "T", .. })
    ));
    assert!(matches!(
        TimeGrid::new(f64::NAN, 10),
        Err(ModelError::InvalidSetting { name: "T", .. })
    ));
}

#[test]
fn non_finite_states() {
    let mut s = stepper();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![f64::NAN, 1.0]);
    assert!(matches!(
        s.step(&mut r, &mut v, 0.01, &[0.0, 0.0]),
        Err(StepFailure::NonFinite {
            what: "velocity v_k",
            ..
        })
    ));
    let (mut r, mut v) = (vec![f64::INFINITY, 0.0], vec![0.0, 1.0]);
    assert!(s.step(&mut r, &mut v, 0.01, &[0.0, 0.0]).is_err());
    let grid = TimeGrid::new(1.0, 10).unwrap();
    let mut noise = GaussianIncrements::for_path(1, 0, 2);
    let (mut r, mut v) = (vec![1.0, f64::NAN], vec![0.0, 1.0]);
    let err = run_path(&mut s, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap_err();
    assert!(matches!(
        err.error.failure,
        StepFailure::Input(ModelError::Manifold(ManifoldError::NonFinite {
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
        Err(StepFailure::NonFinite {
            what: "drift a(r, v)",
            ..
        })
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
        StepFailure::Input(ModelError::Manifold(ManifoldError::OffManifold {
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
        StepFailure::Input(ModelError::Manifold(ManifoldError::OffTangent {
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
    // A mass coupling bead 0 to bead 1 does not fit a chain's tridiagonal Gram matrix.
    let mut coupled = vec![0.0; 36];
    for i in 0..6 {
        coupled[i * 6 + i] = 1.0;
    }
    coupled[3] = 0.3;
    coupled[3 * 6] = 0.3;
    let e = MechanicalSystem::new(
        BeadChain::new(2, 1.0).unwrap(),
        DenseMass::new(6, coupled).unwrap(),
        ZeroDrift,
        AdditiveNoise::new(1.0, 6).unwrap(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            ModelError::Manifold(ManifoldError::CoupledMass {
                first: 0,
                second: 1,
                ..
            })
        ),
        "{e}"
    );
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
        Err(SchemeError::Model(ModelError::InvalidSetting {
            name: "C_eta",
            ..
        }))
    ));
}
