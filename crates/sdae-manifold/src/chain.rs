//! The inextensible bead chain of seed Section 5.3: K beads in R^3, K - 1 segment constraints.

use crate::constraint::{
    Constraint, Curvature, TheoryBound, assemble_tridiagonal_by_probing, displace_in_passes,
    motion_measure,
};
use crate::error::{ManifoldError, check_at_least, check_positive};
use crate::gram::TridiagonalGram;
use crate::lane_form::{LaneForm, LaneFormVisitor};
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::vector::{distance_value, dot3, max_norm3_squared};
use sdae_lanes::Real;

/// g_i(x) = 1/2 - |x_{i+1} - x_i|^2 / (2 ds^2), i = 0..K-1 (seed Section 5.3). Bead j occupies
/// coordinates 3j..3j+3. Its Gram matrix is tridiagonal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeadChain {
    beads: usize,
    segment: f64,
    inv_ds2: f64,
}

/// The segment d_i = x_{i+1} - x_i from beads i and i + 1 (six coordinates), for one path or
/// for lanes.
#[inline(always)]
pub(crate) fn difference<T: Real>(a: &[T; 6]) -> [T; 3] {
    [a[3] - a[0], a[4] - a[1], a[5] - a[2]]
}

/// The segment d_i of x.
#[inline(always)]
fn segment<T: Real>(x: &[T], i: usize) -> [T; 3] {
    let beads: &[T; 6] = x[3 * i..3 * i + 6]
        .try_into()
        .expect("six coordinates of beads i and i + 1");
    difference(beads)
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
/// v_i| / ds, alpha = max_j |a_j| / ds, max(w, w^2, alpha), for one path or for lanes.
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

    /// Calls `f(j, (grad g(x) z)_j)` for every bead j, where (grad g(x) z)_j =
    /// (z_j d_j - z_{j-1} d_{j-1}) / ds^2 (terms with j-1 < 0 or j > K-2 are absent).
    #[inline(always)]
    fn for_each_bead_force(&self, x: &[f64], z: &[f64], mut f: impl FnMut(usize, [f64; 3])) {
        let mut previous = [0.0; 3];
        for (i, zi) in z.iter().enumerate().take(self.beads - 1) {
            let current = segment(x, i).map(|c| c * zi * self.inv_ds2);
            f(i, [0, 1, 2].map(|c| current[c] - previous[c]));
            previous = current;
        }
        f(self.beads - 1, previous.map(|c| -c));
    }

    /// The direct O(K) assembly of Dg(x1) M^-1 grad g(x2) for a diagonal mass (`w(k)` is
    /// (M^-1)_{kk}), and g(x1) in the same pass when `value` is given.
    #[inline(always)]
    fn cross_gram_diagonal(
        &self, x1: &[f64], x2: &[f64], w: impl Fn(usize) -> f64, mut value: Option<&mut [f64]>,
        out: &mut TridiagonalGram,
    ) {
        let s = self.inv_ds2 * self.inv_ds2;
        let m = self.beads - 1;
        let weighted = |a: [f64; 3], bead: usize, b: [f64; 3]| {
            a[0] * w(3 * bead) * b[0]
                + a[1] * w(3 * bead + 1) * b[1]
                + a[2] * w(3 * bead + 2) * b[2]
        };
        let mut e_next = segment(x1, 0);
        let mut f_next = segment(x2, 0);
        for i in 0..m {
            let (e, f) = (e_next, f_next);
            if let Some(g) = value.as_deref_mut() {
                g[i] = distance_value(&e, self.inv_ds2);
            }
            out.diag[i] = (weighted(e, i, f) + weighted(e, i + 1, f)) * s;
            if i + 1 < m {
                e_next = segment(x1, i + 1);
                f_next = segment(x2, i + 1);
                out.upper[i] = -weighted(e, i + 1, f_next) * s;
                out.lower[i] = -weighted(e_next, i + 1, f) * s;
            }
        }
    }
}

impl Constraint for BeadChain {
    type Gram = TridiagonalGram;
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
    fn dim(&self) -> usize {
        3 * self.beads
    }
    fn n_constraints(&self) -> usize {
        self.beads - 1
    }
    fn value(&self, x: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            let d = segment(x, i);
            *o = distance_value(&d, self.inv_ds2);
        }
    }
    /// (Dg(x) u)_i = -d_i.(u_{i+1} - u_i) / ds^2 with d_i = x_{i+1} - x_i.
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        segment_rates(x, u, -self.inv_ds2, out);
    }
    /// (grad g(x) z)_j = (z_j d_j - z_{j-1} d_{j-1}) / ds^2.
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        self.for_each_bead_force(x, z, |j, force| {
            out[3 * j..3 * j + 3].copy_from_slice(&force)
        });
    }
    fn new_gram(&self) -> TridiagonalGram {
        TridiagonalGram::zeros(self.beads - 1)
    }
    /// Closed form for diagonal masses (3 weighted dot products per segment), probing otherwise.
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, scratch: &mut [f64], out: &mut TridiagonalGram,
    ) {
        if M::DIAGONAL {
            self.cross_gram_diagonal(
                x1,
                x2,
                |k| mass.inverse_diagonal_entry(k).unwrap_or(0.0),
                None,
                out,
            );
        } else {
            assemble_tridiagonal_by_probing(self, x1, x2, mass, scratch, out);
        }
    }

    /// One pass for diagonal masses: out_j = y_j + w_j (z_j d_j - z_{j-1} d_{j-1}) / ds^2.
    fn displace<M: Mass>(&self, r: &[f64], z: &[f64], mass: &M, y: &[f64], out: &mut [f64]) {
        if !M::DIAGONAL {
            return displace_in_passes(self, r, z, mass, y, out);
        }
        self.for_each_bead_force(r, z, |j, force| {
            for (c, f) in force.iter().enumerate() {
                let k = 3 * j + c;
                out[k] = y[k] + mass.inverse_diagonal_entry(k).unwrap_or(0.0) * f;
            }
        });
    }

    /// One pass for diagonal masses: g_i(x) and the three diagonals share the segments of x.
    fn value_and_cross_gram<M: Mass>(
        &self, x: &[f64], r: &[f64], mass: &M, scratch: &mut [f64], value: &mut [f64],
        gram: &mut TridiagonalGram,
    ) {
        if !M::DIAGONAL {
            self.value(x, value);
            self.cross_gram(x, r, mass, scratch, gram);
            return;
        }
        self.cross_gram_diagonal(
            x,
            r,
            |k| mass.inverse_diagonal_entry(k).unwrap_or(0.0),
            Some(value),
            gram,
        );
    }

    /// Rounding of g_i = 1/2 - |x_{i+1} - x_i|^2 / (2 ds^2): the differences carry an error of a
    /// few ulps of |x|, relative to ds.
    /// w = max_i |v_{i+1} - v_i| / ds, alpha = max_i |a_i| / ds.
    fn local_motion(&self, _x: &[f64], v: &[f64], a: &[f64]) -> Option<f64> {
        Some(chain_motion(self.segment, v, a))
    }
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(self.segment)
    }
    /// Newton in lanes (the chain's [`ConstraintLanes`](crate::ConstraintLanes)) for a
    /// diagonal mass.
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        if !M::DIAGONAL {
            return visitor.none();
        }
        visitor.newton(|| LaneForm::new(self, mass))
    }
}

impl Curvature for BeadChain {
    /// D^2 g_i(x)(u, w) = -(u_{i+1} - u_i).(w_{i+1} - w_i) / ds^2.
    fn second_derivative(&self, _x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        segment_rates(u, w, -self.inv_ds2, out);
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
    use super::*;
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
