//! The inextensible bead chain of seed Section 5.3: K beads in R^3, K - 1 segment constraints,
//! written once over [`Real`] ([`Equations`]): one path, and W lanes for an ensemble engine
//! with a diagonal mass (the chain molecule, the fiber), where the rows of the kappa system are
//! factored by Thomas' algorithm as they are formed ([`ThomasSweep`]).

use crate::constraint::{TheoryBound, motion_measure};
use crate::equations::{Equations, InverseMassOf, cross_gram, displace_in_passes};
use crate::error::{ManifoldError, check_at_least, check_positive};
use crate::factor::ThomasFactor;
use crate::gram::TridiagonalGram;
use crate::lane_form::{Evaluation, Point, base_coords};
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::Tridiagonal;
use crate::thomas::ThomasSweep;
use crate::vector::{distance_value, dot3, max_norm3_squared};
use sdae_lanes::{PathMask, Real};

/// g_i(x) = 1/2 - |x_{i+1} - x_i|^2 / (2 ds^2), i = 0..K-1 (seed Section 5.3). Bead j occupies
/// coordinates 3j..3j+3. Its Gram matrix is tridiagonal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeadChain {
    beads: usize,
    segment: f64,
    inv_ds2: f64,
}

/// The segment d_i = x_{i+1} - x_i from beads i and i + 1 (six coordinates).
#[inline(always)]
pub(crate) fn difference<T: Real>(a: &[T; 6]) -> [T; 3] {
    [a[3] - a[0], a[4] - a[1], a[5] - a[2]]
}

/// The segment d_i of x, stored or formed where it is read.
#[inline(always)]
fn segment<T: Real, P: Point<T> + ?Sized>(x: &P, i: usize) -> [T; 3] {
    difference(&x.coords::<6>(3 * i))
}

/// out_i = scale d_i(x).(u_{i+1} - u_i): with scale = 1/ds^2 the rows of -Dg(x) u, with
/// scale = -1/ds^2 those of Dg(x) u (and of D^2 g(u, w) for x = u, u = w, g being quadratic).
#[inline(always)]
pub(crate) fn segment_rates<T: Real>(x: &[T], u: &[T], scale: f64, out: &mut [T]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = dot3(&segment(x, i), &segment(u, i)) * scale;
    }
}

/// The chain's local measure of the motion (`Constraint::local_motion`): w = max_i |v_{i+1} -
/// v_i| / ds, alpha = max_j |a_j| / ds, max(w, w^2, alpha).
#[inline(always)]
pub(crate) fn chain_motion<T: Real>(ds: f64, v: &[T], a: &[T]) -> T {
    let mut w2 = v[0].splat_like(0.0);
    for i in 0..v.len() / 3 - 1 {
        let d = segment(v, i);
        w2 = w2.max(dot3(&d, &d));
    }
    motion_measure(w2.sqrt() / ds, max_norm3_squared(a).sqrt() / ds)
}

impl BeadChain {
    /// A chain of `beads` >= 2 beads with segment length `segment` > 0.
    pub fn new(beads: usize, segment: f64) -> Result<Self, ManifoldError> {
        check_at_least("beads", beads, 2, "a chain needs at least 2 beads")?;
        check_positive("segment", segment)?;
        Ok(Self {
            beads,
            segment,
            inv_ds2: 1.0 / (segment * segment),
        })
    }

    /// Number of beads K.
    pub fn beads(&self) -> usize {
        self.beads
    }

    /// Segment length ds.
    pub fn segment(&self) -> f64 {
        self.segment
    }

    /// 1 / ds^2, the factor of every g_i, (Dg u)_i and (grad g z)_j.
    pub fn inverse_segment_squared(&self) -> f64 {
        self.inv_ds2
    }

    /// Positions of a straight chain starting at the origin along the unit vector of `direction`.
    pub fn straight(&self, direction: [f64; 3]) -> Result<Vec<f64>, ManifoldError> {
        let len = dot3(&direction, &direction).sqrt();
        check_positive("|direction|", len)?;
        let u = direction.map(|c| c / len * self.segment);
        Ok((0..self.beads)
            .flat_map(|j| u.map(|c| c * j as f64))
            .collect())
    }

