//! Factorizations of the Gram storages, by structure: scalar, tridiagonal in O(m), dense
//! (hand-written LU for small orders, faer above [`DENSE_FAER_THRESHOLD`]). Factor once, solve
//! as often as needed.
//!
//! Each factorization is written once over the number type ([`MatrixFactor`]): `f64` for one
//! path, [`Lanes`](sdae_lanes::Lanes) for W paths, lane i computing exactly what `f64` computes
//! for path i ([`ScalarFactor`], [`ThomasFactor`], [`LuFactor`]). The one-path factorizations
//! of a constraint's Gram storage ([`Factorize`], [`Solve`]) run the same code and add what
//! only one path can have: LAPACK's pivoted tridiagonal LU where Thomas' algorithm rejects a
//! pivot ([`TridiagonalFactor`]), faer above [`DENSE_FAER_THRESHOLD`] ([`DenseFactor`]) and
//! typed errors.

mod dense;
mod tridiagonal;

use sdae_lanes::{PathMask, Real};

use crate::error::LinearError;
use crate::gram::{GramMatrix, ScalarGram, SquareMatrix};

pub use dense::{DenseFactor, LuFactor};
pub use tridiagonal::{ThomasFactor, TridiagonalFactor};

/// Above this order, dense systems are factored by faer; below it by the hand-written LU,
/// which does not allocate.
pub const DENSE_FAER_THRESHOLD: usize = 32;

/// Relative size below which a pivot of a dense LU factorization counts as zero: a pivot p
/// is rejected when |p| <= `PIVOT_TOLERANCE` x max_ij |A_ij|.
pub const PIVOT_TOLERANCE: f64 = 1e-14;

/// A right-hand side b and the solution's storage, for a factorization that solves as it goes.
pub type RightHandSide<'a, T> = Option<(&'a [T], &'a mut [T])>;

/// The factorization of a [`SquareMatrix`] of numbers of type T, without fallbacks: the paths
/// whose factorization it rejects are reported (and a one-path caller takes its fallback).
pub trait MatrixFactor<T: Real>: Clone + std::fmt::Debug + Send + Sync + 'static {
    /// The matrix it factors.
    type Matrix: SquareMatrix<T>;
    /// Storage for the factors of order m >= 1, of the kind of `like`.
    fn zeros_like(like: T, m: usize) -> Self;
    /// Factors `a`, and with `rhs` = (b, out) runs the first half of the solve A out = b into
    /// `out` ([`MatrixFactor::back_substitute`] finishes it); the paths whose factorization
    /// passed (the one-path factorization accepts exactly those).
    fn factor(&mut self, a: &Self::Matrix, rhs: RightHandSide<'_, T>) -> T::Mask;
    /// The first half of b <- A^-1 b (the forward substitution).
    fn forward_in_place(&self, b: &mut [T]);
    /// The second half of a solve whose first half [`MatrixFactor::factor`] or
    /// [`MatrixFactor::forward_in_place`] ran.
    fn back_substitute(&self, out: &mut [T]);
    /// b <- A^-1 b.
    #[inline(always)]
    fn solve_in_place(&self, b: &mut [T]) {
        self.forward_in_place(b);
        self.back_substitute(b);
    }
}

/// A one-path matrix storage that can be factored for repeated solves.
pub trait Factorize: GramMatrix {
    /// The factorization; created once per workspace and refilled in place.
    type Factor: Solve + Clone + std::fmt::Debug;
    /// An empty factorization of the right size.
    fn new_factor(&self) -> Self::Factor;
    /// Factors `self` into `factor`.
    fn factor_into(&self, factor: &mut Self::Factor) -> Result<(), LinearError>;
    /// Factors `self` into `factor` and sets out = A^-1 b, with the floating-point operations
    /// of [`Factorize::factor_into`] followed by [`Solve::solve_in_place`] (a storage may do
    /// both in one pass). On failure `out` is unspecified.
    #[inline]
    fn factor_and_solve(
        &self, factor: &mut Self::Factor, b: &[f64], out: &mut [f64],
    ) -> Result<(), LinearError> {
        self.factor_with(factor, Some((b, out)), None)
    }
    /// Factors `self` (A) into `factor` and, with `solve` = (b, out), sets out = A^-1 b, and
    /// with `map` = (B, p, image), image = B^-1 (A p) for a matrix B given by its factors: the
    /// floating-point operations of [`Factorize::factor_into`], [`Solve::solve_in_place`] and
    /// [`GramMatrix::mul_vec`] (a storage may interleave them, so that their recurrences
    /// overlap). On failure `out` and `image` are unspecified.
    #[inline]
    fn factor_with(
        &self, factor: &mut Self::Factor, solve: Option<(&[f64], &mut [f64])>,
        map: Option<(&Self::Factor, &[f64], &mut [f64])>,
    ) -> Result<(), LinearError> {
        self.factor_into(factor)?;
        solve_and_map_apart(self, factor, solve, map);
        Ok(())
    }
}

