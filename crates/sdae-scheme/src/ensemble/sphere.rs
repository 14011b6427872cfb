//! The step of [`Stepper`](crate::Stepper) for a sphere constraint with a diagonal mass, over W
//! lanes: the step written once (`step.rs`) on [`OnSphere`], whose hooks are the sphere's: the
//! local measure of eq. 3.2 from the radius, the untruncated shortcut, the closed-form kappa
//! root of the quadratic kappa system (seed eq. 3.1 upper part, the root connected to 0 of
//! Appendix B), and lambda from Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (eq. 3.1 lower
//! part). Each formula is the general path's (the ball solver's closed form), with the same
//! floating-point operations in the same order.
//!
//! The ensemble runs it W paths at a time; [`Stepper`]'s own step of one path runs the same
//! code at W = 1, in plain f64 ([`step_one_lane`]).

use pulp::{Scalar, Simd};
use sdae_ift::{Certificate, Method};
use sdae_lanes::{LaneWidth, Lanes, dot};
use sdae_manifold::Equations;
use sdae_model::engine::{
    self, LaneKernel, LanePaths, LaneStep, RootLanes, SphereKernels, SphereRoot, StepInput,
    step_sphere_lanes,
};
use sdae_model::{Scheme, StepOutcome, System};

use crate::config::StepperConfig;
use crate::formulas;
use crate::step::{self, HalfExplicitKernel, Update, half_explicit_step, lane_record};
use crate::stepper::Stepper;

/// One step of every path of an ensemble whose constraint is a sphere ([`step_sphere_lanes`]);
/// `false` where the lanes do not apply (another constraint, more than three coordinates,
/// more noise components than coordinates, a mass that is not diagonal).
pub(super) fn step_all<S: System>(
    stepper: &mut Stepper<S>, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool {
    step_sphere_lanes(stepper, Kernels, paths, width, input)
}

/// The stepper's kernels on a sphere ([`SphereKernels`]).
struct Kernels;

impl<S: System> SphereKernels<Stepper<S>> for Kernels {
    type Kernel<E: Equations, const N: usize> = Kernel<E, N>;
    /// The kernel, or `None` if the mass is not diagonal.
    #[inline(always)]
    fn kernel<E: Equations, const N: usize>(
        &self, stepper: &Stepper<S>, constraint: &E, h: f64,
    ) -> Option<Kernel<E, N>> {
        Kernel::new(stepper, constraint, h)
    }
    /// The step with its kappa root, which the certificate of one path's step reads.
    #[inline(always)]
    fn step_with_root<E: Equations, const N: usize>(
        &self, kernel: &Kernel<E, N>, stepper: &Stepper<S>, r: &[Lanes<Scalar>; N],
        v: &[Lanes<Scalar>; N], dw: &[Lanes<Scalar>],
    ) -> Option<(LaneStep<Scalar, N>, Option<RootLanes<Scalar, N>>)> {
        let (step, root) = kernel.step_with_root(stepper, r, v, dw)?;
        Some((step, Some(root)))
    }
}

/// The constants of one step on a constraint of one quadratic equation in N coordinates.
struct Kernel<E, const N: usize> {
    h: f64,
    /// The stepper's configuration, copied: the kernel is a local of the ensemble's loop, so
    /// the compiler keeps what the step derives from it (the untruncated shortcut's bound)
    /// out of the loop, which it does not through the stepper's reference (the W = 1
    /// ensemble measured 4% more instructions per path-step).
    config: StepperConfig,
    /// The kappa root in the ball of radius C_kappa, with the constraint and M^-1.
    root: SphereRoot<E, N>,
}

impl<E: Equations, const N: usize> Kernel<E, N> {
    /// The constants, or `None` if the mass is not diagonal.
    fn new<S: System>(stepper: &Stepper<S>, constraint: &E, h: f64) -> Option<Self> {
        let config = stepper.config();
        let mass = stepper.system().mass();
        let root = SphereRoot::for_mass(constraint, mass, &config.solver, config.c_kappa)?;
        Some(Self {
            h,
            config: *config,
            root,
        })
    }
}

impl<S: System, E: Equations, const N: usize> LaneKernel<Stepper<S>, N> for Kernel<E, N> {
    /// The step of W lanes from (r, v) with increments dw; `None` if the system has no lane
    /// form.
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, stepper: &Stepper<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        self.step_with_root(stepper, r, v, dw).map(|(step, _)| step)
    }
}