    /// Positions of a planar zigzag in the x-y plane: segment i makes the angle
    /// +/- `half_angle` with the x axis, alternating.
    pub fn zigzag(&self, half_angle: f64) -> Vec<f64> {
        let mut x = vec![0.0; 3 * self.beads];
        for i in 0..self.beads - 1 {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            x[3 * i + 3] = x[3 * i] + self.segment * half_angle.cos();
            x[3 * i + 4] = x[3 * i + 1] + sign * self.segment * half_angle.sin();
        }
        x
    }

    /// Segment i's term of grad g(r) z: z_i d_i / ds^2 (added at bead i, taken at bead i + 1).
    #[inline(always)]
    fn segment_term<T: Real>(&self, r: &[T], i: usize, z: T) -> [T; 3] {
        let d = segment(r, i);
        // Written out: a closure (array map) would not inherit the instruction set.
        [
            d[0] * z * self.inv_ds2,
            d[1] * z * self.inv_ds2,
            d[2] * z * self.inv_ds2,
        ]
    }

    /// Row i of -Dg(x) u from beads i and i + 1 of u (`negated_jacobian_mul`'s operations).
    #[inline(always)]
    fn velocity_row<T: Real>(&self, x: &[T], i: usize, bead: &[T; 3], next: &[T; 3]) -> T {
        let du = [next[0] - bead[0], next[1] - bead[1], next[2] - bead[2]];
        dot3(&segment(x, i), &du) * self.inv_ds2
    }

    /// out_j = base_j + (M^-1)_jj (grad g(r) z)_j for a diagonal mass, with (grad g(r) z)_j =
    /// (z_j d_j - z_{j-1} d_{j-1}) / ds^2 (seed eq. 3.1); bead j's base is read before bead j
    /// of out is written, so that out can be its own base.
    #[inline(always)]
    fn displace_beads<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, r: &[T], z: &[T], base: Option<&P>, out: &mut [T],
    ) {
        let mut previous = [r[0].splat_like(0.0); 3];
        for (i, zi) in z.iter().enumerate() {
            let current = self.segment_term(r, i, *zi);
            let b = base_coords::<_, _, 3>(base, out, 3 * i);
            for c in 0..3 {
                let k = 3 * i + c;
                out[k] = b[c] + w.diagonal_product(k, current[c] - previous[c]);
            }
            previous = current;
        }
        let last = 3 * (self.beads - 1);
        let b = base_coords::<_, _, 3>(base, out, last);
        for c in 0..3 {
            out[last + c] = b[c] + w.diagonal_product(last + c, -previous[c]);
        }
    }
}

/// (M^-1)_kk a_k b_k summed over bead j's three coordinates, in order.
#[inline(always)]
fn weighted<T: Real, W: InverseMassOf<T>>(w: &W, a: &[T; 3], bead: usize, b: &[T; 3]) -> T {
    let k = 3 * bead;
    w.diagonal_product(k, a[0]) * b[0]
        + w.diagonal_product(k + 1, a[1]) * b[1]
        + w.diagonal_product(k + 2, a[2]) * b[2]
}

/// The diagonal entry's sum `weighted(a, bead, b) + weighted(a, bead + 1, b)`: with M^-1 = I
/// both terms are a . b, the same bits, which is formed once.
#[inline(always)]
fn diagonal<T: Real, W: InverseMassOf<T>>(w: &W, a: &[T; 3], bead: usize, b: &[T; 3]) -> T {
    if w.is_unit() {
        let t = dot3(a, b);
        t + t
    } else {
        weighted(w, a, bead, b) + weighted(w, a, bead + 1, b)
    }
}

/// The rows of the kappa system at (x1, r) for a diagonal mass, in order: g_i(x1) = 1/2 -
/// |e_i|^2 / (2 ds^2) and row i of Dg(x1) M^-1 grad g(r), the tridiagonal matrix with the
/// diagonal (e_i.W_i f_i + e_i.W_{i+1} f_i) / ds^4 and the off-diagonals -e_i.W_{i+1} f_{i+1}
/// / ds^4 (upper) and -e_{i+1}.W_{i+1} f_i / ds^4 (lower), where e = segments of x1, f =
/// segments of r and W_j bead j's block of M^-1.
struct KappaRows<'a, T, W, P: ?Sized> {
    chain: &'a BeadChain,
    w: &'a W,
    x1: &'a P,
    r: &'a [T],
    e: [T; 3],
    f: [T; 3],
}

