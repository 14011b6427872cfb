//! Observed orders of the stochastic Heun method against Euler-Maruyama: order 2 without noise
//! (trapezoidal drift), order 1 with additive noise (B independent of v: the Milstein
//! correction vanishes, and nothing beyond order 1 is possible with increments alone).

use crate::common::{brownian_path, observed_order, planar, show, state_distance};
use sdae_model::{NoObserver, Scheme, System, TimeGrid, run_path};
use sdae_noise::{Coarsened, GaussianIncrements, RecordedIncrements};
use sdae_reference::{EulerMaruyama, StochasticHeun};
use sdae_systems::Pendulum;

const T: f64 = 1.0;
const FINE: usize = 1 << 12;
const LEVELS: [usize; 4] = [32, 64, 128, 256];

fn run<S: Scheme>(solver: &mut S, fine: &[f64], steps: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut r, mut v) = (vec![0.6, -0.8], vec![1.2, 0.9]);
    if solver.system().noise_dim() == 0 {
        // Without noise (sigma = 0 gives l = 0) no increments are needed.
        let mut none = GaussianIncrements::for_path(0, 0, 0);
        run_path(
            solver,
            &mut r,
            &mut v,
            TimeGrid::new(T, steps).unwrap(),
            &mut none,
            &mut NoObserver,
        )
        .unwrap();
    } else {
        let mut dw = Coarsened::new(RecordedIncrements::new(fine, 2), FINE / steps);
        run_path(
            solver,
            &mut r,
            &mut v,
            TimeGrid::new(T, steps).unwrap(),
            &mut dw,
            &mut NoObserver,
        )
        .unwrap();
    }
    (r, v)
}

/// RMS error over `paths` paths of `make()` at each level against its own fine solution.
fn orders<S: Scheme>(make: impl Fn() -> S, noise: bool, paths: u64) -> (Vec<f64>, f64) {
    let mut solver = make();
    let mut squares = vec![0.0; LEVELS.len()];
    for i in 0..paths {
        let fine = if noise {
            brownian_path(99, i, 2, T, FINE)
        } else {
            vec![0.0; 2 * FINE]
        };
        let reference = run(&mut solver, &fine, FINE);
        for (j, &n) in LEVELS.iter().enumerate() {
            let x = run(&mut solver, &fine, n);
            squares[j] += state_distance(&x.0, &x.1, &reference.0, &reference.1).powi(2);
        }
    }
    let errors: Vec<f64> = squares.iter().map(|s| (s / paths as f64).sqrt()).collect();
    let hs: Vec<f64> = LEVELS.iter().map(|&n| T / n as f64).collect();
    let order = observed_order(&hs, &errors);
    (errors, order)
}

fn system(noise: f64) -> Pendulum {
    planar(1.0, noise)
}

#[test]
fn heun_has_order_two_without_noise_and_one_with_additive_noise() {
    let (heun_det, heun_det_order) = orders(|| StochasticHeun::new(system(0.0)).unwrap(), false, 1);
    let (em_det, em_det_order) = orders(|| EulerMaruyama::new(system(0.0)).unwrap(), false, 1);
    println!(
        "no noise: Heun errors {} order {heun_det_order:.3}",
        show(&heun_det)
    );
    println!(
        "no noise: EM errors {} order {em_det_order:.3}",
        show(&em_det)
    );
    assert!(
        heun_det_order > 1.8,
        "Heun without noise: order {heun_det_order}"
    );
    assert!(
        (0.8..1.3).contains(&em_det_order),
        "EM without noise: order {em_det_order}"
    );

    let (heun, heun_order) = orders(|| StochasticHeun::new(system(1.0)).unwrap(), true, 40);
    let (em, em_order) = orders(|| EulerMaruyama::new(system(1.0)).unwrap(), true, 40);
    println!("noise: Heun errors {} order {heun_order:.3}", show(&heun));
    println!("noise: EM errors {} order {em_order:.3}", show(&em));
    assert!(
        heun_order > 0.8,
        "Heun with additive noise: order {heun_order}"
    );
    // Same order as EM (which is Milstein here) but a smaller error constant.
    assert!(
        heun.iter().zip(&em).all(|(a, b)| a < b),
        "Heun {heun:?} vs EM {em:?}"
    );
}
