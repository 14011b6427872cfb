//! Bring your own constraint, and step its ensembles in SIMD lanes.
//!
//! Two constraints written once over [`Real`] (`f64` for one path, `Lanes<S>` for W paths),
//! each by what it really has:
//!
//! - a particle of mass 2 on a torus (major radius R = 2, tube radius a = 0.5): one equation,
//!   its g and grad g (a [`Surface`], made a constraint by [`Hypersurface`]);
//! - a planar double pendulum, q = (x1, y1, x2, y2), |p1| = L1, |p2 - p1| = L2: two
//!   equations, as ONE `impl` of [`Equations`] (g, Dg u, Dg^T z and D^2 g(u, w); its Gram
//!   matrix is tridiagonal), `#[inline(always)]` as the torus's (the lanes run inside
//!   functions compiled for the instruction set).
//!
//! Each is then a one-path [`Constraint`], stepped by the scalar stepper, and a lane form,
//! with which an [`Ensemble`] steps W paths at once by Newton with a convergence mask per
//! lane. The example checks that every path of the ensemble, at W = 1, 4 and 8, is the scalar
//! stepper's bit for bit (position, velocity and multipliers after 400 steps) under three
//! settings of the half-explicit scheme, and that the lanes decided every step, and prints
//! the time of each. Any difference ends the run with an error.
//!
//! Run with `cargo run --release -p sdae-scheme --example custom_constraint`.

use std::time::Instant;

use sdae_lanes::{LaneWidth, Real};
use sdae_manifold::{
    Constraint, DiagonalMass, Equations, Hypersurface, Roundoff, Surface, Tridiagonal, check_state,
};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem, PathEnsemble, PathState, Scheme, System};
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
    /// D^2 g(x)(u, w) = ((n.u)(n.w) + (rho - R) / rho (u.w - (n.u)(n.w)) in the x-y plane
    /// + u_z w_z) / a, n = (x, y) / rho.
    #[inline(always)]
    fn second_derivative<T: Real>(&self, x: &[T; 3], u: &[T; 3], w: &[T; 3]) -> T {
        let rho = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let (nu, nw) = (
            (x[0] * u[0] + x[1] * u[1]) / rho,
            (x[0] * w[0] + x[1] * w[1]) / rho,
        );
        let plane = u[0] * w[0] + u[1] * w[1];
        let radial = nu * nw;
        (radial + (rho - self.major) / rho * (plane - radial) + u[2] * w[2]) / self.minor
    }
    /// g is a length: rounding leaves a few ulps of the coordinates.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(1.0)
    }
}

/// The double pendulum's rods: p1 = (x1, y1) at L1 from the pivot, p2 = (x2, y2) at L2 from p1.
#[derive(Debug, Clone, Copy)]
struct DoublePendulum {
    /// 1 / L1^2 and 1 / L2^2.
    inverse_squared: [f64; 2],
}

impl Equations for DoublePendulum {
    type Shape = Tridiagonal;
    fn dim(&self) -> usize {
        4
    }
    fn n_constraints(&self) -> usize {
        2
    }
    /// g = ((|p1|^2 / L1^2 - 1) / 2, (|p2 - p1|^2 / L2^2 - 1) / 2).
    #[inline(always)]
    fn value<T: Real>(&self, q: &[T], out: &mut [T]) {
        let [s1, s2] = self.inverse_squared;
        let (dx, dy) = (q[2] - q[0], q[3] - q[1]);
        out[0] = ((q[0] * q[0] + q[1] * q[1]) * s1 - 1.0) * 0.5;
        out[1] = ((dx * dx + dy * dy) * s2 - 1.0) * 0.5;
    }
    /// Dg u = (p1.u1 / L1^2, d.(u2 - u1) / L2^2), d = p2 - p1.
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, q: &[T], u: &[T], out: &mut [T]) {
        let [s1, s2] = self.inverse_squared;
        out[0] = (q[0] * u[0] + q[1] * u[1]) * s1;
        out[1] = ((q[2] - q[0]) * (u[2] - u[0]) + (q[3] - q[1]) * (u[3] - u[1])) * s2;
    }
    /// Dg^T z = (z1 p1 / L1^2 - z2 d / L2^2, z2 d / L2^2).
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, q: &[T], z: &[T], out: &mut [T]) {
        let [s1, s2] = self.inverse_squared;
        let (dx, dy) = ((q[2] - q[0]) * z[1] * s2, (q[3] - q[1]) * z[1] * s2);
        out[0] = q[0] * z[0] * s1 - dx;
        out[1] = q[1] * z[0] * s1 - dy;
        out[2] = dx;
        out[3] = dy;
    }
    /// D^2 g(u, w) = (u1.w1 / L1^2, (u2 - u1).(w2 - w1) / L2^2), the same at every q.
    #[inline(always)]
    fn second_derivative<T: Real>(&self, _q: &[T], u: &[T], w: &[T], out: &mut [T]) {
        let [s1, s2] = self.inverse_squared;
        out[0] = (u[0] * w[0] + u[1] * w[1]) * s1;
        out[1] = ((u[2] - u[0]) * (w[2] - w[0]) + (u[3] - u[1]) * (w[3] - w[1])) * s2;
    }
    fn is_quadratic(&self) -> bool {
        true
    }
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(1.0)
    }
}

