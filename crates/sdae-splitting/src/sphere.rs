//! The splitting step for a sphere constraint with a diagonal mass over W lanes: the step body
//! of `kernel.rs` with the SHAKE projection's root in closed form ([`SphereRoot`], the root of
//! the quadratic kappa system connected to 0) and the RATTLE projection's multiplier
//! -Dg(x) v / G_M(x) with G_M(x) = x^T M^-1 x / rho^4 ([`SphereLanes`]). The ensemble runs it W
//! paths at a time; [`Splitting`]'s own step of one path runs the same code at W = 1
//! ([`step_one_lane`]), so a lane computes its path's numbers. A lane it does not decide (no
//! real root: tau |v| beyond the radius; a non-finite value) goes through the scalar step,
//! which reports the failure as for one path.

use pulp::Simd;
use sdae_lanes::{LaneMask, LaneWidth, Lanes};
use sdae_manifold::Equations;
use sdae_model::engine::{
    self, LaneKernel, LanePaths, LaneStep, SphereKernels, SphereRoot, StepInput,
    step_offered_newton_lanes, step_sphere_lanes,
};
use sdae_model::{LaneScheme, StepOutcome, System};

use crate::kernel::{
    self, Motion, NoLaneForm, Shaken, SplittingKernel, StepNumbers, shake_impulse,
};
use crate::splitting::Splitting;

impl<S: System> LaneScheme for Splitting<S> {
    /// The sphere's closed form in lanes where the constraint is a sphere of dimension <= 3
    /// with a diagonal mass, Newton's SHAKE in lanes where it offers formulas over lanes
    /// (`newton.rs`); `false` (every path through the scalar step) otherwise.
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        self.refresh_numbers(h);
        let input = StepInput { h, dw };
        step_sphere_lanes(self, Kernels, paths, width, input)
            || step_offered_newton_lanes(self, paths, width, input)
    }
}

/// The splitting step's kernels on a sphere ([`SphereKernels`]).
struct Kernels;

impl<S: System> SphereKernels<Splitting<S>> for Kernels {
    type Kernel<E: Equations, const N: usize> = Kernel<E, N>;
    #[inline(always)]
    fn kernel<E: Equations, const N: usize>(
        &self, scheme: &Splitting<S>, constraint: &E, h: f64,
    ) -> Option<Kernel<E, N>> {
        Some(Kernel::new(scheme, constraint, h))
    }
}

/// The constants of one step: the scheme's and the constraint's.
struct Kernel<E, const N: usize> {
    numbers: StepNumbers,
    /// The SHAKE root (an unbounded ball: no certificate is claimed), with the sphere and
    /// M^-1.
    root: SphereRoot<E, N>,
}

impl<E: Equations, const N: usize> Kernel<E, N> {
    /// The constants for h; the scheme's O factors must be those of h
    /// ([`Splitting::refresh_numbers`]).
    fn new<S: System>(scheme: &Splitting<S>, constraint: &E, h: f64) -> Self {
        let inverse_mass: [f64; N] = std::array::from_fn(|k| scheme.inverse_mass[k]);
        let config = scheme.config();
        Self {
            numbers: {
                debug_assert_eq!(scheme.numbers.sizes.h.to_bits(), h.to_bits());
                scheme.numbers.clone()
            },
            root: SphereRoot::new(constraint, inverse_mass, &config.solver, f64::INFINITY),
        }
    }
}

impl<S: System, E: Equations, const N: usize> LaneKernel<Splitting<S>, N> for Kernel<E, N> {
    /// The step of W lanes ([`Splitting`]'s B A O A B, [`kernel::step`]); `None` if the
    /// system's force has no lane form.
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, scheme: &Splitting<S>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let zero = r[0].splat_like(0.0);
        let (mut r, mut v, mut dmu, mut lambda) = (*r, *v, [zero], [zero]);
        let mut lanes = SphereLanes {
            kernel: self,
            force: [zero; N],
            root: [zero; N],
        };
        let mut m = Motion::new(&mut r, &mut v, &mut dmu, &mut lambda, zero);
        let velocity_residual = kernel::step(&scheme.system, &mut lanes, &mut m, dw, false).ok()?;
        let (ok, record) = (m.ok, m.record(velocity_residual));
        Some(LaneStep {
            ok,
            r,
            v,
            dmu: dmu[0],
            record,
        })
    }
}

