//! Rigid bonds between atoms in R^3: the holonomic constraints of constrained molecular
//! dynamics (seed Section 5.2), for any bond network (a rigid triatomic, a tetrahedron, ...).

use crate::constraint::{TheoryBound, motion_measure};
use crate::equations::{Equations, InverseMassOf, cross_gram};
use crate::error::{ManifoldError, check_at_least, check_positive};
use crate::factor::LuFactor;
use crate::gram::DenseGram;
use crate::lane_form::{Evaluation, Point, base_coords};
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::Dense;
use crate::vector::{distance_value, dot3, max_norm3_squared};
use sdae_lanes::Real;

/// One bond: atoms `i` and `j` are held at distance `length`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bond {
    /// First atom.
    pub i: usize,
    /// Second atom.
    pub j: usize,
    /// The bond length L_b > 0.
    pub length: f64,
}

/// g_b(x) = 1/2 - |x_j - x_i|^2 / (2 L_b^2) for every bond b = (i, j, L_b) (the convention of
/// [`BeadChain`](crate::BeadChain)). Atom a occupies coordinates 3a..3a+3, so n = 3N for N
/// atoms and m is the number of bonds. The Gram matrix is dense ([`DenseGram`]); for diagonal
/// masses it is assembled in closed form from the bonds that meet at each atom, O(m^2 + sum of
/// squared atom degrees), otherwise column by column.
///
/// ```
/// use sdae_manifold::{Constraint, RigidBonds};
/// // A rigid triangle with sides 1, 1, 1.5.
/// let triangle = RigidBonds::new(3, &[(0, 1, 1.0), (0, 2, 1.0), (1, 2, 1.5)])?;
/// assert_eq!((triangle.dim(), triangle.n_constraints()), (9, 3));
/// let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
/// let mut g = [0.0; 3];
/// triangle.value(&x, &mut g);
/// assert_eq!(g[0], 0.0);
/// # Ok::<(), sdae_manifold::ManifoldError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBonds {
    atoms: usize,
    bonds: Vec<Bond>,
    /// 1 / L_b^2 per bond.
    inv_l2: Vec<f64>,
    /// Bonds at atom a: `incidence[start[a]..start[a + 1]]`, each as (bond, sign), where the
    /// sign is +1 if a is the bond's first atom and -1 if it is the second: grad g_b has
    /// sign (x_j - x_i) / L_b^2 at atom a.
    start: Vec<usize>,
    incidence: Vec<(usize, f64)>,
    /// (min atom, max atom, bond) sorted, for pair look-ups.
    pairs: Vec<(usize, usize, usize)>,
    shortest: f64,
}

