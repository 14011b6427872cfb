//! Potentials V(x) of atoms in R^3 (atom a at coordinates 3a..3a+3) for the Langevin drift
//! a(x, y) = -grad V(x) - gamma y of seed Section 5.2.
//!
//! Terms compose: `(A, B)` is the sum of two potentials, `Option<P>` is P or nothing (and
//! `None` costs nothing), `()` is V = 0. Every term is O(number of atoms it acts on).
//!
//! Every built-in term adds its force for one path or for W paths at once
//! ([`Potential::add_force`] over [`Real`]), lane i computing exactly what one path computes
//! for path i; the sines and arc tangents are taken lane by lane.

use sdae_lanes::{PathMask, Real};
use serde::{Deserialize, Serialize};

use crate::error::{SystemError, finite, finite_entries, non_negative};
use crate::vec3::{Vec3, add_to, atom, cross, dot, sub};

/// A potential energy V(x) and its force -grad V(x).
pub trait Potential {
    /// V(x).
    fn energy(&self, x: &[f64]) -> f64;
    /// force += -grad V(x), for one path (`f64`) or W paths at once ([`sdae_lanes::Lanes`]:
    /// coordinate i of every path in `x[i]` and `force[i]`). Returns `false` where the lanes
    /// have no evaluation (`force` is then to be recomputed path by path, [`Real::each_path`]);
    /// one path always returns `true`.
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool;
    /// The smallest configuration dimension n the term can act on (3 x (largest atom index +
    /// 1)); 0 if it fits any.
    fn min_dim(&self) -> usize {
        0
    }
}

impl Potential for () {
    #[inline(always)]
    fn energy(&self, _x: &[f64]) -> f64 {
        0.0
    }
    #[inline(always)]
    fn add_force<T: Real>(&self, _x: &[T], _force: &mut [T]) -> bool {
        true
    }
}

impl<P: Potential> Potential for Option<P> {
    #[inline]
    fn energy(&self, x: &[f64]) -> f64 {
        self.as_ref().map_or(0.0, |p| p.energy(x))
    }
    #[inline(always)]
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool {
        self.as_ref().is_none_or(|p| p.add_force(x, force))
    }
    fn min_dim(&self) -> usize {
        self.as_ref().map_or(0, P::min_dim)
    }
}

impl<A: Potential, B: Potential> Potential for (A, B) {
    #[inline]
    fn energy(&self, x: &[f64]) -> f64 {
        self.0.energy(x) + self.1.energy(x)
    }
    #[inline(always)]
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool {
        self.0.add_force(x, force) && self.1.add_force(x, force)
    }
    fn min_dim(&self) -> usize {
        self.0.min_dim().max(self.1.min_dim())
    }
}

/// Checks that the atoms of one term are distinct; returns 3 (largest index + 1).
fn check_term<const K: usize>(
    name: &'static str, terms: &[[usize; K]],
) -> Result<usize, SystemError> {
    let mut dim = 0;
    for (index, t) in terms.iter().enumerate() {
        for p in 0..K {
            if t[p + 1..].contains(&t[p]) {
                return Err(SystemError::InvalidEntry {
                    name,
                    index,
                    value: t[p] as f64,
                    rule: "the atoms of a term must be distinct",
                });
            }
        }
        dim = dim.max(3 * (t.iter().max().copied().unwrap_or(0) + 1));
    }
    Ok(dim)
}

/// The terms (i, i + 1, ..., i + K - 1) of K consecutive atoms of a linear chain of `atoms`
/// atoms.
fn chain_terms<const K: usize>(atoms: usize) -> Vec<[usize; K]> {
    (0..atoms.saturating_sub(K - 1))
        .map(|i| std::array::from_fn(|k| i + k))
        .collect()
}

/// Parameters of a harmonic bond-angle potential (serde: `stiffness`, `equilibrium`; missing
/// fields take their defaults, unknown ones are an error).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AngleParams {
    /// k_theta >= 0 (unit: energy / rad^2); 0 switches the term off (no cost).
    pub stiffness: f64,
    /// theta_0 in (0, pi] (unit: rad), the angle between the two bonds at the middle atom.
    pub equilibrium: f64,
}

impl Default for AngleParams {
    /// Off (k_theta = 0), with the tetrahedral angle theta_0 = arccos(-1/3) (109.47 degrees).
    fn default() -> Self {
        Self {
            stiffness: 0.0,
            equilibrium: (-1.0_f64 / 3.0).acos(),
        }
    }
}