/// The solve and the product of [`Factorize::factor_with`] after `a` is factored in `factor`,
/// one after the other.
fn solve_and_map_apart<A: Factorize>(
    a: &A, factor: &A::Factor, solve: Option<(&[f64], &mut [f64])>,
    map: Option<(&A::Factor, &[f64], &mut [f64])>,
) {
    if let Some((b, out)) = solve {
        out.copy_from_slice(b);
        factor.solve_in_place(out);
    }
    if let Some((other, p, image)) = map {
        a.mul_vec(p, image);
        other.solve_in_place(image);
    }
}

/// Solving with a factored one-path matrix.
pub trait Solve {
    /// b <- A^-1 b.
    fn solve_in_place(&self, b: &mut [f64]);
}

fn check_finite(values: &[f64]) -> Result<(), LinearError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(LinearError::NonFinite { index }),
    }
}

/// The inverse 1 / A of a 1 x 1 matrix A: a solve is b (1 / A).
#[derive(Debug, Clone, Copy, Default)]
pub struct ScalarFactor<T = f64>(T);

impl<T: Real> MatrixFactor<T> for ScalarFactor<T> {
    type Matrix = ScalarGram<T>;

    fn zeros_like(like: T, _m: usize) -> Self {
        Self(like.splat_like(0.0))
    }

    /// 1 / A, and with `rhs` = (b, out) the whole solve out = b (1 / A); the paths where A is
    /// finite and not zero.
    #[inline(always)]
    fn factor(&mut self, a: &ScalarGram<T>, rhs: RightHandSide<'_, T>) -> T::Mask {
        let a = a.0;
        self.0 = a.splat_like(1.0) / a;
        if let Some((b, out)) = rhs {
            out[0] = b[0] * self.0;
        }
        a.finite().and(!a.equal(a.splat_like(0.0)))
    }

    /// b <- b (1 / A): the whole solve.
    #[inline(always)]
    fn forward_in_place(&self, b: &mut [T]) {
        b[0] = b[0] * self.0;
    }

    /// Nothing left after [`MatrixFactor::forward_in_place`].
    #[inline(always)]
    fn back_substitute(&self, _out: &mut [T]) {}
}

impl Solve for ScalarFactor {
    #[inline]
    fn solve_in_place(&self, b: &mut [f64]) {
        self.forward_in_place(b);
    }
}

impl Factorize for ScalarGram {
    type Factor = ScalarFactor;
    fn new_factor(&self) -> ScalarFactor {
        ScalarFactor(0.0)
    }
    /// [`MatrixFactor::factor`], with a typed error where it fails.
    #[inline]
    fn factor_into(&self, factor: &mut ScalarFactor) -> Result<(), LinearError> {
        if factor.factor(self, None) {
            return Ok(());
        }
        Err(if self.0.is_finite() {
            LinearError::Singular {
                index: 0,
                pivot: 0.0,
            }
        } else {
            LinearError::NonFinite { index: 0 }
        })
    }
}

/// The check that a factorization over lanes is the one-path factorization in each lane.
#[cfg(test)]
pub(crate) mod lanes_check {
    use super::*;
    use pulp::{Simd, WithSimd};
    use sdae_lanes::{LaneWidth, Lanes};

    /// `check` (made by `make` for each width) at one lane, four, eight and the machine's
    /// widest.
    pub(crate) fn at_every_width<C: WithSimd<Output = ()>>(make: impl Fn() -> C) {
        for width in LaneWidth::ALL {
            width.dispatch(make());
        }
    }

    /// W lanes whose lane i holds `value(i)`.
    pub(crate) fn lanes_of<S: Simd>(simd: S, value: impl Fn(usize) -> f64) -> Lanes<S> {
        let per_lane: Vec<f64> = (0..Lanes::<S>::WIDTH).map(value).collect();
        Lanes::load(simd, &per_lane)
    }