impl<'a, T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized> KappaRows<'a, T, W, P> {
    #[inline(always)]
    fn new(chain: &'a BeadChain, w: &'a W, x1: &'a P, r: &'a [T]) -> Self {
        let (e, f) = (segment(x1, 0), segment(r, 0));
        Self {
            chain,
            w,
            x1,
            r,
            e,
            f,
        }
    }

    /// Row i (the rows taken in order): g_i(x1), the diagonal entry and, unless i is the last
    /// row, (upper, lower).
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn row(&mut self, i: usize) -> (T, T, Option<(T, T)>) {
        let s = self.chain.inv_ds2 * self.chain.inv_ds2;
        let (e, f) = (self.e, self.f);
        let value = distance_value(&e, self.chain.inv_ds2);
        let diag = diagonal(self.w, &e, i, &f) * s;
        if i + 2 >= self.chain.beads {
            return (value, diag, None);
        }
        self.e = segment(self.x1, i + 1);
        self.f = segment(self.r, i + 1);
        let upper = -weighted(self.w, &e, i + 1, &self.f) * s;
        let lower = -weighted(self.w, &self.e, i + 1, &f) * s;
        (value, diag, Some((upper, lower)))
    }
}

/// The chain written once over [`Real`]: one path with any mass that couples no two beads,
/// lanes with a diagonal mass.
impl Equations for BeadChain {
    type Shape = Tridiagonal;
    fn dim(&self) -> usize {
        3 * self.beads
    }
    fn n_constraints(&self) -> usize {
        self.beads - 1
    }
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = distance_value(&segment(x, i), self.inv_ds2);
        }
    }
    /// (Dg(x) u)_i = -d_i.(u_{i+1} - u_i) / ds^2 with d_i = x_{i+1} - x_i.
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        segment_rates(x, u, -self.inv_ds2, out);
    }
    /// (grad g(x) z)_j = (z_j d_j - z_{j-1} d_{j-1}) / ds^2.
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        let mut previous = [x[0].splat_like(0.0); 3];
        for (i, zi) in z.iter().enumerate().take(self.beads - 1) {
            let current = self.segment_term(x, i, *zi);
            for c in 0..3 {
                out[3 * i + c] = current[c] - previous[c];
            }
            previous = current;
        }
        let last = 3 * (self.beads - 1);
        for c in 0..3 {
            out[last + c] = -previous[c];
        }
    }
    /// D^2 g_i(x)(u, w) = -(u_{i+1} - u_i).(w_{i+1} - w_i) / ds^2.
    #[inline(always)]
    fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        segment_rates(u, w, -self.inv_ds2, out);
    }
    /// Rounding of g_i = 1/2 - |x_{i+1} - x_i|^2 / (2 ds^2): the differences carry an error of
    /// a few ulps of |x|, relative to ds.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(self.segment)
    }
    /// G_M = Dg M^-1 grad g is tridiagonal only if M^-1 couples no two beads: a diagonal mass,
    /// or one block-diagonal with a 3 x 3 block per bead. Any other mass is refused, naming
    /// the largest entry of M^-1 that couples two beads (relative size above 1e-12).
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        if M::DIAGONAL {
            return Ok(());
        }
        let n = self.dim();
        mass.check_order(n)?;
        let mut column = vec![0.0; n];
        let mut largest = 0.0_f64;
        let mut coupling: Option<(usize, usize, f64)> = None;
        for col in 0..n {
            column.fill(0.0);
            column[col] = 1.0;
            mass.apply_inverse(&mut column);
            for (row, &w) in column.iter().enumerate() {
                largest = largest.max(w.abs());
                let beyond = coupling.is_none_or(|(_, _, e)| w.abs() > e.abs());
                if row / 3 != col / 3 && w != 0.0 && beyond {
                    coupling = Some((row, col, w));
                }
            }
        }
        match coupling {
            Some((row, col, entry)) if entry.abs() > 1e-12 * largest => {
                Err(ManifoldError::CoupledMass {
                    first: row.min(col) / 3,
                    second: row.max(col) / 3,
                    row,
                    col,
                    entry,
                })
            }
            _ => Ok(()),
        }
    }
    /// Closed form for diagonal masses (3 weighted dot products per segment,
    /// `KappaRows`), by products otherwise.
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, x1: &[T], x2: &[T], scratch: &mut [T], out: &mut TridiagonalGram<T>,
    ) {
        if w.diagonal_entry(0).is_none() {
            return cross_gram(self, x1, x2, w, scratch, out);
        }
        let mut rows = KappaRows::new(self, w, x1, x2);
        for i in 0..self.beads - 1 {
            let (_, diag, off_diagonal) = rows.row(i);
            out.diag[i] = diag;
            if let Some((upper, lower)) = off_diagonal {
                out.upper[i] = upper;
                out.lower[i] = lower;
            }
        }
    }
    /// One pass for diagonal masses: g_i(x) and the three diagonals share the segments of x.
    #[inline(always)]
    fn value_and_cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, x: &[T], r: &[T], scratch: &mut [T], value: &mut [T],
        gram: &mut TridiagonalGram<T>,
    ) {
        if w.diagonal_entry(0).is_none() {
            Equations::value(self, x, value);
            return cross_gram(self, x, r, w, scratch, gram);
        }
        let mut rows = KappaRows::new(self, w, x, r);
        for (i, g) in value.iter_mut().enumerate() {
            let (gi, diag, off_diagonal) = rows.row(i);
            *g = gi;
            gram.diag[i] = diag;
            if let Some((upper, lower)) = off_diagonal {
                gram.upper[i] = upper;
                gram.lower[i] = lower;
            }
        }
    }
    /// One pass for diagonal masses (`displace_beads`), in passes otherwise.
    #[inline(always)]
    fn displace<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, r: &[T], z: &[T], base: Option<&[T]>, out: &mut [T], scratch: &mut [T],
    ) {
        if w.diagonal_entry(0).is_none() {
            return displace_in_passes(self, w, r, z, base, out, scratch);
        }
        self.displace_beads(w, r, z, base, out);
    }
    /// w = max_i |v_{i+1} - v_i| / ds, alpha = max_i |a_i| / ds.
    #[inline(always)]
    fn local_motion<T: Real>(&self, _x: &[T], v: &[T], a: &[T]) -> Option<T> {
        Some(chain_motion(self.segment, v, a))
    }

    /// The rows of g(x1) and Dg(x1) M^-1 grad g(r) (`KappaRows`), each factored as soon as
    /// it is formed (`ThomasSweep::row`, forward substitution on g into `step`), with
    /// `max_abs_and_finite`'s reduction of g in its order, so g and the matrix are not read
    /// back (`values` is not used).
    #[inline(always)]
    fn evaluate_and_factor<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, x1: &P, r: &[T], _values: &mut [T], jacobian: &mut TridiagonalGram<T>,
        factor: &mut ThomasFactor<T>, step: &mut [T],
    ) -> Evaluation<T> {
        let half = r[0].splat_like(0.5);
        let mut largest = half.splat_like(0.0);
        let mut sum = largest;
        let mut sweep = ThomasSweep::new(half);
        let mut factors = factor.factors();
        let mut rows = KappaRows::new(self, w, x1, r);
        for (i, out) in step.iter_mut().enumerate().take(self.beads - 1) {
            let (value, diag, off_diagonal) = rows.row(i);
            jacobian.diag[i] = diag;
            if let Some((upper, lower)) = off_diagonal {
                jacobian.upper[i] = upper;
                jacobian.lower[i] = lower;
            }
            largest = largest.max(value.abs());
            sum = sum + value;
            if let Some(forward) = sweep.row(&mut factors, i, diag, off_diagonal, Some(value)) {
                *out = forward;
            }
        }
        Evaluation {
            largest,
            ok: sum.finite().and(sweep.ok),
        }
    }

    /// v~ = M^-1 force + v bead by bead into `force`, and in the same pass lambda's right-hand
    /// side -(Dg(x) v~)_i = d_i.(v~_{i+1} - v~_i) / ds^2 through the forward substitution
    /// (the default's three passes in one).
    #[inline(always)]
    fn velocity_right_hand_side<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, x: &[T], force: &mut [T], v: &[T], factor: &ThomasFactor<T>, out: &mut [T],
    ) {
        let mut previous = [x[0]; 3];
        for c in 0..3 {
            force[c] = w.diagonal_product(c, force[c]) + v[c];
            previous[c] = force[c];
        }
        let mut forward = x[0].splat_like(0.0);
        for (i, o) in out.iter_mut().enumerate() {
            let k = 3 * (i + 1);
            let mut next = previous;
            for c in 0..3 {
                force[k + c] = w.diagonal_product(k + c, force[k + c]) + v[k + c];
                next[c] = force[k + c];
            }
            forward = factor.forward_row(i, self.velocity_row(x, i, &previous, &next), forward);
            *o = forward;
            previous = next;
        }
    }

    /// `displace_beads` (the engines' masses are diagonal).
    #[inline(always)]
    fn displace_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, r: &[T], z: &[T], base: Option<&P>, out: &mut [T],
    ) {
        self.displace_beads(w, r, z, base, out);
    }

    /// [`Equations::displace_at`] in place, the check of v_{k+1} and the velocity residual in
    /// one pass over the beads: bead j of v_{k+1} is final once segment j is displaced, so row
    /// j - 1 of Dg(x) v_{k+1} follows at once. A path passes the check if every |v_k| <=
    /// sqrt(MAX / (2 n)), under which |v|^2 cannot overflow whatever the order of the sum: it
    /// passes only where the scalar step finds |v|^2 finite, and a lane beyond the bound (or
    /// NaN) steps through the scalar stepper. The residual is `max_abs` of
    /// `negated_jacobian_mul`'s rows, in their order.
    #[inline(always)]
    fn finish_velocity<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, r: &[T], lambda: &[T], x: &[T], monitor: bool, v: &mut [T],
        _scratch: &mut [T],
    ) -> (T::Mask, T) {
        let zero = r[0].splat_like(0.0);
        let bound = zero.splat_like((f64::MAX / (6 * self.beads) as f64).sqrt());
        let mut bounded = zero.mask_like(true);
        let mut residual = zero;
        let mut previous = [zero; 3];
        let mut before = [zero; 3];
        for (i, zi) in lambda.iter().enumerate() {
            let current = self.segment_term(r, i, *zi);
            let mut bead = [zero; 3];
            for c in 0..3 {
                let k = 3 * i + c;
                v[k] = v[k] + w.diagonal_product(k, current[c] - previous[c]);
                bead[c] = v[k];
                bounded = bounded.and(bead[c].abs().at_most(bound));
            }
            if monitor && i > 0 {
                residual = residual.max(self.velocity_row(x, i - 1, &before, &bead).abs());
            }
            before = bead;
            previous = current;
        }
        let last = 3 * (self.beads - 1);
        let mut bead = [zero; 3];
        for c in 0..3 {
            v[last + c] = v[last + c] + w.diagonal_product(last + c, -previous[c]);
            bead[c] = v[last + c];
            bounded = bounded.and(bead[c].abs().at_most(bound));
        }
        if monitor {
            let row = self.beads - 2;
            residual = residual.max(self.velocity_row(x, row, &before, &bead).abs());
        }
        (bounded, residual)
    }

    /// out_i = -(Dg(x) u)_i = d_i.(u_{i+1} - u_i) / ds^2.
    #[inline(always)]
    fn negated_jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        segment_rates(x, u, self.inv_ds2, out);
    }
}

