//! The reference solvers against the half-explicit scheme (sdae-scheme) on the same Brownian
//! paths (fine increments drawn once, summed to coarse ones): the fine solutions agree far
//! better than either is accurate at 2^5 steps, and each solver's error against the other's
//! fine reference decreases with an observed order > 0.5.

use crate::common::{brownian_path, observed_order, planar, show, state_distance};
use sdae_model::{NoObserver, Observer, Recorder, Scheme, TimeGrid, run_path};
use sdae_noise::{Coarsened, RecordedIncrements};
use sdae_reference::{ProjectedEulerMaruyama, StochasticHeun, TruncatedEulerMaruyama};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::Pendulum;

const T: f64 = 1.0;
const FINE: usize = 1 << 12;
const PATHS: u64 = 50;
const LEVELS: [usize; 5] = [16, 32, 64, 128, 256];
const R0: [f64; 2] = [1.0, 0.0];
const V0: [f64; 2] = [0.0, 0.5];

type State = (Vec<f64>, Vec<f64>);

/// The state at T of `scheme` at `steps` steps on the fine Brownian path.
fn state_at<S: Scheme>(scheme: &mut S, fine: &[f64], steps: usize) -> State {
    let (mut r, mut v) = (R0.to_vec(), V0.to_vec());
    let mut dw = Coarsened::new(RecordedIncrements::new(fine, 2), FINE / steps);
    let grid = TimeGrid::new(T, steps).unwrap();
    run_path(scheme, &mut r, &mut v, grid, &mut dw, &mut NoObserver).unwrap();
    (r, v)
}

fn distance(a: &State, b: &State) -> f64 {
    state_distance(&a.0, &a.1, &b.0, &b.1)
}

fn rms(sum_squares: f64) -> f64 {
    (sum_squares / PATHS as f64).sqrt()
}

#[test]
fn scheme_and_reference_solvers_converge_to_each_other() {
    let system = planar(1.0, 1.0);
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let mut truncated = TruncatedEulerMaruyama::new(system.clone()).unwrap();
    let mut heun = StochasticHeun::new(system.clone()).unwrap();
    let mut projected = ProjectedEulerMaruyama::new(system).unwrap();

    let mut fine_gap = 0.0;
    let (mut coarse_scheme, mut coarse_truncated) = (0.0, 0.0);
    // Squared errors per level: scheme vs fine truncated EM, truncated EM / Heun / projected EM
    // vs the fine scheme.
    let mut errors = [[0.0; LEVELS.len()]; 4];
    for i in 0..PATHS {
        let fine = brownian_path(2026, i, 2, T, FINE);
        let scheme_ref = state_at(&mut stepper, &fine, FINE);
        let truncated_ref = state_at(&mut truncated, &fine, FINE);
        fine_gap += distance(&scheme_ref, &truncated_ref).powi(2);
        for (j, &n) in LEVELS.iter().enumerate() {
            let s = state_at(&mut stepper, &fine, n);
            let t = state_at(&mut truncated, &fine, n);
            if n == 32 {
                coarse_scheme += distance(&s, &scheme_ref).powi(2);
                coarse_truncated += distance(&t, &truncated_ref).powi(2);
            }
            errors[0][j] += distance(&s, &truncated_ref).powi(2);
            errors[1][j] += distance(&t, &scheme_ref).powi(2);
            errors[2][j] += distance(&state_at(&mut heun, &fine, n), &scheme_ref).powi(2);
            errors[3][j] += distance(&state_at(&mut projected, &fine, n), &scheme_ref).powi(2);
        }
    }
    let (fine_gap, coarse_scheme, coarse_truncated) =
        (rms(fine_gap), rms(coarse_scheme), rms(coarse_truncated));
    println!(
        "rms |scheme - truncated EM| at 2^12 steps: {fine_gap:.3e}; rms errors at 2^5 steps: \
         scheme {coarse_scheme:.3e}, truncated EM {coarse_truncated:.3e}"
    );
    assert!(
        fine_gap < 0.05 * coarse_scheme.min(coarse_truncated),
        "fine solutions differ by {fine_gap:e}, coarse errors {coarse_scheme:e}, {coarse_truncated:e}"
    );

    let hs: Vec<f64> = LEVELS.iter().map(|&n| T / n as f64).collect();
    let names = [
        "scheme vs fine truncated EM",
        "truncated EM vs fine scheme",
        "stochastic Heun vs fine scheme",
        "projected EM vs fine scheme",
    ];
    for (name, squares) in names.iter().zip(&errors) {
        let rms_errors: Vec<f64> = squares.iter().map(|&s| rms(s)).collect();
        let order = observed_order(&hs, &rms_errors);
        println!(
            "{name}: rms errors {}, observed order {order:.3}",
            show(&rms_errors)
        );
        assert!(
            rms_errors.windows(2).all(|w| w[1] < w[0]),
            "{name}: errors do not decrease: {rms_errors:?}"
        );
        assert!(order > 0.5, "{name}: observed order {order}");
    }
}

