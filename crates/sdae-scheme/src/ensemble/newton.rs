//! The step of [`Stepper`](crate::Stepper) over W lanes for a constraint whose kappa system is
//! solved by Newton's method, with a diagonal mass: eq. 3.2 for eta, Newton from kappa = 0 for
//! the kappa system (seed eq. 3.1 upper part) with a convergence mask per lane, the solver's
//! certificate (ball, plausibility, contraction probes), and the velocity update with lambda
//! from Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (eq. 3.1 lower part), whose matrix is the
//! Newton matrix at the root. The step is written once here; a constraint brings its formulas
//! over lanes ([`ConstraintLanes`] through [`Constraint::lane_form`]: g, the Newton matrix, the
//! displacement, Dg u, the local measure of the motion) and the factorization of its Newton
//! matrix ([`FactorLanes`]): `sdae_manifold::lane_form` has the bead chain's and rigid bonds'.
//!
//! Each formula is the scalar stepper's, with the same floating-point operations in the same
//! order, so that a decided lane is the scalar step of its path. A lane Newton does not decide
//! (no convergence within the iteration limit, a pivot the lane factorization rejects, a root
//! outside the ball, implausible or not contracting, a non-finite value) finishes its step
//! through the scalar stepper, with its homotopy fallback and its failures.
//!
//! The system's drift and noise come from [`System::drift_lanes`] and
//! [`System::add_noise_lanes`] where the system has lane forms of any size, else from its
//! scalar functions path by path ([`per_path`]).

use std::any::Any;
use std::marker::PhantomData;

use pulp::{Simd, WithSimd};
use sdae_ift::{ProbeMap, power_iteration};
use sdae_manifold::Constraint;
use sdae_manifold::lane_form::{
    ConstraintLanes, Evaluation, FactorLanes, Jacobian, LaneFormVisitor, MatrixLanes, PointLanes,
    active_any,
};
use sdae_manifold::vector::sum_squares;
use sdae_model::engine::{GroupState, LanePaths, LaneRecord, LaneRows, StepInput, WideKernel};
use sdae_model::lanes::{LaneMask, LaneWidth, Lanes, per_path};
use sdae_model::{Scheme, System};

use crate::config::StepperConfig;
use crate::formulas::{self, ForceScale};
use crate::stepper::Stepper;

/// y = r_k + eta h v_k of eq. 3.1, formed where it is read: the same bits each time, and no
/// pass that stores it.
pub(super) struct Drifted<'a, Sd: Simd> {
    pub(super) r: &'a [Lanes<Sd>],
    pub(super) v: &'a [Lanes<Sd>],
    pub(super) eta_h: Lanes<Sd>,
}

impl<Sd: Simd> Drifted<'_, Sd> {
    /// y_k.
    #[inline(always)]
    fn at(&self, k: usize) -> Lanes<Sd> {
        self.coords::<1>(k)[0]
    }
}

impl<Sd: Simd> PointLanes<Sd> for Drifted<'_, Sd> {
    #[inline(always)]
    fn coords<const N: usize>(&self, k: usize) -> [Lanes<Sd>; N] {
        let (r, v) = (self.r.coords::<N>(k), self.v.coords::<N>(k));
        let mut y = r;
        for j in 0..N {
            y[j] = formulas::drifted(r[j], v[j], self.eta_h);
        }
        y
    }
}

/// J(0)^-1 J(gamma*) over lanes from J(gamma*) and J(0)'s factors ([`ProbeMap`]).
struct AtZero<'a, Sd: Simd, C: ConstraintLanes> {
    jacobian: &'a Jacobian<Sd, C>,
    factor_at_zero: &'a C::Factor<Sd>,
}

impl<Sd: Simd, C: ConstraintLanes> ProbeMap<Lanes<Sd>> for AtZero<'_, Sd, C> {
    #[inline(always)]
    fn apply(&mut self, probe: &[Lanes<Sd>], image: &mut [Lanes<Sd>]) {
        self.jacobian.mul_vec(probe, image);
        self.factor_at_zero.solve_in_place(image);
    }
}