/// d_b = x_j - x_i of bond b = (i, j), x stored or formed where it is read.
#[inline(always)]
fn bond_vector<T: Real, P: Point<T> + ?Sized>(x: &P, bond: &Bond) -> [T; 3] {
    let (a, b) = (x.coords::<3>(3 * bond.i), x.coords::<3>(3 * bond.j));
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// out_b = sign d_b(x).(u_j - u_i) / L_b^2: with sign = 1 the rows of -Dg(x) u, with sign = -1
/// those of Dg(x) u (and of D^2 g(u, w) for x = u, u = w, g being quadratic).
#[inline(always)]
pub(crate) fn bond_rates<T: Real>(
    bonds: &[Bond], inv_l2: &[f64], x: &[T], u: &[T], sign: f64, out: &mut [T],
) {
    for ((o, bond), s) in out.iter_mut().zip(bonds).zip(inv_l2) {
        *o = dot3(&bond_vector(x, bond), &bond_vector(u, bond)) * (sign * s);
    }
}

/// The network's local measure of the motion (`Constraint::local_motion`): max(w, w^2, alpha)
/// with w = max_b |v_j - v_i| / L_b and alpha = max_i |a_i| / (the shortest bond), for one
/// path or for lanes.
#[inline(always)]
pub(crate) fn bonds_motion<T: Real>(
    bonds: &[Bond], inv_l2: &[f64], shortest: f64, v: &[T], a: &[T],
) -> T {
    let mut w = v[0].splat_like(0.0);
    for (bond, s) in bonds.iter().zip(inv_l2) {
        let d = bond_vector(v, bond);
        w = w.max((dot3(&d, &d) * *s).sqrt());
    }
    motion_measure(w, max_norm3_squared(a).sqrt() / shortest)
}

impl RigidBonds {
    /// `atoms` >= 2 atoms joined by `bonds` given as (i, j, L_b). Fails with
    /// [`ManifoldError::InvalidParameter`] naming the rule broken: no bonds (`bonds`), at least
    /// as many bonds as coordinates (`bonds`), an atom index >= `atoms` (`bond atom index`),
    /// i == j (`bond atoms`), a length that is not finite and > 0 (`bond length`), the same pair
    /// twice (`bond`, with the index of the repeated bond as value).
    pub fn new(atoms: usize, bonds: &[(usize, usize, f64)]) -> Result<Self, ManifoldError> {
        check_at_least("atoms", atoms, 2, "rigid bonds need at least 2 atoms")?;
        if bonds.is_empty() {
            return Err(ManifoldError::InvalidParameter {
                name: "bonds",
                value: 0.0,
                reason: "need at least one bond",
            });
        }
        if bonds.len() >= 3 * atoms {
            return Err(ManifoldError::InvalidParameter {
                name: "bonds",
                value: bonds.len() as f64,
                reason: "need fewer bonds than coordinates (m < 3 N)",
            });
        }
        let mut pairs = Vec::with_capacity(bonds.len());
        for (b, &(i, j, length)) in bonds.iter().enumerate() {
            if let Some(&bad) = [i, j].iter().find(|&&a| a >= atoms) {
                return Err(ManifoldError::InvalidParameter {
                    name: "bond atom index",
                    value: bad as f64,
                    reason: "atom index must be < the number of atoms",
                });
            }
            if i == j {
                return Err(ManifoldError::InvalidParameter {
                    name: "bond atoms",
                    value: i as f64,
                    reason: "a bond joins two different atoms (i == j)",
                });
            }
            check_positive("bond length", length)?;
            pairs.push((i.min(j), i.max(j), b));
        }
        pairs.sort_unstable();
        if let Some(w) = pairs
            .windows(2)
            .find(|w| (w[0].0, w[0].1) == (w[1].0, w[1].1))
        {
            return Err(ManifoldError::InvalidParameter {
                name: "bond",
                value: w[0].2.max(w[1].2) as f64,
                reason: "duplicate bond: the same pair of atoms is bonded twice",
            });
        }
        let bonds: Vec<Bond> = bonds
            .iter()
            .map(|&(i, j, length)| Bond { i, j, length })
            .collect();
        let mut start = vec![0; atoms + 1];
        for bond in &bonds {
            start[bond.i + 1] += 1;
            start[bond.j + 1] += 1;
        }
        for a in 0..atoms {
            start[a + 1] += start[a];
        }
        let mut fill = start.clone();
        let mut incidence = vec![(0, 0.0); 2 * bonds.len()];
        for (b, bond) in bonds.iter().enumerate() {
            for (atom, sign) in [(bond.i, 1.0), (bond.j, -1.0)] {
                incidence[fill[atom]] = (b, sign);
                fill[atom] += 1;
            }
        }
        Ok(Self {
            atoms,
            inv_l2: bonds.iter().map(|b| 1.0 / (b.length * b.length)).collect(),
            shortest: bonds.iter().map(|b| b.length).fold(f64::INFINITY, f64::min),
            bonds,
            start,
            incidence,
            pairs,
        })
    }

    /// Number of atoms N.
    pub fn atoms(&self) -> usize {
        self.atoms
    }

    /// The bonds, in the order of the constraints.
    pub fn bonds(&self) -> &[Bond] {
        &self.bonds
    }

    /// The bond joining atoms p and q, if there is one.
    pub fn bond_between(&self, p: usize, q: usize) -> Option<usize> {
        let key = (p.min(q), p.max(q));
        self.pairs
            .binary_search_by(|&(a, b, _)| (a, b).cmp(&key))
            .ok()
            .map(|k| self.pairs[k].2)
    }

    /// The bonds at atom `atom` as (bond, sign), in the order of the bonds: the sign is +1 if
    /// the atom is the bond's first atom and -1 if it is the second, so that grad g_b has
    /// sign (x_j - x_i) / L_b^2 at the atom.
    pub fn incident(&self, atom: usize) -> &[(usize, f64)] {
        &self.incidence[self.start[atom]..self.start[atom + 1]]
    }

    /// 1 / L_b^2 for every bond b, in the order of the bonds.
    pub fn inverse_lengths_squared(&self) -> &[f64] {
        &self.inv_l2
    }

    /// The shortest bond length: the length scale of [`Constraint::roundoff`](crate::Constraint::roundoff) and of
    /// the force term of [`Constraint::local_motion`](crate::Constraint::local_motion).
    pub fn shortest(&self) -> f64 {
        self.shortest
    }

    /// The other atom of bond b.
    fn other_end(&self, b: usize, atom: usize) -> usize {
        let bond = &self.bonds[b];
        if bond.i == atom { bond.j } else { bond.i }
    }

    /// G_M on the manifold when it is fixed by the bond lengths alone (see [`TheoryBound`]):
    /// row-major m x m, or `None` if some angle is not braced.
    fn gram_from_lengths(&self, inverse_mass: &[f64]) -> Option<Vec<f64>> {
        let m = self.bonds.len();
        let mut gram = vec![0.0; m * m];
        for (b, bond) in self.bonds.iter().enumerate() {
            gram[b * m + b] = (inverse_mass[bond.i] + inverse_mass[bond.j]) * self.inv_l2[b];
        }
        for (c, w) in inverse_mass.iter().enumerate() {
            for &(a, _) in self.incident(c) {
                for &(b, _) in self.incident(c) {
                    if a == b {
                        continue;
                    }
                    let brace = self.bond_between(self.other_end(a, c), self.other_end(b, c))?;
                    let (la, lb, lp) = (
                        self.bonds[a].length,
                        self.bonds[b].length,
                        self.bonds[brace].length,
                    );
                    // e_a.e_b of the bond vectors from c (law of cosines); the signs cancel.
                    let inner = 0.5 * (la * la + lb * lb - lp * lp);
                    gram[a * m + b] = w * inner * self.inv_l2[a] * self.inv_l2[b];
                }
            }
        }
        Some(gram)
    }
}

impl RigidBonds {
    /// g_b(x) = 1/2 - |d_b(x)|^2 / (2 L_b^2), x stored or formed where it is read.
    #[inline(always)]
    fn value_at<T: Real, P: Point<T> + ?Sized>(&self, x: &P, out: &mut [T]) {
        for ((o, bond), s) in out.iter_mut().zip(&self.bonds).zip(&self.inv_l2) {
            *o = distance_value(&bond_vector(x, bond), *s);
        }
    }

    /// Dg(x1) M^-1 grad g(x2) for a diagonal mass: entry (a, b) sums, over the atoms c that
    /// bonds a and b share, sign_a sign_b d_a(x1).W_c d_b(x2) / (L_a^2 L_b^2) with W_c the
    /// inverse masses of atom c.
    #[inline(always)]
    fn cross_gram_diagonal<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, x1: &P, x2: &[T], out: &mut DenseGram<T>,
    ) {
        let m = self.bonds.len();
        let zero = x2[0].splat_like(0.0);
        for a in 0..m {
            for b in 0..m {
                out.set(a, b, zero);
            }
        }
        for c in 0..self.atoms {
            let k = 3 * c;
            for &(a, sa) in self.incident(c) {
                let da = bond_vector(x1, &self.bonds[a]);
                let wa = [
                    w.diagonal_product(k, da[0]),
                    w.diagonal_product(k + 1, da[1]),
                    w.diagonal_product(k + 2, da[2]),
                ];
                for &(b, sb) in self.incident(c) {
                    let db = bond_vector(x2, &self.bonds[b]);
                    let term = dot3(&wa, &db) * (sa * sb) * self.inv_l2[a] * self.inv_l2[b];
                    out.set(a, b, out.get(a, b) + term);
                }
            }
        }
    }
}

