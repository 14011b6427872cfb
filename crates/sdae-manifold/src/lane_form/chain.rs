//! The bead chain's formulas over lanes ([`BeadChain`] with a diagonal mass: the chain
//! molecule, the fiber) for the Newton step of an ensemble engine (`sdae_scheme::Ensemble`):
//! over W lanes, with the floating-point operations of `BeadChain`'s one-path methods in the
//! same order, and Thomas' algorithm for its tridiagonal Newton matrix ([`ThomasFactor`]).

use crate::chain::{BeadChain, chain_motion, difference, segment_rates};
use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use super::{ConstraintLanes, Evaluation, InverseMass, PointLanes, base_coords};
use crate::factor::ThomasFactor;
use crate::gram::TridiagonalGram;
use crate::shape::Tridiagonal;
use crate::thomas::ThomasSweep;
use crate::vector::{distance_value, dot3};

/// The chain's formulas over lanes, each with the operations of the one-path method it names.
impl BeadChain {
    /// (M^-1)_kk a_k b_k summed over bead j's three coordinates, in the scalar order.
    #[inline(always)]
    fn weighted<Sd: Simd>(
        w: &InverseMass, a: &[Lanes<Sd>; 3], bead: usize, b: &[Lanes<Sd>; 3],
    ) -> Lanes<Sd> {
        let k = 3 * bead;
        w.apply(k, a[0]) * b[0] + w.apply(k + 1, a[1]) * b[1] + w.apply(k + 2, a[2]) * b[2]
    }

    /// Segment i's term of grad g(r) z: z_i d_i / ds^2 (added at bead i, taken at bead i + 1).
    #[inline(always)]
    fn segment_term<Sd: Simd>(&self, r: &[Lanes<Sd>], i: usize, z: Lanes<Sd>) -> [Lanes<Sd>; 3] {
        let d = segment(r, i);
        // Written out: a closure (array map) would not inherit the instruction set.
        [
            d[0] * z * self.inverse_segment_squared(),
            d[1] * z * self.inverse_segment_squared(),
            d[2] * z * self.inverse_segment_squared(),
        ]
    }

    /// Row i of -Dg(x) u from beads i and i + 1 of u (`negated_jacobian_mul`'s operations).
    #[inline(always)]
    fn velocity_row<Sd: Simd>(
        &self, x: &[Lanes<Sd>], i: usize, bead: &[Lanes<Sd>; 3], next: &[Lanes<Sd>; 3],
    ) -> Lanes<Sd> {
        let du = [next[0] - bead[0], next[1] - bead[1], next[2] - bead[2]];
        dot3(&segment(x, i), &du) * self.inverse_segment_squared()
    }

    /// The diagonal entry's sum `weighted(a, bead, b) + weighted(a, bead + 1, b)`: with M^-1 = I
    /// both terms are a . b, the same bits, which is formed once.
    #[inline(always)]
    fn diagonal<Sd: Simd>(
        w: &InverseMass, a: &[Lanes<Sd>; 3], bead: usize, b: &[Lanes<Sd>; 3],
    ) -> Lanes<Sd> {
        if w.is_unit() {
            let t = dot3(a, b);
            t + t
        } else {
            Self::weighted(w, a, bead, b) + Self::weighted(w, a, bead + 1, b)
        }
    }
}

impl ConstraintLanes for BeadChain {
    type Shape = Tridiagonal;

    /// g(x1) and Dg(x1) M^-1 grad g(r), with e = segments of x1 and f = segments of r:
    /// g_i = 1/2 - |e_i|^2 / (2 ds^2) and the tridiagonal matrix scaled by 1 / ds^4
    /// (`BeadChain::value_and_cross_gram` for a diagonal mass). Each row is factored as soon
    /// as it is formed (`ThomasSweep::row`, forward substitution on g into `step`), with
    /// `max_abs_and_finite`'s reduction of g in its order, so g and the matrix are not read
    /// back (`values` is not used).
    #[inline(always)]
    fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, x1: &P, r: &[Lanes<Sd>], _values: &mut [Lanes<Sd>],
        jacobian: &mut TridiagonalGram<Lanes<Sd>>, factor: &mut ThomasFactor<Lanes<Sd>>,
        step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd> {
        let s = self.inverse_segment_squared() * self.inverse_segment_squared();
        let m = self.beads() - 1;
        let mut e_next = segment(x1, 0);
        let mut f_next = segment(r, 0);
        let half = r[0].splat_like(0.5);
        let mut largest = half.splat_like(0.0);
        let mut sum = largest;
        let mut sweep = ThomasSweep::new(half);
        let mut factors = factor.factors();
        for (i, out) in step.iter_mut().enumerate().take(m) {
            let (e, f) = (e_next, f_next);
            let value = distance_value(&e, self.inverse_segment_squared());
            let diag = Self::diagonal(w, &e, i, &f) * s;
            jacobian.diag[i] = diag;
            let off_diagonal = if i + 1 < m {
                e_next = segment(x1, i + 1);
                f_next = segment(r, i + 1);
                let upper = -Self::weighted(w, &e, i + 1, &f_next) * s;
                let lower = -Self::weighted(w, &e_next, i + 1, &f) * s;
                jacobian.upper[i] = upper;
                jacobian.lower[i] = lower;
                Some((upper, lower))
            } else {
                None
            };
            largest = largest.max(value.abs());
            sum = sum + value;
            if let Some(forward) = sweep.row(&mut factors, i, diag, off_diagonal, Some(value)) {
                *out = forward;
            }
        }
        Evaluation {
            largest,
            ok: sum.is_finite().and(sweep.ok),
        }
    }