/// One step of every path of an ensemble whose constraint has the lane form C
/// ([`LaneFormVisitor::newton`]): `false` if the constraint offers none for this mass after
/// all.
pub(super) fn step_all<S: System, C: ConstraintLanes>(
    stepper: &mut Stepper<S>, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool {
    width.dispatch(StepAll {
        stepper,
        paths,
        input,
        constraint: PhantomData::<C>,
    })
}

/// [`step_all`] at the instruction set Sd.
struct StepAll<'a, S: System, C> {
    stepper: &'a mut Stepper<S>,
    paths: &'a mut LanePaths,
    input: StepInput<'a>,
    constraint: PhantomData<C>,
}

impl<S: System, C: ConstraintLanes> WithSimd for StepAll<'_, S, C> {
    type Output = bool;
    #[inline(always)]
    fn with_simd<Sd: Simd>(self, simd: Sd) -> bool {
        let mut store = std::mem::take(&mut self.stepper.lanes);
        let kept = store.take::<(Kernel<Sd, C>, LaneRows<Sd>)>().or_else(|| {
            let system = self.stepper.system();
            let constraint = system
                .constraint()
                .lane_form(system.mass(), Build::<C>(PhantomData))?;
            let (n, m) = constraint.dims();
            let rows = LaneRows::new(simd, n, m, system.noise_dim());
            Some(Box::new((Kernel::new(simd, constraint), rows)))
        });
        let Some(mut buffers) = kept else {
            self.stepper.lanes = store;
            return false;
        };
        let (kernel, rows) = &mut *buffers;
        kernel.h = self.input.h;
        self.paths
            .step_wide_groups(self.stepper, self.input, kernel, rows);
        store.put(buffers);
        self.stepper.lanes = store;
        true
    }
}

/// Builds the lane form C that a constraint offered ([`LaneFormVisitor::newton`]) when an
/// ensemble first steps.
struct Build<C>(PhantomData<C>);

impl<C: ConstraintLanes> LaneFormVisitor for Build<C> {
    type Output = Option<C>;
    fn none(self) -> Option<C> {
        None
    }
    fn newton<L: ConstraintLanes>(self, build: impl FnOnce() -> Option<L>) -> Option<C> {
        // L is C: the constraint offers one lane form, which chose this kernel.
        let built: Box<dyn Any> = Box::new(build()?);
        built.downcast::<C>().ok().map(|lanes| *lanes)
    }
}

/// The constraint's lane form and the buffers of one group's step.
struct Kernel<Sd: Simd, C: ConstraintLanes> {
    simd: Sd,
    h: f64,
    constraint: C,
    x: Vec<Lanes<Sd>>,
    /// Scratch for R(gamma) of the kappa system (a constraint that stores g(x1)).
    residual: Vec<Lanes<Sd>>,
    /// J(gamma) = Dg(x) M^-1 grad g(r) of the last evaluation.
    jacobian: Jacobian<Sd, C>,
    factor_at_zero: C::Factor<Sd>,
    factor: C::Factor<Sd>,
    /// gamma, then the contraction's probes, then -Dg(r_{k+1}) v_{k+1}.
    gamma: Vec<Lanes<Sd>>,
    step: Vec<Lanes<Sd>>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
}

impl<Sd: Simd, C: ConstraintLanes> Kernel<Sd, C> {
    fn new(simd: Sd, constraint: C) -> Self {
        let (n, m) = constraint.dims();
        let zero = Lanes::splat(simd, 0.0);
        Self {
            simd,
            h: 0.0,
            constraint,
            x: vec![zero; n],
            residual: vec![zero; m],
            jacobian: MatrixLanes::zeros(simd, m),
            factor_at_zero: FactorLanes::zeros(simd, m),
            factor: FactorLanes::zeros(simd, m),
            gamma: vec![zero; m],
            step: vec![zero; m],
            scratch: Vec::new(),
        }
    }

    #[inline(always)]
    fn splat(&self, x: f64) -> Lanes<Sd> {
        Lanes::splat(self.simd, x)
    }