impl<E: Equations, const N: usize> Kernel<E, N> {
    /// [`LaneKernel::step`], with the kappa root: the step written once
    /// ([`half_explicit_step`]) on [`OnSphere`].
    #[inline(always)]
    fn step_with_root<S: System, Sd: Simd>(
        &self, stepper: &Stepper<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<(LaneStep<Sd, N>, RootLanes<Sd, N>)> {
        let config = &self.config;
        let mut on_sphere = OnSphere {
            kernel: self,
            system: stepper.system(),
            root: None,
            next: None,
        };
        let (mut force, mut dmu) = ([r[0].splat_like(0.0); N], [r[0].splat_like(0.0)]);
        let step = half_explicit_step(
            &mut on_sphere,
            config,
            self.h,
            [r, v, dw],
            &mut force,
            &mut dmu,
        )
        .ok()?;
        let (root, v_new) = (on_sphere.root?, on_sphere.next?);
        let step = LaneStep {
            ok: step.ok,
            r: root.x,
            v: v_new,
            dmu: dmu[0],
            record: lane_record(&step, config.c_kappa),
        };
        Some((step, root))
    }
}

/// The step's [`HalfExplicitKernel`] on a sphere with a diagonal mass, over W lanes: the
/// system's lane forms of its drift and noise, the sphere's local measure w = |v| / rho,
/// alpha = |a| / rho, and the closed-form kappa root.
struct OnSphere<'a, S: System, Sd: Simd, E, const N: usize> {
    kernel: &'a Kernel<E, N>,
    system: &'a S,
    /// The kappa root at y = r + eta h v (with r_{k+1}), once eta is known.
    root: Option<RootLanes<Sd, N>>,
    /// v_{k+1}, once constrained.
    next: Option<[Lanes<Sd>; N]>,
}

/// The first N rows of `x`.
#[inline(always)]
fn coordinates<Sd: Simd, const N: usize>(x: &[Lanes<Sd>]) -> &[Lanes<Sd>; N] {
    x.first_chunk::<N>()
        .expect("a sphere kernel's rows have N coordinates")
}

/// A system without the lane form of its drift or noise: its paths take the one-path step.
struct NoLaneForm;

