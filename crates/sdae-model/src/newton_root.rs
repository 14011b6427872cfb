//! The kappa root over W lanes by Newton's method, for a constraint that offers its formulas
//! over lanes ([`Equations`]) with a diagonal mass: the root gamma connected to 0 of
//! R(gamma) = g(y + M^-1 grad g(r) gamma) (seed eq. 3.1 upper part, eq. 3.10), Newton from
//! gamma = 0 with a convergence mask per lane, and the ball solver's certificate (the ball,
//! the plausibility bound, the contraction probes): the iteration and certificate of
//! `sdae-ift` ([`newton_from_zero`], [`certify`]), which `BallSolver` runs for one path of one
//! unknown, over this constraint's lane formulas. It is `BallSolver::solve` on its general path
//! without the homotopy, with the same floating-point operations in the same order, so that a
//! decided lane has its path's scalar numbers. With y = r + tau v it is the
//! half-explicit step's root (tau = eta h) and a SHAKE projection (tau the substep).
//!
//! A lane the iteration does not decide (no convergence within the iteration limit, a pivot
//! the lane factorization rejects, a root outside the ball, implausible or not contracting, a
//! non-finite value) is left out of `ok`; the scalar solver decides it (the homotopy, or the
//! error).

use std::any::Any;
use std::marker::PhantomData;

use pulp::Simd;
use sdae_ift::{
    NewtonSystem, ProbeMap, QuadraticRoot, SolverSettings, certify, newton_from_zero,
    quadratic_root,
};
use sdae_lanes::{LaneMask, Lanes, LineVec};
use sdae_manifold::Equations;
use sdae_manifold::lane_form::{Factor, Jacobian, LaneForm, LaneFormVisitor, Point, active_any};
use sdae_manifold::{Constraint, Mass, MatrixFactor, SquareMatrix};

use crate::system::System;

/// The lane form C that the system's constraint offers for its mass
/// ([`LaneFormVisitor::newton`]), built when an ensemble first steps; `None` where it offers
/// another (or none for this mass).
pub fn build_lane_form<C: Equations, S: System>(system: &S) -> Option<LaneForm<C>> {
    system
        .constraint()
        .lane_form(system.mass(), Build::<C>(PhantomData))
}

/// [`build_lane_form`]'s visitor.
struct Build<C>(PhantomData<C>);

impl<C: Equations> LaneFormVisitor for Build<C> {
    type Output = Option<LaneForm<C>>;
    fn none(self) -> Option<LaneForm<C>> {
        None
    }
    fn newton<L: Equations, M: Mass>(self, constraint: &L, mass: &M) -> Option<LaneForm<C>> {
        // A constraint offers one lane form: L is C where C was chosen from its offer.
        let built: Box<dyn Any> = Box::new(LaneForm::new(constraint, mass)?);
        built.downcast::<LaneForm<C>>().ok().map(|form| *form)
    }
}

/// The drifted point y = r + tau v of W lanes (eq. 3.1 with tau = eta h), formed where it is
/// read: the same bits each time, and no pass that stores it.
pub struct Drifted<'a, Sd: Simd> {
    /// r, n rows.
    pub r: &'a [Lanes<Sd>],
    /// v, n rows.
    pub v: &'a [Lanes<Sd>],
    /// tau.
    pub tau: Lanes<Sd>,
}

impl<Sd: Simd> Drifted<'_, Sd> {
    /// y_k.
    #[inline(always)]
    pub fn at(&self, k: usize) -> Lanes<Sd> {
        self.coords::<1>(k)[0]
    }

    /// max_k |y_k| (`sdae_manifold::vector::max_abs` of y).
    #[inline(always)]
    pub fn max_abs(&self) -> Lanes<Sd> {
        let mut largest = self.tau.splat_like(0.0);
        for k in 0..self.r.len() {
            largest = largest.max(self.at(k).abs());
        }
        largest
    }
}

impl<Sd: Simd> Point<Lanes<Sd>> for Drifted<'_, Sd> {
    #[inline(always)]
    fn coords<const N: usize>(&self, k: usize) -> [Lanes<Sd>; N] {
        let (r, v) = (self.r.coords::<N>(k), self.v.coords::<N>(k));
        let mut y = r;
        for j in 0..N {
            y[j] = r[j] + self.tau * v[j];
        }
        y
    }
}

/// The buffers of the root of W lanes for constraint C.
pub struct NewtonRoot<Sd: Simd, C: Equations> {
    simd: Sd,
    /// The point x = y + M^-1 grad g(r) gamma of the last evaluation: the root's point in the
    /// lanes whose root is not 0 ([`NewtonRoot::point`] takes y in the others).
    pub x: LineVec<Lanes<Sd>>,
    /// Scratch for R(gamma) (a constraint that stores g(x)).
    residual: LineVec<Lanes<Sd>>,
    /// J(gamma) = Dg(x) M^-1 grad g(r) of the last evaluation.
    jacobian: Jacobian<Sd, C>,
    factor_at_zero: Factor<Sd, C>,
    factor: Factor<Sd, C>,
    /// gamma*, unless the certificate's probes took its place (then free scratch of m rows).
    pub gamma: LineVec<Lanes<Sd>>,
    step: LineVec<Lanes<Sd>>,
}