    /// The kappa root's Newton iteration from 0 at y = r_k + eta h v_k and its certificate,
    /// with max_i |y_i| for the residual floor (`BallSolver::solve` on the general path,
    /// without the homotopy): the lanes it decides, with r_{k+1} in `x` (the caller takes y
    /// where the root is 0), the Jacobian at the root factored in `factor` (or
    /// `factor_at_zero`, `true` in the returned flag's lanes) and the certificate's numbers.
    #[inline(always)]
    fn kappa_root_lanes(
        &mut self, config: &StepperConfig, y: &Drifted<'_, Sd>, max_abs_y: Lanes<Sd>,
    ) -> KappaLanes<Sd> {
        let r = y.r;
        let settings = &config.solver;
        let zero = self.splat(0.0);
        let one = self.splat(1.0);
        // The residual floor of g near y (`Constraint::value_roundoff`) and the tolerance.
        let floor = self.splat(4.0 * f64::EPSILON) * max_abs_y / self.constraint.roundoff_length();
        let tolerance = self.splat(settings.tolerance).max(floor);

        let mut step = std::mem::take(&mut self.step);
        let (at_y, first_step) = self.first_newton_step(y, &mut step);
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
            self.constraint
                .displace(r, &self.gamma, Some(y), &mut self.x);
            let at_x = self.constraint.evaluate_and_factor(
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
            // iteration converges); the factors at the root are kept for the velocity either way.
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
        let (ok, norm, contraction) = self.certificate(config, first_step, lanes.ok);
        KappaLanes {
            ok,
            iterated,
            at_zero: lanes.iterations.eq(zero),
            iterations: lanes.iterations,
            residual: lanes.residual,
            norm,
            contraction,
        }
    }

    /// R(0) and J(0) at x = y, J(0) factored into `factor_at_zero`, and the first Newton step
    /// J(0)^-1 R(0) into `step`: the evaluation's result and the step's length.
    #[inline(always)]
    fn first_newton_step(
        &mut self, y: &Drifted<'_, Sd>, step: &mut [Lanes<Sd>],
    ) -> (Evaluation<Sd>, Lanes<Sd>) {
        let at_y = self.constraint.evaluate_and_factor(
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

    /// eta of eq. 3.2 from v, a and their squared norms, or with the constraint's local
    /// measure of the motion.
    #[inline(always)]
    fn eta(
        &self, config: &StepperConfig, v: &[Lanes<Sd>], a: &[Lanes<Sd>], v_norm2: Lanes<Sd>,
        a_norm2: Lanes<Sd>,
    ) -> Lanes<Sd> {
        let local = if config.local_size && config.c_eta.is_some() {
            self.constraint.local_motion(v, a)
        } else {
            None
        };
        formulas::eta(config.c_eta, self.h, v_norm2.sqrt(), a_norm2.sqrt(), local)
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
    /// radius C_kappa, within the plausibility bound of the first Newton step, and a
    /// contraction estimate below its maximum where the radius is finite. The lanes that
    /// pass, |gamma*| and the contraction estimate.
    #[inline(always)]
    fn certificate(
        &mut self, config: &StepperConfig, first_step: Lanes<Sd>, mut ok: LaneMask<Sd>,
    ) -> (LaneMask<Sd>, Lanes<Sd>, Lanes<Sd>) {
        let settings = &config.solver;
        let norm = sum_squares(&self.gamma).sqrt();
        let radius = config.c_kappa;
        ok = ok.and(norm.lt(self.splat(radius)));
        ok = ok.and(!settings.implausible(norm, settings.plausibility_bound(first_step)));
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
        let contraction =
            power_iteration(norm, settings.probes(radius), probe, image, false, &mut map);
        ok = ok.and(!settings.not_contracting(contraction, radius));
        (ok, norm, contraction)
    }

    /// The velocity update of eq. 3.1 (lower part) from the force eta a h + B dw, which
    /// `v_next` holds on entry (rescaled by sqrt(eta) where asked) and which becomes v~, then
    /// v_{k+1} in place; and the group's outcomes.
    #[inline(always)]
    fn velocity_lanes(
        &mut self, config: &StepperConfig,
        Velocity {
            mut ok,
            eta,
            scale,
            root,
        }: Velocity<Sd>,
        GroupRows { r, v, v_next, dmu }: GroupRows<'_, Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let force = v_next;
        scale.rescale(force);
        // lambda = -Dg(r') v~ solved with the Newton matrix at the root. Lanes whose root is 0
        // were evaluated again at 0 if any lane iterated: then `factor` holds every lane's.
        let factor = if root.iterated {
            &self.factor
        } else {
            &self.factor_at_zero
        };
        self.constraint
            .velocity_right_hand_side(&self.x, force, v, factor, dmu);
        factor.back_substitute(dmu);
        // v' = v~ + M^-1 grad g(r) lambda in place of v~, and max_i |(Dg(r') v')_i| (gamma's
        // rows are free until the next step's Newton iteration sets them).
        let (finite, velocity_residual) = self.constraint.finish_velocity(
            r,
            dmu,
            &self.x,
            config.monitor_velocity_constraint,
            force,
            &mut self.gamma,
        );
        ok = ok.and(finite);
        Some((
            ok,
            LaneRecord {
                eta,
                newton_iterations: root.iterations,
                position_residual: Some(root.residual),
                velocity_residual: config
                    .monitor_velocity_constraint
                    .then_some(velocity_residual),
                certificate: Some((root.contraction, kappa_ratio(root.norm, config.c_kappa))),
            },
        ))
    }

    /// [`Kernel::kappa_root_lanes`] compiled once per instruction set and constraint, not once
    /// per system.
    #[inline(never)]
    fn kappa_root(
        &mut self, config: &StepperConfig, y: &Drifted<'_, Sd>, max_abs_y: Lanes<Sd>,
    ) -> KappaLanes<Sd> {
        let simd = self.simd;
        simd.vectorize(KappaRootOp {
            kernel: self,
            config,
            y,
            max_abs_y,
        })
    }

    /// [`Kernel::velocity_lanes`] compiled once per instruction set and constraint, not once
    /// per system.
    #[inline(never)]
    fn velocity(
        &mut self, config: &StepperConfig, state: Velocity<Sd>, rows: GroupRows<'_, Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let simd = self.simd;
        simd.vectorize(VelocityOp {
            kernel: self,
            config,
            state,
            rows,
        })
    }
}

/// [`Kernel::kappa_root_lanes`] as an operation `Simd::vectorize` compiles as a function of
/// its own with the caller's instruction set (a closure would not inherit it).
struct KappaRootOp<'a, Sd: Simd, C: ConstraintLanes> {
    kernel: &'a mut Kernel<Sd, C>,
    config: &'a StepperConfig,
    y: &'a Drifted<'a, Sd>,
    max_abs_y: Lanes<Sd>,
}

impl<Sd: Simd, C: ConstraintLanes> WithSimd for KappaRootOp<'_, Sd, C> {
    type Output = KappaLanes<Sd>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> KappaLanes<Sd> {
        self.kernel
            .kappa_root_lanes(self.config, self.y, self.max_abs_y)
    }
}

/// [`Kernel::velocity_lanes`] as an operation of its own ([`KappaRootOp`]).
struct VelocityOp<'a, Sd: Simd, C: ConstraintLanes> {
    kernel: &'a mut Kernel<Sd, C>,
    config: &'a StepperConfig,
    state: Velocity<Sd>,
    rows: GroupRows<'a, Sd>,
}

impl<Sd: Simd, C: ConstraintLanes> WithSimd for VelocityOp<'_, Sd, C> {
    type Output = Option<(LaneMask<Sd>, LaneRecord<Sd>)>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> Self::Output {
        self.kernel
            .velocity_lanes(self.config, self.state, self.rows)
    }
}

