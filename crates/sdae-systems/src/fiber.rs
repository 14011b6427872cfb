//! An inextensible elastic fiber in turbulent air (seed Section 5.3), as a chain of K beads.
//!
//! Bead j at x_j in R^3 with mass m_j, segments of fixed length ds (the [`BeadChain`]
//! constraint g_i(x) = 1/2 - |x_{i+1} - x_i|^2 / (2 ds^2), seed Section 5.3), n = 3K, m = K - 1:
//!
//! ```text
//! m_j dv_j = [f_bend,j + m_j g_vec - (c1 + c2 |w_j|) w_j] dt + s_j dw_j + (grad g dmu)_j
//! w_j      = v_j - u(x_j),                u(x) = u_0 + S x        (air velocity)
//! s_j      = sigma_0 (1 + alpha |w_j|)   (turbulent forcing, dw_j 3 independent components)
//! E_b      = EI / (2 ds^3) sum_{i=1}^{K-2} |x_{i+1} - 2 x_i + x_{i-1}|^2,   f_bend = -grad E_b
//! ```
//!
//! - Bending (f_int of the seed): with D_i = x_{i+1} - 2 x_i + x_{i-1} for 1 <= i <= K - 2 and
//!   D_i = 0 otherwise, f_bend,j = -(EI / ds^3)(D_{j-1} - 2 D_j + D_{j+1}). Inside, this is the
//!   discrete fourth derivative -(EI / ds^3)(x_{j-2} - 4 x_{j-1} + 6 x_j - 4 x_{j+1} + x_{j+2});
//!   at the ends it is the free-free stencil (coefficients 1, -2, 1 at bead 0 and -2, 5, -4, 1
//!   at bead 1), the natural boundary conditions of a free end: no bending moment and no shear
//!   force. Translations and rotations of a straight fiber cost no energy.
//! - Gravity (f_grav): m_j g_vec.
//! - Air drag (f_air) relative to the air: linear (Stokes-like) -c1 w_j plus quadratic
//!   (form drag) -c2 |w_j| w_j, with a uniform wind u_0 and an optional linear shear S.
//! - Turbulence (L_air D_turb dw of the seed): the air velocity seen by bead j fluctuates,
//!   u -> u + u'. Linearizing the drag F(w) = -(c1 + c2 |w|) w about the mean relative velocity
//!   gives the force fluctuation DF(w) u' with c1 + c2 |w| <= |DF(w)| <= c1 + 2 c2 |w|: a
//!   turbulent force whose size grows linearly with |w|. This crate takes it isotropic per
//!   bead, s_j = sigma_0 (1 + alpha |w_j|) (alpha ~ c2 / c1 .. 2 c2 / c1 matches that
//!   linearization), with l = 3K. Its dependence on the position (through u(x_j)) and on the
//!   velocity is Lipschitz with linear growth, as Assumption 2.2 of the seed asks (the seed's
//!   own example uses l = K; three components per bead make the forcing isotropic).
//!
//! Constraint forces and the internal bending force sum to zero, so the center of mass moves
//! under gravity, drag and turbulence only. With S = 0 the drift satisfies the one-sided growth
//! bound of Assumption 2.2; with a shear the air's velocity grows with |x| and the bound holds
//! on bounded regions only. Every evaluation is O(K) and allocation-free.
//!
//! Two limits on the parameters and the step, both seen in the tests:
//!
//! - The scheme is explicit in the bending force. Its stiffest mode has
//!   omega_max^2 ~ 16 EI / (m ds^4), and the explicit step multiplies the energy of an undamped
//!   oscillation by 1 + omega^2 h^2 per step, while drag takes about 2 c h / m; so drag must win:
//!   omega_max^2 h < 2 (c1 + c2 |w|) / m, or the finest bending mode grows (the truncation of
//!   eq. 3.2 then caps but does not cure it).
//! - The turbulent amplitude grows with |w|, so the noise feeds itself: the mean square relative
//!   velocity stays moderate only while 3 (alpha sigma_0 / m)^2 < 2 c1 / m (from
//!   d E|w|^2 / dt at large |w| without the quadratic drag; beyond that only the quadratic drag
//!   holds |w|, at large relative speeds). The defaults have 1.08 against 2.
//!
//! The zigzag state lies on the constraint (`sdae_scheme::Stepper` steps it; its documentation
//! has a fiber's path):
//!
//! ```
//! use sdae_manifold::Constraint;
//! use sdae_model::System;
//! use sdae_systems::{Fiber, FiberParams};
//! let fiber = Fiber::new(&FiberParams::default())?;
//! let (r, v) = fiber.zigzag(0.2);
//! let mut g = vec![1.0; fiber.constraint().n_constraints()];
//! fiber.constraint().value(&r, &mut g);
//! assert!(g.iter().all(|x| x.abs() < 1e-12));
//! let mut a = vec![0.0; r.len()];
//! fiber.drift(&r, &v, &mut a);
//! assert!(a.iter().all(|x| x.is_finite()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use sdae_lanes::Real;
use sdae_manifold::{BeadChain, DiagonalMass};
use sdae_model::System;
use serde::{Deserialize, Serialize};

