//! A constraint of one equation, g(x) = 0 in R^N, from its g, grad g and D^2 g written once
//! over [`Real`]: [`Hypersurface`] makes of a [`Surface`] an [`Equations`] constraint, so that
//! an ensemble steps its paths in SIMD lanes with the numbers of the one-path stepper, bit for
//! bit (every formula below is one function run over `f64` and over lanes, in the same order),
//! and the solvers of the inherent SDE run on it too.
//!
//! ```
//! use sdae_lanes::Real;
//! use sdae_manifold::{Constraint, Hypersurface, Roundoff, Surface};
//!
//! /// The ellipse x^2 / 4 + y^2 = 1, as g(x) = (x^2 / 4 + y^2 - 1) / 2.
//! #[derive(Debug, Clone, Copy)]
//! struct Ellipse;
//!
//! impl Surface<2> for Ellipse {
//!     fn value<T: Real>(&self, x: &[T; 2]) -> T {
//!         (x[0] * x[0] * 0.25 + x[1] * x[1] - 1.0) * 0.5
//!     }
//!     fn gradient<T: Real>(&self, x: &[T; 2]) -> [T; 2] {
//!         [x[0] * 0.25, x[1]]
//!     }
//!     fn second_derivative<T: Real>(&self, _x: &[T; 2], u: &[T; 2], w: &[T; 2]) -> T {
//!         u[0] * w[0] * 0.25 + u[1] * w[1]
//!     }
//!     fn is_quadratic(&self) -> bool {
//!         true
//!     }
//!     fn roundoff(&self) -> Roundoff {
//!         Roundoff::Length(1.0)
//!     }
//! }
//!
//! let ellipse = Hypersurface::new(Ellipse);
//! let mut g = [0.0];
//! ellipse.value(&[2.0, 0.0], &mut g);
//! assert_eq!(g[0], 0.0);
//! let mut normal_speed = [0.0];
//! ellipse.jacobian_mul(&[0.0, 1.0], &[0.3, 0.5], &mut normal_speed);
//! assert_eq!(normal_speed[0], 0.5);
//! assert_eq!((ellipse.dim(), ellipse.n_constraints()), (2, 1));
//! ```

use sdae_lanes::Real;

use crate::equations::{Equations, InverseMassOf};
use crate::factor::ScalarFactor;
use crate::gram::ScalarGram;
use crate::lane_form::{Evaluation, Point, base_coords};
use crate::roundoff::Roundoff;
use crate::shape::Scalar;

/// The formulas of a hypersurface g(x) = 0 in R^N (one equation), over any [`Real`]: `f64` for
/// one path, lanes for W paths. [`Hypersurface`] turns them into a constraint.
pub trait Surface<const N: usize>: Clone + Send + Sync + 'static {
    /// g(x).
    fn value<T: Real>(&self, x: &[T; N]) -> T;
    /// grad g(x).
    fn gradient<T: Real>(&self, x: &[T; N]) -> [T; N];
    /// D^2 g(x)(u, w) (the inherent SDE's force, seed eq. 2.3, 2.4; the kappa quadratic).
    fn second_derivative<T: Real>(&self, x: &[T; N], u: &[T; N], w: &[T; N]) -> T;
    /// g is a quadratic polynomial (its second derivative is constant): the kappa system of
    /// seed eq. 3.1 is then a quadratic in kappa, whose root the solvers take in closed form
    /// (one path and lanes alike). Default false: Newton.
    fn is_quadratic(&self) -> bool {
        false
    }
    /// The kind of g's rounding floor (`Constraint::roundoff`); none known by default.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Unknown
    }
}

/// The constraint g(x) = 0 of a [`Surface`] in R^N, with the scalar Gram matrix Dg(x1) M^-1
/// grad g(x2): one path with any mass, an ensemble's paths in lanes with a diagonal mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hypersurface<F, const N: usize>(F);

