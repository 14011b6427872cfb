//! The system of seed eq. 1.1: M dv = a(r, v) dt + B(r, v) dw + grad g(r) dmu, g(r) = 0.

use pulp::Simd;
use sdae_lanes::{Lanes, Real, per_path};
use sdae_manifold::{Constraint, Mass};

use crate::error::{ModelError, check_dim, check_step_size};

/// Everything the stepper needs to know about a constrained stochastic mechanical system.
pub trait System {
    /// The constraint g.
    type Constraint: Constraint;
    /// The mass matrix M.
    type Mass: Mass;
    /// The constraint g.
    fn constraint(&self) -> &Self::Constraint;
    /// The mass matrix M.
    fn mass(&self) -> &Self::Mass;
    /// out = a(r, v), for one path (`T = f64`) or W paths at once (`T` = [`Lanes`](
    /// sdae_lanes::Lanes): coordinate i of every path in `r[i]`, `v[i]`, `out[i]`, lane k
    /// computing exactly what one path computes). Returns `false` where the lanes have no
    /// evaluation (a closure beyond [`PER_LANE_MAX_DIM`](sdae_lanes::PER_LANE_MAX_DIM)
    /// coordinates, [`Real::each_path`]): an ensemble then steps its paths one at a time. One
    /// path always returns `true`.
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool;
    /// The dimension l of the Brownian motion (0: deterministic, no random numbers drawn).
    fn noise_dim(&self) -> usize;
    /// out += B(r, v) dw, for one path or W paths at once (layout and result of
    /// [`System::drift`]).
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool;
    /// The system's Langevin form, if it has one: a(r, v) = a(r, 0) - gamma v with a constant
    /// friction gamma >= 0 and additive noise B = sigma I ([`LangevinForm`]), which splitting
    /// schemes (BAOAB) need to take the force F(r) = a(r, 0) apart from the friction and to
    /// update the velocity by the exact Ornstein-Uhlenbeck law. The default has none.
    fn langevin(&self) -> Option<LangevinForm> {
        None
    }
}

/// out = a(r, v) for W paths: the system's evaluation over lanes ([`System::drift`]), or path
/// by path on contiguous copies in `scratch` where the lanes have none. Lane k is path k's
/// drift either way.
#[inline(always)]
pub fn drift_over_lanes<S: System + ?Sized, Sd: Simd>(
    system: &S, r: &[Lanes<Sd>], v: &[Lanes<Sd>], out: &mut [Lanes<Sd>], scratch: &mut Vec<f64>,
) {
    if !system.drift(r, v, out) {
        per_path([r, v], out, scratch, |[r, v], out| {
            system.drift(r, v, out);
        });
    }
}

/// out += B(r, v) dw for W paths, as [`drift_over_lanes`] evaluates the drift.
#[inline(always)]
pub fn add_noise_over_lanes<S: System + ?Sized, Sd: Simd>(
    system: &S, r: &[Lanes<Sd>], v: &[Lanes<Sd>], dw: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    scratch: &mut Vec<f64>,
) {
    if !system.add_noise(r, v, dw, out) {
        per_path([r, v, dw], out, scratch, |[r, v, dw], out| {
            system.add_noise(r, v, dw, out);
        });
    }
}

/// The Langevin form of a system ([`System::langevin`]): with the force F(r) = a(r, 0),
/// M dv = [F(r) - gamma v] dt + sigma dw + grad g(r) dmu. At equilibrium the temperature is
/// kT = sigma^2 / (2 gamma) (fluctuation-dissipation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LangevinForm {
    /// The friction gamma >= 0 (the drift's -gamma v).
    pub friction: f64,
    /// The noise amplitude sigma >= 0 (B = sigma I).
    pub noise: f64,
}

/// The drift a(r, v).
pub trait Drift {
    /// out = a(r, v), for one path or W paths at once ([`System::drift`]). A closure
    /// `f(r, v, out)` for one path is a drift, evaluated lane by lane over lanes
    /// ([`Real::each_path`]).
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool;
    /// The constant friction gamma if the drift is a(r, v) = a(r, 0) - gamma v; the default
    /// (e.g. for a closure) says nothing (`None`).
    fn friction(&self) -> Option<f64> {
        None
    }
}

impl<F: Fn(&[f64], &[f64], &mut [f64])> Drift for F {
    #[inline(always)]
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        T::each_path([r, v], out, |[r, v], out| self(r, v, out))
    }
}

/// No drift: a = 0.
#[derive(Debug, Clone, Copy, Default)]
pub struct ZeroDrift;

impl Drift for ZeroDrift {
    #[inline(always)]
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (o, vi) in out.iter_mut().zip(v) {
            *o = vi.splat_like(0.0);
        }
        true
    }
    /// gamma = 0.
    fn friction(&self) -> Option<f64> {
        Some(0.0)
    }
}

/// The noise B(r, v) applied to increments dw.
pub trait Noise {
    /// The dimension l of the Brownian motion.
    fn dim(&self) -> usize;
    /// out += B(r, v) dw, for one path or W paths at once ([`System::add_noise`]).
    fn add<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool;
    /// sigma if the noise is additive, B = sigma I; the default (e.g. for a closure) says
    /// nothing (`None`).
    fn amplitude(&self) -> Option<f64> {
        None
    }
}

/// B = 0, l = 0: no random numbers are drawn.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoNoise;