use crate::error::{SystemError, finite_entries, non_negative, particle_count, positive};
use crate::masses::Masses;
use crate::vec3::{Vec3, atom, dot};

/// The air velocity field u(x) = u_0 + S x (serde: `wind`, `shear`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AirFlow {
    /// The uniform wind u_0 (unit: length / time).
    #[serde(deserialize_with = "crate::exact::array")]
    pub wind: [f64; 3],
    /// The velocity gradient S (unit: 1 / time), row-major:
    /// u_k(x) = wind_k + sum_l `shear[k][l]` x_l.
    /// A simple shear flow along x varying with height z has only `shear[0][2]` nonzero.
    /// Optional in a file (no shear).
    #[serde(default, deserialize_with = "crate::exact::matrix")]
    pub shear: [[f64; 3]; 3],
}

impl AirFlow {
    /// u(x).
    #[inline(always)]
    pub fn velocity(&self, x: [f64; 3]) -> [f64; 3] {
        self.velocity_at(x)
    }

    /// u(x) for one path (`f64`) or W paths ([`Lanes`](sdae_lanes::Lanes)).
    #[inline(always)]
    fn velocity_at<T: Real>(&self, x: Vec3<T>) -> Vec3<T> {
        let s = &self.shear;
        let mut u = x;
        for k in 0..3 {
            u[k] = x[0] * s[k][0] + self.wind[k] + x[1] * s[k][1] + x[2] * s[k][2];
        }
        u
    }

    /// The wind `wind` plus a simple shear flow along x varying with height z: u(x) = wind +
    /// (`rate` z, 0, 0), the gradient S zero but for `shear[0][2]` = `rate`.
    pub fn sheared(wind: [f64; 3], rate: f64) -> Self {
        Self {
            wind,
            shear: [[0.0, 0.0, rate], [0.0; 3], [0.0; 3]],
        }
    }

    /// The velocity v - u(x) relative to the air.
    #[inline(always)]
    fn relative_velocity<T: Real>(&self, x: Vec3<T>, v: Vec3<T>) -> Vec3<T> {
        let u = self.velocity_at(x);
        [v[0] - u[0], v[1] - u[1], v[2] - u[2]]
    }
}