/// The step body's kernel on a sphere of N coordinates over W lanes: the closed forms, F(r)
/// and the last SHAKE's point.
struct SphereLanes<'a, Sd: Simd, E, const N: usize> {
    kernel: &'a Kernel<E, N>,
    force: [Lanes<Sd>; N],
    /// The point of the last SHAKE projection.
    root: [Lanes<Sd>; N],
}

impl<Sd: Simd, E: Equations, const N: usize> SplittingKernel<Lanes<Sd>>
    for SphereLanes<'_, Sd, E, N>
{
    type Rows = [Lanes<Sd>; N];
    type Failure = NoLaneForm;
    #[inline(always)]
    fn numbers(&self) -> &StepNumbers {
        &self.kernel.numbers
    }
    #[inline(always)]
    fn inverse_mass(&self, k: usize, x: Lanes<Sd>) -> Lanes<Sd> {
        x * self.kernel.root.inverse_mass()[k]
    }
    /// The system's lane form of F(r); [`NoLaneForm`] without one.
    #[inline(always)]
    fn evaluate_force<S: System>(&mut self, system: &S, r: &[Lanes<Sd>]) -> Result<(), NoLaneForm> {
        let zero = [r[0].splat_like(0.0); N];
        if system.drift(r, &zero, &mut self.force) {
            Ok(())
        } else {
            Err(NoLaneForm)
        }
    }
    #[inline(always)]
    fn force(&self) -> &[Lanes<Sd>] {
        &self.force
    }
    /// lambda = -Dg(r) v / G_M(r) with G_M(r) = r^T M^-1 r / rho^4, which is evaluated at
    /// every call (`refactor` changes nothing).
    #[inline(always)]
    fn rattle_multiplier(
        &mut self, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], _refactor: bool,
        lambda: &mut [Lanes<Sd>],
    ) -> Result<LaneMask<Sd>, NoLaneForm> {
        let root = &self.kernel.root;
        let [_, gram] = root.value_and_gram(r, r);
        lambda[0] = -root.normal_rate(r, v) / gram;
        Ok(gram.is_finite().and(!gram.eq(gram.splat_like(0.0))))
    }
    #[inline(always)]
    fn displace(&mut self, r: &[Lanes<Sd>; N], z: &[Lanes<Sd>], v: &mut [Lanes<Sd>; N]) {
        let mut displaced = *v;
        self.kernel.root.displace(r, z[0], v, &mut displaced);
        *v = displaced;
    }
    /// The closed-form root at y = r + tau v ([`SphereRoot`]).
    #[inline(always)]
    fn shake(
        &mut self, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], impulse: &mut [Lanes<Sd>],
    ) -> Result<Shaken<Lanes<Sd>>, NoLaneForm> {
        let mut y = *r;
        for (yi, &vi) in y.iter_mut().zip(v) {
            *yi = *yi + vi * self.kernel.numbers.sizes.tau;
        }
        let root = self.kernel.root.solve(r, &y);
        self.root = root.x;
        let inverse_tau = self.kernel.numbers.sizes.inverse_tau;
        shake_impulse(&[root.gamma], inverse_tau, impulse);
        Ok(Shaken {
            ok: root.ok,
            iterations: root.residual.splat_like(0.0),
            residual: root.residual,
        })
    }
    #[inline(always)]
    fn move_to_root(&mut self, r: &mut [Lanes<Sd>; N]) {
        *r = self.root;
    }
    #[inline(always)]
    fn velocity_residual(
        &mut self, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], _scratch: &mut [Lanes<Sd>],
    ) -> Lanes<Sd> {
        self.kernel.root.normal_rate(r, v).abs()
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
