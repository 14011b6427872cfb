//! Bring your own constraint, and step its ensembles in SIMD lanes.
//!
//! A particle of mass 2 on a torus (major radius R = 2, tube radius a = 0.5) under gravity
//! and additive noise. The torus is defined here by what a constraint of one equation really
//! has: g and grad g, written once over [`Real`] (its [`Surface`]). [`Hypersurface`] makes of
//! them both forms:
//!
//! - `f64`: the scalar [`Constraint`](sdae_manifold::Constraint) the stepper solves one path at a time;
//! - `Lanes<S>`: its [`ConstraintLanes`](sdae_manifold::ConstraintLanes), with which an [`Ensemble`] steps W paths at once
//!   (W = 8 with AVX-512, 4 with AVX2) by Newton with a convergence mask per lane.
//!
//! A constraint of several equations implements `Constraint` and `ConstraintLanes` itself,
//! naming the structure of its Newton matrix (`sdae_manifold::lane_form`; the bead chain and
//! rigid bonds are built that way).
//!
//! It then checks that every path of the ensemble, at every lane width, is the scalar
//! stepper's path bit for bit (position, velocity and multiplier after 400 steps) under three
//! settings of the scheme, and that the lanes decided every step, and prints the time of each.
//! Any difference ends the run with an error.
//!
//! Run with `cargo run --release -p sdae-scheme --example custom_constraint`.

use std::time::Instant;

use sdae_lanes::{LaneWidth, Real};
use sdae_manifold::{DiagonalMass, Hypersurface, Roundoff, Surface, check_state};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem, PathEnsemble, PathState};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Ensemble, Stepper, StepperConfig};

/// The torus ((x^2 + y^2)^(1/2) - R)^2 + z^2 = a^2 in R^3.
#[derive(Debug, Clone, Copy)]
struct Torus {
    major: f64,
    minor: f64,
}

impl Surface<3> for Torus {
    /// g(x) = ((rho - R)^2 + z^2 - a^2) / (2a), rho = (x^2 + y^2)^(1/2): a length, whose
    /// gradient has norm 1 on the torus.
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T; 3]) -> T {
        let d = (x[0] * x[0] + x[1] * x[1]).sqrt() - self.major;
        (d * d + x[2] * x[2] - self.minor * self.minor) / (2.0 * self.minor)
    }
    /// grad g(x) = ((rho - R) x / (a rho), (rho - R) y / (a rho), z / a).
    #[inline(always)]
    fn gradient<T: Real>(&self, x: &[T; 3]) -> [T; 3] {
        let rho = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let s = (rho - self.major) / (rho * self.minor);
        [s * x[0], s * x[1], x[2] / self.minor]
    }
    /// g is a length: rounding leaves a few ulps of the coordinates (relative to a unit
    /// length).
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(1.0)
    }
}

impl Torus {
    /// A point of the torus: angle `theta` around the axis, `phi` around the tube.
    fn point(&self, theta: f64, phi: f64) -> [f64; 3] {
        let rho = self.major + self.minor * phi.cos();
        [rho * theta.cos(), rho * theta.sin(), self.minor * phi.sin()]
    }
}

/// Gravity (0, 0, -1), with a lane form.
#[derive(Debug, Clone, Copy)]
struct Gravity;

impl Drift for Gravity {
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (k, o) in out.iter_mut().enumerate() {
            *o = v[0].splat_like(if k == 2 { -1.0 } else { 0.0 });
        }
        true
    }
}

/// The particle on the torus.
type TorusSystem = MechanicalSystem<Hypersurface<Torus, 3>, DiagonalMass, Gravity, AdditiveNoise>;

const PATHS: usize = 64;
const STEPS: usize = 400;
const H: f64 = 0.01;
const SEED: u64 = 11;

/// Path p's start: spread around the torus, with a tangent velocity.
fn start(torus: &Torus, p: usize) -> ([f64; 3], [f64; 3]) {
    let (theta, phi) = (0.1 * p as f64, 0.37 * p as f64);
    let r = torus.point(theta, phi);
    // d/dphi of the point, times 1.5: tangent to the tube.
    let v = [
        -1.5 * torus.minor * phi.sin() * theta.cos(),
        -1.5 * torus.minor * phi.sin() * theta.sin(),
        1.5 * torus.minor * phi.cos(),
    ];
    (r, v)
}