/// Parameters of a [`Fiber`] in any consistent units (the defaults are nondimensional: fiber
/// length about 1, gravity 1). In a file every field is required except `air.shear`; unknown
/// fields are an error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiberParams {
    /// Number of beads K >= 2.
    pub beads: usize,
    /// Segment length ds > 0 (unit: length); the fiber is (K - 1) ds long.
    pub segment: f64,
    /// Bead masses (unit: mass): one for all beads or one per bead.
    pub masses: Masses,
    /// Bending stiffness EI >= 0 (unit: force x length^2).
    pub bending_stiffness: f64,
    /// Gravitational acceleration g (unit: length / time^2) (finite).
    #[serde(deserialize_with = "crate::exact::array")]
    pub gravity: [f64; 3],
    /// The air velocity u(x) = wind + shear x.
    pub air: AirFlow,
    /// Linear drag coefficient c1 >= 0 per bead (unit: mass / time).
    pub linear_drag: f64,
    /// Quadratic drag coefficient c2 >= 0 per bead (unit: mass / length).
    pub quadratic_drag: f64,
    /// Turbulent force amplitude sigma_0 >= 0 per bead and component (unit: force x time^(1/2));
    /// 0 switches the noise off (no random numbers are drawn).
    pub turbulence: f64,
    /// Growth alpha >= 0 of the turbulent amplitude with the relative speed (unit: time / length).
    pub turbulence_gain: f64,
}

impl Default for FiberParams {
    /// 20 beads of mass 0.05 on a fiber of length 1, EI = 0.001, gravity (0, 0, -1), wind
    /// (1, 0, 0), c1 = c2 = 0.05 (velocity relaxation time 1), sigma_0 = 0.02, alpha = 1.5
    /// (between c2 / c1 and 2 c2 / c1).
    fn default() -> Self {
        Self {
            beads: 20,
            segment: 1.0 / 19.0,
            masses: Masses::Uniform(0.05),
            bending_stiffness: 1e-3,
            gravity: [0.0, 0.0, -1.0],
            air: AirFlow {
                wind: [1.0, 0.0, 0.0],
                shear: [[0.0; 3]; 3],
            },
            linear_drag: 0.05,
            quadratic_drag: 0.05,
            turbulence: 0.02,
            turbulence_gain: 1.5,
        }
    }
}

/// The fiber of seed Section 5.3 as a [`System`] (see the module documentation for the
/// equations).
#[derive(Debug, Clone)]
pub struct Fiber {
    chain: BeadChain,
    mass: DiagonalMass,
    params: FiberParams,
    /// EI / ds^3.
    bending: f64,
    /// m_j g_vec, per coordinate.
    weight: Vec<f64>,
}