/// r_k, v_k, v_{k+1} and the increment of mu of a group ([`LaneRows`]).
struct GroupRows<'a, Sd: Simd> {
    r: &'a [Lanes<Sd>],
    v: &'a [Lanes<Sd>],
    /// The force on entry, v_{k+1} on return.
    v_next: &'a mut [Lanes<Sd>],
    dmu: &'a mut [Lanes<Sd>],
}

/// What the velocity update needs of the step so far, per lane.
struct Velocity<Sd: Simd> {
    ok: LaneMask<Sd>,
    eta: Lanes<Sd>,
    /// The lanes whose noise is rescaled, and the factor sqrt(eta) (1 elsewhere).
    scale: ForceScale<Lanes<Sd>>,
    root: KappaLanes<Sd>,
}

/// The kappa root's Newton iteration, per lane, while it runs.
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

/// What the kappa root's Newton iteration decided, per lane.
struct KappaLanes<Sd: Simd> {
    ok: LaneMask<Sd>,
    /// Whether any Newton iteration ran (then `factor` holds every lane's Jacobian at its root).
    iterated: bool,
    /// The lanes whose root is 0 (R(0) within the tolerance): r_{k+1} = y.
    at_zero: LaneMask<Sd>,
    iterations: Lanes<Sd>,
    residual: Lanes<Sd>,
    norm: Lanes<Sd>,
    contraction: Lanes<Sd>,
}

