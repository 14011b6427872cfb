//! The stochastic pendulum of seed Section 5.1, planar (d = 2) or spherical (d = 3):
//! dv = (-c_g e_d - gamma v) dt + sigma dw - r dmu / rho^2, |r| = rho, unit mass.

use sdae_lanes::Real;
use sdae_manifold::{IdentityMass, Sphere};
use sdae_model::{AdditiveNoise, Drift, MechanicalSystem};
use serde::{Deserialize, Serialize};

use crate::error::{SystemError, non_negative};

/// Gravity along -e_d and linear friction: a(r, v) = -c_g e_d - gamma v.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PendulumDrift {
    /// Gravity constant c_g >= 0.
    pub gravity: f64,
    /// Friction coefficient gamma >= 0.
    pub friction: f64,
}

impl Drift for PendulumDrift {
    #[inline(always)]
    fn drift<T: Real>(&self, _r: &[T], v: &[T], out: &mut [T]) -> bool {
        for (o, &vi) in out.iter_mut().zip(v) {
            *o = vi * -self.friction;
        }
        if let Some(last) = out.last_mut() {
            *last = *last - self.gravity;
        }
        true
    }
    /// gamma: the drift is a(r, 0) - gamma v.
    fn friction(&self) -> Option<f64> {
        Some(self.friction)
    }
}

/// The seed's stochastic pendulum as a system.
pub type Pendulum = MechanicalSystem<Sphere, IdentityMass, PendulumDrift, AdditiveNoise>;

/// Parameters of [`pendulum`] (in a scene file, the table `[system.pendulum]`; every field is
/// required there).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PendulumParams {
    /// Space dimension d: 2 (planar) or 3 (spherical).
    pub dim: usize,
    /// Length rho.
    pub length: f64,
    /// Gravity c_g.
    pub gravity: f64,
    /// Noise amplitude sigma (B = sigma I).
    pub noise: f64,
    /// Friction gamma.
    pub friction: f64,
}

impl Default for PendulumParams {
    /// The seed's planar unit pendulum with c_g = 1 and unit noise, no friction.
    fn default() -> Self {
        Self {
            dim: 2,
            length: 1.0,
            gravity: 1.0,
            noise: 1.0,
            friction: 0.0,
        }
    }
}

/// Builds the pendulum; fails on d not in {2, 3}, non-positive length, negative or non-finite
/// gravity, noise or friction, naming the parameter.
pub fn pendulum(params: PendulumParams) -> Result<Pendulum, SystemError> {
    if !(params.dim == 2 || params.dim == 3) {
        return Err(SystemError::InvalidParameter {
            name: "dim",
            value: params.dim as f64,
            rule: "a pendulum is planar (2) or spherical (3)",
        });
    }
    let gravity = non_negative("gravity", params.gravity)?;
    let friction = non_negative("friction", params.friction)?;
    let noise = AdditiveNoise::new(non_negative("noise", params.noise)?, params.dim)?;
    let sphere = Sphere::new(params.dim, crate::error::positive("length", params.length)?)?;
    Ok(MechanicalSystem::new(
        sphere,
        IdentityMass,
        PendulumDrift { gravity, friction },
        noise,
    )?)
}