/// What the Newton iteration decided, per lane.
pub struct NewtonLanes<Sd: Simd> {
    /// The lanes decided.
    pub ok: LaneMask<Sd>,
    /// Whether any Newton iteration ran (then the root's factors hold every lane's Jacobian
    /// at its root).
    pub iterated: bool,
    /// The lanes whose root is 0 (R(0) within the tolerance): the root's point is y.
    pub at_zero: LaneMask<Sd>,
    /// The iteration at which a lane converged (0 at a root of 0).
    pub iterations: Lanes<Sd>,
    /// max_i |R_i(gamma*)|.
    pub residual: Lanes<Sd>,
    /// |gamma*|.
    pub norm: Lanes<Sd>,
    /// The contraction estimate (NaN without probes).
    pub contraction: Lanes<Sd>,
}

/// The kappa system of W lanes at y as the [`NewtonSystem`] of [`newton_from_zero`]: x = y +
/// M^-1 grad g(r) gamma, R(gamma) = g(x) and J(gamma) = Dg(x) M^-1 grad g(r) from the
/// constraint's lane formulas, J(0) factored into `factor_at_zero`, the others into `factor`.
struct KappaLanes<'a, Sd: Simd, C: Equations, Y: Point<Lanes<Sd>> + ?Sized> {
    constraint: &'a LaneForm<C>,
    r: &'a [Lanes<Sd>],
    y: &'a Y,
    x: &'a mut [Lanes<Sd>],
    residual: &'a mut [Lanes<Sd>],
    jacobian: &'a mut Jacobian<Sd, C>,
    factor_at_zero: &'a mut Factor<Sd, C>,
    factor: &'a mut Factor<Sd, C>,
    /// Whether the last evaluation was at gamma = 0 (at y).
    at_zero: bool,
}

impl<Sd: Simd, C: Equations, Y: Point<Lanes<Sd>> + ?Sized> NewtonSystem<Lanes<Sd>>
    for KappaLanes<'_, Sd, C, Y>
{
    #[inline(always)]
    fn evaluate_and_factor(
        &mut self, gamma: Option<&[Lanes<Sd>]>, step: &mut [Lanes<Sd>],
    ) -> (Lanes<Sd>, LaneMask<Sd>) {
        let (y, r) = (self.y, self.r);
        self.at_zero = gamma.is_none();
        let evaluation = match gamma {
            None => self.constraint.evaluate_and_factor(
                y,
                r,
                self.residual,
                self.jacobian,
                self.factor_at_zero,
                step,
            ),
            Some(gamma) => {
                self.constraint.displace(r, gamma, Some(y), self.x);
                self.constraint.evaluate_and_factor(
                    &self.x[..],
                    r,
                    self.residual,
                    self.jacobian,
                    self.factor,
                    step,
                )
            }
        };
        (evaluation.largest, evaluation.ok)
    }
    #[inline(always)]
    fn back_substitute(&mut self, step: &mut [Lanes<Sd>]) {
        if self.at_zero {
            self.factor_at_zero.back_substitute(step);
        } else {
            self.factor.back_substitute(step);
        }
    }
}

/// J(0)^-1 J(gamma*) over lanes from J(gamma*) and J(0)'s factors ([`ProbeMap`]).
impl<Sd: Simd, C: Equations, Y: Point<Lanes<Sd>> + ?Sized> ProbeMap<Lanes<Sd>>
    for KappaLanes<'_, Sd, C, Y>
{
    #[inline(always)]
    fn apply(&mut self, probe: &[Lanes<Sd>], image: &mut [Lanes<Sd>]) {
        self.jacobian.product(probe, image);
        self.factor_at_zero.solve_in_place(image);
    }
}

impl<Sd: Simd, C: Equations> NewtonRoot<Sd, C> {
    /// Buffers for `constraint`'s dimensions.
    pub fn new(simd: Sd, constraint: &LaneForm<C>) -> Self {
        let (n, m) = constraint.dims();
        let zero = Lanes::splat(simd, 0.0);
        Self {
            simd,
            x: LineVec::from_elem(zero, n),
            residual: LineVec::from_elem(zero, m),
            jacobian: SquareMatrix::zeros_like(zero, m),
            factor_at_zero: MatrixFactor::zeros_like(zero, m),
            factor: MatrixFactor::zeros_like(zero, m),
            gamma: LineVec::from_elem(zero, m),
            step: LineVec::from_elem(zero, m),
        }
    }

