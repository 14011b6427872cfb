//! The kappa root over W lanes by Newton's method, for a constraint that offers its formulas
//! over lanes ([`ConstraintLanes`]) with a diagonal mass: the root gamma connected to 0 of
//! R(gamma) = g(y + M^-1 grad g(r) gamma) (seed eq. 3.1 upper part, eq. 3.10), Newton from
//! gamma = 0 with a convergence mask per lane, and the ball solver's certificate (the ball,
//! the plausibility bound, the contraction probes). It is `BallSolver::solve` of `sdae-ift` on
//! its general path without the homotopy, with the same floating-point operations in the same
//! order, so that a decided lane has its path's scalar numbers. With y = r + tau v it is the
//! half-explicit step's root (tau = eta h) and a SHAKE projection (tau the substep).
//!
//! A lane the iteration does not decide (no convergence within the iteration limit, a pivot
//! the lane factorization rejects, a root outside the ball, implausible or not contracting, a
//! non-finite value) is left out of `ok`; the scalar solver decides it (the homotopy, or the
//! error).

use std::any::Any;
use std::marker::PhantomData;

use pulp::Simd;
use sdae_ift::{ProbeMap, SolverSettings, power_iteration};
use sdae_lanes::{LaneMask, Lanes};
use sdae_manifold::lane_form::{
    ConstraintLanes, Evaluation, Factor, Jacobian, LaneForm, LaneFormVisitor, PointLanes,
    active_any,
};
use sdae_manifold::vector::sum_squares;
use sdae_manifold::{Constraint, MatrixFactor, SquareMatrix};

use crate::system::System;

/// The lane form C that the system's constraint offers for its mass
/// ([`LaneFormVisitor::newton`]), built when an ensemble first steps; `None` where it offers
/// another (or none for this mass).
pub fn build_lane_form<C: ConstraintLanes, S: System>(system: &S) -> Option<LaneForm<C>> {
    system
        .constraint()
        .lane_form(system.mass(), Build::<C>(PhantomData))
}

/// [`build_lane_form`]'s visitor.
struct Build<C>(PhantomData<C>);

impl<C: ConstraintLanes> LaneFormVisitor for Build<C> {
    type Output = Option<LaneForm<C>>;
    fn none(self) -> Option<LaneForm<C>> {
        None
    }
    fn newton<L: ConstraintLanes>(
        self, build: impl FnOnce() -> Option<LaneForm<L>>,
    ) -> Option<LaneForm<C>> {
        // A constraint offers one lane form: L is C where C was chosen from its offer.
        let built: Box<dyn Any> = Box::new(build()?);
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

impl<Sd: Simd> PointLanes<Sd> for Drifted<'_, Sd> {
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
pub struct NewtonRoot<Sd: Simd, C: ConstraintLanes> {
    simd: Sd,
    /// The point x = y + M^-1 grad g(r) gamma of the last evaluation: the root's point in the
    /// lanes whose root is not 0 ([`NewtonRoot::point`] takes y in the others).
    pub x: Vec<Lanes<Sd>>,
    /// Scratch for R(gamma) (a constraint that stores g(x)).
    residual: Vec<Lanes<Sd>>,
    /// J(gamma) = Dg(x) M^-1 grad g(r) of the last evaluation.
    jacobian: Jacobian<Sd, C>,
    factor_at_zero: Factor<Sd, C>,
    factor: Factor<Sd, C>,
    /// gamma*, unless the certificate's probes took its place (then free scratch of m rows).
    pub gamma: Vec<Lanes<Sd>>,
    step: Vec<Lanes<Sd>>,
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

/// The root's Newton iteration, per lane, while it runs.
struct Iterates<Sd: Simd> {
    /// The lanes not failed so far.
    ok: LaneMask<Sd>,
    /// The lanes still iterating.
    active: LaneMask<Sd>,
    /// The iteration at which a lane converged (0 while it runs, and at a root of 0).
    iterations: Lanes<Sd>,
    /// The residual at which a lane converged.
    residual: Lanes<Sd>,
    /// The residual of the last iteration of the lanes still iterating.
    previous: Lanes<Sd>,
}

impl<Sd: Simd> Iterates<Sd> {
    /// Iteration k with residual `r_k`: the active lanes that `fails` drop out of `ok`, those
    /// `converged` (and not failed) record k and r_k, the rest go on.
    #[inline(always)]
    fn record(
        &mut self, k: Lanes<Sd>, r_k: Lanes<Sd>, converged: LaneMask<Sd>, fails: LaneMask<Sd>,
    ) {
        self.ok = self.ok.and(!self.active.and(fails));
        let finished = self.active.and(converged).and(!fails);
        self.iterations = Lanes::select(finished, k, self.iterations);
        self.residual = Lanes::select(finished, r_k, self.residual);
        self.active = self.active.and(!converged).and(!fails);
        self.previous = Lanes::select(self.active, r_k, self.previous);
    }
}

/// J(0)^-1 J(gamma*) over lanes from J(gamma*) and J(0)'s factors ([`ProbeMap`]).
struct AtZero<'a, Sd: Simd, C: ConstraintLanes> {
    jacobian: &'a Jacobian<Sd, C>,
    factor_at_zero: &'a Factor<Sd, C>,
}

impl<Sd: Simd, C: ConstraintLanes> ProbeMap<Lanes<Sd>> for AtZero<'_, Sd, C> {
    #[inline(always)]
    fn apply(&mut self, probe: &[Lanes<Sd>], image: &mut [Lanes<Sd>]) {
        self.jacobian.product(probe, image);
        self.factor_at_zero.solve_in_place(image);
    }
}

impl<Sd: Simd, C: ConstraintLanes> NewtonRoot<Sd, C> {
    /// Buffers for `constraint`'s dimensions.
    pub fn new(simd: Sd, constraint: &LaneForm<C>) -> Self {
        let (n, m) = constraint.dims();
        let zero = Lanes::splat(simd, 0.0);
        Self {
            simd,
            x: vec![zero; n],
            residual: vec![zero; m],
            jacobian: SquareMatrix::zeros_like(zero, m),
            factor_at_zero: MatrixFactor::zeros_like(zero, m),
            factor: MatrixFactor::zeros_like(zero, m),
            gamma: vec![zero; m],
            step: vec![zero; m],
        }
    }

