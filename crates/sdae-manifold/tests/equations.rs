//! A constraint written once over `Real` ([`Equations`]): its blanket one-path forms
//! ([`Constraint`], [`Curvature`]) against central differences and closed forms, for two
//! equations (tridiagonal Gram matrix) and three (dense), with diagonal and dense masses; its
//! lane forms against the one-path forms bit for bit at every lane width; and the kappa
//! closed form of a quadratic equation against the hypersurface's; and no allocation once the
//! first call has made the thread's scratch.

use std::alloc::{GlobalAlloc, Layout, System as SystemAlloc};
use std::cell::Cell;

use pulp::{Simd, WithSimd};
use sdae_lanes::{LaneWidth, Lanes, Real};
use sdae_manifold::lane_form::{LaneForm, LaneFormVisitor, Point};
use sdae_manifold::{
    Constraint, Curvature, Dense, DenseMass, DiagonalMass, Equations, Factorize, GramMatrix,
    GramShape, Hypersurface, Mass, MatrixFactor, Scalar, Solve, SquareMatrix, Surface, Tridiagonal,
    scratch_len,
};

/// Two equations in R^4, neither quadratic: g1 = |(x0, x1)| - 1, g2 = x0 x2 + x1^2 x3 - 1/2
/// (the Gram matrix of two equations is tridiagonal).
#[derive(Debug, Clone, Copy)]
struct Pair;

impl Equations for Pair {
    type Shape = Tridiagonal;
    fn dim(&self) -> usize {
        4
    }
    fn n_constraints(&self) -> usize {
        2
    }
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        out[0] = (x[0] * x[0] + x[1] * x[1]).sqrt() - 1.0;
        out[1] = x[0] * x[2] + x[1] * x[1] * x[3] - 0.5;
    }
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        let rho = (x[0] * x[0] + x[1] * x[1]).sqrt();
        out[0] = (x[0] * u[0] + x[1] * u[1]) / rho;
        out[1] = x[2] * u[0] + x[1] * x[3] * u[1] * 2.0 + x[0] * u[2] + x[1] * x[1] * u[3];
    }
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        let s = z[0] / (x[0] * x[0] + x[1] * x[1]).sqrt();
        out[0] = x[0] * s + x[2] * z[1];
        out[1] = x[1] * s + x[1] * x[3] * z[1] * 2.0;
        out[2] = x[0] * z[1];
        out[3] = x[1] * x[1] * z[1];
    }
    /// D^2 of |p| is (I - p p^T / |p|^2) / |p|; of g2 the symmetric part of its bilinear terms.
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        let rho2 = x[0] * x[0] + x[1] * x[1];
        let (pu, pw) = (x[0] * u[0] + x[1] * u[1], x[0] * w[0] + x[1] * w[1]);
        out[0] = (u[0] * w[0] + u[1] * w[1] - pu * pw / rho2) / rho2.sqrt();
        out[1] = u[0] * w[2]
            + u[2] * w[0]
            + (x[3] * u[1] * w[1] + x[1] * (u[1] * w[3] + u[3] * w[1])) * 2.0;
    }
}

/// Three equations in R^5 with a dense Gram matrix: g1 = |x|^2 / 2 - 1, g2 = x0 x1 x2 - 1/10,
/// g3 = (1 + x3^2)^(1/2) + x4 x0 - 2.
#[derive(Debug, Clone, Copy)]
struct Triple;

