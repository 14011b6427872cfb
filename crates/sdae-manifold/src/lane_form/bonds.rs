//! The formulas of rigid bonds over lanes ([`RigidBonds`] with a diagonal mass: the rigid triatomic, any bond network of up to `DENSE_FAER_THRESHOLD` bonds) for the
//! Newton step of an ensemble engine: g_b = 1/2 - |x_j - x_i|^2 / (2 L_b^2), the Newton matrix in
//! closed form from the bonds that meet at each atom, the displacement and Dg u over W lanes,
//! with the floating-point operations of `RigidBonds`' methods (and of the default
//! `Constraint::displace`) in the same order, and the dense LU factorization with partial
//! pivoting of [`LuFactor`].

use crate::bonds::{Bond, RigidBonds, bond_rates, bonds_motion};
use crate::constraint::Constraint;
use crate::vector::{distance_value, dot3};
use pulp::Simd;
use sdae_lanes::Lanes;

use super::{ConstraintLanes, Evaluation, InverseMass, PointLanes, base_coords};
use crate::factor::LuFactor;
use crate::gram::DenseGram;
use crate::shape::Dense;

/// The network's formulas over lanes, each with the operations of the one-path method it
/// names.
impl RigidBonds {
    /// g_b(x1) = 1/2 - |d_b(x1)|^2 / (2 L_b^2) (`RigidBonds::value`), then entry (a, b) of
    /// Dg(x1) M^-1 grad g(r): over the atoms c that bonds a and b share, sign_a sign_b
    /// d_a(x1).W_c d_b(r) / (L_a^2 L_b^2) (`RigidBonds::cross_gram` for a diagonal mass).
    #[inline(always)]
    fn value_and_cross_gram_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut DenseGram<Lanes<Sd>>,
    ) {
        for ((value, bond), s) in values
            .iter_mut()
            .zip(self.bonds())
            .zip(self.inverse_lengths_squared())
        {
            let d = bond_vector(x1, bond);
            *value = distance_value(&d, *s);
        }
        let m = self.n_constraints();
        let zero = r[0].splat_like(0.0);
        for a in 0..m {
            for b in 0..m {
                jacobian.set(a, b, zero);
            }
        }
        for c in 0..self.atoms() {
            let k = 3 * c;
            for &(a, sa) in self.incident(c) {
                let da = bond_vector(x1, &self.bonds()[a]);
                let wa = [
                    w.apply(k, da[0]),
                    w.apply(k + 1, da[1]),
                    w.apply(k + 2, da[2]),
                ];
                for &(b, sb) in self.incident(c) {
                    let db = bond_vector(r, &self.bonds()[b]);
                    let term = dot3(&wa, &db)
                        * (sa * sb)
                        * self.inverse_lengths_squared()[a]
                        * self.inverse_lengths_squared()[b];
                    jacobian.set(a, b, jacobian.get(a, b) + term);
                }
            }
        }
    }
}

impl ConstraintLanes for RigidBonds {
    type Shape = Dense;

    /// g(x1) and the dense Newton matrix (`RigidBonds::value_and_cross_gram_lanes`), then the
    /// largest |g_b| and the LU factorization, each in a pass of its own.
    #[inline(always)]
    fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut DenseGram<Lanes<Sd>>, factor: &mut LuFactor<Lanes<Sd>>,
        step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd> {
        self.value_and_cross_gram_lanes(w, x1, r, values, jacobian);
        Evaluation::reduce_and_factor(values, jacobian, factor, step)
    }

    /// out = base + M^-1 grad g(r) z, with (grad g(r) z)_a = sum over the bonds b at atom a
    /// of sign z_b d_b(r) / L_b^2 accumulated from 0 in the order of the bonds, atom by atom
    /// (`RigidBonds::jacobian_transpose_mul`'s operations on each entry: adding sign f is
    /// adding or subtracting f, then the mass and the sum of `Constraint::displace`), so that
    /// out can be its own base.
    #[inline(always)]
    fn displace_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>,
        out: &mut [Lanes<Sd>],
    ) {
        let zero = r[0].splat_like(0.0);
        for atom in 0..self.atoms() {
            let mut sum = [zero; 3];
            for &(b, sign) in self.incident(atom) {
                let d = bond_vector(r, &self.bonds()[b]);
                for c in 0..3 {
                    sum[c] = sum[c] + d[c] * z[b] * self.inverse_lengths_squared()[b] * sign;
                }
            }
            let k = 3 * atom;
            let y = base_coords::<_, _, 3>(base, out, k);
            for c in 0..3 {
                out[k + c] = w.apply(k + c, sum[c]) + y[c];
            }
        }
    }

    /// -(Dg(x) u)_b = d_b(x).(u_j - u_i) / L_b^2 (the negation of `RigidBonds::jacobian_mul`).
    #[inline(always)]
    fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        bond_rates(self.bonds(), self.inverse_lengths_squared(), x, u, 1.0, out);
    }

    /// The network's local measure of the motion (`RigidBonds`' formula).
    #[inline(always)]
    fn local_motion_lanes<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        Some(bonds_motion(
            self.bonds(),
            self.inverse_lengths_squared(),
            self.shortest(),
            v,
            a,
        ))
    }
}

/// d_b = x_j - x_i of bond b = (i, j).
#[inline(always)]
fn bond_vector<Sd: Simd, P: PointLanes<Sd> + ?Sized>(x: &P, bond: &Bond) -> [Lanes<Sd>; 3] {
    let (a, b) = (x.coords::<3>(3 * bond.i), x.coords::<3>(3 * bond.j));
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}