/// Path p's final (r, v, mu) as bits, each path through the scalar stepper.
fn scalar_paths(stepper: &Stepper<TorusSystem>, torus: &Torus) -> Vec<Vec<u64>> {
    (0..PATHS)
        .map(|p| {
            let mut scheme = stepper.clone();
            let mut noise = GaussianIncrements::for_path(SEED, p as u64, 3);
            let (mut r, mut v) = start(torus, p);
            let mut path = PathState::new(1, true, false);
            let mut dw = [0.0; 3];
            for _ in 0..STEPS {
                noise.next_increment(H, &mut dw);
                path.step(&mut scheme, &mut r, &mut v, H, &dw)
                    .expect("the scalar step succeeds");
            }
            r.iter()
                .chain(&v)
                .chain(&path.mu)
                .map(|x| x.to_bits())
                .collect()
        })
        .collect()
}

/// What an ensemble's run gave.
struct EnsembleRun {
    /// Every path's final (r, v, mu) as bits.
    bits: Vec<Vec<u64>>,
    /// The steps the lanes left to the scalar stepper.
    left_to_scalar: usize,
    /// The truncated steps (eta < 1) of all paths.
    truncated: usize,
}

/// The paths in an ensemble of `width`.
fn ensemble_paths(
    stepper: &Stepper<TorusSystem>, torus: &Torus, width: LaneWidth,
) -> Result<EnsembleRun, Box<dyn std::error::Error>> {
    let (r0, v0) = start(torus, 0);
    let mut ensemble = Ensemble::new(stepper.clone(), PATHS, &r0, &v0)?.with_width(width);
    for p in 0..PATHS {
        let (r, v) = start(torus, p);
        ensemble.set_state(p, &r, &v)?;
    }
    let mut sources: Vec<_> = (0..PATHS)
        .map(|p| GaussianIncrements::for_path(SEED, p as u64, 3))
        .collect();
    let stride = ensemble.stride();
    let (mut dw, mut one) = (vec![0.0; 3 * stride], [0.0; 3]);
    for _ in 0..STEPS {
        for (p, source) in sources.iter_mut().enumerate() {
            source.next_increment(H, &mut one);
            for j in 0..3 {
                dw[j * stride + p] = one[j];
            }
        }
        ensemble.step(H, &dw)?;
    }
    let (mut bits, mut truncated) = (Vec::with_capacity(PATHS), 0);
    for p in 0..PATHS {
        truncated += ensemble.diagnostics(p)?.truncated_steps;
        let (mut r, mut v, mut mu) = ([0.0; 3], [0.0; 3], [0.0; 1]);
        ensemble.state(p, &mut r, &mut v, &mut mu)?;
        check_state(&Hypersurface::new(*torus), &r, &v, 1e-10)?;
        bits.push(r.iter().chain(&v).chain(&mu).map(|x| x.to_bits()).collect());
    }
    Ok(EnsembleRun {
        bits,
        left_to_scalar: ensemble.scalar_steps(),
        truncated,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let torus = Torus {
        major: 2.0,
        minor: 0.5,
    };
    let system = MechanicalSystem::new(
        Hypersurface::new(torus),
        DiagonalMass::new(vec![2.0; 3])?,
        Gravity,
        AdditiveNoise::new(0.8, 3)?,
    )?;
    let settings = [
        (
            "truncated (C_eta = 0.05)",
            StepperConfig::new(0.05, f64::INFINITY)?,
        ),
        (
            "untruncated",
            StepperConfig::new(1.0, f64::INFINITY)?.untruncated(),
        ),
        (
            "local size (C_eta = 0.05)",
            StepperConfig::new(0.05, f64::INFINITY)?.local(),
        ),
    ];
    println!("{PATHS} paths on a torus, {STEPS} steps of h = {H}:");
    for (name, config) in settings {
        let stepper = Stepper::new(system.clone(), config)?;
        let clock = Instant::now();
        let scalar = scalar_paths(&stepper, &torus);
        let scalar_time = clock.elapsed();
        for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
            let clock = Instant::now();
            let EnsembleRun {
                bits: lanes,
                left_to_scalar: left,
                truncated,
            } = ensemble_paths(&stepper, &torus, width)?;
            let lane_time = clock.elapsed();
            let differing = (0..PATHS).filter(|&p| lanes[p] != scalar[p]).count();
            println!(
                "  {name:<27} W = {}: {differing} paths differ from the scalar stepper, \
                 {left} steps left to it, {truncated} truncated; {:.2} ms in lanes, {:.2} ms \
                 path by path",
                width.lanes(),
                lane_time.as_secs_f64() * 1e3,
                scalar_time.as_secs_f64() * 1e3,
            );
            if differing > 0 || left > 0 {
                return Err(format!(
                    "{name} at W = {}: {differing} paths differ, {left} scalar steps",
                    width.lanes()
                )
                .into());
            }
        }
    }
    println!("Every path in lanes is the scalar stepper's, bit for bit.");
    Ok(())
}
