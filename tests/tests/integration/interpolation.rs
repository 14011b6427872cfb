//! Piecewise constant and linear interpolation of a recorded path (seed Remark 4.2).

use sdae_model::{Interpolation, Recorder, TimeGrid, run_path};
use sdae_noise::GaussianIncrements;
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

/// A pendulum path of 100 steps recorded every 10 steps, and its end position.
fn recorded_path() -> (Recorder, Vec<f64>) {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![1.0, 0.0], vec![0.0, 1.0]);
    let grid = TimeGrid::new(1.0, 100).unwrap();
    let mut recorder = Recorder::every(10).with_mu();
    let mut noise = GaussianIncrements::for_path(3, 0, 2);
    run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut noise,
        &mut recorder,
    )
    .unwrap();
    (recorder, r)
}

#[test]
fn interpolation_between_recorded_steps() {
    let (recorder, r) = recorded_path();
    assert_eq!(recorder.len(), 11);
    assert_eq!(recorder.steps, (0..=100).step_by(10).collect::<Vec<_>>());
    let (mut ri, mut vi, mut mi) = (vec![0.0; 2], vec![0.0; 2], vec![0.0; 1]);
    // At a recorded time both interpolations return the record.
    for how in [
        Interpolation::PiecewiseConstant,
        Interpolation::PiecewiseLinear,
    ] {
        recorder
            .interpolate(0.3, how, &mut ri, &mut vi, &mut mi)
            .unwrap();
        assert_eq!(ri, recorder.position(3));
        assert_eq!(mi, recorder.multiplier(3));
    }
    // A quarter of the way from t = 0.3 to 0.4.
    recorder
        .interpolate(
            0.325,
            Interpolation::PiecewiseConstant,
            &mut ri,
            &mut vi,
            &mut mi,
        )
        .unwrap();
    assert_eq!(vi, recorder.velocity(3));
    recorder
        .interpolate(
            0.325,
            Interpolation::PiecewiseLinear,
            &mut ri,
            &mut vi,
            &mut mi,
        )
        .unwrap();
    let (v3, v4) = (recorder.velocity(3), recorder.velocity(4));
    for ((got, a), b) in vi.iter().zip(v3).zip(v4) {
        assert!((got - (0.75 * a + 0.25 * b)).abs() < 1e-15);
    }
    let expected_mu = 0.75 * recorder.multiplier(3)[0] + 0.25 * recorder.multiplier(4)[0];
    assert!((mi[0] - expected_mu).abs() < 1e-15);
    // Beyond the ends: clamped.
    recorder
        .interpolate(
            5.0,
            Interpolation::PiecewiseLinear,
            &mut ri,
            &mut vi,
            &mut mi,
        )
        .unwrap();
    assert_eq!(ri, recorder.position(10));
    assert_eq!(ri, r);
}

#[test]
fn an_empty_record_has_nothing_to_interpolate() {
    let (mut ri, mut vi, mut mi) = (vec![0.0; 2], vec![0.0; 2], vec![0.0; 1]);
    assert!(
        Recorder::every(1)
            .interpolate(
                0.0,
                Interpolation::PiecewiseLinear,
                &mut ri,
                &mut vi,
                &mut mi
            )
            .is_none()
    );
}