/// Gravity: -1 on every `every`-th coordinate from `axis` (z in R^3, y of each planar particle).
#[derive(Debug, Clone, Copy)]
struct Gravity {
    every: usize,
    axis: usize,
}

impl Drift for Gravity {
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (k, o) in out.iter_mut().enumerate() {
            let down = k % self.every == self.axis;
            *o = v[0].splat_like(if down { -1.0 } else { 0.0 });
        }
        true
    }
}

type Particles<C> = MechanicalSystem<C, DiagonalMass, Gravity, AdditiveNoise>;
/// A path's start (r, v).
type Start = (Vec<f64>, Vec<f64>);
/// Every path's final (r, v, mu) as bits, the steps the lanes left to the scalar stepper and
/// the truncated steps (eta < 1) of all paths.
type EnsembleRun = (Vec<Vec<u64>>, usize, usize);

const PATHS: usize = 64;
const STEPS: usize = 400;
const H: f64 = 0.01;
const SEED: u64 = 11;

/// Each path's start (r, v) on the torus: spread around it, with a velocity along the tube.
fn torus_starts(t: &Torus) -> Vec<Start> {
    let start = |p: usize| {
        let (theta, phi) = (0.1 * p as f64, 0.37 * p as f64);
        let rho = t.major + t.minor * phi.cos();
        let r = vec![rho * theta.cos(), rho * theta.sin(), t.minor * phi.sin()];
        let (s, c) = (1.5 * t.minor * phi.sin(), 1.5 * t.minor * phi.cos());
        (r, vec![-s * theta.cos(), -s * theta.sin(), c])
    };
    (0..PATHS).map(start).collect()
}

/// Each path's start on the pendulum with rods L1 = 1, L2 = 0.75: angles from the downward
/// vertical and angular speeds spread over the paths.
fn pendulum_starts() -> Vec<Start> {
    let start = |p: usize| {
        let (a1, a2) = (0.3 + 0.05 * p as f64, -0.6 + 0.11 * p as f64);
        let (w1, w2) = (0.4 - 0.01 * p as f64, 0.5 + 0.01 * p as f64);
        let (e1, e2) = ([a1.sin(), -a1.cos()], [0.75 * a2.sin(), -0.75 * a2.cos()]);
        let r = vec![e1[0], e1[1], e1[0] + e2[0], e1[1] + e2[1]];
        let v1 = [-w1 * e1[1], w1 * e1[0]];
        let v = vec![v1[0], v1[1], v1[0] - w2 * e2[1], v1[1] + w2 * e2[0]];
        (r, v)
    };
    (0..PATHS).map(start).collect()
}

/// (r, v, mu) of a path as bits.
fn bits(r: &[f64], v: &[f64], mu: &[f64]) -> Vec<u64> {
    r.iter().chain(v).chain(mu).map(|x| x.to_bits()).collect()
}

/// Every path's final (r, v, mu), each path through the scalar stepper.
fn scalar_paths<C: Constraint + Clone>(
    stepper: &Stepper<Particles<C>>, starts: &[Start], m: usize,
) -> Vec<Vec<u64>> {
    let run = |(p, (r0, v0)): (usize, &Start)| {
        let mut scheme = stepper.clone();
        let mut noise = GaussianIncrements::for_path(SEED, p as u64, r0.len());
        let (mut r, mut v, mut dw) = (r0.clone(), v0.clone(), vec![0.0; r0.len()]);
        let mut path = PathState::new(m, true, false);
        for _ in 0..STEPS {
            noise.next_increment(H, &mut dw);
            path.step(&mut scheme, &mut r, &mut v, H, &dw)
                .expect("the scalar step succeeds");
        }
        bits(&r, &v, &path.mu)
    };
    starts.iter().enumerate().map(run).collect()
}

