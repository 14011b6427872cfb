//! Integer diagnostics of fixed-seed runs (Newton iteration histogram, truncation and homotopy
//! counts). A change in these numbers is a change in the scheme's behaviour.

mod common;

use sdae_scheme::{
    GaussianIncrements, NoObserver, PathDiagnostics, PendulumParams, Stepper, StepperConfig,
    TimeGrid, pendulum, run_path,
};

fn summary(d: &PathDiagnostics) -> String {
    let histogram: Vec<String> = d
        .iteration_histogram
        .iter()
        .enumerate()
        .filter(|&(_, &c)| c > 0)
        .map(|(i, c)| format!("{i}:{c}"))
        .collect();
    format!(
        "steps: {}\ntruncated_steps: {}\nnewton_iterations: {}\niteration_histogram: {}\nhomotopy_steps: {}\nposition_residual_below_1e-13: {}\n",
        d.steps,
        d.truncated_steps,
        d.newton_iterations,
        histogram.join(" "),
        d.homotopy_steps,
        d.max_position_residual < 1e-13,
    )
}

#[test]
fn pendulum_run_diagnostics() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![0.0, -1.0], vec![2.0, 0.0]);
    let grid = TimeGrid::new(10.0, 200).unwrap();
    let mut noise = GaussianIncrements::for_path(2026, 0, 2);
    let d = run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut noise,
        &mut NoObserver,
    )
    .unwrap();
    insta::assert_snapshot!("pendulum_theory_constants_h_0.05", summary(&d));
}

#[test]
fn chain_run_diagnostics() {
    let system = common::chain_system(20, 1.0);
    let chain = *sdae_scheme::System::constraint(&system);
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let mut r = chain.zigzag(0.4);
    let mut v = vec![0.0; 60];
    let grid = TimeGrid::new(1.0, 500).unwrap();
    let mut noise = GaussianIncrements::for_path(2026, 1, 60);
    let d = run_path(
        &mut stepper,
        &mut r,
        &mut v,
        grid,
        &mut noise,
        &mut NoObserver,
    )
    .unwrap();
    insta::assert_snapshot!("chain20_c_eta_1_h_0.002", summary(&d));
}