    #[inline(always)]
    fn splat(&self, x: f64) -> Lanes<Sd> {
        Lanes::splat(self.simd, x)
    }

    /// The root at y (`BallSolver::solve` on the general path, without the homotopy) in the
    /// ball of `radius` (infinite: no ball), with `max_abs_y` = max_i |y_i| for the residual
    /// floor: the lanes it decides, with the root's point in `x` where the root is not 0, the
    /// Jacobian at the root factored ([`NewtonRoot::root_factor`]) and the certificate's
    /// numbers. gamma* stays in `gamma` where `settings.probes(radius)` is 0.
    #[inline(always)]
    pub fn solve(
        &mut self, constraint: &LaneForm<C>, settings: &SolverSettings, radius: f64,
        y: &Drifted<'_, Sd>, max_abs_y: Lanes<Sd>,
    ) -> NewtonLanes<Sd> {
        let r = y.r;
        let zero = self.splat(0.0);
        let one = self.splat(1.0);
        // The residual floor of g near y (`Constraint::roundoff`) and the tolerance.
        let floor = constraint.roundoff().floor(max_abs_y);
        let tolerance = self.splat(settings.tolerance).max(floor);

        let mut step = std::mem::take(&mut self.step);
        let (at_y, first_step) = self.first_newton_step(constraint, y, &mut step);
        let (residual_at_zero, ok) = (at_y.largest, at_y.ok);
        let at_zero = residual_at_zero.le(tolerance);
        for (g, s) in self.gamma.iter_mut().zip(&step) {
            *g = Lanes::select(at_zero, zero, zero - *s);
        }
        let mut lanes = Iterates {
            ok,
            active: ok.and(!at_zero),
            iterations: zero,
            residual: residual_at_zero,
            previous: residual_at_zero,
        };
        let mut iterated = false;
        let max_iterations = settings.max_iterations;
        for k in 1..=max_iterations {
            if !active_any(lanes.active) {
                break;
            }
            iterated = true;
            constraint.displace(r, &self.gamma, Some(y), &mut self.x);
            let at_x = constraint.evaluate_and_factor(
                &self.x[..],
                r,
                &mut self.residual,
                &mut self.jacobian,
                &mut self.factor,
                &mut step,
            );
            let r_k = at_x.largest;
            let converged = settings.converged(r_k, lanes.previous, tolerance, k == max_iterations);
            // The next Newton step only if a lane goes on (most often none does: one
            // iteration converges); the factors at the root are kept either way.
            if active_any(lanes.active.and(!converged)) {
                self.factor.back_substitute(&mut step);
            }
            // A lane that fails now (no finite residual, a rejected pivot, the last
            // iteration without convergence) goes through the scalar step.
            let fails = (!at_x.ok).or(if k == max_iterations {
                !converged
            } else {
                !one.eq(one)
            });
            lanes.record(self.splat(k as f64), r_k, converged, fails);
            self.newton_update(lanes.active, &step);
        }
        self.step = step;
        let (ok, norm, contraction) = self.certificate(settings, radius, first_step, lanes.ok);
        NewtonLanes {
            ok,
            iterated,
            at_zero: lanes.iterations.eq(zero),
            iterations: lanes.iterations,
            residual: lanes.residual,
            norm,
            contraction,
        }
    }