/// V = sum over triples (a, b, c) of k_theta / 2 (theta - theta_0)^2, theta the angle at b
/// between x_a - x_b and x_c - x_b, computed as atan2(|u x w|, u.w).
///
/// The force on a is -k_theta (theta - theta_0) dtheta/dx_a with dtheta/dx_a =
/// -(n x u) / (|u|^2 |n|), u = x_a - x_b, n = u x w: its size k_theta |theta - theta_0| / |u| is
/// bounded. At an exactly collinear triple the bending plane is undefined and the term adds no
/// force (there V has a cusp unless theta_0 = pi; for theta_0 = pi the force tends to 0).
#[derive(Debug, Clone, PartialEq)]
pub struct BondAngles {
    triples: Vec<[usize; 3]>,
    params: AngleParams,
    min_dim: usize,
}

impl BondAngles {
    /// Angles at the middle atoms of `triples` [a, b, c]; fails on a non-finite or negative
    /// stiffness, an equilibrium angle outside (0, pi], or a triple with a repeated atom.
    pub fn new(triples: Vec<[usize; 3]>, params: AngleParams) -> Result<Self, SystemError> {
        non_negative("angle.stiffness", params.stiffness)?;
        let theta = finite("angle.equilibrium", params.equilibrium)?;
        if !(theta > 0.0 && theta <= std::f64::consts::PI) {
            return Err(SystemError::InvalidParameter {
                name: "angle.equilibrium",
                value: theta,
                rule: "must lie in (0, pi] (radians)",
            });
        }
        let min_dim = check_term("angle triples", &triples)?;
        Ok(Self {
            triples,
            params,
            min_dim,
        })
    }

    /// The angles (i, i+1, i+2) of a linear chain of `atoms` atoms.
    pub fn chain(atoms: usize, params: AngleParams) -> Result<Self, SystemError> {
        Self::new(chain_terms(atoms), params)
    }

    /// The triples (a, b, c), b the vertex.
    pub fn triples(&self) -> &[[usize; 3]] {
        &self.triples
    }

    /// Stiffness and equilibrium angle.
    pub fn params(&self) -> AngleParams {
        self.params
    }
}

impl Potential for BondAngles {
    /// force += -grad V(x), for one path (`f64`) or W paths ([`Lanes`](sdae_lanes::Lanes); the arc tangent lane
    /// by lane).
    #[inline(always)]
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool {
        let AngleParams {
            stiffness,
            equilibrium,
        } = self.params;
        for &[a, b, c] in &self.triples {
            let xb = atom(x, b);
            let (u, w) = (sub(atom(x, a), xb), sub(atom(x, c), xb));
            let n = cross(u, w);
            let s = dot(n, n).sqrt();
            // No bending plane: the term adds no force.
            let skip = s.equal(s.splat_like(0.0));
            let theta = s.zip_map_each(dot(u, w), f64::atan2);
            let scale = (theta - equilibrium) * stiffness / s;
            // F_a = -k (theta - theta_0) dtheta/du = k (theta - theta_0) (n x u) / (|u|^2 |n|),
            // F_c = -k (theta - theta_0) (n x w) / (|w|^2 |n|), F_b = -(F_a + F_c).
            let (nu, nw) = (cross(n, u), cross(n, w));
            let (uu, ww) = (dot(u, u), dot(w, w));
            let fa = [nu[0] * scale / uu, nu[1] * scale / uu, nu[2] * scale / uu];
            let fc: Vec3<T> = [
                -nw[0] * scale / ww,
                -nw[1] * scale / ww,
                -nw[2] * scale / ww,
            ];
            add_to(force, a, fa, skip);
            add_to(force, c, fc, skip);
            let fb = [
                (fa[0] + fc[0]) * -1.0,
                (fa[1] + fc[1]) * -1.0,
                (fa[2] + fc[2]) * -1.0,
            ];
            add_to(force, b, fb, skip);
        }
        true
    }
    fn energy(&self, x: &[f64]) -> f64 {
        let AngleParams {
            stiffness,
            equilibrium,
        } = self.params;
        self.triples
            .iter()
            .map(|&[a, b, c]| {
                let xb = atom(x, b);
                let (u, w) = (sub(atom(x, a), xb), sub(atom(x, c), xb));
                let theta = dot(cross(u, w), cross(u, w)).sqrt().atan2(dot(u, w));
                0.5 * stiffness * (theta - equilibrium).powi(2)
            })
            .sum()
    }

    fn min_dim(&self) -> usize {
        self.min_dim
    }
}