impl Equations for Triple {
    type Shape = Dense;
    fn dim(&self) -> usize {
        5
    }
    fn n_constraints(&self) -> usize {
        3
    }
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        let mut sq = x[0] * x[0];
        for xk in &x[1..] {
            sq = sq + *xk * *xk;
        }
        out[0] = sq * 0.5 - 1.0;
        out[1] = x[0] * x[1] * x[2] - 0.1;
        out[2] = (x[3] * x[3] + 1.0).sqrt() + x[4] * x[0] - 2.0;
    }
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        let mut dot = x[0] * u[0];
        for k in 1..5 {
            dot = dot + x[k] * u[k];
        }
        out[0] = dot;
        out[1] = x[1] * x[2] * u[0] + x[0] * x[2] * u[1] + x[0] * x[1] * u[2];
        out[2] = x[3] / (x[3] * x[3] + 1.0).sqrt() * u[3] + x[4] * u[0] + x[0] * u[4];
    }
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        let s = x[3] / (x[3] * x[3] + 1.0).sqrt();
        out[0] = x[0] * z[0] + x[1] * x[2] * z[1] + x[4] * z[2];
        out[1] = x[1] * z[0] + x[0] * x[2] * z[1];
        out[2] = x[2] * z[0] + x[0] * x[1] * z[1];
        out[3] = x[3] * z[0] + s * z[2];
        out[4] = x[4] * z[0] + x[0] * z[2];
    }
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        let mut dot = u[0] * w[0];
        for k in 1..5 {
            dot = dot + u[k] * w[k];
        }
        out[0] = dot;
        out[1] = x[2] * (u[0] * w[1] + u[1] * w[0])
            + x[1] * (u[0] * w[2] + u[2] * w[0])
            + x[0] * (u[1] * w[2] + u[2] * w[1]);
        let q = x[3] * x[3] + 1.0;
        out[2] = u[3] * w[3] / (q * q.sqrt()) + u[4] * w[0] + u[0] * w[4];
    }
}

/// The ellipse x^2 / 4 + y^2 = 1 as g = (x^2 / 4 + y^2 - 1) / 2, once as [`Equations`] and
/// once as a [`Surface`], with the same operations.
#[derive(Debug, Clone, Copy)]
struct Ellipse;

impl Equations for Ellipse {
    type Shape = Scalar;
    fn dim(&self) -> usize {
        2
    }
    fn n_constraints(&self) -> usize {
        1
    }
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        out[0] = (x[0] * x[0] * 0.25 + x[1] * x[1] - 1.0) * 0.5;
    }
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        out[0] = x[0] * 0.25 * u[0] + x[1] * u[1];
    }
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        out[0] = x[0] * 0.25 * z[0];
        out[1] = x[1] * z[0];
    }
    fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        out[0] = u[0] * w[0] * 0.25 + u[1] * w[1];
    }
    fn is_quadratic(&self) -> bool {
        true
    }
}

impl Surface<2> for Ellipse {
    fn value<T: Real>(&self, x: &[T; 2]) -> T {
        (x[0] * x[0] * 0.25 + x[1] * x[1] - 1.0) * 0.5
    }
    fn gradient<T: Real>(&self, x: &[T; 2]) -> [T; 2] {
        [x[0] * 0.25, x[1]]
    }
    fn second_derivative<T: Real>(&self, _x: &[T; 2], u: &[T; 2], w: &[T; 2]) -> T {
        u[0] * w[0] * 0.25 + u[1] * w[1]
    }
    fn is_quadratic(&self) -> bool {
        true
    }
}

/// The sphere |x|^2 = 2 in R^20 as g = |x|^2 / 2 - 1: enough coordinates that the lane forms'
/// scratch is the thread's buffer rather than the stack.
#[derive(Debug, Clone, Copy)]
struct Ball;

impl Equations for Ball {
    type Shape = Scalar;
    fn dim(&self) -> usize {
        20
    }
    fn n_constraints(&self) -> usize {
        1
    }
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        let mut sum = x[0] * x[0];
        for xk in &x[1..] {
            sum = sum + *xk * *xk;
        }
        out[0] = sum * 0.5 - 1.0;
    }
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        Equations::second_derivative(self, u, x, u, out);
    }
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        for (o, xk) in out.iter_mut().zip(x) {
            *o = *xk * z[0];
        }
    }
    fn second_derivative<T: Real>(&self, _x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        let mut sum = u[0] * w[0];
        for k in 1..20 {
            sum = sum + u[k] * w[k];
        }
        out[0] = sum;
    }
    fn is_quadratic(&self) -> bool {
        true
    }
}

/// Coordinate k of test point `which` of path `lane` (n coordinates).
fn coordinate(which: usize, lane: usize, k: usize) -> f64 {
    0.6 + 0.37 * (1.3 * k as f64 + 0.7 * which as f64 + 0.11 * lane as f64).sin()
}