/// The network written once over [`Real`]: one path with any mass, lanes with a diagonal mass
/// and at most [`DENSE_FAER_THRESHOLD`](crate::DENSE_FAER_THRESHOLD) bonds.
impl Equations for RigidBonds {
    type Shape = Dense;
    fn dim(&self) -> usize {
        3 * self.atoms
    }
    fn n_constraints(&self) -> usize {
        self.bonds.len()
    }
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        self.value_at(x, out);
    }
    /// (Dg(x) u)_b = -d_b.(u_j - u_i) / L_b^2 with d_b = x_j - x_i.
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        bond_rates(&self.bonds, &self.inv_l2, x, u, -1.0, out);
    }
    /// (grad g(x) z)_a = sum over bonds b at atom a of sign z_b d_b / L_b^2, accumulated from
    /// 0 in the order of the bonds.
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        out.fill(x[0].splat_like(0.0));
        for ((bond, s), zb) in self.bonds.iter().zip(&self.inv_l2).zip(z) {
            let d = bond_vector(x, bond);
            for c in 0..3 {
                let f = d[c] * *zb * *s;
                out[3 * bond.i + c] = out[3 * bond.i + c] + f;
                out[3 * bond.j + c] = out[3 * bond.j + c] - f;
            }
        }
    }
    /// D^2 g_b(x)(u, w) = -(u_j - u_i).(w_j - w_i) / L_b^2.
    #[inline(always)]
    fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        bond_rates(&self.bonds, &self.inv_l2, u, w, -1.0, out);
    }
    /// Rounding of g_b = 1/2 - |x_j - x_i|^2 / (2 L_b^2): the differences carry an error of a
    /// few ulps of |x|, relative to the shortest bond (as for [`BeadChain`](crate::BeadChain)).
    fn roundoff(&self) -> Roundoff {
        Roundoff::Length(self.shortest)
    }
    /// Closed form for diagonal masses (`cross_gram_diagonal`), column by column
    /// otherwise.
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, x1: &[T], x2: &[T], scratch: &mut [T], out: &mut DenseGram<T>,
    ) {
        if w.diagonal_entry(0).is_none() {
            return cross_gram(self, x1, x2, w, scratch, out);
        }
        self.cross_gram_diagonal(w, x1, x2, out);
    }
    /// w = max_b |v_j - v_i| / L_b over the bonds, alpha = max_i |a_i| / (shortest bond).
    #[inline(always)]
    fn local_motion<T: Real>(&self, _x: &[T], v: &[T], a: &[T]) -> Option<T> {
        Some(bonds_motion(&self.bonds, &self.inv_l2, self.shortest, v, a))
    }
    /// g(x1) and the dense Newton matrix at a point formed where it is read, then the largest
    /// |g_b| and the LU factorization with partial pivoting, each in a pass of its own.
    #[inline(always)]
    fn evaluate_and_factor<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, x1: &P, r: &[T], values: &mut [T], jacobian: &mut DenseGram<T>,
        factor: &mut LuFactor<T>, step: &mut [T],
    ) -> Evaluation<T> {
        self.value_at(x1, values);
        self.cross_gram_diagonal(w, x1, r, jacobian);
        Evaluation::reduce_and_factor(values, jacobian, factor, step)
    }

    /// out = base + M^-1 grad g(r) z atom by atom, (grad g(r) z)_a accumulated as in
    /// [`Equations::jacobian_transpose_mul`] (adding sign f is adding or subtracting f), then
    /// the mass and the sum of [`Equations::displace`], so that out can be its own base.
    #[inline(always)]
    fn displace_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, r: &[T], z: &[T], base: Option<&P>, out: &mut [T],
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
                out[k + c] = w.diagonal_product(k + c, sum[c]) + y[c];
            }
        }
    }

    /// -(Dg(x) u)_b = d_b(x).(u_j - u_i) / L_b^2.
    #[inline(always)]
    fn negated_jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        bond_rates(&self.bonds, &self.inv_l2, x, u, 1.0, out);
    }
}