    /// The root's point in every lane: y where the root is 0 (most often no lane's is), x
    /// elsewhere, into `x`.
    #[inline(always)]
    pub fn point(&mut self, root: &NewtonLanes<Sd>, y: &Drifted<'_, Sd>) {
        if active_any(root.at_zero) {
            for (k, x) in self.x.iter_mut().enumerate() {
                *x = Lanes::select(root.at_zero, y.at(k), *x);
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

    /// R(0) and J(0) at x = y, J(0) factored into `factor_at_zero`, and the first Newton step
    /// J(0)^-1 R(0) into `step`: the evaluation's result and the step's length.
    #[inline(always)]
    fn first_newton_step(
        &mut self, constraint: &LaneForm<C>, y: &Drifted<'_, Sd>, step: &mut [Lanes<Sd>],
    ) -> (Evaluation<Sd>, Lanes<Sd>) {
        let at_y = constraint.evaluate_and_factor(
            y,
            y.r,
            &mut self.residual,
            &mut self.jacobian,
            &mut self.factor_at_zero,
            step,
        );
        self.factor_at_zero.back_substitute(step);
        (at_y, sum_squares(step).sqrt())
    }

    /// gamma <- gamma - step in the `active` lanes (the Newton update).
    #[inline(always)]
    fn newton_update(&mut self, active: LaneMask<Sd>, step: &[Lanes<Sd>]) {
        if active.all() {
            for (g, s) in self.gamma.iter_mut().zip(step) {
                *g = *g - *s;
            }
        } else if active_any(active) {
            let zero = self.splat(0.0);
            for (g, s) in self.gamma.iter_mut().zip(step) {
                *g = *g - Lanes::select(active, *s, zero);
            }
        }
    }

    /// The root's certificate in the lanes `ok` (`BallSolver`'s): |gamma*| inside the ball of
    /// `radius`, within the plausibility bound of the first Newton step, and a contraction
    /// estimate below its maximum where the radius is finite. The lanes that pass, |gamma*|
    /// and the contraction estimate (NaN without probes, gamma* then kept).
    #[inline(always)]
    fn certificate(
        &mut self, settings: &SolverSettings, radius: f64, first_step: Lanes<Sd>,
        mut ok: LaneMask<Sd>,
    ) -> (LaneMask<Sd>, Lanes<Sd>, Lanes<Sd>) {
        let norm = sum_squares(&self.gamma).sqrt();
        ok = ok.and(norm.lt(self.splat(radius)));
        ok = ok.and(!settings.implausible(norm, settings.plausibility_bound(first_step)));
        let probes = settings.probes(radius);
        if probes == 0 {
            return (ok, norm, self.splat(f64::NAN));
        }
        // gamma* is not read again: the probes take its place, starting at gamma* / |gamma*|.
        for p in self.gamma.iter_mut() {
            *p = *p / norm;
        }
        let Self {
            jacobian,
            factor_at_zero,
            gamma: probe,
            step: image,
            ..
        } = self;
        let mut map = AtZero::<Sd, C> {
            jacobian,
            factor_at_zero,
        };
        let contraction = power_iteration(norm, probes, probe, image, false, &mut map);
        ok = ok.and(!settings.not_contracting(contraction, radius));
        (ok, norm, contraction)
    }
}