/// Parameters of a dihedral cosine potential (serde: `stiffness`, `multiplicity`, `phase`;
/// missing fields take their defaults, unknown ones are an error).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TorsionParams {
    /// k_phi >= 0 (unit: energy); 0 switches the term off (no cost).
    pub stiffness: f64,
    /// Multiplicity n >= 1 (number of minima per turn).
    pub multiplicity: u32,
    /// Phase delta (unit: rad).
    pub phase: f64,
}

impl Default for TorsionParams {
    /// Off (k_phi = 0), with the threefold alkane-like shape n = 3, delta = 0.
    fn default() -> Self {
        Self {
            stiffness: 0.0,
            multiplicity: 3,
            phase: 0.0,
        }
    }
}

/// V = sum over quadruples (a, b, c, d) of k_phi (1 + cos(n phi - delta)), phi the dihedral
/// angle about the bond b-c: with b1 = x_b - x_a, b2 = x_c - x_b, b3 = x_d - x_c,
/// n1 = b1 x b2, n2 = b2 x b3, phi = atan2(|b2| b1.n2, n1.n2) (phi = pi is trans).
///
/// dphi/dx_a = -|b2| n1 / |n1|^2, dphi/dx_d = |b2| n2 / |n2|^2, and the middle atoms take the
/// rest so that the forces sum to zero with zero torque. The force grows like 1 / sin of the
/// bond angle as three consecutive atoms become collinear (phi is undefined there; at exactly
/// collinear atoms the term adds no force): combine it with a [`BondAngles`] term whose
/// equilibrium is away from pi.
#[derive(Debug, Clone, PartialEq)]
pub struct Torsions {
    quadruples: Vec<[usize; 4]>,
    params: TorsionParams,
    min_dim: usize,
}

impl Torsions {
    /// Dihedrals of `quadruples` [a, b, c, d]; fails on a non-finite or negative stiffness,
    /// multiplicity 0, a non-finite phase, or a quadruple with a repeated atom.
    pub fn new(quadruples: Vec<[usize; 4]>, params: TorsionParams) -> Result<Self, SystemError> {
        non_negative("torsion.stiffness", params.stiffness)?;
        finite("torsion.phase", params.phase)?;
        if params.multiplicity == 0 {
            return Err(SystemError::InvalidParameter {
                name: "torsion.multiplicity",
                value: 0.0,
                rule: "must be >= 1",
            });
        }
        let min_dim = check_term("torsion quadruples", &quadruples)?;
        Ok(Self {
            quadruples,
            params,
            min_dim,
        })
    }

    /// The dihedrals (i, i+1, i+2, i+3) of a linear chain of `atoms` atoms.
    pub fn chain(atoms: usize, params: TorsionParams) -> Result<Self, SystemError> {
        Self::new(chain_terms(atoms), params)
    }

    /// The quadruples (a, b, c, d).
    pub fn quadruples(&self) -> &[[usize; 4]] {
        &self.quadruples
    }

    /// Stiffness, multiplicity and phase.
    pub fn params(&self) -> TorsionParams {
        self.params
    }

    /// The dihedral angle phi of the quadruple (a, b, c, d) at x.
    pub fn dihedral(x: &[f64], [a, b, c, d]: [usize; 4]) -> f64 {
        let (b1, b2, b3) = (
            sub(atom(x, b), atom(x, a)),
            sub(atom(x, c), atom(x, b)),
            sub(atom(x, d), atom(x, c)),
        );
        let (n1, n2) = (cross(b1, b2), cross(b2, b3));
        (dot(b2, b2).sqrt() * dot(b1, n2)).atan2(dot(n1, n2))
    }
}