    /// Factors, solves and multiplies the lanes' matrix `a` (lane i holding `one_path[i]`)
    /// with F, and checks each lane against one path's storage and factorization bit for
    /// bit: the product A b in every lane, the lanes F accepts exactly where `accepted` holds
    /// of one path's factorization (its factor and result), and their solutions A^-1 b.
    pub(crate) fn assert_lanes_are_one_path<S: Simd, F: MatrixFactor<Lanes<S>>, G: Factorize>(
        simd: S, a: &F::Matrix, one_path: &[G],
        accepted: impl Fn(&G::Factor, Result<(), LinearError>) -> bool,
    ) {
        let m = one_path[0].order();
        let b_of = |lane: usize, i: usize| (i as f64 + 0.5 * lane as f64).sin();
        let b: Vec<Lanes<S>> = (0..m)
            .map(|i| lanes_of(simd, |lane| b_of(lane, i)))
            .collect();
        let zero = Lanes::splat(simd, 0.0);
        let (mut x, mut product) = (vec![zero; m], vec![zero; m]);
        let mut factor = F::zeros_like(zero, m);
        let ok = factor.factor(a, Some((&b, &mut x)));
        factor.back_substitute(&mut x);
        a.product(&b, &mut product);
        for (lane, gram) in one_path.iter().enumerate() {
            let b_lane: Vec<f64> = (0..m).map(|i| b_of(lane, i)).collect();
            let mut expected_product = vec![0.0; m];
            gram.mul_vec(&b_lane, &mut expected_product);
            let mut one_factor = gram.new_factor();
            let result = gram.factor_into(&mut one_factor);
            let lane_ok = accepted(&one_factor, result);
            assert_eq!(ok.lane(lane), lane_ok, "m = {m}, lane {lane}");
            let mut expected = b_lane;
            one_factor.solve_in_place(&mut expected);
            for i in 0..m {
                let case = format!("m = {m}, lane {lane}, entry {i}");
                assert_eq!(
                    product[i].lane(lane).to_bits(),
                    expected_product[i].to_bits(),
                    "{case}"
                );
                if lane_ok {
                    assert_eq!(x[i].lane(lane).to_bits(), expected[i].to_bits(), "{case}");
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DenseGram, TridiagonalGram};

    /// 1 / A over lanes against one path's `ScalarFactor`, with lanes of A = 0 and A infinite
    /// that both reject.
    struct ScalarCheck;

    impl pulp::WithSimd for ScalarCheck {
        type Output = ();
        fn with_simd<S: pulp::Simd>(self, simd: S) {
            let value = |lane: usize| match lane % 4 {
                1 => 0.0,
                3 => f64::INFINITY,
                _ => 2.5 - 1.75 * lane as f64,
            };
            let width = sdae_lanes::Lanes::<S>::WIDTH;
            let one_path: Vec<ScalarGram> =
                (0..width).map(|lane| ScalarGram(value(lane))).collect();
            let a = ScalarGram(lanes_check::lanes_of(simd, value));
            lanes_check::assert_lanes_are_one_path::<S, ScalarFactor<_>, _>(
                simd,
                &a,
                &one_path,
                |_, result| result.is_ok(),
            );
        }
    }

    #[test]
    fn scalar_lanes_are_one_path_bit_for_bit() {
        lanes_check::at_every_width(|| ScalarCheck);
    }

    fn residual<A: GramMatrix>(a: &A, x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; b.len()];
        a.mul_vec(x, &mut ax);
        ax.iter()
            .zip(b)
            .fold(0.0, |s, (p, q)| f64::max(s, (p - q).abs()))
    }

    fn solve<A: Factorize>(a: &A, b: &[f64]) -> Vec<f64> {
        let mut f = a.new_factor();
        a.factor_into(&mut f).unwrap();
        let mut x = b.to_vec();
        f.solve_in_place(&mut x);
        x
    }

    #[test]
    fn tridiagonal_thomas_and_pivoted_paths_solve() {
        let m = 9;
        let mut a = TridiagonalGram::zeros(m);
        for i in 0..m {
            a.diag[i] = 2.0 + 0.1 * i as f64;
        }
        for i in 0..m - 1 {
            a.lower[i] = -1.0;
            a.upper[i] = -0.9;
        }
        let b: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-14);
        // A zero diagonal forces the pivoted path.
        a.diag.iter_mut().for_each(|d| *d = 0.0);
        a.lower.iter_mut().for_each(|l| *l = 1.0);
        a.upper.iter_mut().for_each(|u| *u = -1.0);
        a.diag[m - 1] = 1.0;
        let mut f = a.new_factor();
        a.factor_into(&mut f).unwrap();
        assert!(f.is_pivoted());
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-13, "{}", residual(&a, &x, &b));
    }

    /// A tridiagonal matrix of order m whose Thomas pivots are safe (`zero_diagonal` false) or
    /// that needs row interchanges (true).
    fn tridiagonal(m: usize, shift: f64, zero_diagonal: bool) -> TridiagonalGram {
        let mut a = TridiagonalGram::zeros(m);
        for i in 0..m {
            a.diag[i] = if zero_diagonal && i + 1 < m {
                0.0
            } else {
                2.0 + shift * (i as f64 + 0.5).sin()
            };
        }
        for i in 0..m.saturating_sub(1) {
            a.lower[i] = -1.0 + 0.1 * (i as f64).cos();
            a.upper[i] = -0.9 + shift * 0.05 * i as f64 / m as f64;
        }
        a
    }