    #[inline(always)]
    fn splat(&self, x: f64) -> Lanes<Sd> {
        Lanes::splat(self.simd, x)
    }

    /// The root at y along the normals at r (`BallSolver::solve` on the general path, without
    /// the homotopy; y stored, or formed where it is read, [`Drifted`]) in the
    /// ball of `radius` (infinite: no ball), with `max_abs_y` = max_i |y_i| for the residual
    /// floor: the lanes it decides, with the root's point in `x` where the root is not 0, the
    /// Jacobian at the root factored ([`NewtonRoot::root_factor`]) and the certificate's
    /// numbers ([`newton_from_zero`], [`certify`]). gamma* stays in `gamma` where
    /// `settings.probes(radius)` is 0.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn solve<Y: Point<Lanes<Sd>> + ?Sized>(
        &mut self, constraint: &LaneForm<C>, settings: &SolverSettings, radius: f64,
        r: &[Lanes<Sd>], y: &Y, max_abs_y: Lanes<Sd>,
    ) -> NewtonLanes<Sd> {
        // The residual floor of g near y (`Constraint::roundoff`) and the tolerance.
        let floor = constraint.roundoff().floor(max_abs_y);
        let tolerance = self.splat(settings.tolerance).max(floor);
        if let Some(coefficients) = constraint.kappa_quadratic(r, y) {
            let root = quadratic_root(coefficients, tolerance);
            return self.closed_form(constraint, (settings, radius), r, y, root, tolerance);
        }
        let Self {
            x,
            residual,
            jacobian,
            factor_at_zero,
            factor,
            gamma,
            step,
            ..
        } = self;
        let mut system = KappaLanes {
            constraint,
            r,
            y,
            x,
            residual,
            jacobian,
            factor_at_zero,
            factor,
            at_zero: true,
        };
        let root = newton_from_zero(&mut system, settings, tolerance, gamma, step);
        // gamma* is not read again where there are probes: they take its place.
        let (ok, norm, contraction) = certify(
            &mut system,
            settings,
            radius,
            settings.probes(radius),
            root.first_step,
            root.ok,
            gamma,
            step,
        );
        NewtonLanes {
            ok,
            iterated: root.iterated,
            at_zero: root.iterations.eq(self.splat(0.0)),
            iterations: root.iterations,
            residual: root.residual,
            norm,
            contraction,
        }
    }

    /// The root connected to 0 of a quadratic kappa system (`root`, [`quadratic_root`]) with
    /// the checks of the ball solver's closed form (`BallSolver::solve` with
    /// `Constraint::kappa_quadratic`): accepted by the one rule of every root
    /// ([`QuadraticRoot::accepted`]), with the residual at its point x within the tolerance
    /// and J(gamma*) factored. Its point is in `x` (y where the root is 0).
    #[inline(always)]
    fn closed_form<Y: Point<Lanes<Sd>> + ?Sized>(
        &mut self, constraint: &LaneForm<C>, (settings, radius): (&SolverSettings, f64),
        r: &[Lanes<Sd>], y: &Y, root: QuadraticRoot<Lanes<Sd>>, tolerance: Lanes<Sd>,
    ) -> NewtonLanes<Sd> {
        let zero = self.splat(0.0);
        let mut ok = root.accepted(settings, radius);
        self.gamma[0] = root.gamma;
        constraint.displace(r, &self.gamma, Some(y), &mut self.x);
        let at_x = constraint.evaluate_and_factor(
            &self.x[..],
            r,
            &mut self.residual,
            &mut self.jacobian,
            &mut self.factor,
            &mut self.step,
        );
        ok = ok.and(at_x.ok).and(at_x.largest.le(tolerance));
        NewtonLanes {
            ok,
            iterated: true,
            at_zero: root.gamma.eq(zero),
            iterations: zero,
            residual: at_x.largest,
            norm: root.norm,
            contraction: root.contraction,
        }
    }

    /// The root's point in every lane: y where the root is 0 (most often no lane's is), x
    /// elsewhere, into `x`.
    #[inline(always)]
    pub fn point<Y: Point<Lanes<Sd>> + ?Sized>(&mut self, root: &NewtonLanes<Sd>, y: &Y) {
        if active_any(root.at_zero) {
            for (k, x) in self.x.iter_mut().enumerate() {
                *x = Lanes::select(root.at_zero, y.coords::<1>(k)[0], *x);
            }
        }
    }

    /// The Jacobian at the root, factored: the lanes whose root is 0 were evaluated again at
    /// 0 if any lane iterated, so one of the two factors holds every lane's.
    #[inline(always)]
    pub fn root_factor(&self, root: &NewtonLanes<Sd>) -> &Factor<Sd, C> {
        if root.iterated {
            &self.factor
        } else {
            &self.factor_at_zero
        }
    }
}