impl Potential for Torsions {
    /// force += -grad V(x), for one path (`f64`) or W paths ([`Lanes`](sdae_lanes::Lanes); the arc tangent and
    /// the sine lane by lane).
    #[inline(always)]
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool {
        let TorsionParams {
            stiffness,
            multiplicity,
            phase,
        } = self.params;
        let n = f64::from(multiplicity);
        for &[a, b, c, d] in &self.quadruples {
            let (b1, b2, b3) = (
                sub(atom(x, b), atom(x, a)),
                sub(atom(x, c), atom(x, b)),
                sub(atom(x, d), atom(x, c)),
            );
            let (n1, n2) = (cross(b1, b2), cross(b2, b3));
            let (nn1, nn2, bb2) = (dot(n1, n1), dot(n2, n2), dot(b2, b2));
            // Three collinear atoms: phi is undefined and the term adds no force.
            let zero = bb2.splat_like(0.0);
            let skip = nn1.equal(zero).or(nn2.equal(zero));
            let len2 = bb2.sqrt();
            let phi = (len2 * dot(b1, n2)).zip_map_each(dot(n1, n2), f64::atan2);
            // F = -dV/dphi dphi/dx, dV/dphi = -k n sin(n phi - delta).
            let torque = (phi * n - phase).map_each(f64::sin) * (stiffness * n);
            let (ta, td) = (-torque * len2, torque * len2);
            let fa = [ta * n1[0] / nn1, ta * n1[1] / nn1, ta * n1[2] / nn1];
            let fd = [td * n2[0] / nn2, td * n2[1] / nn2, td * n2[2] / nn2];
            let (p, q) = (dot(b1, b2) / bb2, dot(b3, b2) / bb2);
            // dphi/dx_b = -(1 + p) dphi/dx_a + q dphi/dx_d,
            // dphi/dx_c = p dphi/dx_a - (1 + q) dphi/dx_d.
            let (p1, q1) = (p + 1.0, q + 1.0);
            let fb = [
                q * fd[0] - p1 * fa[0],
                q * fd[1] - p1 * fa[1],
                q * fd[2] - p1 * fa[2],
            ];
            let fc = [
                p * fa[0] - q1 * fd[0],
                p * fa[1] - q1 * fd[1],
                p * fa[2] - q1 * fd[2],
            ];
            add_to(force, a, fa, skip);
            add_to(force, b, fb, skip);
            add_to(force, c, fc, skip);
            add_to(force, d, fd, skip);
        }
        true
    }
    fn energy(&self, x: &[f64]) -> f64 {
        let TorsionParams {
            stiffness,
            multiplicity,
            phase,
        } = self.params;
        self.quadruples
            .iter()
            .map(|&q| {
                let phi = Self::dihedral(x, q);
                stiffness * (1.0 + (f64::from(multiplicity) * phi - phase).cos())
            })
            .sum()
    }

    fn min_dim(&self) -> usize {
        self.min_dim
    }
}

/// Parameters of a harmonic trap (serde: `stiffness`, `center`; missing fields take their
/// defaults, unknown ones are an error).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrapParams {
    /// k >= 0 (unit: energy / length^2); 0 switches the trap off.
    pub stiffness: f64,
    /// Center c (unit: length).
    #[serde(deserialize_with = "crate::exact::array")]
    pub center: [f64; 3],
}

impl Default for TrapParams {
    /// A unit trap at the origin.
    fn default() -> Self {
        Self {
            stiffness: 1.0,
            center: [0.0; 3],
        }
    }
}

/// The confining potential V = sum over all atoms a of k / 2 |x_a - c|^2, force -k (x_a - c).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarmonicTrap {
    params: TrapParams,
}

impl HarmonicTrap {
    /// Fails on a negative or non-finite stiffness or a non-finite center.
    pub fn new(params: TrapParams) -> Result<Self, SystemError> {
        non_negative("trap.stiffness", params.stiffness)?;
        finite_entries("trap.center", &params.center)?;
        Ok(Self { params })
    }

    /// Stiffness and center.
    pub fn params(&self) -> TrapParams {
        self.params
    }
}

