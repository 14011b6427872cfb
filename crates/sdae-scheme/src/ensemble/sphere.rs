//! The step of [`Stepper`](crate::Stepper) for a sphere constraint with a diagonal mass, over W
//! lanes: eq. 3.2 for eta, the closed-form kappa root of the quadratic kappa system (seed eq.
//! 3.1 upper part, the root connected to 0 of Appendix B), and the velocity update with lambda
//! from Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (eq. 3.1 lower part). Each formula is the
//! general path's (the ball solver's closed form), with the same floating-point operations in
//! the same order.
//!
//! The ensemble runs it W paths at a time; [`Stepper`]'s own step of one path runs the same
//! code at W = 1, in plain f64 ([`step_one_lane`]).

use pulp::{Scalar, Simd};
use sdae_ift::{Certificate, Method};
use sdae_lanes::{LaneWidth, Lanes, dot};
use sdae_manifold::{Mass, Sphere, motion_measure};
use sdae_model::engine::{
    self, LaneKernel, LanePaths, LaneRecord, LaneStep, RootLanes, SphereKernels, SphereRoot,
    StepInput, step_sphere_lanes,
};
use sdae_model::{Scheme, StepOutcome, System};

use super::newton::kappa_ratio;
use crate::formulas::{self, ForceScale};
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
    type Kernel<const N: usize> = Kernel<N>;
    /// The kernel, or `None` if the mass is not diagonal.
    #[inline(always)]
    fn kernel<const N: usize>(
        &self, stepper: &Stepper<S>, sphere: &Sphere, h: f64,
    ) -> Option<Kernel<N>> {
        Kernel::new(stepper, sphere, h)
    }
    /// The step with its kappa root, which the certificate of one path's step reads.
    #[inline(always)]
    fn step_with_root<const N: usize>(
        &self, kernel: &Kernel<N>, stepper: &Stepper<S>, r: &[Lanes<Scalar>; N],
        v: &[Lanes<Scalar>; N], dw: &[Lanes<Scalar>],
    ) -> Option<(LaneStep<Scalar, N>, Option<RootLanes<Scalar, N>>)> {
        let (step, root) = kernel.step_with_root(stepper, r, v, dw)?;
        Some((step, Some(root)))
    }
}

/// The constants of one step: the scheme's and the sphere's.
struct Kernel<const N: usize> {
    h: f64,
    c_eta: Option<f64>,
    local_size: bool,
    rescale_noise: bool,
    monitor_velocity: bool,
    /// The kappa root in the ball of radius C_kappa.
    root: SphereRoot<N>,
    sphere: Sphere,
    /// (M^-1)_ii.
    inverse_mass: [f64; N],
}

impl<const N: usize> Kernel<N> {
    /// The constants, or `None` if the mass is not diagonal.
    fn new<S: System>(stepper: &Stepper<S>, sphere: &Sphere, h: f64) -> Option<Self> {
        let mass = stepper.system().mass();
        if !<S::Mass as Mass>::DIAGONAL {
            return None;
        }
        let mut inverse_mass = [0.0; N];
        for (k, w) in inverse_mass.iter_mut().enumerate() {
            *w = mass.inverse_diagonal_entry(k).unwrap_or(0.0);
        }
        let config = stepper.config();
        Some(Self {
            h,
            c_eta: config.c_eta,
            local_size: config.local_size,
            rescale_noise: config.rescale_noise,
            monitor_velocity: config.monitor_velocity_constraint,
            root: SphereRoot::new(sphere, inverse_mass, &config.solver, config.c_kappa),
            sphere: *sphere,
            inverse_mass,
        })
    }
}

impl<S: System, const N: usize> LaneKernel<Stepper<S>, N> for Kernel<N> {
    /// The step of W lanes from (r, v) with increments dw; `None` if the system has no lane
    /// form.
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, stepper: &Stepper<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        self.step_with_root(stepper, r, v, dw).map(|(step, _)| step)
    }
}

impl<const N: usize> Kernel<N> {
    /// Whether eq. 3.2 leaves every lane's step untruncated (eta = 1), decided without the
    /// square roots and divisions of the motion's measure: with B = |v|^2 + |a|^2 (divided
    /// by rho^2 for the local measure), the measure max(w, w^2, alpha) is at most max(sqrt(B),
    /// B) to a few ulps, so B <= min(C_eta / (2h), C_eta^2 / (4h^2)) keeps h times it below
    /// C_eta / 2 whatever the rounding, where the full formula gives eta = 1 exactly. Not
    /// finite B, or any lane beyond the bound, leaves it to the full formula.
    #[inline(always)]
    fn surely_untruncated<Sd: Simd>(&self, norms2: Lanes<Sd>, c_eta: f64) -> bool {
        let b = if self.local_size {
            norms2 * self.sphere.inverse_radius_squared()
        } else {
            norms2
        };
        let half_step = 0.5 * c_eta / self.h;
        b.le(b.splat_like(half_step.min(half_step * half_step)))
            .all()
    }

    /// eta of eq. 3.2 from |v|^2 and |a|^2 (or the sphere's local measure w = |v|/rho, alpha =
    /// |a|/rho).
    #[inline(always)]
    fn eta<Sd: Simd>(&self, v_norm2: Lanes<Sd>, a_norm2: Lanes<Sd>, c_eta: f64) -> Lanes<Sd> {
        let (speed, acceleration) = (v_norm2.sqrt(), a_norm2.sqrt());
        let local = if self.local_size {
            let rho = self.sphere.radius();
            Some(motion_measure(speed / rho, acceleration / rho))
        } else {
            None
        };
        formulas::eta(Some(c_eta), self.h, speed, acceleration, local)
    }

