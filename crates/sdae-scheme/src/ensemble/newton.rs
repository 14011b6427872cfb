//! The step of [`Stepper`](crate::Stepper) over W lanes for a constraint whose kappa system is
//! solved by Newton's method, with a diagonal mass: the step written once (`step.rs`) on
//! [`OnRows`], whose hooks are Newton from kappa = 0 for the kappa system (seed eq. 3.1 upper
//! part) with a convergence mask per lane, the solver's certificate (ball, plausibility,
//! contraction probes), and the velocity update with lambda from Dg(r') M^-1 grad g(r)
//! lambda = -Dg(r') v~ (eq. 3.1 lower part), whose matrix is the Newton matrix at the root.
//! The kernel is written once for every such constraint; a constraint brings its formulas
//! over lanes ([`Equations`] through [`Constraint::lane_form`]: g, the Newton matrix, the
//! displacement, Dg u, the local measure of the motion) and the factorization of its Newton
//! matrix ([`MatrixFactor`]): `sdae_manifold::lane_form` has the bead chain's and rigid bonds'.
//!
//! Each formula is the scalar stepper's, with the same floating-point operations in the same
//! order, so that a decided lane is the scalar step of its path. A lane Newton does not decide
//! (no convergence within the iteration limit, a pivot the lane factorization rejects, a root
//! outside the ball, implausible or not contracting, a non-finite value) finishes its step
//! through the scalar stepper, with its homotopy fallback and its failures.
//!
//! The system's drift and noise come from [`System::drift`] and [`System::add_noise`] over
//! lanes, or path by path where the lanes have no evaluation of them
//! ([`drift_over_lanes`](sdae_model::drift_over_lanes)).

use std::convert::Infallible;

use pulp::{Simd, WithSimd};
use sdae_lanes::{LaneMask, Lanes};
use sdae_manifold::Equations;
use sdae_manifold::MatrixFactor;
use sdae_manifold::lane_form::LaneForm;
use sdae_manifold::vector::sum_squares;
use sdae_model::engine::{
    Drifted, GroupState, LaneRecord, LaneRows, LaneStore, NewtonKernels, NewtonLanes, NewtonRoot,
    WideKernel,
};
use sdae_model::{Scheme, System, add_noise_over_lanes, drift_over_lanes};

use crate::config::StepperConfig;
use crate::step::{HalfExplicitKernel, Update, half_explicit_step, lane_record};
use crate::stepper::Stepper;

impl<S: System> NewtonKernels for Stepper<S> {
    type Kernel<Sd: Simd, C: Equations> = Kernel<Sd, C>;
    fn kernel<Sd: Simd, C: Equations>(&self, simd: Sd, constraint: LaneForm<C>) -> Kernel<Sd, C> {
        Kernel::new(simd, constraint)
    }
    fn prepare<Sd: Simd, C: Equations>(&self, kernel: &mut Kernel<Sd, C>, h: f64) {
        kernel.h = h;
    }
    fn lane_store(&mut self) -> &mut LaneStore {
        &mut self.lanes
    }
}

/// The constraint's lane form and the buffers of one group's step.
pub struct Kernel<Sd: Simd, C: Equations> {
    simd: Sd,
    h: f64,
    constraint: LaneForm<C>,
    /// The kappa root; its `gamma` rows are scratch after it (-Dg(r_{k+1}) v_{k+1}).
    root: NewtonRoot<Sd, C>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
}

impl<Sd: Simd, C: Equations> Kernel<Sd, C> {
    fn new(simd: Sd, constraint: LaneForm<C>) -> Self {
        Self {
            simd,
            h: 0.0,
            root: NewtonRoot::new(simd, &constraint),
            constraint,
            scratch: Vec::new(),
        }
    }