fn point(which: usize, lane: usize, n: usize) -> Vec<f64> {
    (0..n).map(|k| coordinate(which, lane, k)).collect()
}

fn diagonal_mass(n: usize) -> DiagonalMass {
    DiagonalMass::new((0..n).map(|k| 1.5 + 0.25 * k as f64).collect()).unwrap()
}

/// An SPD mass coupling every pair of coordinates.
fn dense_mass(n: usize) -> DenseMass {
    let m = (0..n * n)
        .map(|ij| {
            let (i, j) = (ij / n, ij % n);
            if i == j {
                2.0
            } else {
                0.3 / (1 + i + j) as f64
            }
        })
        .collect();
    DenseMass::new(n, m).unwrap()
}

/// The Jacobian Dg(x) by central differences of g, row-major m x n.
fn jacobian_by_differences<C: Constraint>(c: &C, x: &[f64]) -> Vec<f64> {
    let (n, m) = (c.dim(), c.n_constraints());
    let eps = 1e-6;
    let mut jac = vec![0.0; m * n];
    let (mut plus, mut minus) = (vec![0.0; m], vec![0.0; m]);
    for k in 0..n {
        let mut y = x.to_vec();
        y[k] = x[k] + eps;
        c.value(&y, &mut plus);
        y[k] = x[k] - eps;
        c.value(&y, &mut minus);
        for i in 0..m {
            jac[i * n + k] = (plus[i] - minus[i]) / (2.0 * eps);
        }
    }
    jac
}

fn assert_close(got: f64, want: f64, tolerance: f64, what: &str) {
    assert!(
        (got - want).abs() <= tolerance * (1.0 + want.abs()),
        "{what}: {got} vs {want}"
    );
}

/// Dg u, Dg^T z, D^2 g(u, w) and Dg(x1) M^-1 grad g(x2) of the blanket forms against central
/// differences (truncation O(eps^2) ~ 1e-12, rounding ~ 1e-10 relative).
fn check_against_differences<E: Equations + Constraint + Curvature, M: sdae_manifold::Mass>(
    e: &E, mass: &M,
) {
    let (n, m) = (Constraint::dim(e), Constraint::n_constraints(e));
    let (x, x2, u, w) = (
        point(0, 0, n),
        point(1, 0, n),
        point(2, 0, n),
        point(3, 0, n),
    );
    let z: Vec<f64> = (0..m).map(|i| 0.5 - 0.3 * i as f64).collect();
    let jac = jacobian_by_differences(e, &x);
    let mut ju = vec![0.0; m];
    Constraint::jacobian_mul(e, &x, &u, &mut ju);
    let mut jtz = vec![0.0; n];
    Constraint::jacobian_transpose_mul(e, &x, &z, &mut jtz);
    for i in 0..m {
        let want: f64 = (0..n).map(|k| jac[i * n + k] * u[k]).sum();
        assert_close(ju[i], want, 1e-8, &format!("(Dg u)_{i}"));
    }
    for k in 0..n {
        let want: f64 = (0..m).map(|i| jac[i * n + k] * z[i]).sum();
        assert_close(jtz[k], want, 1e-8, &format!("(Dg^T z)_{k}"));
    }
    // D^2 g(x)(u, w) = d/dt Dg(x + t w) u at t = 0.
    let eps = 1e-6;
    let (mut plus, mut minus, mut second) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
    let shifted = |t: f64| -> Vec<f64> { x.iter().zip(&w).map(|(a, b)| a + t * b).collect() };
    Constraint::jacobian_mul(e, &shifted(eps), &u, &mut plus);
    Constraint::jacobian_mul(e, &shifted(-eps), &u, &mut minus);
    Curvature::second_derivative(e, &x, &u, &w, &mut second);
    for i in 0..m {
        let want = (plus[i] - minus[i]) / (2.0 * eps);
        assert_close(second[i], want, 1e-8, &format!("D^2 g_{i}(u, w)"));
    }
    // Dg(x) M^-1 grad g(x2) entry by entry from the differenced Jacobians.
    let jac2 = jacobian_by_differences(e, &x2);
    let mut gram = e.new_gram();
    let mut scratch = vec![0.0; scratch_len(n, m)];
    Constraint::cross_gram(e, &x, &x2, mass, &mut scratch, &mut gram);
    for j in 0..m {
        let mut column: Vec<f64> = (0..n).map(|k| jac2[j * n + k]).collect();
        mass.apply_inverse(&mut column);
        for i in 0..m {
            let want: f64 = (0..n).map(|k| jac[i * n + k] * column[k]).sum();
            assert_close(gram.entry(i, j), want, 1e-8, &format!("G({i}, {j})"));
        }
    }
}

