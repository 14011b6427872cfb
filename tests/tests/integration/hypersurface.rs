//! A user's constraint of one equation from its g and grad g over `Real` (`Hypersurface`): the
//! half-explicit stepper's ensembles step it in lanes with the one-path numbers bit for bit at
//! every width; where g is quadratic the kappa root is the closed form in lanes as on one path
//! (no Newton iteration, the one-path certificate's method `ClosedForm`), elsewhere Newton.

use crate::common::{Ellipse, ensemble_bits};
use sdae_ift::Method;
use sdae_lanes::LaneWidth;
use sdae_manifold::{Hypersurface, IdentityMass};
use sdae_model::{AdditiveNoise, MechanicalSystem, PathLoop, PathState, Scheme, System};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};

const PATHS: usize = 19;
const STEPS: usize = 200;
const H: f64 = 0.01;

fn gravity(_r: &[f64], _v: &[f64], out: &mut [f64]) {
    out[0] = 0.0;
    out[1] = -1.0;
}

/// The stepper (truncated, C_eta = 0.5) on the ellipse under gravity and additive noise, its
/// ensembles at every width against the per-path loop; returns the path-steps left to the
/// one-path step and the Newton iterations of one path's first 50 steps.
fn check<const QUADRATIC: bool>() -> (usize, usize, Vec<Method>) {
    let noise = AdditiveNoise::new(0.5, 2).unwrap();
    let system = MechanicalSystem::new(
        Hypersurface::new(Ellipse::<QUADRATIC>),
        IdentityMass,
        gravity,
        noise,
    )
    .unwrap();
    let stepper = Stepper::new(system, StepperConfig::new(0.5, f64::INFINITY).unwrap()).unwrap();
    let (r0, v0) = ([0.0, -1.0], [0.8, 0.0]);
    let mut one_path = PathLoop::new(stepper.clone(), PATHS, &r0, &v0).unwrap();
    let expected = ensemble_bits(&mut one_path, STEPS, 3, H);
    let mut left = 0;
    for width in LaneWidth::ALL {
        let mut lanes = Ensemble::new(stepper.clone(), PATHS, &r0, &v0)
            .unwrap()
            .with_width(width);
        assert_eq!(
            ensemble_bits(&mut lanes, STEPS, 3, H),
            expected,
            "{width:?}"
        );
        left = lanes.scalar_steps();
    }
    let mut scheme = stepper;
    let (mut r, mut v) = (r0, v0);
    let mut path = PathState::new(1, true, false);
    let (mut iterations, mut methods) = (0, Vec::new());
    for k in 0..50 {
        let dw = [0.3 * f64::sin(k as f64), 0.2 * f64::cos(k as f64)];
        let outcome = path.step(&mut scheme, &mut r, &mut v, H, &dw).unwrap();
        iterations += outcome.newton_iterations;
        methods.extend(outcome.certificate.map(|c| c.method));
    }
    assert_eq!(scheme.system().noise_dim(), 2);
    (left, iterations, methods)
}

#[test]
fn a_quadratic_hypersurface_takes_the_closed_form_in_lanes_as_on_one_path() {
    let (left, iterations, methods) = check::<true>();
    assert_eq!(left, 0, "the closed form decides every step in lanes");
    assert_eq!(iterations, 0);
    assert!(
        methods.iter().all(|&m| m == Method::ClosedForm),
        "{methods:?}"
    );
}

#[test]
fn a_hypersurface_without_a_constant_second_derivative_takes_newton() {
    let (left, iterations, methods) = check::<false>();
    assert!(left < PATHS * STEPS / 100, "{left} one-path steps");
    assert!(
        iterations >= 50,
        "{iterations} Newton iterations in 50 steps"
    );
    assert!(methods.iter().all(|&m| m == Method::Newton), "{methods:?}");
}