impl<S: System, Sd: Simd, C: ConstraintLanes> WideKernel<Stepper<S>, Sd> for Kernel<Sd, C> {
    /// Seed eq. 3.1-3.2 for W lanes from `state` = (r_k, v_k) into `rows` (module
    /// documentation).
    #[inline(always)]
    fn step(
        &mut self, stepper: &Stepper<S>, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let system = stepper.system();
        let config = stepper.config();
        let h = self.h;
        let GroupState { r, v, dw } = state;
        let LaneRows {
            r: r_next,
            v: v_next,
            dmu,
            ..
        } = rows;
        let v_norm2 = sum_squares(v);
        // a(r_k, v_k) into `force` (v_{k+1}'s rows), which becomes the force in the pass that
        // forms y, then v~ and v_{k+1} in the velocity update.
        let force = v_next;
        if !system.drift_lanes(r, v, force) {
            per_path([r, v], force, &mut self.scratch, |[r, v], out| {
                system.drift(r, v, out)
            });
        }
        let a_norm2 = sum_squares(force);
        let mut ok = v_norm2.is_finite().and(a_norm2.is_finite());

        let eta = self.eta(config, v, force, v_norm2, a_norm2);
        let eta_h = eta * h;
        // v~ = v + M^-1 (eta a h + B dw), or sqrt(eta) (sqrt(eta) h a + B dw) when rescaled:
        // the force here, v~ in the velocity update.
        let scale = ForceScale::new(config.rescale_noise, eta, h);
        let y = Drifted { r, v, eta_h };
        let max_abs_y = scale_and_max_abs(&y, scale.drift_h, force);
        if !system.add_noise_lanes(r, v, dw, force) {
            per_path([r, v, dw], force, &mut self.scratch, |[r, v, dw], out| {
                system.add_noise(r, v, dw, out)
            });
        }
        let root = self.kappa_root(config, &y, max_abs_y);
        ok = ok.and(root.ok);
        // r_{k+1}: y where the root is 0, else x (most often no lane's root is 0).
        if active_any(root.at_zero) {
            for (k, x) in self.x.iter_mut().enumerate() {
                *x = Lanes::select(root.at_zero, y.at(k), *x);
            }
        }

        let outcomes = self.velocity(
            config,
            Velocity {
                ok,
                eta,
                scale,
                root,
            },
            GroupRows {
                r,
                v,
                v_next: force,
                dmu,
            },
        );
        // r_{k+1} is in `x`: the rows take it, `x` takes the rows' old buffer (overwritten
        // next step).
        std::mem::swap(r_next, &mut self.x);
        outcomes
    }
}

/// force <- drift_h force and max_k |y_k| in one pass. The maximum runs in four chains (k mod
/// 4) so that the pass does not wait on one comparison per coordinate; a maximum is exact and
/// never takes a NaN, so it is the bits of `vector::max_abs(y)` in order.
#[inline(always)]
fn scale_and_max_abs<Sd: Simd>(
    y: &Drifted<'_, Sd>, drift_h: Lanes<Sd>, force: &mut [Lanes<Sd>],
) -> Lanes<Sd> {
    let mut largest = [drift_h.splat_like(0.0); 4];
    let start = force.len() - force.len() % 4;
    let (quads, tail) = force.split_at_mut(start);
    for (q, f) in quads.chunks_exact_mut(4).enumerate() {
        for j in 0..4 {
            largest[j] = largest[j].max(y.at(4 * q + j).abs());
            f[j] = drift_h * f[j];
        }
    }
    for (k, f) in tail.iter_mut().enumerate() {
        largest[0] = largest[0].max(y.at(start + k).abs());
        *f = drift_h * *f;
    }
    largest[0].max(largest[1]).max(largest[2].max(largest[3]))
}

/// |kappa| / C_kappa of the certificate where the ball's radius C_kappa is finite
/// (`PathDiagnostics::max_kappa_ratio`).
#[inline(always)]
pub(super) fn kappa_ratio<Sd: Simd>(norm: Lanes<Sd>, radius: f64) -> Option<Lanes<Sd>> {
    radius.is_finite().then(|| norm / radius)
}