impl Noise for NoNoise {
    fn dim(&self) -> usize {
        0
    }
    #[inline(always)]
    fn add<T: Real>(&self, _r: &[T], _v: &[T], _dw: &[T], _out: &mut [T]) -> bool {
        true
    }
    /// sigma = 0.
    fn amplitude(&self) -> Option<f64> {
        Some(0.0)
    }
}

/// Additive noise B = sigma I_n (l = n; l = 0 for sigma = 0, so that a noise-free system draws
/// no random numbers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdditiveNoise {
    sigma: f64,
    dim: usize,
}

impl AdditiveNoise {
    /// B = sigma I_dim; sigma must be finite and >= 0. With sigma = 0 the noise dimension is
    /// 0: no increments are asked for.
    pub fn new(sigma: f64, dim: usize) -> Result<Self, ModelError> {
        if !(sigma.is_finite() && sigma >= 0.0) {
            return Err(ModelError::InvalidSetting {
                name: "sigma",
                value: sigma,
                reason: "noise amplitude must be finite and >= 0",
            });
        }
        let dim = if sigma == 0.0 { 0 } else { dim };
        Ok(Self { sigma, dim })
    }
    /// The amplitude sigma.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }
}

impl Noise for AdditiveNoise {
    fn dim(&self) -> usize {
        self.dim
    }
    #[inline(always)]
    fn add<T: Real>(&self, _r: &[T], _v: &[T], dw: &[T], out: &mut [T]) -> bool {
        for (o, &w) in out.iter_mut().zip(dw) {
            *o = *o + w * self.sigma;
        }
        true
    }
    fn amplitude(&self) -> Option<f64> {
        Some(self.sigma)
    }
}

/// Noise from a closure `f(r, v, dw, out)` that adds B(r, v) dw to out, with l = `dim`.
#[derive(Clone)]
pub struct ClosureNoise<F> {
    dim: usize,
    f: F,
}

impl<F: Fn(&[f64], &[f64], &[f64], &mut [f64])> ClosureNoise<F> {
    /// Noise of dimension `dim` given by `f`.
    pub fn new(dim: usize, f: F) -> Self {
        Self { dim, f }
    }
}

impl<F: Fn(&[f64], &[f64], &[f64], &mut [f64])> Noise for ClosureNoise<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    #[inline(always)]
    fn add<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        T::each_path([r, v, dw], out, |[r, v, dw], out| (self.f)(r, v, dw, out))
    }
}

/// A system assembled from its parts.
#[derive(Debug, Clone)]
pub struct MechanicalSystem<C, M, A, B> {
    constraint: C,
    mass: M,
    drift: A,
    noise: B,
}

impl<C: Constraint, M: Mass, A: Drift, B: Noise> MechanicalSystem<C, M, A, B> {
    /// Checks that the mass matrix has order n and fits the constraint (a bead chain refuses a
    /// mass that couples beads).
    pub fn new(constraint: C, mass: M, drift: A, noise: B) -> Result<Self, ModelError> {
        mass.check_order(constraint.dim())?;
        constraint.check_mass(&mass)?;
        Ok(Self {
            constraint,
            mass,
            drift,
            noise,
        })
    }
    /// The drift.
    pub fn drift_part(&self) -> &A {
        &self.drift
    }
    /// The noise.
    pub fn noise_part(&self) -> &B {
        &self.noise
    }
}

impl<C: Constraint, M: Mass, A: Drift, B: Noise> System for MechanicalSystem<C, M, A, B> {
    type Constraint = C;
    type Mass = M;
    fn constraint(&self) -> &C {
        &self.constraint
    }
    fn mass(&self) -> &M {
        &self.mass
    }
    #[inline(always)]
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        self.drift.drift(r, v, out)
    }
    fn noise_dim(&self) -> usize {
        self.noise.dim()
    }
    #[inline(always)]
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        self.noise.add(r, v, dw, out)
    }
    /// The Langevin form where the drift has a constant friction and the noise is additive.
    fn langevin(&self) -> Option<LangevinForm> {
        Some(LangevinForm {
            friction: self.drift.friction()?,
            noise: self.noise.amplitude()?,
        })
    }
}

/// Checks that a system fits a scheme of seed eq. 1.1: 1 <= m < n constraints and a mass
/// matrix of order n that fits the constraint's Gram storage ([`Constraint::check_mass`]).
/// Returns (n, m).
pub fn check_dimensions<S: System + ?Sized>(system: &S) -> Result<(usize, usize), ModelError> {
    let c = system.constraint();
    let (n, m) = (c.dim(), c.n_constraints());
    if m == 0 || m >= n {
        return Err(ModelError::DimensionMismatch {
            what: "number of constraints m (need 1 <= m < n)",
            expected: n.saturating_sub(1),
            found: m,
        });
    }
    system.mass().check_order(n)?;
    c.check_mass(system.mass())?;
    Ok((n, m))
}

/// Checks a step's inputs against `system`: r and v of length n, dw of length l, and a step
/// size h that is finite and > 0.
pub fn check_step_input<S: System + ?Sized>(
    system: &S, r: &[f64], v: &[f64], h: f64, dw: &[f64],
) -> Result<(), ModelError> {
    let n = system.constraint().dim();
    check_dim("position r", n, r.len())?;
    check_dim("velocity v", n, v.len())?;
    check_dim("Brownian increment dw", system.noise_dim(), dw.len())?;
    check_step_size(h)
}