/// mu(T) of the scheme (sum of lambda_k, eq. 1.4) and of truncated EM (sum of the increments of
/// eq. 2.3) on the same path at `steps` steps, recorded only at the end.
fn multipliers(
    stepper: &mut Stepper<Pendulum>, truncated: &mut TruncatedEulerMaruyama<Pendulum>,
    fine: &[f64], steps: usize,
) -> (f64, f64) {
    let grid = TimeGrid::new(T, steps).unwrap();
    let coarse = || Coarsened::new(RecordedIncrements::new(fine, 2), FINE / steps);
    let mut a = Recorder::every(steps).with_mu();
    let (mut r, mut v) = (R0.to_vec(), V0.to_vec());
    run_path(stepper, &mut r, &mut v, grid, &mut coarse(), &mut a).unwrap();
    let mut b = Recorder::every(steps).with_mu();
    let (mut r, mut v) = (R0.to_vec(), V0.to_vec());
    run_path(
        truncated,
        &mut r,
        &mut v,
        TimeGrid::new(T, steps).unwrap(),
        &mut coarse(),
        &mut b,
    )
    .unwrap();
    assert_eq!(b.len(), 2);
    (a.multiplier(1)[0], b.multiplier(1)[0])
}

#[test]
fn multipliers_agree_and_are_recorded_only_when_asked() {
    let system = planar(1.0, 1.0);
    let config = StepperConfig::for_system(&system).unwrap();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let mut truncated = TruncatedEulerMaruyama::new(system).unwrap();
    let paths = 20;
    let (mut fine_gap, mut coarse_error) = (0.0, 0.0);
    for i in 0..paths {
        let fine = brownian_path(77, i, 2, T, FINE);
        let (scheme_fine, truncated_fine) = multipliers(&mut stepper, &mut truncated, &fine, FINE);
        let (scheme_coarse, truncated_coarse) =
            multipliers(&mut stepper, &mut truncated, &fine, 32);
        fine_gap += (scheme_fine - truncated_fine).powi(2);
        coarse_error +=
            (scheme_coarse - scheme_fine).powi(2) + (truncated_coarse - truncated_fine).powi(2);
    }
    let fine_gap = (fine_gap / paths as f64).sqrt();
    let coarse_error = (coarse_error / (2 * paths) as f64).sqrt();
    println!(
        "mu(T): rms gap at 2^12 steps {fine_gap:.3e}, rms coarse error at 2^5 steps {coarse_error:.3e}"
    );
    assert!(
        fine_gap < 0.1 * coarse_error,
        "{fine_gap} vs {coarse_error}"
    );

    // Without asking, no mu is accumulated or passed.
    struct NoMu(usize);
    impl Observer for NoMu {
        fn observe(&mut self, _k: usize, _t: f64, _r: &[f64], _v: &[f64], mu: &[f64]) {
            assert!(mu.is_empty());
            self.0 += 1;
        }
    }
    let fine = brownian_path(77, 0, 2, T, FINE);
    let mut observer = NoMu(0);
    let (mut r, mut v) = (R0.to_vec(), V0.to_vec());
    let mut dw = RecordedIncrements::new(&fine, 2);
    run_path(
        &mut truncated,
        &mut r,
        &mut v,
        TimeGrid::new(T, 64).unwrap(),
        &mut dw,
        &mut observer,
    )
    .unwrap();
    assert_eq!(observer.0, 65);
}