    #[test]
    fn factor_with_is_factor_solve_and_product_bit_for_bit() {
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for m in [1, 2, 3, 9, 40] {
            for (a_pivots, b_pivots) in [(false, false), (true, false), (false, true), (true, true)]
            {
                let a = tridiagonal(m, 0.3, a_pivots && m > 1);
                let b = tridiagonal(m, -0.2, b_pivots && m > 1);
                let mut b_factor = b.new_factor();
                b.factor_into(&mut b_factor).unwrap();
                assert_eq!(b_factor.is_pivoted(), b_pivots && m > 1);
                let p: Vec<f64> = (0..m).map(|i| (0.7 * i as f64).cos()).collect();
                let rhs: Vec<f64> = (0..m).map(|i| 1.0 - 0.3 * i as f64).collect();
                // The separate passes.
                let mut a_factor = a.new_factor();
                a.factor_into(&mut a_factor).unwrap();
                assert_eq!(a_factor.is_pivoted(), a_pivots && m > 1);
                let mut image_apart = vec![0.0; m];
                a.mul_vec(&p, &mut image_apart);
                b_factor.solve_in_place(&mut image_apart);
                let mut solution_apart = rhs.clone();
                a_factor.solve_in_place(&mut solution_apart);
                // One pass, asked for the solve, the product or both, into a factor that held
                // another matrix.
                for (with_solve, with_map) in [(true, false), (false, true), (true, true)] {
                    let mut fused = b.new_factor();
                    b.factor_into(&mut fused).unwrap();
                    let mut image = vec![f64::NAN; m];
                    let mut solution = vec![f64::NAN; m];
                    a.factor_with(
                        &mut fused,
                        with_solve.then_some((&rhs[..], &mut solution[..])),
                        with_map.then_some((&b_factor, &p[..], &mut image[..])),
                    )
                    .unwrap();
                    let case =
                        format!("m={m} pivots {a_pivots} {b_pivots}: {with_solve} {with_map}");
                    if with_map {
                        assert_eq!(bits(&image), bits(&image_apart), "{case}");
                    }
                    if with_solve {
                        assert_eq!(bits(&solution), bits(&solution_apart), "{case}");
                    }
                    // The factor is the one factor_into gives: it solves alike.
                    assert_eq!(fused.is_pivoted(), a_factor.is_pivoted(), "{case}");
                    let mut x = p.clone();
                    fused.solve_in_place(&mut x);
                    let mut y = p.clone();
                    a_factor.solve_in_place(&mut y);
                    assert_eq!(bits(&x), bits(&y), "{case}");
                }
            }
        }
    }

    #[test]
    fn singular_tridiagonal_is_reported() {
        // [[1,1,0],[1,1,1],[0,1,1]] has det -1 and a zero Thomas pivot: pivoting solves it.
        let mut a = TridiagonalGram::zeros(3);
        a.diag.copy_from_slice(&[1.0, 1.0, 1.0]);
        a.lower.copy_from_slice(&[1.0, 1.0]);
        a.upper.copy_from_slice(&[1.0, 1.0]);
        let b = [1.0, 2.0, 3.0];
        let x = solve(&a, &b);
        assert!(residual(&a, &x, &b) < 1e-15);
        // Rows 0 and 1 equal: singular.
        a.lower.copy_from_slice(&[1.0, 0.0]);
        a.upper.copy_from_slice(&[1.0, 0.0]);
        let mut f = a.new_factor();
        assert!(matches!(
            a.factor_into(&mut f),
            Err(LinearError::Singular { .. })
        ));
    }

    #[test]
    fn dense_small_and_faer_paths_solve() {
        for m in [3, 40] {
            let mut a = DenseGram::zeros(m);
            for i in 0..m {
                for j in 0..m {
                    a.set(
                        i,
                        j,
                        ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 0.5 } else { 0.0 },
                    );
                }
            }
            let b: Vec<f64> = (0..m).map(|i| 1.0 + i as f64).collect();
            let x = solve(&a, &b);
            let scale = x.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            assert!(
                residual(&a, &x, &b) < 1e-11 * scale,
                "m={m}: {}",
                residual(&a, &x, &b)
            );
        }
        let a = DenseGram::zeros(2);
        let mut f = a.new_factor();
        assert!(matches!(
            a.factor_into(&mut f),
            Err(LinearError::Singular { index: 0, .. })
        ));
    }
}
