//! Builders shared by the integration tests.

use sdae_lanes::Real;
use sdae_manifold::{BeadChain, Constraint, IdentityMass, Roundoff, Surface, TheoryBound};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem, PathEnsemble, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::StepperConfig;
use sdae_systems::{Pendulum, PendulumParams, pendulum};

/// Gravity -c e_z on every bead.
#[derive(Debug, Clone, Copy)]
pub struct Gravity(pub f64);

impl Drift for Gravity {
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        let (zero, down) = (v[0].splat_like(0.0), v[0].splat_like(-self.0));
        for bead in out.chunks_exact_mut(3) {
            bead[0] = zero;
            bead[1] = zero;
            bead[2] = down;
        }
        true
    }
}

/// A chain of `beads` beads of total length 1 under gravity with additive noise.
pub fn chain_system(
    beads: usize, noise: f64,
) -> MechanicalSystem<BeadChain, IdentityMass, Gravity, AdditiveNoise> {
    let chain = BeadChain::new(beads, 1.0 / (beads - 1) as f64).unwrap();
    MechanicalSystem::new(
        chain,
        IdentityMass,
        Gravity(1.0),
        AdditiveNoise::new(noise, 3 * beads).unwrap(),
    )
    .unwrap()
}

/// max |x_i|.
pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |s, v| s.max(v.abs()))
}

/// A pendulum of length 1.5 in `dim` dimensions with strong noise and friction: fast enough
/// that C_eta = 0.05 truncates often.
pub fn noisy_pendulum(dim: usize) -> Pendulum {
    pendulum(PendulumParams {
        dim,
        length: 1.5,
        gravity: 1.0,
        noise: 3.0,
        friction: 0.5,
    })
    .unwrap()
}

/// The lane tests' configurations: "practical" (C_eta = 0.05, truncated often enough that
/// both branches of eta are taken, no ball), the same with rescaled noise and with the
/// constraint's local measure of the motion, and the theory's constants (a finite ball).
pub fn lane_configs<S: System>(system: &S) -> Vec<(&'static str, StepperConfig)>
where
    S::Constraint: TheoryBound,
{
    let practical = StepperConfig::for_system(system)
        .unwrap()
        .with_c_eta(0.05)
        .unwrap()
        .with_c_kappa(f64::INFINITY)
        .unwrap();
    vec![
        ("practical", practical),
        ("rescaled", practical.rescaled()),
        ("local", practical.local()),
        ("theory", StepperConfig::for_system(system).unwrap()),
    ]
}

/// Increments of `paths` paths (streams (`seed`, p), l components) for `steps` steps of size
/// h, each step's in the layout of an ensemble of `stride` (component j of path p at
/// `j * stride + p`).
pub fn lane_increments(
    paths: usize, steps: usize, seed: u64, l: usize, stride: usize, h: f64,
) -> Vec<Vec<f64>> {
    let mut sources: Vec<_> = (0..paths)
        .map(|p| GaussianIncrements::for_path(seed, p as u64, l))
        .collect();
    let mut one = vec![0.0; l];
    (0..steps)
        .map(|_| {
            let mut dw = vec![0.0; l * stride];
            for (p, source) in sources.iter_mut().enumerate() {
                source.next_increment(h, &mut one);
                for (j, x) in one.iter().enumerate() {
                    dw[j * stride + p] = *x;
                }
            }
            dw
        })
        .collect()
}

/// Steps every path of `ensemble` `steps` times through [`lane_increments`] (streams (`seed`,
/// p)) and reads every path's final (r, v, mu) as bits (a stopped path's where it stopped)
/// with its failure.
pub fn ensemble_bits<E: PathEnsemble + ?Sized>(
    ensemble: &mut E, steps: usize, seed: u64, h: f64,
) -> Vec<(Vec<u64>, Option<String>)> {
    let (paths, l) = (ensemble.paths(), ensemble.system().noise_dim());
    for dw in lane_increments(paths, steps, seed, l, ensemble.stride(), h) {
        ensemble.step(h, &dw).unwrap();
    }
    let c = ensemble.system().constraint();
    let (n, m) = (c.dim(), c.n_constraints());
    (0..paths)
        .map(|p| {
            let (mut r, mut v, mut mu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
            ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
            let bits = r.iter().chain(&v).chain(&mu).map(|x| x.to_bits()).collect();
            let failure = ensemble.failure(p).unwrap().map(|f| f.to_string());
            (bits, failure)
        })
        .collect()
}

/// The ellipse x^2 / 4 + y^2 = 1 as g = (x^2 / 4 + y^2 - 1) / 2; `QUADRATIC` says whether it
/// declares itself quadratic (the kappa root in closed form) or not (Newton).
#[derive(Debug, Clone, Copy)]
pub struct Ellipse<const QUADRATIC: bool>;

impl<const QUADRATIC: bool> Surface<2> for Ellipse<QUADRATIC> {
    fn value<T: Real>(&self, x: &[T; 2]) -> T {
        (x[0] * x[0] * 0.25 + x[1] * x[1] - 1.0) * 0.5
    }
    fn gradient<T: Real>(&self, x: &[T; 2]) -> [T; 2] {
        [x[0] * 0.25, x[1]]
    }
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(1.0)
    }
    fn second_derivative<T: Real>(&self, _x: &[T; 2], u: &[T; 2], w: &[T; 2]) -> T {
        u[0] * w[0] * 0.25 + u[1] * w[1]
    }
    fn is_quadratic(&self) -> bool {
        QUADRATIC
    }
}
