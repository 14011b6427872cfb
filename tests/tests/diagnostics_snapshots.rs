//! Integer diagnostics of fixed-seed runs (Newton iteration histogram, truncation and homotopy
//! counts). A change in these numbers is a change in the scheme's behaviour.

mod common;

use sdae_scheme::{
    GaussianIncrements, NoObserver, PathDiagnostics, PendulumParams, Stepper, StepperConfig,
    System, TimeGrid, pendulum, run_path,
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

/// Runs one fixed-seed path (stream `index` of seed 2026) and summarizes its diagnostics.
fn run_summary<S: System>(
    stepper: &mut Stepper<S>,
    mut r: Vec<f64>,
    mut v: Vec<f64>,
    grid: TimeGrid,
    index: u64,
) -> String
where
    <S::Constraint as sdae_manifold::Constraint>::Gram: sdae_ift::Factorize,
{
    let mut noise = GaussianIncrements::for_path(2026, index, stepper.system().noise_dim());
    let d = run_path(stepper, &mut r, &mut v, grid, &mut noise, &mut NoObserver).unwrap();
    summary(&d)
}

#[test]
fn pendulum_run_diagnostics() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let grid = TimeGrid::new(10.0, 200).unwrap();
    let text = run_summary(&mut stepper, vec![0.0, -1.0], vec![2.0, 0.0], grid, 0);
    insta::assert_snapshot!("pendulum_theory_constants_h_0.05", text);
}

#[test]
fn chain_run_diagnostics() {
    let system = common::chain_system(20, 1.0);
    let chain = *system.constraint();
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let grid = TimeGrid::new(1.0, 500).unwrap();
    let text = run_summary(&mut stepper, chain.zigzag(0.4), vec![0.0; 60], grid, 1);
    insta::assert_snapshot!("chain20_c_eta_1_h_0.002", text);
}
