//! The splitting step for a sphere constraint with a diagonal mass over W lanes: the SHAKE
//! projection's root in closed form ([`SphereRoot`], the root of the quadratic kappa system
//! connected to 0), the RATTLE projection's multiplier -Dg(x) v / G_M(x) with G_M(x) =
//! x^T M^-1 x / rho^4. The ensemble runs it W paths at a time; [`Splitting`]'s own step of one
//! path runs the same code at W = 1 ([`step_one_lane`]), so a lane computes its path's numbers.
//! A lane it does not decide (no real root: tau |v| beyond the radius; a non-finite value)
//! goes through the scalar step, which reports the failure as for one path.

use pulp::Simd;
use sdae_lanes::{LaneMask, LaneWidth, Lanes, dot};
use sdae_manifold::Sphere;
use sdae_model::engine::{
    self, LaneKernel, LanePaths, LaneRecord, LaneStep, SphereKernels, SphereRoot, StepInput,
    step_offered_newton_lanes, step_sphere_lanes,
};
use sdae_model::{LaneScheme, StepOutcome, System};

use crate::config::StepSizes;
use crate::ou::OuFactors;
use crate::splitting::Splitting;

impl<S: System> LaneScheme for Splitting<S> {
    /// The sphere's closed form in lanes where the constraint is a sphere of dimension <= 3
    /// with a diagonal mass, Newton's SHAKE in lanes where it offers formulas over lanes
    /// (`newton.rs`); `false` (every path through the scalar step) otherwise.
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        self.refresh_ou(h);
        let input = StepInput { h, dw };
        step_sphere_lanes(self, Kernels, paths, width, input)
            || step_offered_newton_lanes(self, paths, width, input)
    }
}

/// The splitting step's kernels on a sphere ([`SphereKernels`]).
struct Kernels;

impl<S: System> SphereKernels<Splitting<S>> for Kernels {
    type Kernel<const N: usize> = Kernel<N>;
    #[inline(always)]
    fn kernel<const N: usize>(
        &self, scheme: &Splitting<S>, sphere: &Sphere, h: f64,
    ) -> Option<Kernel<N>> {
        Some(Kernel::new(scheme, sphere, h))
    }
}

/// The constants of one step: the scheme's and the sphere's.
struct Kernel<const N: usize> {
    sizes: StepSizes,
    /// The SHAKE root (an unbounded ball: no certificate is claimed).
    root: SphereRoot<N>,
    sphere: Sphere,
    /// (M^-1)_ii.
    inverse_mass: [f64; N],
    /// The O step's factors for h.
    ou: [OuFactors; N],
    monitor_velocity: bool,
}

impl<const N: usize> Kernel<N> {
    /// The constants for h; the scheme's O factors must be those of h
    /// ([`Splitting::refresh_ou`]).
    fn new<S: System>(scheme: &Splitting<S>, sphere: &Sphere, h: f64) -> Self {
        let inverse_mass: [f64; N] = std::array::from_fn(|k| scheme.inverse_mass[k]);
        let config = scheme.config();
        Self {
            sizes: StepSizes::new(config, h),
            root: SphereRoot::new(sphere, inverse_mass, &config.solver, f64::INFINITY),
            sphere: *sphere,
            ou: std::array::from_fn(|k| scheme.ou[k]),
            inverse_mass,
            monitor_velocity: config.monitor_velocity_constraint,
        }
    }
}

/// The state of W lanes inside a step.
struct Motion<Sd: Simd, const N: usize> {
    r: [Lanes<Sd>; N],
    v: [Lanes<Sd>; N],
    /// The sum of the step's constraint impulses (mu's increment).
    impulse: Lanes<Sd>,
    /// The lanes decided so far.
    ok: LaneMask<Sd>,
    /// |g| after the last SHAKE projection.
    residual: Lanes<Sd>,
}