#[test]
fn two_equations_agree_with_differences() {
    check_against_differences(&Pair, &diagonal_mass(4));
    check_against_differences(&Pair, &sdae_manifold::IdentityMass);
}

#[test]
fn three_dense_equations_agree_with_differences() {
    check_against_differences(&Triple, &diagonal_mass(5));
    check_against_differences(&Triple, &dense_mass(5));
}

/// The closed form of the kappa system of a quadratic equation is the hypersurface's, bit for
/// bit, and is the kappa system R(gamma) = g(y + M^-1 grad g(r) gamma) at every gamma; there
/// is none for several equations or an equation not declared quadratic.
#[test]
fn the_kappa_closed_form_is_the_hypersurface_s() {
    let mass = diagonal_mass(2);
    let (r, y) = ([1.2, 0.8], [1.9, 0.4]);
    let ours = Constraint::kappa_quadratic(&Ellipse, &r, &y, &mass).unwrap();
    let surface = Constraint::kappa_quadratic(&Hypersurface::new(Ellipse), &r, &y, &mass).unwrap();
    assert_eq!(ours.map(f64::to_bits), surface.map(f64::to_bits));
    let [c0, c1, c2] = ours;
    for gamma in [-0.7, -0.1, 0.0, 0.25, 1.5] {
        let mut x = [0.0; 2];
        Constraint::displace(&Ellipse, &r, &[gamma], &mass, &y, &mut x);
        let mut g = [0.0];
        Constraint::value(&Ellipse, &x, &mut g);
        assert_close(
            c0 + c1 * gamma + c2 * gamma * gamma,
            g[0],
            1e-15,
            "R(gamma)",
        );
    }
    let (four, two) = (point(0, 0, 4), point(1, 0, 4));
    assert!(Constraint::kappa_quadratic(&Pair, &four, &two, &mass).is_none());
}

/// What a constraint offers: a name of the form.
struct Offered;

impl LaneFormVisitor for Offered {
    type Output = &'static str;
    fn none(self) -> &'static str {
        "none"
    }
    fn newton<L: Equations, M: Mass>(self, constraint: &L, mass: &M) -> &'static str {
        if LaneForm::new(constraint, mass).is_some() {
            "newton"
        } else {
            "none"
        }
    }
}

#[test]
fn a_lane_form_is_offered_for_a_diagonal_mass_only() {
    assert_eq!(
        Constraint::lane_form(&Pair, &diagonal_mass(4), Offered),
        "newton"
    );
    assert_eq!(
        Constraint::lane_form(&Triple, &dense_mass(5), Offered),
        "none"
    );
}

/// A point formed where it is read: a + b (as the engine's drifted point r + tau v).
struct Sum<'a, Sd: Simd>(&'a [Lanes<Sd>], &'a [Lanes<Sd>]);

impl<Sd: Simd> Point<Lanes<Sd>> for Sum<'_, Sd> {
    fn coords<const N: usize>(&self, k: usize) -> [Lanes<Sd>; N] {
        std::array::from_fn(|j| self.0[k + j] + self.1[k + j])
    }
}

/// Each lane of an equation system's lane forms against its one-path forms, bit for bit:
/// g and the Newton step J^-1 g at a stored and at a formed point, the product of J, the
/// displacement with and without a base, -Dg u and the kappa coefficients.
struct LanesCheck<E>(E);

