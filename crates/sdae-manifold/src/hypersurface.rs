//! A constraint of one equation, g(x) = 0 in R^N, from its g and grad g written once over
//! [`Real`]: [`Hypersurface`] makes of a [`Surface`] both the one-path [`Constraint`] and its
//! [`ConstraintLanes`], so that an ensemble steps its paths in SIMD lanes with the numbers of
//! the one-path stepper, bit for bit (every formula below is one function run over `f64` and
//! over lanes, in the same order).
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

use pulp::Simd;
use sdae_lanes::{Lanes, Real};

use crate::constraint::{Constraint, Curvature};
use crate::gram::ScalarGram;
use crate::lane_form::{
    ConstraintLanes, Evaluation, Factor, InverseMass, Jacobian, LaneForm, LaneFormVisitor,
    PointLanes, base_coords,
};
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::Scalar;

/// The formulas of a hypersurface g(x) = 0 in R^N (one equation), over any [`Real`]: `f64` for
/// one path, lanes for W paths. [`Hypersurface`] turns them into a constraint.
pub trait Surface<const N: usize>: Clone + Send + Sync + 'static {
    /// g(x).
    fn value<T: Real>(&self, x: &[T; N]) -> T;
    /// grad g(x).
    fn gradient<T: Real>(&self, x: &[T; N]) -> [T; N];
    /// The kind of g's rounding floor ([`Constraint::roundoff`]); none known by default.
    fn roundoff(&self) -> Roundoff {
        Roundoff::Unknown
    }
    /// D^2 g(u, w) where g is a quadratic polynomial (its second derivative is constant): the
    /// kappa system of seed eq. 3.1 is then a quadratic in kappa, whose root the solvers take
    /// in closed form (one path and lanes alike). `None` (the default): Newton.
    fn constant_second_derivative<T: Real>(&self, u: &[T; N], w: &[T; N]) -> Option<T> {
        let _ = (u, w);
        None
    }
}

/// A [`Surface`] whose second derivative is known: then its [`Hypersurface`] is a
/// [`Curvature`] too, for the solvers of the inherent SDE (seed eq. 2.3, 2.4).
pub trait CurvedSurface<const N: usize>: Surface<N> {
    /// D^2 g(x)(u, w).
    fn second_derivative(&self, x: &[f64; N], u: &[f64; N], w: &[f64; N]) -> f64;
}