impl TheoryBound for RigidBonds {
    /// Known when every angle of the network is braced (any two bonds that share an atom are
    /// closed into a triangle by a third bond: a single bond, disjoint bonds, a rigid triangle,
    /// a tetrahedron, ...) and the mass is diagonal with equal entries within each atom. Then the
    /// inner products of bond vectors that meet are fixed by the lengths (law of cosines), so
    /// G_M is the same matrix G at every point of the manifold (the limit epsilon -> 0 of
    /// eq. 2.2) and, with m_lo the smallest mass and deg the largest number of bonds at an atom:
    /// |G_M| = lambda_max(G), |G_M^-1| = 1 / lambda_min(G),
    /// |M^-1 grad g| <= sqrt(lambda_max(G) / m_lo) (since |M^-1 y|^2 <= y.M^-1 y / m_lo),
    /// |D^2 g| <= 2 sqrt(deg) / L_min^2 (|u_j - u_i|^2 <= 2 |u_i|^2 + 2 |u_j|^2, summed over the
    /// bonds), D^3 g = 0. `None` for other networks (G_M then varies over the manifold, e.g. with
    /// the angle between two unbraced bonds, and can become singular), for other masses, and
    /// when G is not positive definite (lengths that violate a triangle inequality).
    fn c_g<M: Mass>(&self, mass: &M) -> Option<f64> {
        if mass.order().is_some_and(|o| o != self.dim()) {
            return None;
        }
        let mut inverse_mass = Vec::with_capacity(self.atoms);
        for a in 0..self.atoms {
            let w = mass.inverse_diagonal_entry(3 * a)?;
            if (1..3).any(|k| mass.inverse_diagonal_entry(3 * a + k) != Some(w)) {
                return None;
            }
            inverse_mass.push(w);
        }
        let gram = self.gram_from_lengths(&inverse_mass)?;
        let m = self.bonds.len();
        let (lo, hi) = crate::mass::eigenvalue_range(m, &gram).ok()?;
        // Not positive definite, or NaN: no bound.
        if lo.is_nan() || lo <= 1e-12 * hi {
            return None;
        }
        let degree = (0..self.atoms)
            .map(|a| self.incident(a).len())
            .max()
            .unwrap_or(1);
        let (mass_lo, _) = mass.eigenvalue_bounds();
        Some(
            [
                (hi / mass_lo).sqrt(),
                hi,
                1.0 / lo,
                2.0 * (degree as f64).sqrt() / (self.shortest * self.shortest),
            ]
            .into_iter()
            .fold(1.0, f64::max),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::RigidBonds;
    use crate::constraint::scratch_len;
    use crate::constraint::{Constraint, Curvature, TheoryBound};
    use crate::error::ManifoldError;
    use crate::gram::GramMatrix;
    use crate::mass::{DenseMass, DiagonalMass, IdentityMass};

    /// A tetrahedron-like network of 5 atoms: a braced triangle (0, 1, 2) plus an unbraced
    /// tail 2-3-4 and a bond 1-3 that shares atoms with both.
    fn network() -> RigidBonds {
        RigidBonds::new(
            5,
            &[
                (0, 1, 1.0),
                (1, 2, 1.2),
                (2, 0, 0.9),
                (2, 3, 1.1),
                (4, 3, 0.8),
                (1, 3, 1.5),
            ],
        )
        .unwrap()
    }

    fn point(n: usize, phase: f64) -> Vec<f64> {
        (0..n)
            .map(|k| (k as f64 * 0.77 + phase).sin() + 0.3 * k as f64)
            .collect()
    }

    fn masses() -> DiagonalMass {
        DiagonalMass::per_particle(&[1.0, 2.5, 0.7, 3.0, 1.3], 3).unwrap()
    }

    /// Dg(x) as a dense m x n matrix, row-major, from products with unit vectors.
    fn dense_jacobian(c: &RigidBonds, x: &[f64]) -> Vec<f64> {
        let (n, m) = (c.dim(), c.n_constraints());
        let mut jac = vec![0.0; m * n];
        let mut unit = vec![0.0; n];
        let mut column = vec![0.0; m];
        for k in 0..n {
            unit[k] = 1.0;
            c.jacobian_mul(x, &unit, &mut column);
            for b in 0..m {
                jac[b * n + k] = column[b];
            }
            unit[k] = 0.0;
        }
        jac
    }

    #[test]
    fn jacobian_matches_finite_differences_and_transpose_is_adjoint() {
        let c = network();
        let (n, m) = (c.dim(), c.n_constraints());
        let x = point(n, 0.1);
        let jac = dense_jacobian(&c, &x);
        let eps = 1e-6;
        let (mut gp, mut gm) = (vec![0.0; m], vec![0.0; m]);
        for k in 0..n {
            let mut xp = x.clone();
            xp[k] += eps;
            c.value(&xp, &mut gp);
            xp[k] -= 2.0 * eps;
            c.value(&xp, &mut gm);
            for b in 0..m {
                let fd = (gp[b] - gm[b]) / (2.0 * eps);
                let exact = jac[b * n + k];
                assert!(
                    (fd - exact).abs() < 1e-8,
                    "bond {b} coord {k}: {fd} vs {exact}"
                );
            }
        }
        let z: Vec<f64> = (0..m).map(|b| 0.5 + b as f64).collect();
        let mut gz = vec![7.0; n];
        c.jacobian_transpose_mul(&x, &z, &mut gz);
        for k in 0..n {
            let expected: f64 = (0..m).map(|b| jac[b * n + k] * z[b]).sum();
            assert!((gz[k] - expected).abs() < 1e-12, "coord {k}");
        }
    }

    #[test]
    fn gram_matches_dense_product_for_diagonal_and_dense_masses() {
        let c = network();
        let (n, m) = (c.dim(), c.n_constraints());
        let (x1, x2) = (point(n, 0.1), point(n, 1.3));
        let (j1, j2) = (dense_jacobian(&c, &x1), dense_jacobian(&c, &x2));
        let diag = masses();
        let full = DenseMass::new(
            n,
            (0..n * n)
                .map(|k| {
                    if k / n == k % n {
                        diag.diagonal()[k / n]
                    } else {
                        0.0
                    }
                })
                .collect(),
        )
        .unwrap();
        let mut scratch = vec![0.0; scratch_len(n, m)];
        for dense_mass in [false, true] {
            let mut gram = c.new_gram();
            if dense_mass {
                c.cross_gram(&x1, &x2, &full, &mut scratch, &mut gram);
            } else {
                c.cross_gram(&x1, &x2, &diag, &mut scratch, &mut gram);
            }
            for a in 0..m {
                for b in 0..m {
                    let expected: f64 = (0..n)
                        .map(|k| j1[a * n + k] * j2[b * n + k] / diag.diagonal()[k])
                        .sum();
                    let got = gram.entry(a, b);
                    assert!(
                        (got - expected).abs() < 1e-12 * (1.0 + expected.abs()),
                        "dense mass {dense_mass}, ({a},{b}): {got} vs {expected}"
                    );
                }
            }
        }
    }

    #[test]
    fn curvature_matches_finite_differences_of_the_jacobian() {
        let c = network();
        let (n, m) = (c.dim(), c.n_constraints());
        let x = point(n, 0.4);
        let u = point(n, 2.0);
        let w = point(n, -1.1);
        let mut exact = vec![0.0; m];
        c.second_derivative(&x, &u, &w, &mut exact);
        let eps = 1e-6;
        let (mut p, mut q) = (vec![0.0; m], vec![0.0; m]);
        let shifted = |s: f64| -> Vec<f64> { x.iter().zip(&w).map(|(a, b)| a + s * b).collect() };
        c.jacobian_mul(&shifted(eps), &u, &mut p);
        c.jacobian_mul(&shifted(-eps), &u, &mut q);
        for b in 0..m {
            let fd = (p[b] - q[b]) / (2.0 * eps);
            assert!(
                (fd - exact[b]).abs() < 1e-7,
                "bond {b}: {fd} vs {}",
                exact[b]
            );
        }
    }

    #[test]
    fn each_bad_network_is_rejected_by_name() {
        let name = |r: Result<RigidBonds, ManifoldError>| match r {
            Err(ManifoldError::InvalidParameter { name, value, .. }) => (name, value),
            other => panic!("expected InvalidParameter, got {other:?}"),
        };
        assert_eq!(name(RigidBonds::new(3, &[])), ("bonds", 0.0));
        assert_eq!(
            name(RigidBonds::new(3, &[(0, 1, 1.0), (1, 3, 1.0)])),
            ("bond atom index", 3.0)
        );
        assert_eq!(
            name(RigidBonds::new(3, &[(2, 2, 1.0)])),
            ("bond atoms", 2.0)
        );
        assert_eq!(name(RigidBonds::new(3, &[(0, 1, 0.0)])).0, "bond length");
        assert_eq!(name(RigidBonds::new(3, &[(0, 1, -1.0)])).0, "bond length");
        assert_eq!(
            name(RigidBonds::new(3, &[(0, 1, f64::NAN)])).0,
            "bond length"
        );
        assert_eq!(
            name(RigidBonds::new(3, &[(0, 1, f64::INFINITY)])).0,
            "bond length"
        );
        assert_eq!(
            name(RigidBonds::new(3, &[(0, 1, 1.0), (1, 2, 1.0), (1, 0, 1.0)])),
            ("bond", 2.0)
        );
        assert_eq!(name(RigidBonds::new(1, &[(0, 0, 1.0)])).0, "atoms");
        let too_many: Vec<(usize, usize, f64)> = (0..7)
            .flat_map(|i| (i + 1..7).map(move |j| (i, j, 1.0)))
            .collect();
        assert_eq!(name(RigidBonds::new(7, &too_many)), ("bonds", 21.0));
    }

    #[test]
    fn braced_networks_have_c_g_from_the_gram_on_the_manifold() {
        let triangle = RigidBonds::new(3, &[(0, 1, 1.0), (0, 2, 1.0), (1, 2, 1.5)]).unwrap();
        let mass = DiagonalMass::per_particle(&[2.0, 1.0, 1.0], 3).unwrap();
        let c_g = triangle.c_g(&mass).unwrap();
        // At a point of the manifold, rotated arbitrarily, G_M has the eigenvalues behind c_g.
        let half = (1.0_f64 - 0.75 * 0.75).sqrt();
        let planar = [0.0, 0.0, 0.0, half, 0.75, 0.0, half, -0.75, 0.0];
        let (s, co) = (0.3_f64.sin(), 0.3_f64.cos());
        let x: Vec<f64> = planar
            .chunks_exact(3)
            .flat_map(|p| [co * p[0] - s * p[2], p[1] + 0.2, s * p[0] + co * p[2]])
            .collect();
        let mut g = [0.0; 3];
        triangle.value(&x, &mut g);
        assert!(g.iter().all(|v| v.abs() < 1e-15), "{g:?}");
        let mut gram = triangle.new_gram();
        let mut scratch = vec![0.0; scratch_len(9, 3)];
        triangle.cross_gram(&x, &x, &mass, &mut scratch, &mut gram);
        let matrix = faer::Mat::<f64>::from_fn(3, 3, |a, b| gram.entry(a, b));
        let eig = matrix.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        let lo = eig.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = eig.iter().copied().fold(0.0, f64::max);
        let expected = [(hi / 1.0).sqrt(), hi, 1.0 / lo, 2.0 * 2.0_f64.sqrt()]
            .into_iter()
            .fold(1.0, f64::max);
        assert!(
            (c_g - expected).abs() < 1e-10 * expected,
            "{c_g} {expected}"
        );
        // A single bond is braced too; an open chain of two bonds is not.
        assert!(
            RigidBonds::new(2, &[(0, 1, 1.0)])
                .unwrap()
                .c_g(&IdentityMass)
                .is_some()
        );
        let open = RigidBonds::new(3, &[(0, 1, 1.0), (1, 2, 1.0)]).unwrap();
        assert_eq!(open.c_g(&IdentityMass), None);
        // Lengths that violate the triangle inequality give no manifold and no bound.
        let impossible = RigidBonds::new(3, &[(0, 1, 1.0), (0, 2, 1.0), (1, 2, 3.0)]).unwrap();
        assert_eq!(impossible.c_g(&IdentityMass), None);
        // Anisotropic masses make G_M depend on the orientation.
        let anisotropic = DiagonalMass::new(vec![1.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(triangle.c_g(&anisotropic.unwrap()), None);
    }
}