impl<S: System, const N: usize> LaneKernel<Splitting<S>, N> for Kernel<N> {
    /// The step of W lanes ([`Splitting`]'s B A O A B); `None` if the system's force has no
    /// lane form.
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, scheme: &Splitting<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let system = &scheme.system;
        let zero = r[0].splat_like(0.0);
        let mut m = Motion {
            r: *r,
            v: *v,
            impulse: zero,
            ok: zero.eq(zero),
            residual: zero,
        };
        self.kick(system, &mut m)?;
        for _ in 0..self.sizes.substeps {
            self.geodesic_drift(&mut m);
        }
        for (vi, ou) in m.v.iter_mut().zip(&self.ou) {
            *vi = *vi * ou.decay;
        }
        for ((vi, ou), &w) in m.v.iter_mut().zip(&self.ou).zip(dw) {
            *vi = *vi + w * ou.noise;
        }
        self.project_velocity(&mut m);
        for _ in 0..self.sizes.substeps {
            self.geodesic_drift(&mut m);
        }
        self.kick(system, &mut m)?;
        m.ok = m.ok.and(dot(&m.v, &m.v).is_finite());
        // Written out, not `then`: a closure would not inherit the instruction set.
        let velocity_residual = if self.monitor_velocity {
            Some(self.sphere.normal_rate(&m.r, &m.v).abs())
        } else {
            None
        };
        Some(LaneStep {
            ok: m.ok,
            r: m.r,
            v: m.v,
            dmu: m.impulse,
            record: LaneRecord {
                eta: zero.splat_like(1.0),
                newton_iterations: zero,
                position_residual: Some(m.residual),
                velocity_residual,
                certificate: None,
            },
        })
    }
}

impl<const N: usize> Kernel<N> {
    /// B: v <- v + (h/2) M^-1 F(r), then RATTLE; `None` without a lane form of the force.
    #[inline(always)]
    fn kick<S: System, Sd: Simd>(&self, system: &S, m: &mut Motion<Sd, N>) -> Option<()> {
        let zero = m.r[0].splat_like(0.0);
        let mut force = [zero; N];
        if !system.drift_lanes(&m.r, &[zero; N], &mut force) {
            return None;
        }
        m.ok = m.ok.and(dot(&force, &force).is_finite());
        let half_h = 0.5 * self.sizes.h;
        for ((vi, &fi), &wi) in m.v.iter_mut().zip(&force).zip(&self.inverse_mass) {
            *vi = *vi + fi * wi * half_h;
        }
        self.project_velocity(m);
        Some(())
    }

    /// RATTLE at r: v <- v + M^-1 grad g(r) lambda, lambda = -Dg(r) v / G_M(r).
    #[inline(always)]
    fn project_velocity<Sd: Simd>(&self, m: &mut Motion<Sd, N>) {
        let [_, gram] = self
            .sphere
            .value_and_gram(&m.r, &m.r, |k| self.inverse_mass[k]);
        let zero = gram.splat_like(0.0);
        m.ok = m.ok.and(gram.is_finite()).and(!gram.eq(zero));
        let lambda = -self.sphere.normal_rate(&m.r, &m.v) / gram;
        m.impulse = m.impulse + lambda;
        let mut v = [zero; N];
        self.sphere
            .displace_diagonal(&m.r, lambda, |k| self.inverse_mass[k], &m.v, &mut v);
        m.v = v;
    }

    /// A geodesic substep of length tau: SHAKE (the closed-form root), the velocity
    /// v + M^-1 grad g(r) kappa / tau, RATTLE at the new point.
    #[inline(always)]
    fn geodesic_drift<Sd: Simd>(&self, m: &mut Motion<Sd, N>) {
        let mut y = m.r;
        for (yi, &vi) in y.iter_mut().zip(&m.v) {
            *yi = *yi + vi * self.sizes.tau;
        }
        let root = self.root.solve(&m.r, &y);
        m.ok = m.ok.and(root.ok);
        m.residual = root.residual;
        let lambda = root.gamma * self.sizes.inverse_tau;
        m.impulse = m.impulse + lambda;
        let mut v = m.v;
        self.sphere
            .displace_diagonal(&m.r, lambda, |k| self.inverse_mass[k], &m.v, &mut v);
        m.v = v;
        m.r = root.x;
        self.project_velocity(m);
    }
}

/// [`Splitting`]'s step of one path (checked input) for a sphere of dimension 2 or 3 with a
/// diagonal mass: this module's step at W = 1, in plain f64 ([`engine::step_one_lane`]), with
/// mu's increment. `None` where the lane form does not apply or does not decide; (r, v) are
/// then unchanged and the general path decides, with its errors.
#[inline]
pub(crate) fn step_one_lane<S: System>(
    scheme: &Splitting<S>, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
) -> Option<(StepOutcome, f64)> {
    let step = engine::step_one_lane(scheme, Kernels, r, v, h, dw)?;
    let outcome = StepOutcome {
        position_residual: step.position_residual,
        velocity_residual: step.velocity_residual,
        ..StepOutcome::PLAIN
    };
    Some((outcome, step.dmu))
}