/// The constraint g(x) = 0 of a [`Surface`] in R^N: a [`Constraint`] (one path, with the
/// scalar Gram matrix Dg(x1) M^-1 grad g(x2)) and, for a diagonal mass, its [`ConstraintLanes`]
/// (an ensemble's paths in lanes, by Newton with a convergence mask per lane).
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
    /// grad g(r) (seed eq. 3.1, upper part): g(y), Dg(y) w and D^2 g(w, w) / 2, where g is
    /// quadratic ([`Surface::constant_second_derivative`]).
    #[inline(always)]
    fn kappa_coefficients<T: Real>(&self, w: &[T; N], y: &[T; N]) -> Option<[T; 3]> {
        let c2 = self.0.constant_second_derivative(w, w)? * 0.5;
        Some([self.0.value(y), dot(&self.0.gradient(y), w), c2])
    }
    /// M^-1 grad g(r) for a diagonal M^-1 = `w`, over lanes.
    #[inline(always)]
    fn weighted_gradient<Sd: Simd>(&self, w: &InverseMass, r: &[Lanes<Sd>]) -> [Lanes<Sd>; N] {
        let mut weighted = self.gradient_at(r);
        for (k, entry) in weighted.iter_mut().enumerate() {
            *entry = w.apply(k, *entry);
        }
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

impl<F: Surface<N>, const N: usize> Constraint for Hypersurface<F, N> {
    type Gram = ScalarGram;
    fn dim(&self) -> usize {
        N
    }
    fn n_constraints(&self) -> usize {
        1
    }
    fn value(&self, x: &[f64], out: &mut [f64]) {
        out[0] = self.0.value(point(x));
    }
    fn jacobian_mul(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        out[0] = dot(&self.gradient_at(x), point(u));
    }
    fn jacobian_transpose_mul(&self, x: &[f64], z: &[f64], out: &mut [f64]) {
        for (o, gk) in out.iter_mut().zip(self.gradient_at(x)) {
            *o = gk * z[0];
        }
    }
    fn new_gram(&self) -> ScalarGram {
        ScalarGram(0.0)
    }
    /// Dg(x1) M^-1 grad g(x2) = grad g(x1) . (M^-1 grad g(x2)).
    fn cross_gram<M: Mass>(
        &self, x1: &[f64], x2: &[f64], mass: &M, _scratch: &mut [f64], out: &mut ScalarGram,
    ) {
        let mut weighted = self.gradient_at(x2);
        mass.apply_inverse(&mut weighted);
        out.0 = dot(&self.gradient_at(x1), &weighted);
    }
    fn roundoff(&self) -> Roundoff {
        self.0.roundoff()
    }
    /// The closed form where g is quadratic ([`Surface::constant_second_derivative`]).
    fn kappa_quadratic<M: Mass>(&self, r: &[f64], y: &[f64], mass: &M) -> Option<[f64; 3]> {
        let mut w = self.gradient_at(r);
        mass.apply_inverse(&mut w);
        self.kappa_coefficients(&w, point(y))
    }
    /// Newton in lanes (the [`ConstraintLanes`] below) for a diagonal mass.
    fn lane_form<M: Mass, V: LaneFormVisitor>(&self, mass: &M, visitor: V) -> V::Output {
        if !M::DIAGONAL {
            return visitor.none();
        }
        visitor.newton(|| LaneForm::new(self, mass))
    }
}

impl<F: CurvedSurface<N>, const N: usize> Curvature for Hypersurface<F, N> {
    fn second_derivative(&self, x: &[f64], u: &[f64], w: &[f64], out: &mut [f64]) {
        out[0] = self.0.second_derivative(point(x), point(u), point(w));
    }
}

/// The one-path formulas over lanes, with the same operations in the same order (the default
/// `Constraint::displace`: grad g(r) z, then M^-1, then + y).
impl<F: Surface<N>, const N: usize> ConstraintLanes for Hypersurface<F, N> {
    type Shape = Scalar;

    #[inline(always)]
    fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut Jacobian<Sd, Self>, factor: &mut Factor<Sd, Self>, step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd> {
        let x = x1.coords::<N>(0);
        values[0] = self.0.value(&x);
        let weighted = self.weighted_gradient(w, r);
        jacobian.0 = dot(&self.0.gradient(&x), &weighted);
        Evaluation::reduce_and_factor(values, jacobian, factor, step)
    }
    #[inline(always)]
    fn kappa_quadratic_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], y: &P,
    ) -> Option<[Lanes<Sd>; 3]> {
        let weighted = self.weighted_gradient(w, r);
        self.kappa_coefficients(&weighted, &y.coords::<N>(0))
    }
    #[inline(always)]
    fn displace_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>,
        out: &mut [Lanes<Sd>],
    ) {
        let y = base_coords::<Sd, P, N>(base, out, 0);
        let gradient = self.gradient_at(r);
        for k in 0..N {
            out[k] = w.apply(k, gradient[k] * z[0]) + y[k];
        }
    }
    #[inline(always)]
    fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        out[0] = -dot(&self.gradient_at(x), point(u));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::factor::lanes_check::{at_every_width, lanes_of};
    use crate::{DiagonalMass, Factorize, MatrixFactor, Solve, SquareMatrix};
    use pulp::WithSimd;

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
        fn constant_second_derivative<T: Real>(&self, u: &[T; 2], w: &[T; 2]) -> Option<T> {
            Some(u[0] * w[0] * 0.25 + u[1] * w[1])
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
        c.value(&[x, y], &mut out[..1]);
        assert_eq!(out[0], (x * x / 4.0 + y * y - 1.0) / 2.0);
        c.jacobian_mul(&[x, y], &[0.3, 0.7], &mut out[..1]);
        assert_eq!(out[0], x / 4.0 * 0.3 + y * 0.7);
        c.jacobian_transpose_mul(&[x, y], &[2.0], &mut out);
        assert_eq!(out, [x / 2.0, 2.0 * y]);
        let mut gram = c.new_gram();
        c.cross_gram(&[x, y], &[0.4, 0.9], &mass(), &mut [], &mut gram);
        assert_eq!(gram.0, x / 4.0 * (0.4 / 4.0 / 2.0) + y * (0.9 / 0.5));
        for t in [0.0, 0.7, 2.0, 4.5] {
            c.value(&[2.0 * f64::cos(t), f64::sin(t)], &mut out[..1]);
            assert!(out[0].abs() < 1e-15, "t = {t}: g = {}", out[0]);
        }
    }

    /// The kappa quadratic is R(gamma) = g(y + M^-1 grad g(r) gamma) at any gamma (to rounding).
    #[test]
    fn the_kappa_quadratic_is_the_kappa_system() {
        let c = Hypersurface::new(Ellipse);
        let (r, y) = ([1.2, 0.8], [1.9, 0.4]);
        let [c0, c1, c2] = c.kappa_quadratic(&r, &y, &mass()).unwrap();
        for gamma in [-0.7, -0.1, 0.0, 0.25, 1.5] {
            let mut x = [0.0; 2];
            c.displace(&r, &[gamma], &mass(), &y, &mut x);
            let mut g = [0.0];
            c.value(&x, &mut g);
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
            let evaluation = c.evaluate_and_factor(
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
            c.displace_lanes(&w, &r_lanes, &z_lanes, Some(&x1_lanes[..]), &mut displaced);
            let mut negated = [zero];
            c.negated_jacobian_mul(&x1_lanes, &u_lanes, &mut negated);
            let coefficients = c
                .kappa_quadratic_lanes(&w, &r_lanes, &x1_lanes[..])
                .unwrap();
            for lane in 0..Lanes::<S>::WIDTH {
                let point = |f: &dyn Fn(usize, usize) -> f64| [f(lane, 0), f(lane, 1)];
                let (x1, r, u) = (point(&x1), point(&r), point(&u));
                let mut g = [0.0];
                let mut gram = c.new_gram();
                c.value_and_cross_gram(&x1, &r, &mass(), &mut [], &mut g, &mut gram);
                let mut one_factor = gram.new_factor();
                gram.factor_into(&mut one_factor).unwrap();
                let mut one_step = g;
                Solve::solve_in_place(&one_factor, &mut one_step);
                let mut one_displaced = [0.0; 2];
                c.displace(&r, &[z(lane)], &mass(), &x1, &mut one_displaced);
                let mut normal = [0.0];
                c.jacobian_mul(&x1, &u, &mut normal);
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
                let one_path = c.kappa_quadratic(&r, &x1, &mass()).unwrap();
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