impl<E: Equations> WithSimd for LanesCheck<E> {
    type Output = ();
    fn with_simd<S: Simd>(self, simd: S) {
        let e = &self.0;
        let (n, m) = (Equations::dim(e), Equations::n_constraints(e));
        let mass = diagonal_mass(n);
        let form = LaneForm::new(e, &mass).unwrap();
        let width = Lanes::<S>::WIDTH;
        let rows = |which: usize, len: usize| -> Vec<Lanes<S>> {
            (0..len)
                .map(|k| {
                    let lanes: Vec<f64> = (0..width).map(|l| point(which, l, len)[k]).collect();
                    Lanes::load(simd, &lanes)
                })
                .collect()
        };
        let (x1, r, u, half) = (rows(0, n), rows(1, n), rows(2, n), rows(4, n));
        let z: Vec<Lanes<S>> = rows(3, m).iter().map(|x| *x - 0.6).collect();
        let zero = Lanes::splat(simd, 0.0);
        let formed: Vec<Lanes<S>> = x1.iter().zip(&half).map(|(a, b)| *a - *b).collect();
        let sum = Sum(&formed, &half);
        let lane_of =
            |x: &[Lanes<S>], l: usize| -> Vec<f64> { x.iter().map(|v| v.lane(l)).collect() };
        let bits = |x: &[f64]| -> Vec<u64> { x.iter().map(|v| v.to_bits()).collect() };
        for stored in [true, false] {
            let mut values = vec![zero; m];
            let mut jacobian = <E::Shape as GramShape>::Matrix::<Lanes<S>>::zeros_like(zero, m);
            let mut factor = <E::Shape as GramShape>::Factor::<Lanes<S>>::zeros_like(zero, m);
            let mut step = vec![zero; m];
            let evaluation = if stored {
                form.evaluate_and_factor(
                    &x1[..],
                    &r,
                    &mut values,
                    &mut jacobian,
                    &mut factor,
                    &mut step,
                )
            } else {
                form.evaluate_and_factor(
                    &sum,
                    &r,
                    &mut values,
                    &mut jacobian,
                    &mut factor,
                    &mut step,
                )
            };
            factor.back_substitute(&mut step);
            let mut product = vec![zero; m];
            jacobian.product(&z, &mut product);
            for l in 0..width {
                let (x1_l, r_l) = (
                    lane_of(if stored { &x1 } else { &formed }, l),
                    lane_of(&r, l),
                );
                let x1_l = if stored {
                    x1_l
                } else {
                    (0..n).map(|k| x1_l[k] + half[k].lane(l)).collect()
                };
                let mut g = vec![0.0; m];
                let mut gram = e.new_gram();
                let mut scratch = vec![0.0; scratch_len(n, m)];
                Constraint::value_and_cross_gram(
                    e,
                    &x1_l,
                    &r_l,
                    &mass,
                    &mut scratch,
                    &mut g,
                    &mut gram,
                );
                let mut one_factor = gram.new_factor();
                gram.factor_into(&mut one_factor).unwrap();
                let mut one_step = g.clone();
                one_factor.solve_in_place(&mut one_step);
                let mut one_product = vec![0.0; m];
                gram.mul_vec(&lane_of(&z, l), &mut one_product);
                assert!(evaluation.ok.lane(l), "lane {l}");
                assert_eq!(bits(&lane_of(&values, l)), bits(&g), "g, lane {l}");
                assert_eq!(
                    bits(&lane_of(&step, l)),
                    bits(&one_step),
                    "J^-1 g, lane {l}"
                );
                assert_eq!(
                    bits(&lane_of(&product, l)),
                    bits(&one_product),
                    "J z, lane {l}"
                );
            }
        }
        let mut with_base = vec![zero; n];
        form.displace(&r, &z, Some(&x1[..]), &mut with_base);
        let mut own_base = u.clone();
        form.displace(&r, &z, None::<&[Lanes<S>]>, &mut own_base);
        let mut negated = vec![zero; m];
        form.negated_jacobian_mul(&x1, &u, &mut negated);
        for l in 0..width {
            let (x1_l, r_l, u_l, z_l) = (
                lane_of(&x1, l),
                lane_of(&r, l),
                lane_of(&u, l),
                lane_of(&z, l),
            );
            let mut displaced = vec![0.0; n];
            Constraint::displace(e, &r_l, &z_l, &mass, &x1_l, &mut displaced);
            assert_eq!(bits(&lane_of(&with_base, l)), bits(&displaced), "lane {l}");
            Constraint::displace(e, &r_l, &z_l, &mass, &u_l, &mut displaced);
            assert_eq!(bits(&lane_of(&own_base, l)), bits(&displaced), "lane {l}");
            let mut normal = vec![0.0; m];
            Constraint::jacobian_mul(e, &x1_l, &u_l, &mut normal);
            let minus: Vec<f64> = normal.iter().map(|v| -v).collect();
            assert_eq!(bits(&lane_of(&negated, l)), bits(&minus), "lane {l}");
        }
        let quadratic = form.kappa_quadratic(&r, &sum);
        assert_eq!(quadratic.is_some(), e.is_quadratic() && m == 1);
        if let Some(coefficients) = quadratic {
            for l in 0..width {
                let r_l = lane_of(&r, l);
                let y_l: Vec<f64> = (0..n)
                    .map(|k| formed[k].lane(l) + half[k].lane(l))
                    .collect();
                let one_path = Constraint::kappa_quadratic(e, &r_l, &y_l, &mass).unwrap();
                assert_eq!(
                    bits(&coefficients.map(|c| c.lane(l))),
                    bits(&one_path),
                    "lane {l}"
                );
            }
        }
    }
}

