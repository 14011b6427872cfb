//! The step of [`Stepper`](crate::Stepper) over W lanes for a constraint whose kappa system is
//! solved by Newton's method, with a diagonal mass: eq. 3.2 for eta, Newton from kappa = 0 for
//! the kappa system (seed eq. 3.1 upper part) with a convergence mask per lane, the solver's
//! certificate (ball, plausibility, contraction probes), and the velocity update with lambda
//! from Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (eq. 3.1 lower part), whose matrix is the
//! Newton matrix at the root. The step is written once here; a constraint brings its formulas
//! over lanes ([`ConstraintLanes`] through [`Constraint::lane_form`]: g, the Newton matrix, the
//! displacement, Dg u, the local measure of the motion) and the factorization of its Newton
//! matrix ([`MatrixFactor`]): `sdae_manifold::lane_form` has the bead chain's and rigid bonds'.
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

use pulp::{Simd, WithSimd};
use sdae_lanes::{LaneMask, Lanes, per_path};
use sdae_manifold::MatrixFactor;
use sdae_manifold::lane_form::{ConstraintLanes, LaneForm};
use sdae_manifold::vector::sum_squares;
use sdae_model::engine::{
    Drifted, GroupState, LaneRecord, LaneRows, LaneStore, NewtonKernels, NewtonLanes, NewtonRoot,
    WideKernel,
};
use sdae_model::{Scheme, System};

use crate::config::StepperConfig;
use crate::formulas::{self, ForceScale};
use crate::stepper::Stepper;

impl<S: System> NewtonKernels for Stepper<S> {
    type Kernel<Sd: Simd, C: ConstraintLanes> = Kernel<Sd, C>;
    fn kernel<Sd: Simd, C: ConstraintLanes>(
        &self, simd: Sd, constraint: LaneForm<C>,
    ) -> Kernel<Sd, C> {
        Kernel::new(simd, constraint)
    }
    fn prepare<Sd: Simd, C: ConstraintLanes>(&self, kernel: &mut Kernel<Sd, C>, h: f64) {
        kernel.h = h;
    }
    fn lane_store(&mut self) -> &mut LaneStore {
        &mut self.lanes
    }
}

/// The constraint's lane form and the buffers of one group's step.
pub struct Kernel<Sd: Simd, C: ConstraintLanes> {
    simd: Sd,
    h: f64,
    constraint: LaneForm<C>,
    /// The kappa root; its `gamma` rows are scratch after it (-Dg(r_{k+1}) v_{k+1}).
    root: NewtonRoot<Sd, C>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
}

impl<Sd: Simd, C: ConstraintLanes> Kernel<Sd, C> {
    fn new(simd: Sd, constraint: LaneForm<C>) -> Self {
        Self {
            simd,
            h: 0.0,
            root: NewtonRoot::new(simd, &constraint),
            constraint,
            scratch: Vec::new(),
        }
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
        let factor = self.root.root_factor(&root);
        self.constraint
            .velocity_right_hand_side(&self.root.x, force, v, factor, dmu);
        factor.back_substitute(dmu);
        // v' = v~ + M^-1 grad g(r) lambda in place of v~, and max_i |(Dg(r') v')_i| (gamma's
        // rows are free until the next step's Newton iteration sets them).
        let (finite, velocity_residual) = self.constraint.finish_velocity(
            r,
            dmu,
            &self.root.x,
            config.monitor_velocity_constraint,
            force,
            &mut self.root.gamma,
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

/// [`Kernel::kappa_root`] as an operation `Simd::vectorize` compiles as a function of its own
/// with the caller's instruction set (a closure would not inherit it).
struct KappaRootOp<'a, Sd: Simd, C: ConstraintLanes> {
    kernel: &'a mut Kernel<Sd, C>,
    config: &'a StepperConfig,
    y: &'a Drifted<'a, Sd>,
    max_abs_y: Lanes<Sd>,
}

impl<Sd: Simd, C: ConstraintLanes> WithSimd for KappaRootOp<'_, Sd, C> {
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
    root: NewtonLanes<Sd>,
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
        let GroupState { r, v, dw, .. } = state;
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
        let y = Drifted { r, v, tau: eta_h };
        let max_abs_y = scale_and_max_abs(&y, scale.drift_h, force);
        if !system.add_noise_lanes(r, v, dw, force) {
            per_path([r, v, dw], force, &mut self.scratch, |[r, v, dw], out| {
                system.add_noise(r, v, dw, out)
            });
        }
        let root = self.kappa_root(config, &y, max_abs_y);
        ok = ok.and(root.ok);
        // r_{k+1}: y where the root is 0, else x.
        self.root.point(&root, &y);

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
        std::mem::swap(r_next, &mut self.root.x);
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