impl<S: System, Sd: Simd, E: Equations, const N: usize> HalfExplicitKernel<Lanes<Sd>>
    for OnSphere<'_, S, Sd, E, N>
{
    type Stop = NoLaneForm;
    #[inline(always)]
    fn norm2(&self, _: &'static str, x: &[Lanes<Sd>]) -> Result<Lanes<Sd>, NoLaneForm> {
        let x = coordinates::<Sd, N>(x);
        Ok(dot(x, x))
    }
    #[inline(always)]
    fn drift(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) -> Result<(), NoLaneForm> {
        if self.system.drift(r, v, out) {
            Ok(())
        } else {
            Err(NoLaneForm)
        }
    }
    #[inline(always)]
    fn add_noise(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], dw: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) -> Result<(), NoLaneForm> {
        if self.system.add_noise(r, v, dw, out) {
            Ok(())
        } else {
            Err(NoLaneForm)
        }
    }
    /// The constraint's local measure of the motion (`Equations::local_motion`: for the
    /// sphere w = |v| / rho, alpha = |a| / rho), or the seed's where it has none.
    #[inline(always)]
    fn local_motion(
        &self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], a: &[Lanes<Sd>], _: Lanes<Sd>, _: Lanes<Sd>,
    ) -> Option<Lanes<Sd>> {
        let [r, v, a] = [r, v, a].map(coordinates::<Sd, N>);
        Equations::local_motion(self.kernel.root.constraint(), r, v, a)
    }
    /// The drift's part of the force, and the closed-form kappa root at y = r + eta_h v: solved
    /// here, before the noise is added, so that its square root and divisions overlap the
    /// noise's evaluation (the W = 1 ensemble measured 10% slower with the root solved in
    /// [`HalfExplicitKernel::constrain`]).
    #[inline(always)]
    fn scale_drift(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], eta_h: Lanes<Sd>, drift_h: Lanes<Sd>,
        force: &mut [Lanes<Sd>],
    ) {
        step::scale_force(drift_h, force);
        let (r, v) = (coordinates::<Sd, N>(r), coordinates::<Sd, N>(v));
        let mut y = [eta_h.splat_like(0.0); N];
        for i in 0..N {
            y[i] = formulas::drifted(r[i], v[i], eta_h);
        }
        self.root = Some(self.kernel.root.solve(r, &y));
    }
    /// v~ = v + M^-1 force and the velocity at the root of [`HalfExplicitKernel::scale_drift`]
    /// ([`SphereRoot::velocity`]).
    #[inline(always)]
    fn constrain(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], eta_h: Lanes<Sd>, force: &mut [Lanes<Sd>],
        dmu: &mut [Lanes<Sd>], monitor: bool,
    ) -> Result<Update<Lanes<Sd>>, NoLaneForm> {
        // The step always scales the drift first; without the root its paths take the
        // one-path step.
        let root = self.root.as_ref().ok_or(NoLaneForm)?;
        let (r, v) = (coordinates::<Sd, N>(r), coordinates::<Sd, N>(v));
        let solver = &self.kernel.root;
        let inverse_mass = solver.inverse_mass();
        let zero = eta_h.splat_like(0.0);
        for i in 0..N {
            force[i] = force[i] * inverse_mass[i] + v[i];
        }
        let (lambda, v_new) = solver.velocity(r, root, coordinates::<Sd, N>(force));
        let finite = dot(&v_new, &v_new).is_finite();
        // Written out, not `then`: a closure would not inherit the instruction set.
        let velocity_residual = if monitor {
            Some(solver.normal_rate(&root.x, &v_new).abs())
        } else {
            None
        };
        dmu[0] = lambda;
        let update = Update {
            ok: root.ok.and(finite),
            newton_iterations: zero,
            position_residual: root.residual,
            velocity_residual,
            contraction: root.contraction,
            kappa_norm: root.norm,
        };
        self.next = Some(v_new);
        Ok(update)
    }
}

/// One path's step decided by the lane form at W = 1 ([`step_one_lane`]).
pub(crate) struct OneLane {
    pub(crate) outcome: StepOutcome,
    /// kappa_{k+1}.
    pub(crate) kappa: f64,
    /// lambda_{k+1}.
    pub(crate) lambda: f64,
}

/// [`Stepper`]'s step of one path (checked input) for a sphere of dimension 2 or 3 with a
/// diagonal mass: this module's step at W = 1, in plain f64 ([`engine::step_one_lane`]), with
/// the certificate of the ball solver's closed form (no iterations, no rounding correction: a
/// decided root lies in the ball). `None` where the lane form does not apply (another
/// constraint or mass, more noise components than coordinates) or does not decide the step;
/// (r, v) are then unchanged and the general path decides, with its errors.
#[inline]
pub(crate) fn step_one_lane<S: System>(
    stepper: &Stepper<S>, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
) -> Option<OneLane> {
    let step = engine::step_one_lane(stepper, Kernels, r, v, h, dw)?;
    let root = step.root?;
    let certificate = Certificate {
        iterations: 0,
        homotopy_steps: 0,
        method: Method::ClosedForm,
        residual: root.residual,
        norm: root.gamma.abs(),
        radius: stepper.config().c_kappa,
        first_step: root.first_step,
        contraction: root.contraction,
        rounding: 0.0,
    };
    Some(OneLane {
        outcome: StepOutcome {
            eta: step.eta,
            newton_iterations: 0,
            certificate: Some(certificate),
            position_residual: Some(root.residual),
            velocity_residual: step.velocity_residual,
        },
        kappa: root.gamma,
        lambda: step.dmu,
    })
}