/// The paths in an ensemble of `width`.
fn ensemble_paths<C: Constraint + Clone + Send + Sync + 'static>(
    stepper: &Stepper<Particles<C>>, starts: &[Start], m: usize, width: LaneWidth,
) -> Result<EnsembleRun, Box<dyn std::error::Error>> {
    let n = starts[0].0.len();
    let mut ensemble =
        Ensemble::new(stepper.clone(), PATHS, &starts[0].0, &starts[0].1)?.with_width(width);
    for (p, (r, v)) in starts.iter().enumerate() {
        ensemble.set_state(p, r, v)?;
    }
    let mut sources: Vec<_> = (0..PATHS)
        .map(|p| GaussianIncrements::for_path(SEED, p as u64, n))
        .collect();
    let stride = ensemble.stride();
    let (mut dw, mut one) = (vec![0.0; n * stride], vec![0.0; n]);
    for _ in 0..STEPS {
        for (p, source) in sources.iter_mut().enumerate() {
            source.next_increment(H, &mut one);
            for j in 0..n {
                dw[j * stride + p] = one[j];
            }
        }
        ensemble.step(H, &dw)?;
    }
    let (mut paths, mut truncated) = (Vec::with_capacity(PATHS), 0);
    let (mut r, mut v, mut mu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
    for p in 0..PATHS {
        truncated += ensemble.diagnostics(p)?.truncated_steps;
        ensemble.state(p, &mut r, &mut v, &mut mu)?;
        check_state(stepper.system().constraint(), &r, &v, 1e-10)?;
        paths.push(bits(&r, &v, &mu));
    }
    Ok((paths, ensemble.scalar_steps(), truncated))
}

/// Steps `system`'s paths from `starts` path by path and in lanes of every width under three
/// settings, and refuses any difference.
fn compare<C: Constraint + Clone + Send + Sync + 'static>(
    what: &str, system: Particles<C>, starts: &[Start],
) -> Result<(), Box<dyn std::error::Error>> {
    let m = system.constraint().n_constraints();
    let truncated = StepperConfig::new(0.05, f64::INFINITY)?;
    let settings = [
        ("truncated (C_eta = 0.05)", truncated),
        (
            "untruncated",
            StepperConfig::new(1.0, f64::INFINITY)?.untruncated(),
        ),
        ("local size (C_eta = 0.05)", truncated.local()),
    ];
    println!("{PATHS} paths on {what}, {STEPS} steps of h = {H}:");
    for (name, config) in settings {
        let stepper = Stepper::new(system.clone(), config)?;
        let clock = Instant::now();
        let scalar = scalar_paths(&stepper, starts, m);
        let scalar_ms = clock.elapsed().as_secs_f64() * 1e3;
        for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
            let clock = Instant::now();
            let (lanes, left, truncated) = ensemble_paths(&stepper, starts, m, width)?;
            let lane_ms = clock.elapsed().as_secs_f64() * 1e3;
            let differing = (0..PATHS).filter(|&p| lanes[p] != scalar[p]).count();
            let w = width.lanes();
            println!(
                "  {name:<27} W = {w}: {differing} paths differ from the scalar stepper, \
                 {left} steps left to it, {truncated} truncated; {lane_ms:.2} ms in lanes, \
                 {scalar_ms:.2} ms path by path",
            );
            if differing > 0 || left > 0 {
                let error = format!(
                    "{what}, {name} at W = {w}: {differing} paths differ, {left} scalar steps"
                );
                return Err(error.into());
            }
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let torus = Torus {
        major: 2.0,
        minor: 0.5,
    };
    let on_torus = MechanicalSystem::new(
        Hypersurface::new(torus),
        DiagonalMass::new(vec![2.0; 3])?,
        Gravity { every: 3, axis: 2 },
        AdditiveNoise::new(0.8, 3)?,
    )?;
    compare("a torus", on_torus, &torus_starts(&torus))?;
    let pendulum = MechanicalSystem::new(
        DoublePendulum {
            inverse_squared: [1.0, 1.0 / (0.75 * 0.75)],
        },
        DiagonalMass::new(vec![1.0, 1.0, 0.5, 0.5])?,
        Gravity { every: 2, axis: 1 },
        AdditiveNoise::new(0.3, 4)?,
    )?;
    compare("a double pendulum", pendulum, &pendulum_starts())?;
    println!("Every path in lanes is the scalar stepper's, bit for bit.");
    Ok(())
}
