//! The lane form of rigid bonds ([`RigidBonds`](sdae_manifold::RigidBonds) with a diagonal
//! mass: the rigid triatomic, any bond network of up to `DENSE_FAER_THRESHOLD` bonds) for the
//! Newton step of an ensemble engine: g_b = 1/2 - |x_j - x_i|^2 / (2 L_b^2), the Newton matrix in
//! closed form from the bonds that meet at each atom, the displacement and Dg u over W lanes,
//! with the floating-point operations of `RigidBonds`' methods (and of the default
//! `Constraint::displace`) in the same order, and the dense LU factorization with partial
//! pivoting of `super::dense`.

use crate::bonds::{Bond, RigidBonds, bond_rates, bonds_motion};
use crate::constraint::Constraint;
use crate::factor::DENSE_FAER_THRESHOLD;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::vector::{distance_value, dot3};
use pulp::Simd;
use sdae_lanes::Lanes;

use super::{
    ConstraintLanes, Evaluation, InverseMass, PointLanes, base_coords, max_abs_and_finite,
};
use crate::factor::{LuFactor, MatrixFactor};
use crate::gram::{Dense, DenseGram};

/// The bond network's constants for a diagonal mass.
pub struct BondLanes {
    atoms: usize,
    bonds: Vec<Bond>,
    /// 1 / L_b^2.
    inv_l2: Vec<f64>,
    /// The bonds at each atom as (bond, sign): `incidence[start[a]..start[a + 1]]`
    /// (`RigidBonds::incident`).
    start: Vec<usize>,
    incidence: Vec<(usize, f64)>,
    shortest: f64,
    /// The network's rounding floor (`Constraint::roundoff`).
    roundoff: Roundoff,
    inverse_mass: InverseMass,
}

impl BondLanes {
    /// The network's lane form for a diagonal `mass`, with at most `DENSE_FAER_THRESHOLD`
    /// bonds (larger networks are factored by faer, path by path); `None` otherwise.
    pub fn new<M: Mass>(network: &RigidBonds, mass: &M) -> Option<Self> {
        if !M::DIAGONAL || network.n_constraints() > DENSE_FAER_THRESHOLD {
            return None;
        }
        let mut start = vec![0];
        let mut incidence = Vec::with_capacity(2 * network.n_constraints());
        for atom in 0..network.atoms() {
            incidence.extend_from_slice(network.incident(atom));
            start.push(incidence.len());
        }
        Some(Self {
            atoms: network.atoms(),
            bonds: network.bonds().to_vec(),
            inv_l2: network.inverse_lengths_squared().to_vec(),
            start,
            incidence,
            shortest: network.shortest(),
            roundoff: network.roundoff(),
            inverse_mass: InverseMass::of(mass, network.dim()),
        })
    }

    /// The bonds at atom `atom` as (bond, sign).
    #[inline(always)]
    fn incident(&self, atom: usize) -> &[(usize, f64)] {
        &self.incidence[self.start[atom]..self.start[atom + 1]]
    }

    /// g_b(x1) = 1/2 - |d_b(x1)|^2 / (2 L_b^2) (`RigidBonds::value`), then entry (a, b) of
    /// Dg(x1) M^-1 grad g(r): over the atoms c that bonds a and b share, sign_a sign_b
    /// d_a(x1).W_c d_b(r) / (L_a^2 L_b^2) (`RigidBonds::cross_gram` for a diagonal mass).
    #[inline(always)]
    fn value_and_cross_gram<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut DenseGram<Lanes<Sd>>,
    ) {
        for ((value, bond), s) in values.iter_mut().zip(&self.bonds).zip(&self.inv_l2) {
            let d = bond_vector(x1, bond);
            *value = distance_value(&d, *s);
        }
        let m = self.bonds.len();
        let zero = r[0].splat_like(0.0);
        for a in 0..m {
            for b in 0..m {
                jacobian.set(a, b, zero);
            }
        }
        for c in 0..self.atoms {
            let (w, k) = (&self.inverse_mass, 3 * c);
            for &(a, sa) in self.incident(c) {
                let da = bond_vector(x1, &self.bonds[a]);
                let wa = [
                    w.apply(k, da[0]),
                    w.apply(k + 1, da[1]),
                    w.apply(k + 2, da[2]),
                ];
                for &(b, sb) in self.incident(c) {
                    let db = bond_vector(r, &self.bonds[b]);
                    let term = dot3(&wa, &db) * (sa * sb) * self.inv_l2[a] * self.inv_l2[b];
                    jacobian.set(a, b, jacobian.get(a, b) + term);
                }
            }
        }
    }
}

impl ConstraintLanes for BondLanes {
    type Shape = Dense;

    fn dims(&self) -> (usize, usize) {
        (3 * self.atoms, self.bonds.len())
    }

    fn roundoff(&self) -> Roundoff {
        self.roundoff
    }

    fn inverse_mass(&self) -> &InverseMass {
        &self.inverse_mass
    }

    /// g(x1) and the dense Newton matrix (`BondLanes::value_and_cross_gram`), then the
    /// largest |g_b| and the LU factorization, each in a pass of its own.
    #[inline(always)]
    fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut DenseGram<Lanes<Sd>>, factor: &mut LuFactor<Lanes<Sd>>,
        step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd> {
        self.value_and_cross_gram(x1, r, values, jacobian);
        let (largest, finite) = max_abs_and_finite(values);
        let factored = factor.factor(jacobian, Some((values, step)));
        Evaluation {
            largest,
            ok: finite.and(factored),
        }
    }

    /// out = base + M^-1 grad g(r) z, with (grad g(r) z)_a = sum over the bonds b at atom a
    /// of sign z_b d_b(r) / L_b^2 accumulated from 0 in the order of the bonds, atom by atom
    /// (`RigidBonds::jacobian_transpose_mul`'s operations on each entry: adding sign f is
    /// adding or subtracting f, then the mass and the sum of `Constraint::displace`), so that
    /// out can be its own base.
    #[inline(always)]
    fn displace<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>, out: &mut [Lanes<Sd>],
    ) {
        let zero = r[0].splat_like(0.0);
        for atom in 0..self.atoms {
            let mut sum = [zero; 3];
            for &(b, sign) in self.incident(atom) {
                let d = bond_vector(r, &self.bonds[b]);
                for c in 0..3 {
                    sum[c] = sum[c] + d[c] * z[b] * self.inv_l2[b] * sign;
                }
            }
            let k = 3 * atom;
            let y = base_coords::<_, _, 3>(base, out, k);
            for c in 0..3 {
                out[k + c] = self.inverse_mass.apply(k + c, sum[c]) + y[c];
            }
        }
    }

    /// -(Dg(x) u)_b = d_b(x).(u_j - u_i) / L_b^2 (the negation of `RigidBonds::jacobian_mul`).
    #[inline(always)]
    fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        bond_rates(&self.bonds, &self.inv_l2, x, u, 1.0, out);
    }

    /// The network's local measure of the motion (`RigidBonds`' formula).
    #[inline(always)]
    fn local_motion<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        Some(bonds_motion(&self.bonds, &self.inv_l2, self.shortest, v, a))
    }
}

/// d_b = x_j - x_i of bond b = (i, j).
#[inline(always)]
fn bond_vector<Sd: Simd, P: PointLanes<Sd> + ?Sized>(x: &P, bond: &Bond) -> [Lanes<Sd>; 3] {
    let (a, b) = (x.coords::<3>(3 * bond.i), x.coords::<3>(3 * bond.j));
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}