impl Potential for HarmonicTrap {
    /// force_a += -k (x_a - c), for one path (`f64`) or W paths ([`Lanes`](sdae_lanes::Lanes)).
    #[inline(always)]
    fn add_force<T: Real>(&self, x: &[T], force: &mut [T]) -> bool {
        let TrapParams { stiffness, center } = self.params;
        for (f, p) in force.chunks_exact_mut(3).zip(x.chunks_exact(3)) {
            for k in 0..3 {
                f[k] = f[k] - (p[k] - center[k]) * stiffness;
            }
        }
        true
    }
    fn energy(&self, x: &[f64]) -> f64 {
        let TrapParams { stiffness, center } = self.params;
        0.5 * stiffness
            * x.chunks_exact(3)
                .map(|p| {
                    let d = [p[0] - center[0], p[1] - center[1], p[2] - center[2]];
                    dot(d, d)
                })
                .sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bent, twisted, non-planar configuration of 6 atoms.
    fn configuration() -> Vec<f64> {
        (0..18)
            .map(|k| (k as f64 * 1.37).sin() + 0.4 * (k / 3) as f64)
            .collect()
    }

    /// Checks add_force against central differences of energy.
    fn check_force<P: Potential>(potential: &P, x: &[f64], tolerance: f64) {
        let mut force = vec![0.0; x.len()];
        potential.add_force(x, &mut force);
        let eps = 1e-6;
        let mut y = x.to_vec();
        let mut scale: f64 = 0.0;
        for k in 0..x.len() {
            y[k] = x[k] + eps;
            let up = potential.energy(&y);
            y[k] = x[k] - eps;
            let down = potential.energy(&y);
            y[k] = x[k];
            let fd = -(up - down) / (2.0 * eps);
            scale = scale.max(fd.abs());
            assert!(
                (fd - force[k]).abs() < tolerance,
                "coordinate {k}: finite difference {fd} vs force {}",
                force[k]
            );
        }
        assert!(scale > 1e-3, "the check must see a nonzero force ({scale})");
    }

    #[test]
    fn angle_force_is_minus_the_energy_gradient() {
        let x = configuration();
        for equilibrium in [1.9, std::f64::consts::PI, 0.5] {
            let angles = BondAngles::chain(
                6,
                AngleParams {
                    stiffness: 3.0,
                    equilibrium,
                },
            )
            .unwrap();
            check_force(&angles, &x, 1e-7);
        }
    }

    #[test]
    fn torsion_force_is_minus_the_energy_gradient() {
        let x = configuration();
        for (multiplicity, phase) in [(1, 0.0), (3, 0.4), (2, -1.0)] {
            let torsions = Torsions::chain(
                6,
                TorsionParams {
                    stiffness: 2.0,
                    multiplicity,
                    phase,
                },
            )
            .unwrap();
            check_force(&torsions, &x, 1e-7);
        }
    }

    #[test]
    fn trap_and_sum_forces_are_minus_the_energy_gradient() {
        let x = configuration();
        let trap = HarmonicTrap::new(TrapParams {
            stiffness: 1.5,
            center: [0.1, -0.2, 0.3],
        })
        .unwrap();
        check_force(&trap, &x, 1e-7);
        let angles = BondAngles::chain(6, AngleParams::default()).unwrap();
        let total = (Some(trap), (angles, ()));
        check_force(&total, &x, 1e-7);
    }

    #[test]
    fn straight_chain_angle_force_is_zero_or_finite() {
        let x: Vec<f64> = (0..9)
            .map(|k| if k % 3 == 0 { k as f64 } else { 0.0 })
            .collect();
        let mut force = vec![0.0; 9];
        let straight = BondAngles::chain(
            3,
            AngleParams {
                stiffness: 1.0,
                equilibrium: std::f64::consts::PI,
            },
        )
        .unwrap();
        straight.add_force(&x, &mut force);
        assert!(force.iter().all(|f| *f == 0.0), "{force:?}");
        let torsion = Torsions::chain(
            4,
            TorsionParams {
                stiffness: 1.0,
                ..TorsionParams::default()
            },
        )
        .unwrap();
        let x4: Vec<f64> = (0..12)
            .map(|k| if k % 3 == 0 { k as f64 } else { 0.0 })
            .collect();
        let mut force = vec![0.0; 12];
        torsion.add_force(&x4, &mut force);
        assert!(force.iter().all(|f| f.is_finite()), "{force:?}");
    }

    #[test]
    fn bad_terms_are_rejected_by_name() {
        let e = BondAngles::new(vec![[0, 1, 0]], AngleParams::default()).unwrap_err();
        assert!(
            matches!(
                e,
                SystemError::InvalidEntry {
                    name: "angle triples",
                    index: 0,
                    ..
                }
            ),
            "{e}"
        );
        let e = BondAngles::chain(
            3,
            AngleParams {
                stiffness: f64::NAN,
                ..AngleParams::default()
            },
        )
        .unwrap_err();
        assert_eq!(e.parameter(), Some("angle.stiffness"), "{e}");
        let e = BondAngles::chain(
            3,
            AngleParams {
                stiffness: 1.0,
                equilibrium: 4.0,
            },
        )
        .unwrap_err();
        assert_eq!(e.parameter(), Some("angle.equilibrium"), "{e}");
        let e = Torsions::chain(
            4,
            TorsionParams {
                multiplicity: 0,
                ..TorsionParams::default()
            },
        )
        .unwrap_err();
        assert_eq!(e.parameter(), Some("torsion.multiplicity"), "{e}");
        let e = HarmonicTrap::new(TrapParams {
            stiffness: -1.0,
            ..TrapParams::default()
        })
        .unwrap_err();
        assert_eq!(e.parameter(), Some("trap.stiffness"), "{e}");
        let e = HarmonicTrap::new(TrapParams {
            stiffness: 1.0,
            center: [0.0, f64::INFINITY, 0.0],
        })
        .unwrap_err();
        assert!(
            matches!(
                e,
                SystemError::InvalidEntry {
                    name: "trap.center",
                    index: 1,
                    ..
                }
            ),
            "{e}"
        );
    }
}