    /// The velocity update of eq. 3.1 (lower part) from the force eta a h + B dw (rescaled by
    /// sqrt(eta) where asked), which `force` holds on entry and which becomes v~, then
    /// v_{k+1} in place, with lambda into `dmu`: the lambda system solved with the Newton
    /// matrix at the root, M^-1 and v fused into its right-hand side.
    #[inline(always)]
    fn velocity_lanes(
        &mut self, monitor: bool, root: &NewtonLanes<Sd>,
        GroupRows { r, v, force, dmu }: GroupRows<'_, Sd>,
    ) -> Update<Lanes<Sd>> {
        // lambda = -Dg(r') v~ solved with the Newton matrix at the root. Lanes whose root is 0
        // were evaluated again at 0 if any lane iterated: then `factor` holds every lane's.
        let factor = self.root.root_factor(root);
        self.constraint
            .velocity_right_hand_side(&self.root.x, force, v, factor, dmu);
        factor.back_substitute(dmu);
        // v' = v~ + M^-1 grad g(r) lambda in place of v~, and max_i |(Dg(r') v')_i| (gamma's
        // rows are free until the next step's Newton iteration sets them).
        let (finite, velocity_residual) = self.constraint.finish_velocity(
            r,
            dmu,
            &self.root.x,
            monitor,
            force,
            &mut self.root.gamma,
        );
        Update {
            ok: root.ok.and(finite),
            newton_iterations: root.iterations,
            position_residual: root.residual,
            velocity_residual: monitor.then_some(velocity_residual),
            contraction: root.contraction,
            kappa_norm: root.norm,
        }
    }

    /// The kappa root ([`NewtonRoot::solve`] in the ball of radius C_kappa) compiled once per
    /// instruction set and constraint, not once per system.
    #[inline(never)]
    fn kappa_root(
        &mut self, config: &StepperConfig, y: &Drifted<'_, Sd>, max_abs_y: Lanes<Sd>,
    ) -> NewtonLanes<Sd> {
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
        &mut self, monitor: bool, root: &NewtonLanes<Sd>, rows: GroupRows<'_, Sd>,
    ) -> Update<Lanes<Sd>> {
        let simd = self.simd;
        simd.vectorize(VelocityOp {
            kernel: self,
            monitor,
            root,
            rows,
        })
    }
}

/// [`Kernel::kappa_root`] as an operation `Simd::vectorize` compiles as a function of its own
/// with the caller's instruction set (a closure would not inherit it).
struct KappaRootOp<'a, Sd: Simd, C: Equations> {
    kernel: &'a mut Kernel<Sd, C>,
    config: &'a StepperConfig,
    y: &'a Drifted<'a, Sd>,
    max_abs_y: Lanes<Sd>,
}

impl<Sd: Simd, C: Equations> WithSimd for KappaRootOp<'_, Sd, C> {
    type Output = NewtonLanes<Sd>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> NewtonLanes<Sd> {
        let Kernel {
            constraint, root, ..
        } = self.kernel;
        let config = self.config;
        root.solve(
            constraint,
            &config.solver,
            config.c_kappa,
            self.y.r,
            self.y,
            self.max_abs_y,
        )
    }
}

/// [`Kernel::velocity_lanes`] as an operation of its own ([`KappaRootOp`]).
struct VelocityOp<'a, Sd: Simd, C: Equations> {
    kernel: &'a mut Kernel<Sd, C>,
    monitor: bool,
    root: &'a NewtonLanes<Sd>,
    rows: GroupRows<'a, Sd>,
}

impl<Sd: Simd, C: Equations> WithSimd for VelocityOp<'_, Sd, C> {
    type Output = Update<Lanes<Sd>>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> Self::Output {
        self.kernel
            .velocity_lanes(self.monitor, self.root, self.rows)
    }
}

/// r_k, v_k, the force (v_{k+1} on return) and the increment of mu of a group.
struct GroupRows<'a, Sd: Simd> {
    r: &'a [Lanes<Sd>],
    v: &'a [Lanes<Sd>],
    /// The force on entry, v_{k+1} on return.
    force: &'a mut [Lanes<Sd>],
    dmu: &'a mut [Lanes<Sd>],
}