impl Fiber {
    /// Builds the fiber; fails with the name, value and rule of the first bad parameter.
    pub fn new(params: &FiberParams) -> Result<Self, SystemError> {
        let beads = particle_count("beads", params.beads, 2, "a fiber needs >= 2 beads")?;
        let segment = positive("segment", params.segment)?;
        let masses = params.masses.resolve(beads)?;
        let stiffness = non_negative("bending_stiffness", params.bending_stiffness)?;
        finite_entries("gravity", &params.gravity)?;
        finite_entries("air.wind", &params.air.wind)?;
        finite_entries("air.shear", params.air.shear.as_flattened())?;
        non_negative("linear_drag", params.linear_drag)?;
        non_negative("quadratic_drag", params.quadratic_drag)?;
        non_negative("turbulence", params.turbulence)?;
        non_negative("turbulence_gain", params.turbulence_gain)?;
        Ok(Self {
            chain: BeadChain::new(beads, segment)?,
            mass: DiagonalMass::per_particle(&masses, 3)?,
            bending: stiffness / segment.powi(3),
            weight: masses
                .iter()
                .flat_map(|m| params.gravity.map(|g| m * g))
                .collect(),
            params: params.clone(),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &FiberParams {
        &self.params
    }

    /// The dimension l of the Brownian motion: 3K, or 0 without turbulence.
    pub fn noise_dimension(&self) -> usize {
        if self.params.turbulence > 0.0 {
            3 * self.chain.beads()
        } else {
            0
        }
    }

    /// The bending energy E_b = EI / (2 ds^3) sum_i |x_{i+1} - 2 x_i + x_{i-1}|^2.
    pub fn bending_energy(&self, r: &[f64]) -> f64 {
        let sum: f64 = (1..self.chain.beads().saturating_sub(1))
            .map(|i| {
                let d = self.second_difference(r, i);
                d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
            })
            .sum();
        0.5 * self.bending * sum
    }

    /// The potential energy E_b - sum_j m_j g_vec . x_j.
    pub fn potential_energy(&self, r: &[f64]) -> f64 {
        self.bending_energy(r) - r.iter().zip(&self.weight).map(|(x, f)| x * f).sum::<f64>()
    }

    /// The kinetic energy v^T M v / 2.
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        self.mass.kinetic_energy(v)
    }

    /// The mechanical energy: kinetic plus potential. With still air (u = 0) and no
    /// turbulence, drag makes it decrease along exact solutions.
    pub fn energy(&self, r: &[f64], v: &[f64]) -> f64 {
        self.kinetic_energy(v) + self.potential_energy(r)
    }

    /// The mass-weighted mean of the bead positions (or velocities, given v).
    pub fn center_of_mass(&self, r: &[f64]) -> [f64; 3] {
        let m = self.mass.diagonal();
        let total: f64 = m.iter().step_by(3).sum();
        [0, 1, 2].map(|k| {
            r.iter()
                .zip(m)
                .skip(k)
                .step_by(3)
                .map(|(x, mi)| x * mi)
                .sum::<f64>()
                / total
        })
    }

    /// A straight fiber hanging along the gravity (along -z if gravity is 0) from bead 0 at the
    /// origin, at rest.
    pub fn hanging(&self) -> (Vec<f64>, Vec<f64>) {
        let g = self.params.gravity;
        let direction = if dot(g, g).sqrt() > 0.0 {
            g
        } else {
            [0.0, 0.0, -1.0]
        };
        let r = self
            .chain
            .straight(direction)
            .unwrap_or_else(|_| vec![0.0; 3 * self.chain.beads()]);
        let v = vec![0.0; r.len()];
        (r, v)
    }

    /// A planar zigzag in the x-y plane (segments at +/- `half_angle` (unit: rad) to the x axis,
    /// alternating; a small angle gives a gently crumpled fiber) from bead 0 at the origin, at
    /// rest.
    pub fn zigzag(&self, half_angle: f64) -> (Vec<f64>, Vec<f64>) {
        let r = self.chain.zigzag(half_angle);
        let v = vec![0.0; r.len()];
        (r, v)
    }

    /// D_i = x_{i+1} - 2 x_i + x_{i-1} for 1 <= i <= K - 2, else 0.
    #[inline(always)]
    fn second_difference<T: Real>(&self, x: &[T], i: usize) -> Vec3<T> {
        let zero = x[0].splat_like(0.0);
        if i == 0 || i + 1 >= self.chain.beads() {
            return [zero; 3];
        }
        let p = &x[3 * i - 3..3 * i + 6];
        let mut d = [zero; 3];
        for k in 0..3 {
            d[k] = p[k + 6] - p[k + 3] * 2.0 + p[k];
        }
        d
    }

    /// out = a(r, v) (see [`System::drift`]), for one path (`f64`) or W paths ([`Lanes`](sdae_lanes::Lanes)).
    #[inline(always)]
    fn forces<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) {
        let (c1, c2) = (self.params.linear_drag, self.params.quadratic_drag);
        let zero = [r[0].splat_like(0.0); 3];
        let (mut previous, mut current) = (zero, zero);
        for (j, (o, weight)) in out
            .chunks_exact_mut(3)
            .zip(self.weight.chunks_exact(3))
            .enumerate()
        {
            let next = self.second_difference(r, j + 1);
            let w = self.params.air.relative_velocity(atom(r, j), atom(v, j));
            let drag = dot(w, w).sqrt() * c2 + c1;
            for k in 0..3 {
                let bend = previous[k] - current[k] * 2.0 + next[k];
                o[k] = r[0].splat_like(weight[k]) - bend * self.bending - drag * w[k];
            }
            previous = current;
            current = next;
        }
    }

    /// out += B(r, v) dw (see [`System::add_noise`]), for one path (`f64`) or W paths
    /// ([`Lanes`](sdae_lanes::Lanes)).
    #[inline(always)]
    fn turbulence<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) {
        let (sigma, alpha) = (self.params.turbulence, self.params.turbulence_gain);
        for (j, (o, d)) in out.chunks_exact_mut(3).zip(dw.chunks_exact(3)).enumerate() {
            let w = self.params.air.relative_velocity(atom(r, j), atom(v, j));
            let s = (dot(w, w).sqrt() * alpha + 1.0) * sigma;
            for k in 0..3 {
                o[k] = o[k] + s * d[k];
            }
        }
    }
}