    /// v~ = v + M^-1 (eta a h + B dw) of eq. 3.1, or v + M^-1 sqrt(eta) (sqrt(eta) h a + B dw)
    /// when the noise is rescaled; `None` where the system has no lane form of its noise.
    #[inline(always)]
    fn free_velocity<S: System, Sd: Simd>(
        &self, system: &S, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
        a: &[Lanes<Sd>; N], eta: Lanes<Sd>,
    ) -> Option<[Lanes<Sd>; N]> {
        let scale = ForceScale::new(self.rescale_noise, eta, self.h);
        let mut force = [eta.splat_like(0.0); N];
        for i in 0..N {
            force[i] = scale.drift_h * a[i];
        }
        if !system.add_noise_lanes(r, v, dw, &mut force) {
            return None;
        }
        scale.rescale(&mut force);
        for i in 0..N {
            force[i] = force[i] * self.inverse_mass[i] + v[i];
        }
        Some(force)
    }

    /// [`LaneKernel::step`], with the kappa root.
    #[inline(always)]
    fn step_with_root<S: System, Sd: Simd>(
        &self, stepper: &Stepper<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<(LaneStep<Sd, N>, RootLanes<Sd, N>)> {
        let system = stepper.system();
        let zero = r[0].splat_like(0.0);
        let one = zero.splat_like(1.0);
        let mut a = [zero; N];
        if !system.drift_lanes(r, v, &mut a) {
            return None;
        }
        let v_norm2 = dot(v, v);
        let a_norm2 = dot(&a, &a);
        let mut ok = v_norm2.is_finite().and(a_norm2.is_finite());

        // eta of eq. 3.2 (or the sphere's local measure w = |v|/rho, alpha = |a|/rho).
        let eta = match self.c_eta {
            None => one,
            Some(c_eta) if self.surely_untruncated(v_norm2 + a_norm2, c_eta) => one,
            Some(c_eta) => self.eta(v_norm2, a_norm2, c_eta),
        };
        let eta_h = eta * self.h;
        let mut y = [zero; N];
        for i in 0..N {
            y[i] = formulas::drifted(r[i], v[i], eta_h);
        }
        let root = self.root.solve(r, &y);
        ok = ok.and(root.ok);
        let x = root.x;

        let force = self.free_velocity(system, r, v, dw, &a, eta)?;
        // lambda = -Dg(r') v~ / (Dg(r') M^-1 grad g(r)), v' = v~ + M^-1 grad g(r) lambda.
        let lambda = -self.sphere.normal_rate(&x, &force) * (one / root.gram);
        let mut v_new = [zero; N];
        self.sphere
            .displace_diagonal(r, lambda, |k| self.inverse_mass[k], &force, &mut v_new);
        ok = ok.and(dot(&v_new, &v_new).is_finite());
        // Written out, not `then`: a closure would not inherit the instruction set.
        let velocity_residual = if self.monitor_velocity {
            Some(self.sphere.normal_rate(&x, &v_new).abs())
        } else {
            None
        };
        let step = LaneStep {
            ok,
            r: x,
            v: v_new,
            dmu: lambda,
            record: LaneRecord {
                eta,
                newton_iterations: zero,
                position_residual: Some(root.residual),
                velocity_residual,
                certificate: Some((root.contraction, kappa_ratio(root.norm, self.root.radius()))),
            },
        };
        Some((step, root))
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

#[cfg(test)]
mod tests {
    use super::*;
    use sdae_ift::SolverSettings;

    /// The kernel's constants for a sphere of radius `rho` and unit masses.
    fn kernel(rho: f64, h: f64, c_eta: f64, local_size: bool) -> Kernel<2> {
        let sphere = Sphere::new(2, rho).unwrap();
        Kernel {
            h,
            c_eta: Some(c_eta),
            local_size,
            rescale_noise: false,
            monitor_velocity: false,
            root: SphereRoot::new(&sphere, [1.0; 2], &SolverSettings::default(), f64::INFINITY),
            sphere,
            inverse_mass: [1.0; 2],
        }
    }

    /// Wherever the shortcut says eta = 1, eq. 3.2 gives exactly 1; and it says so up to half
    /// the bound of the measure, while eq. 3.2 truncates within four times it (so a looser
    /// shortcut would fail here).
    #[test]
    fn the_untruncated_shortcut_agrees_with_eq_3_2() {
        let lane = |x: f64| Lanes::splat(pulp::Scalar, x);
        let (mut passed, mut truncated) = (0, 0);
        for local_size in [false, true] {
            for (rho, h, c_eta) in [(1.0, 1e-3, 1.0), (0.3, 0.1, 0.05), (2.5, 0.02, 3.0)] {
                let k = kernel(rho, h, c_eta, local_size);
                let half = 0.5 * c_eta / h;
                let limit = half.min(half * half) * if local_size { rho * rho } else { 1.0 };
                for i in 0..=4000 {
                    let b = limit * (0.25 + i as f64 / 1000.0);
                    for share in [0.0, 0.3, 0.5, 0.9, 1.0] {
                        let (v2, a2) = (lane(b * share), lane(b * (1.0 - share)));
                        let eta = k.eta(v2, a2, c_eta).lane(0);
                        if k.surely_untruncated(v2 + a2, c_eta) {
                            assert_eq!(eta, 1.0, "b = {b:e}, share {share}");
                            passed += 1;
                        }
                        if eta < 1.0 {
                            truncated += 1;
                        }
                    }
                }
            }
        }
        assert!(
            passed > 0 && truncated > 0,
            "{passed} passed, {truncated} truncated"
        );
    }
}