impl<S: System, Sd: Simd, C: Equations> WideKernel<Stepper<S>, Sd> for Kernel<Sd, C> {
    /// Seed eq. 3.1-3.2 for W lanes from `state` = (r_k, v_k) into `rows`: the step written
    /// once ([`half_explicit_step`]) on [`OnRows`].
    #[inline(always)]
    fn step(
        &mut self, stepper: &Stepper<S>, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let config = stepper.config();
        let (h, zero) = (self.h, Lanes::splat(self.simd, 0.0));
        let GroupState { r, v, dw, .. } = state;
        let LaneRows {
            r: r_next,
            v: v_next,
            dmu,
            ..
        } = rows;
        let mut on_rows = OnRows {
            kernel: self,
            system: stepper.system(),
            config,
            max_abs_y: zero,
        };
        // a(r_k, v_k) into v_{k+1}'s rows, which become the force, then v~ and v_{k+1}.
        let Ok(step) = half_explicit_step(&mut on_rows, config, h, [r, v, dw], v_next, dmu);
        // r_{k+1} is in `x`: the rows take it, `x` takes the rows' old buffer (overwritten
        // next step).
        std::mem::swap(r_next, &mut self.root.x);
        Some((step.ok, lane_record(&step, config.c_kappa)))
    }
}

/// The step's [`HalfExplicitKernel`] over rows of W lanes: the system's drift and noise in
/// lanes (path by path where it has no lane form of this size), the constraint's local measure
/// of the motion, and Newton for the kappa root over the constraint's lane formulas.
struct OnRows<'a, S: System, Sd: Simd, C: Equations> {
    kernel: &'a mut Kernel<Sd, C>,
    system: &'a S,
    config: &'a StepperConfig,
    /// max_k |y_k|, from [`HalfExplicitKernel::scale_drift`].
    max_abs_y: Lanes<Sd>,
}

impl<S: System, Sd: Simd, C: Equations> HalfExplicitKernel<Lanes<Sd>> for OnRows<'_, S, Sd, C> {
    type Stop = Infallible;
    #[inline(always)]
    fn norm2(&self, _: &'static str, x: &[Lanes<Sd>]) -> Result<Lanes<Sd>, Infallible> {
        Ok(sum_squares(x))
    }
    #[inline(always)]
    fn drift(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) -> Result<(), Infallible> {
        drift_over_lanes(self.system, r, v, out, &mut self.kernel.scratch);
        Ok(())
    }
    #[inline(always)]
    fn add_noise(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], dw: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) -> Result<(), Infallible> {
        add_noise_over_lanes(self.system, r, v, dw, out, &mut self.kernel.scratch);
        Ok(())
    }
    #[inline(always)]
    fn local_motion(
        &self, _: &[Lanes<Sd>], v: &[Lanes<Sd>], a: &[Lanes<Sd>], _: Lanes<Sd>, _: Lanes<Sd>,
    ) -> Option<Lanes<Sd>> {
        self.kernel.constraint.local_motion(v, a)
    }
    /// force <- drift_h force with max_k |y_k| for the root's residual floor in the same pass
    /// ([`scale_and_max_abs`]).
    #[inline(always)]
    fn scale_drift(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], eta_h: Lanes<Sd>, drift_h: Lanes<Sd>,
        force: &mut [Lanes<Sd>],
    ) {
        let y = Drifted { r, v, tau: eta_h };
        self.max_abs_y = scale_and_max_abs(&y, drift_h, force);
    }
    /// The Newton root at y ([`Kernel::kappa_root`]), r_{k+1} into the root's `x`, then the
    /// velocity update ([`Kernel::velocity`]).
    #[inline(always)]
    fn constrain(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], eta_h: Lanes<Sd>, force: &mut [Lanes<Sd>],
        dmu: &mut [Lanes<Sd>], monitor: bool,
    ) -> Result<Update<Lanes<Sd>>, Infallible> {
        let y = Drifted { r, v, tau: eta_h };
        let root = self.kernel.kappa_root(self.config, &y, self.max_abs_y);
        // r_{k+1}: y where the root is 0, else x.
        self.kernel.root.point(&root, &y);
        let rows = GroupRows { r, v, force, dmu };
        Ok(self.kernel.velocity(monitor, &root, rows))
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
