//! The scheme keeps g(r_k) = 0 and Dg(r_k) v_k = 0 to roundoff over long runs.

use crate::common::{chain_system, max_abs};
use sdae_manifold::Constraint;
use sdae_model::{Observer, TimeGrid, run_path};
use sdae_noise::GaussianIncrements;
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

/// Measures |g(r_k)| and |Dg(r_k) v_k| itself, independently of the stepper's diagnostics.
struct ConstraintWatch<C> {
    constraint: C,
    buffer: Vec<f64>,
    max_g: f64,
    max_dgv: f64,
    seen: usize,
}

impl<C: Constraint> Observer for ConstraintWatch<C> {
    fn observe(&mut self, _k: usize, _t: f64, r: &[f64], v: &[f64], _mu: &[f64]) {
        self.constraint.value(r, &mut self.buffer);
        self.max_g = self.max_g.max(max_abs(&self.buffer));
        self.constraint.jacobian_mul(r, v, &mut self.buffer);
        self.max_dgv = self.max_dgv.max(max_abs(&self.buffer));
        self.seen += 1;
    }
}

#[test]
fn pendulum_stays_on_the_tangent_bundle_for_a_million_steps() {
    let system = pendulum(PendulumParams::default()).unwrap();
    let constraint = *sdae_model::System::constraint(&system);
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let (mut r, mut v) = (vec![0.0, -1.0], vec![1.5, 0.0]);
    let mut watch = ConstraintWatch {
        constraint,
        buffer: vec![0.0; 1],
        max_g: 0.0,
        max_dgv: 0.0,
        seen: 0,
    };
    let grid = TimeGrid::new(1000.0, 1_000_000).unwrap();
    let mut noise = GaussianIncrements::for_path(11, 0, 2);
    let diag = run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut watch).unwrap();
    assert_eq!(watch.seen, 1_000_001);
    assert!(watch.max_g < 1e-12, "max |g| = {:e}", watch.max_g);
    assert!(watch.max_dgv < 1e-12, "max |Dg v| = {:e}", watch.max_dgv);
    assert!(diag.max_velocity_residual < 1e-12);
    assert_eq!(diag.homotopy_steps, 0);
}

#[test]
fn hundred_bead_chain_stays_on_the_tangent_bundle() {
    let system = chain_system(100, 0.5);
    let chain = *sdae_model::System::constraint(&system);
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system, config).unwrap();
    let mut r = chain.zigzag(0.5);
    let mut v = vec![0.0; chain.dim()];
    let mut watch = ConstraintWatch {
        constraint: chain,
        buffer: vec![0.0; 99],
        max_g: 0.0,
        max_dgv: 0.0,
        seen: 0,
    };
    let grid = TimeGrid::new(1.0, 10_000).unwrap();
    let mut noise = GaussianIncrements::for_path(12, 0, 300);
    run_path(&mut stepper, &mut r, &mut v, grid, &mut noise, &mut watch).unwrap();
    assert_eq!(watch.seen, 10_001);
    assert!(watch.max_g < 1e-12, "max |g| = {:e}", watch.max_g);
    assert!(watch.max_dgv < 1e-12, "max |Dg v| = {:e}", watch.max_dgv);
}
