//! Truncation that keeps the temperature (beyond the seed): with `StepperConfig::rescaled`, a
//! truncated step from (r, v) with (h, dw) is exactly the untruncated step with (eta h,
//! sqrt(eta) dw), whose increment has the law of a Brownian increment over eta h; an
//! untruncated step (eta = 1) is the seed's step to the bit.

use sdae_model::{Scheme, System};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{PendulumParams, pendulum};

#[test]
fn a_rescaled_truncated_step_is_an_untruncated_step_of_size_eta_h() {
    let params = PendulumParams {
        friction: 0.5,
        ..PendulumParams::default()
    };
    let system = pendulum(params).unwrap();
    let (r0, v0) = ([0.6, -0.8], [2.4, 1.8]);
    let (h, dw) = (0.1, [0.3, -0.2]);
    // |v| = 3: eta = C_eta / (|v|^2 h) = 0.5 / 0.9 < 1.
    let rescaled = StepperConfig::new(0.5, f64::INFINITY).unwrap().rescaled();
    let mut truncated = Stepper::new(system.clone(), rescaled).unwrap();
    let (mut r, mut v) = (r0, v0);
    let eta = truncated.step(&mut r, &mut v, h, &dw).unwrap().eta;
    assert!((eta - 0.5 / 0.9).abs() < 1e-15, "eta = {eta}");
    let untruncated = StepperConfig::new(0.5, f64::INFINITY)
        .unwrap()
        .untruncated();
    let mut plain = Stepper::new(system.clone(), untruncated).unwrap();
    let (mut r_eta, mut v_eta) = (r0, v0);
    let dw_eta = dw.map(|w| eta.sqrt() * w);
    plain
        .step(&mut r_eta, &mut v_eta, eta * h, &dw_eta)
        .unwrap();
    for (a, b) in r.iter().chain(&v).zip(r_eta.iter().chain(&v_eta)) {
        assert!((a - b).abs() < 1e-14, "{r:?} {v:?} vs {r_eta:?} {v_eta:?}");
    }
    // The seed's truncation damps only the drift: another step.
    let mut seed = Stepper::new(
        system.clone(),
        StepperConfig::new(0.5, f64::INFINITY).unwrap(),
    )
    .unwrap();
    let (mut r_seed, mut v_seed) = (r0, v0);
    seed.step(&mut r_seed, &mut v_seed, h, &dw).unwrap();
    assert!((v_seed[0] - v[0]).abs() > 1e-3);
    // Untruncated steps are the seed's, bit for bit.
    let calm = ([0.0, -1.0], [0.1, 0.0]);
    let (mut a, mut b) = calm;
    let (mut c, mut d) = calm;
    truncated.step(&mut a, &mut b, 0.01, &dw).unwrap();
    seed.step(&mut c, &mut d, 0.01, &dw).unwrap();
    assert_eq!((a, b), (c, d));
    assert_eq!(system.noise_dim(), 2);
}