    /// v~ = M^-1 force + v bead by bead into `force`, and in the same pass lambda's right-hand
    /// side -(Dg(x) v~)_i = d_i.(v~_{i+1} - v~_i) / ds^2 through the forward substitution
    /// (the default's three passes in one).
    #[inline(always)]
    fn velocity_right_hand_side<Sd: Simd>(
        &self, w: &InverseMass, x: &[Lanes<Sd>], force: &mut [Lanes<Sd>], v: &[Lanes<Sd>],
        factor: &ThomasFactor<Lanes<Sd>>, out: &mut [Lanes<Sd>],
    ) {
        let mut previous = [x[0]; 3];
        for c in 0..3 {
            force[c] = w.apply(c, force[c]) + v[c];
            previous[c] = force[c];
        }
        let mut forward = x[0].splat_like(0.0);
        for (i, o) in out.iter_mut().enumerate() {
            let k = 3 * (i + 1);
            let mut next = previous;
            for c in 0..3 {
                force[k + c] = w.apply(k + c, force[k + c]) + v[k + c];
                next[c] = force[k + c];
            }
            let du = [
                next[0] - previous[0],
                next[1] - previous[1],
                next[2] - previous[2],
            ];
            let value = dot3(&segment(x, i), &du) * self.inverse_segment_squared();
            forward = factor.forward_row(i, value, forward);
            *o = forward;
            previous = next;
        }
    }

    /// out_j = base_j + (M^-1)_jj (grad g(r) z)_j, with (grad g(r) z)_j = (z_j d_j - z_{j-1}
    /// d_{j-1}) / ds^2 (`BeadChain::displace` for a diagonal mass); bead j's base is read
    /// before bead j of out is written.
    #[inline(always)]
    fn displace_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>,
        out: &mut [Lanes<Sd>],
    ) {
        let mut previous = [r[0].splat_like(0.0); 3];
        for (i, zi) in z.iter().enumerate() {
            let current = self.segment_term(r, i, *zi);
            let b = base_coords::<_, _, 3>(base, out, 3 * i);
            for c in 0..3 {
                let k = 3 * i + c;
                out[k] = b[c] + w.apply(k, current[c] - previous[c]);
            }
            previous = current;
        }
        let last = 3 * (self.beads() - 1);
        let b = base_coords::<_, _, 3>(base, out, last);
        for c in 0..3 {
            out[last + c] = b[c] + w.apply(last + c, -previous[c]);
        }
    }

    /// [`ConstraintLanes::displace_lanes`] in place, the check of v_{k+1} and the velocity residual
    /// in one pass over the beads: bead j of v_{k+1} is final once segment j is displaced, so
    /// row j - 1 of Dg(x) v_{k+1} follows at once. A lane passes the check if every |v_k| <=
    /// sqrt(MAX / (2 n)), under which |v|^2 cannot overflow whatever the order of the sum: it
    /// passes only where the scalar step finds |v|^2 finite, and a lane beyond the bound (or
    /// NaN) steps through the scalar stepper. The residual is `max_abs` of
    /// `negated_jacobian_mul`'s rows, in their order.
    #[inline(always)]
    fn finish_velocity<Sd: Simd>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], lambda: &[Lanes<Sd>], x: &[Lanes<Sd>],
        monitor: bool, v: &mut [Lanes<Sd>], _scratch: &mut [Lanes<Sd>],
    ) -> (LaneMask<Sd>, Lanes<Sd>) {
        let zero = r[0].splat_like(0.0);
        let bound = zero.splat_like((f64::MAX / (6 * self.beads()) as f64).sqrt());
        let mut bounded = [zero.eq(zero); 3];
        let mut residual = zero;
        let mut previous = [zero; 3];
        let mut before = [zero; 3];
        for (i, zi) in lambda.iter().enumerate() {
            let current = self.segment_term(r, i, *zi);
            let mut bead = [zero; 3];
            for c in 0..3 {
                let k = 3 * i + c;
                v[k] = v[k] + w.apply(k, current[c] - previous[c]);
                bead[c] = v[k];
                bounded[c] = bounded[c].and(bead[c].abs().le(bound));
            }
            if monitor && i > 0 {
                residual = residual.max(self.velocity_row(x, i - 1, &before, &bead).abs());
            }
            before = bead;
            previous = current;
        }
        let last = 3 * (self.beads() - 1);
        let mut bead = [zero; 3];
        for c in 0..3 {
            v[last + c] = v[last + c] + w.apply(last + c, -previous[c]);
            bead[c] = v[last + c];
            bounded[c] = bounded[c].and(bead[c].abs().le(bound));
        }
        if monitor {
            let row = self.beads() - 2;
            residual = residual.max(self.velocity_row(x, row, &before, &bead).abs());
        }
        (bounded[0].and(bounded[1]).and(bounded[2]), residual)
    }

    /// out_i = -(Dg(x) u)_i = d_i.(u_{i+1} - u_i) / ds^2 (`BeadChain`'s formula).
    #[inline(always)]
    fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        segment_rates(x, u, self.inverse_segment_squared(), out);
    }

    /// The chain's local measure of the motion (`BeadChain`'s formula).
    #[inline(always)]
    fn local_motion_lanes<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        Some(chain_motion(self.segment(), v, a))
    }
}

/// The segment d_i = x_{i+1} - x_i.
#[inline(always)]
fn segment<Sd: Simd, P: PointLanes<Sd> + ?Sized>(x: &P, i: usize) -> [Lanes<Sd>; 3] {
    difference(&x.coords::<6>(3 * i))
}