impl System for Fiber {
    type Constraint = BeadChain;
    type Mass = DiagonalMass;
    fn constraint(&self) -> &BeadChain {
        &self.chain
    }
    fn mass(&self) -> &DiagonalMass {
        &self.mass
    }
    /// a_j = -(EI / ds^3)(D_{j-1} - 2 D_j + D_{j+1}) + m_j g_vec - (c1 + c2 |w_j|) w_j, one pass.
    #[inline(always)]
    fn drift<T: Real>(&self, r: &[T], v: &[T], out: &mut [T]) -> bool {
        self.forces(r, v, out);
        true
    }
    fn noise_dim(&self) -> usize {
        self.noise_dimension()
    }
    /// out_j += sigma_0 (1 + alpha |v_j - u(x_j)|) dw_j.
    #[inline(always)]
    fn add_noise<T: Real>(&self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> bool {
        self.turbulence(r, v, dw, out);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdae_manifold::check_state;

    fn still_air(beads: usize) -> FiberParams {
        FiberParams {
            beads,
            masses: Masses::PerParticle((0..beads).map(|j| 0.05 + 0.01 * j as f64).collect()),
            air: AirFlow::default(),
            ..FiberParams::default()
        }
    }

    /// A crumpled 3-d configuration (not on the manifold: the forces do not care).
    fn crumpled(beads: usize) -> Vec<f64> {
        (0..3 * beads)
            .map(|k| 0.05 * (k / 3) as f64 + 0.03 * (k as f64 * 1.9).sin())
            .collect()
    }

    #[test]
    fn lane_forms_are_the_scalar_forces_bit_for_bit() {
        use crate::vec3::check::{lane_forms_match_scalar, states_near};
        let fiber = Fiber::new(&FiberParams {
            air: AirFlow {
                wind: [1.0, -0.5, 0.25],
                shear: [[0.1, 0.0, 0.5], [0.0, -0.2, 0.0], [0.3, 0.0, 0.05]],
            },
            ..still_air(13)
        })
        .unwrap();
        lane_forms_match_scalar(&fiber, &states_near(&crumpled(13), 10));
        // Two beads: no bending term at all.
        let short = Fiber::new(&still_air(2)).unwrap();
        lane_forms_match_scalar(&short, &states_near(&crumpled(2), 5));
    }

    #[test]
    fn bending_force_is_minus_the_energy_gradient_with_free_ends() {
        for beads in [2, 3, 4, 5, 9] {
            let fiber = Fiber::new(&FiberParams {
                bending_stiffness: 0.01,
                gravity: [0.0; 3],
                linear_drag: 0.0,
                quadratic_drag: 0.0,
                ..still_air(beads)
            })
            .unwrap();
            let x = crumpled(beads);
            let v = vec![0.0; x.len()];
            let mut force = vec![0.0; x.len()];
            fiber.drift(&x, &v, &mut force);
            let eps = 1e-6;
            let mut y = x.clone();
            for k in 0..x.len() {
                y[k] = x[k] + eps;
                let up = fiber.bending_energy(&y);
                y[k] = x[k] - eps;
                let down = fiber.bending_energy(&y);
                y[k] = x[k];
                let fd = -(up - down) / (2.0 * eps);
                assert!(
                    (fd - force[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "K = {beads}, coordinate {k}: {fd} vs {}",
                    force[k]
                );
            }
            if beads >= 3 {
                assert!(
                    force.iter().any(|f| f.abs() > 0.1),
                    "K = {beads}: {force:?}"
                );
            }
            // Free ends: the bending force has no net force and no net torque.
            let mut torque = [0.0; 3];
            for (x, f) in x.chunks_exact(3).zip(force.chunks_exact(3)) {
                for (c, t) in torque.iter_mut().enumerate() {
                    let (p, q) = ((c + 1) % 3, (c + 2) % 3);
                    *t += x[p] * f[q] - x[q] * f[p];
                }
            }
            for c in 0..3 {
                let net: f64 = force.iter().skip(c).step_by(3).sum();
                assert!(net.abs() < 1e-9, "K = {beads}: net force {net}");
                assert!(torque[c].abs() < 1e-9, "K = {beads}: net torque {torque:?}");
            }
        }
    }

    #[test]
    fn drag_and_noise_follow_the_relative_velocity() {
        let params = FiberParams {
            bending_stiffness: 0.0,
            gravity: [0.0; 3],
            air: AirFlow::sheared([1.0, 0.0, 0.0], 2.0),
            linear_drag: 0.3,
            quadratic_drag: 0.2,
            turbulence: 0.5,
            turbulence_gain: 2.0,
            ..FiberParams::default()
        };
        let fiber = Fiber::new(&FiberParams { beads: 2, ..params }).unwrap();
        // Bead 0 at height 0 moves with the air; bead 1 at height 0.5 sees wind 2 and is at rest.
        let r = [0.0, 0.0, 0.0, 0.0, 0.0, 0.5];
        let v = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut a = [0.0; 6];
        fiber.drift(&r, &v, &mut a);
        let expected = [0.0, 0.0, 0.0, (0.3 + 0.2 * 2.0) * 2.0, 0.0, 0.0];
        for (x, e) in a.iter().zip(expected) {
            assert!((x - e).abs() < 1e-14, "{a:?}");
        }
        let mut out = [0.0; 6];
        fiber.add_noise(&r, &v, &[1.0; 6], &mut out);
        let expected = [0.5, 0.5, 0.5, 2.5, 2.5, 2.5];
        for (x, e) in out.iter().zip(expected) {
            assert!((x - e).abs() < 1e-14, "{out:?}");
        }
    }

    #[test]
    fn initial_states_are_on_the_tangent_bundle() {
        let fiber = Fiber::new(&FiberParams::default()).unwrap();
        for (r, v) in [fiber.hanging(), fiber.zigzag(0.3)] {
            check_state(fiber.constraint(), &r, &v, 1e-14).unwrap();
        }
        let (r, _) = fiber.hanging();
        assert!(r[3 * 19 + 2] < -0.99, "hangs down along gravity");
        assert!(fiber.bending_energy(&r) < 1e-20);
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = |p: FiberParams| Fiber::new(&p).unwrap_err();
        let e = bad(FiberParams {
            beads: 1,
            ..FiberParams::default()
        });
        assert!(
            matches!(e, SystemError::InvalidParameter { name: "beads", .. }),
            "{e}"
        );
        let e = bad(FiberParams {
            bending_stiffness: f64::NAN,
            ..FiberParams::default()
        });
        assert_eq!(e.parameter(), Some("bending_stiffness"), "{e}");
        let e = bad(FiberParams {
            turbulence: -0.1,
            ..FiberParams::default()
        });
        assert_eq!(
            e,
            SystemError::InvalidParameter {
                name: "turbulence",
                value: -0.1,
                rule: "must be finite and >= 0"
            }
        );
        let mut shear = [[0.0; 3]; 3];
        shear[1][2] = f64::INFINITY;
        let e = bad(FiberParams {
            air: AirFlow {
                wind: [0.0; 3],
                shear,
            },
            ..FiberParams::default()
        });
        assert!(
            matches!(
                e,
                SystemError::InvalidEntry {
                    name: "air.shear",
                    index: 5,
                    ..
                }
            ),
            "{e}"
        );
        let e = bad(FiberParams {
            segment: 0.0,
            ..FiberParams::default()
        });
        assert_eq!(e.parameter(), Some("segment"), "{e}");
    }
}