impl TheoryBound for BeadChain {
    /// With eigenvalues of M in [m_lo, m_hi]: |M^-1 grad g| <= 2/(m_lo ds), |G_M| <= 4/(m_lo ds^2)
    /// (Gershgorin), |G_M^-1| <= m_hi ds^2 / (2 - 2 cos(pi/K)) (G_M dominates the straight chain's
    /// tridiag(-1, 2, -1)/(m_hi ds^2)), |D^2 g| <= 2 sqrt(2)/ds^2, D^3 g = 0.
    fn c_g<M: Mass>(&self, mass: &M) -> Option<f64> {
        let (lo, hi) = mass.eigenvalue_bounds();
        let ds = self.segment;
        let lambda_min_laplacian = 2.0 - 2.0 * (std::f64::consts::PI / self.beads as f64).cos();
        Some(
            [
                2.0 / (lo * ds),
                4.0 / (lo * ds * ds),
                hi * ds * ds / lambda_min_laplacian,
                2.0 * std::f64::consts::SQRT_2 / (ds * ds),
            ]
            .into_iter()
            .fold(1.0, f64::max),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::BeadChain;
    use crate::constraint::Constraint;
    use crate::constraint::scratch_len;
    use crate::gram::GramMatrix;
    use crate::mass::{DenseMass, DiagonalMass};

    fn wiggly(chain: &BeadChain) -> Vec<f64> {
        let mut x = chain.zigzag(0.4);
        for (k, xi) in x.iter_mut().enumerate() {
            *xi += 0.01 * ((k as f64) * 1.7).sin();
        }
        x
    }

    #[test]
    fn closed_form_gram_matches_probing_and_dense_mass() {
        let chain = BeadChain::new(7, 0.3).unwrap();
        let x1 = wiggly(&chain);
        let x2 = chain.zigzag(0.2);
        let masses: Vec<f64> = (0..7).map(|j| 1.0 + 0.25 * j as f64).collect();
        let diag = DiagonalMass::per_particle(&masses, 3).unwrap();
        let n = chain.dim();
        let dense_entries: Vec<f64> = (0..n * n)
            .map(|k| {
                if k / n == k % n {
                    diag.diagonal()[k / n]
                } else {
                    0.0
                }
            })
            .collect();
        let dense = DenseMass::new(n, dense_entries).unwrap();
        let mut scratch = vec![0.0; scratch_len(n, 6)];
        let mut closed = chain.new_gram();
        let mut probed = chain.new_gram();
        chain.cross_gram(&x1, &x2, &diag, &mut scratch, &mut closed);
        chain.cross_gram(&x1, &x2, &dense, &mut scratch, &mut probed);
        for i in 0..6 {
            for j in 0..6 {
                let (a, b) = (closed.entry(i, j), probed.entry(i, j));
                assert!((a - b).abs() < 1e-12 * (1.0 + a.abs()), "({i},{j}) {a} {b}");
            }
        }
    }

    #[test]
    fn jacobian_transpose_is_adjoint() {
        let chain = BeadChain::new(5, 0.5).unwrap();
        let x = wiggly(&chain);
        let u: Vec<f64> = (0..15).map(|k| (k as f64 * 0.37).cos()).collect();
        let z: Vec<f64> = (0..4).map(|k| 1.0 + k as f64).collect();
        let mut du = vec![0.0; 4];
        let mut gz = vec![0.0; 15];
        chain.jacobian_mul(&x, &u, &mut du);
        chain.jacobian_transpose_mul(&x, &z, &mut gz);
        let lhs: f64 = du.iter().zip(&z).map(|(a, b)| a * b).sum();
        let rhs: f64 = gz.iter().zip(&u).map(|(a, b)| a * b).sum();
        assert!((lhs - rhs).abs() < 1e-12, "{lhs} {rhs}");
    }

    #[test]
    fn straight_chain_is_on_manifold() {
        let chain = BeadChain::new(10, 0.1).unwrap();
        let x = chain.straight([1.0, 2.0, 2.0]).unwrap();
        let mut g = vec![0.0; 9];
        chain.value(&x, &mut g);
        assert!(g.iter().all(|v| v.abs() < 1e-14), "{g:?}");
        chain.value(&chain.zigzag(0.3), &mut g);
        assert!(g.iter().all(|v| v.abs() < 1e-14), "{g:?}");
    }
}