impl<F: Surface<N>, const N: usize> Hypersurface<F, N> {
    /// The constraint of `surface`.
    pub fn new(surface: F) -> Self {
        Self(surface)
    }
    /// The surface's formulas.
    pub fn surface(&self) -> &F {
        &self.0
    }
    /// [c0, c1, c2] of R(gamma) = g(y + gamma w) = c0 + c1 gamma + c2 gamma^2 with w = M^-1
    /// grad g(r) (seed eq. 3.1, upper part): g(y), Dg(y) w and D^2 g(y)(w, w) / 2, where g is
    /// quadratic ([`Surface::is_quadratic`]).
    #[inline(always)]
    fn kappa_coefficients<T: Real, W: InverseMassOf<T>>(
        &self, inverse_mass: &W, r: &[T], y: &[T; N],
    ) -> Option<[T; 3]> {
        if !self.0.is_quadratic() {
            return None;
        }
        let w = self.weighted_gradient(inverse_mass, r);
        let c2 = self.0.second_derivative(y, &w, &w) * 0.5;
        Some([self.0.value(y), dot(&self.0.gradient(y), &w), c2])
    }
    /// M^-1 grad g(r).
    #[inline(always)]
    fn weighted_gradient<T: Real, W: InverseMassOf<T>>(&self, w: &W, r: &[T]) -> [T; N] {
        let mut weighted = self.gradient_at(r);
        w.apply_inverse(&mut weighted);
        weighted
    }
    /// grad g(x) for the first N coordinates of `x`.
    #[inline(always)]
    fn gradient_at<T: Real>(&self, x: &[T]) -> [T; N] {
        self.0.gradient(point(x))
    }
}

/// The first N entries of `x` (a constraint's vectors have n = N entries).
#[inline(always)]
fn point<T, const N: usize>(x: &[T]) -> &[T; N] {
    x.first_chunk::<N>()
        .expect("a vector of the hypersurface has N entries")
}

/// a . b, summed in order from a_0 b_0.
#[inline(always)]
fn dot<T: Real, const N: usize>(a: &[T; N], b: &[T; N]) -> T {
    let mut sum = a[0] * b[0];
    for k in 1..N {
        sum = sum + a[k] * b[k];
    }
    sum
}