/// At one lane, four, eight and the machine's widest.
fn at_every_width<E: Equations>(e: E) {
    for width in LaneWidth::ALL {
        width.dispatch(LanesCheck(e.clone()));
    }
}

#[test]
fn lane_forms_are_the_one_path_forms_bit_for_bit() {
    at_every_width(Pair);
    at_every_width(Triple);
    at_every_width(Ellipse);
    at_every_width(Ball);
}

struct Counting;

thread_local! {
    /// Allocations made by this thread (the test harness allocates on other threads).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: every block is allocated and freed by the system allocator with the caller's layout;
// the count is a thread-local cell without allocation of its own.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { SystemAlloc.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { SystemAlloc.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The lane forms' evaluation at a formed point, displacement without a base and kappa
/// coefficients, and the one-path kappa coefficients, twice: the second time allocates
/// nothing.
struct NoAllocation<E>(E);

impl<E: Equations> WithSimd for NoAllocation<E> {
    type Output = usize;
    fn with_simd<S: Simd>(self, simd: S) -> usize {
        let e = &self.0;
        let (n, m) = (Equations::dim(e), Equations::n_constraints(e));
        let mass = diagonal_mass(n);
        let form = LaneForm::new(e, &mass).unwrap();
        let zero = Lanes::splat(simd, 0.0);
        let (x, half) = (
            vec![Lanes::splat(simd, 0.5); n],
            vec![Lanes::splat(simd, 0.25); n],
        );
        let (one_x, one_y) = (vec![0.5; n], vec![0.75; n]);
        let mut values = vec![zero; m];
        let mut jacobian = <E::Shape as GramShape>::Matrix::<Lanes<S>>::zeros_like(zero, m);
        let mut factor = <E::Shape as GramShape>::Factor::<Lanes<S>>::zeros_like(zero, m);
        let (mut step, mut out) = (vec![zero; m], vec![zero; n]);
        let mut count = 0;
        for _ in 0..2 {
            let before = ALLOCATIONS.with(Cell::get);
            let sum = Sum(&x, &half);
            form.evaluate_and_factor(&sum, &x, &mut values, &mut jacobian, &mut factor, &mut step);
            form.displace(&x, &step, None::<&[Lanes<S>]>, &mut out);
            let _ = form.kappa_quadratic(&x, &sum);
            let _ = Constraint::kappa_quadratic(e, &one_x, &one_y, &mass);
            count = ALLOCATIONS.with(Cell::get) - before;
        }
        count
    }
}

#[test]
fn a_steady_state_allocates_nothing() {
    for width in LaneWidth::ALL {
        assert_eq!(width.dispatch(NoAllocation(Ellipse)), 0, "{width:?}");
        assert_eq!(width.dispatch(NoAllocation(Ball)), 0, "{width:?}");
    }
}