/// The surface's formulas as a constraint, over any [`Real`]; the position of the kappa system
/// and the velocity update as the default `Constraint::displace` (grad g(r) z, then M^-1, then
/// + y).
impl<F: Surface<N>, const N: usize> Equations for Hypersurface<F, N> {
    type Shape = Scalar;
    fn dim(&self) -> usize {
        N
    }
    fn n_constraints(&self) -> usize {
        1
    }
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        out[0] = self.0.value(point(x));
    }
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        out[0] = dot(&self.gradient_at(x), point(u));
    }
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        for (o, gk) in out.iter_mut().zip(self.gradient_at(x)) {
            *o = gk * z[0];
        }
    }
    #[inline(always)]
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        out[0] = self.0.second_derivative(point(x), point(u), point(w));
    }
    fn is_quadratic(&self) -> bool {
        self.0.is_quadratic()
    }
    fn roundoff(&self) -> Roundoff {
        self.0.roundoff()
    }
    /// Dg(x1) M^-1 grad g(x2) = grad g(x1) . (M^-1 grad g(x2)).
    #[inline(always)]
    fn cross_gram<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, x1: &[T], x2: &[T], _scratch: &mut [T], out: &mut ScalarGram<T>,
    ) {
        out.0 = dot(&self.gradient_at(x1), &self.weighted_gradient(w, x2));
    }
    /// The closed form where g is quadratic ([`Surface::is_quadratic`]).
    #[inline(always)]
    fn kappa_quadratic<T: Real, W: InverseMassOf<T>>(
        &self, w: &W, r: &[T], y: &[T], _scratch: &mut [T],
    ) -> Option<[T; 3]> {
        self.kappa_coefficients(w, r, point(y))
    }
    #[inline(always)]
    fn evaluate_and_factor<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, x1: &P, r: &[T], values: &mut [T], jacobian: &mut ScalarGram<T>,
        factor: &mut ScalarFactor<T>, step: &mut [T],
    ) -> Evaluation<T> {
        let x = x1.coords::<N>(0);
        values[0] = self.0.value(&x);
        jacobian.0 = dot(&self.0.gradient(&x), &self.weighted_gradient(w, r));
        Evaluation::reduce_and_factor(values, jacobian, factor, step)
    }
    #[inline(always)]
    fn kappa_quadratic_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, r: &[T], y: &P,
    ) -> Option<[T; 3]> {
        self.kappa_coefficients(w, r, &y.coords::<N>(0))
    }
    #[inline(always)]
    fn displace_at<T: Real, W: InverseMassOf<T>, P: Point<T> + ?Sized>(
        &self, w: &W, r: &[T], z: &[T], base: Option<&P>, out: &mut [T],
    ) {
        let y = base_coords::<T, P, N>(base, out, 0);
        let gradient = self.gradient_at(r);
        for k in 0..N {
            out[k] = w.diagonal_product(k, gradient[k] * z[0]) + y[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Hypersurface, Surface};
    use crate::Equations;
    use crate::factor::lanes_check::{at_every_width, lanes_of};
    use crate::gram::ScalarGram;
    use crate::lane_form::{Factor, InverseMass};
    use crate::{Constraint, DiagonalMass, Factorize, MatrixFactor, Solve, SquareMatrix};
    use pulp::{Simd, WithSimd};
    use sdae_lanes::Lanes;
    use sdae_lanes::Real;

    /// The ellipse x^2 / 4 + y^2 = 1 as g = (x^2 / 4 + y^2 - 1) / 2.
    #[derive(Debug, Clone, Copy)]
    struct Ellipse;

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

    fn mass() -> DiagonalMass {
        DiagonalMass::new(vec![2.0, 0.5]).unwrap()
    }

    /// Path `lane`'s points: x1 off the ellipse, r on it, and the vectors z and u.
    fn x1(lane: usize, k: usize) -> f64 {
        [1.9, 0.4][k] + 0.01 * lane as f64
    }
    fn r(lane: usize, k: usize) -> f64 {
        let t = 0.3 + 0.2 * lane as f64;
        [2.0 * t.cos(), t.sin()][k]
    }
    fn u(lane: usize, k: usize) -> f64 {
        [0.7, -1.1][k] - 0.05 * lane as f64
    }
    fn z(lane: usize) -> f64 {
        0.25 - 0.125 * lane as f64
    }

    /// The one-path constraint against closed forms: g, Dg u, grad g z, Dg M^-1 grad g.
    #[test]
    fn one_path_forms_are_the_ellipse_s() {
        let c = Hypersurface::new(Ellipse);
        let (x, y) = (1.2, -0.5);
        let mut out = [0.0; 2];
        Constraint::value(&c, &[x, y], &mut out[..1]);
        assert_eq!(out[0], (x * x / 4.0 + y * y - 1.0) / 2.0);
        Constraint::jacobian_mul(&c, &[x, y], &[0.3, 0.7], &mut out[..1]);
        assert_eq!(out[0], x / 4.0 * 0.3 + y * 0.7);
        Constraint::jacobian_transpose_mul(&c, &[x, y], &[2.0], &mut out);
        assert_eq!(out, [x / 2.0, 2.0 * y]);
        let mut gram = c.new_gram();
        Constraint::cross_gram(&c, &[x, y], &[0.4, 0.9], &mass(), &mut [], &mut gram);
        assert_eq!(gram.0, x / 4.0 * (0.4 / 4.0 / 2.0) + y * (0.9 / 0.5));
        for t in [0.0, 0.7, 2.0, 4.5] {
            Constraint::value(&c, &[2.0 * f64::cos(t), f64::sin(t)], &mut out[..1]);
            assert!(out[0].abs() < 1e-15, "t = {t}: g = {}", out[0]);
        }
    }

    /// The kappa quadratic is R(gamma) = g(y + M^-1 grad g(r) gamma) at any gamma (to rounding).
    #[test]
    fn the_kappa_quadratic_is_the_kappa_system() {
        let c = Hypersurface::new(Ellipse);
        let (r, y) = ([1.2, 0.8], [1.9, 0.4]);
        let [c0, c1, c2] = Constraint::kappa_quadratic(&c, &r, &y, &mass()).unwrap();
        for gamma in [-0.7, -0.1, 0.0, 0.25, 1.5] {
            let mut x = [0.0; 2];
            Constraint::displace(&c, &r, &[gamma], &mass(), &y, &mut x);
            let mut g = [0.0];
            Constraint::value(&c, &x, &mut g);
            let quadratic = c0 + c1 * gamma + c2 * gamma * gamma;
            assert!(
                (g[0] - quadratic).abs() < 1e-15,
                "gamma = {gamma}: {g:?} vs {quadratic}"
            );
        }
    }

    /// Each lane of the lane forms against the one-path constraint, bit for bit.
    struct LanesCheck;

    impl WithSimd for LanesCheck {
        type Output = ();
        fn with_simd<S: Simd>(self, simd: S) {
            let c = Hypersurface::new(Ellipse);
            let w = InverseMass::of(&mass(), 2);
            let rows = |f: &dyn Fn(usize, usize) -> f64| -> Vec<Lanes<S>> {
                (0..2).map(|k| lanes_of(simd, |lane| f(lane, k))).collect()
            };
            let (x1_lanes, r_lanes, u_lanes) = (rows(&x1), rows(&r), rows(&u));
            let z_lanes = [lanes_of(simd, z)];
            let zero = Lanes::splat(simd, 0.0);
            let mut values = [zero];
            let mut jacobian: ScalarGram<Lanes<S>> = SquareMatrix::zeros_like(zero, 1);
            let mut factor: Factor<S, Hypersurface<Ellipse, 2>> = MatrixFactor::zeros_like(zero, 1);
            let mut step = [zero];
            let evaluation = Equations::evaluate_and_factor(
                &c,
                &w,
                &x1_lanes[..],
                &r_lanes,
                &mut values,
                &mut jacobian,
                &mut factor,
                &mut step,
            );
            factor.back_substitute(&mut step);
            let mut displaced = vec![zero; 2];
            Equations::displace_at(
                &c,
                &w,
                &r_lanes,
                &z_lanes,
                Some(&x1_lanes[..]),
                &mut displaced,
            );
            let mut negated = [zero];
            Equations::negated_jacobian_mul(&c, &x1_lanes, &u_lanes, &mut negated);
            let coefficients =
                Equations::kappa_quadratic_at(&c, &w, &r_lanes, &x1_lanes[..]).unwrap();
            for lane in 0..Lanes::<S>::WIDTH {
                let point = |f: &dyn Fn(usize, usize) -> f64| [f(lane, 0), f(lane, 1)];
                let (x1, r, u) = (point(&x1), point(&r), point(&u));
                let mut g = [0.0];
                let mut gram = c.new_gram();
                Constraint::value_and_cross_gram(&c, &x1, &r, &mass(), &mut [], &mut g, &mut gram);
                let mut one_factor = gram.new_factor();
                gram.factor_into(&mut one_factor).unwrap();
                let mut one_step = g;
                Solve::solve_in_place(&one_factor, &mut one_step);
                let mut one_displaced = [0.0; 2];
                Constraint::displace(&c, &r, &[z(lane)], &mass(), &x1, &mut one_displaced);
                let mut normal = [0.0];
                Constraint::jacobian_mul(&c, &x1, &u, &mut normal);
                let bits = |x: Lanes<S>| x.lane(lane).to_bits();
                assert!(evaluation.ok.lane(lane), "lane {lane}");
                assert_eq!(
                    bits(evaluation.largest),
                    g[0].abs().to_bits(),
                    "lane {lane}"
                );
                assert_eq!(bits(jacobian.0), gram.0.to_bits(), "lane {lane}");
                assert_eq!(bits(step[0]), one_step[0].to_bits(), "lane {lane}");
                for k in 0..2 {
                    assert_eq!(
                        bits(displaced[k]),
                        one_displaced[k].to_bits(),
                        "lane {lane}"
                    );
                }
                assert_eq!(bits(negated[0]), (-normal[0]).to_bits(), "lane {lane}");
                let one_path = Constraint::kappa_quadratic(&c, &r, &x1, &mass()).unwrap();
                for (a, b) in coefficients.iter().zip(one_path) {
                    assert_eq!(bits(*a), b.to_bits(), "lane {lane}");
                }
            }
        }
    }

    #[test]
    fn lane_forms_are_the_one_path_forms_bit_for_bit() {
        at_every_width(|| LanesCheck);
    }
}
