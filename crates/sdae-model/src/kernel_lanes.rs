//! A [`KernelScheme`]'s step over W lanes ([`Kernelized`] as a [`LaneScheme`](crate::LaneScheme)):
//! the lanes' [`StepKernel`] (the system's lane forms of its drift and noise, path by path
//! where it has none; a diagonal M^-1) with the constrained update of the constraint's lane
//! form: the sphere's closed form ([`SphereRoot`], arrays of N = 2 or 3 coordinates through
//! [`LanePaths::step_groups`](crate::engine::LanePaths::step_groups)) or Newton over its
//! [`Equations`] ([`NewtonRoot`], rows through
//! [`LanePaths::step_wide_groups`](crate::engine::LanePaths::step_wide_groups)). Each formula
//! is the one-path kernel's, with the same floating-point operations in the same order.

use pulp::Simd;
use sdae_ift::SolverSettings;
use sdae_lanes::{LaneMask, LaneWidth, Lanes, LineVec};
use sdae_manifold::lane_form::{LaneForm, max_abs};
use sdae_manifold::vector::sum_squares;
use sdae_manifold::{Equations, MatrixFactor};

use crate::error::StepFailure;
use crate::kernel_scheme::{
    Constrained, KernelNext, KernelScheme, KernelState, Kernelized, StepKernel, lane_record, radius,
};
use crate::lane_diagnostics::LaneRecord;
use crate::lane_ensemble::{
    GroupState, LaneKernel, LanePaths, LaneRows, LaneScheme, LaneStep, LaneStore, StepInput,
    WideKernel,
};
use crate::newton_lanes::{NewtonKernels, step_offered_newton_lanes};
use crate::newton_root::NewtonRoot;
use crate::scheme::Scheme;
use crate::sphere_lanes::{SphereKernels, step_sphere_lanes};
use crate::sphere_root::SphereRoot;
use crate::system::{System, add_noise_over_lanes, drift_over_lanes};

/// How the lanes' kernel applies M^-1 and makes the constrained update: the sphere's closed
/// form or Newton over a lane form.
trait LaneConstraint<Sd: Simd> {
    /// x <- M^-1 x.
    fn apply_inverse_mass(&self, x: &mut [Lanes<Sd>]);
    /// [`StepKernel::constrain`] over lanes.
    fn constrain(
        &mut self, r: &[Lanes<Sd>], y: &[Lanes<Sd>], velocity: &mut [Lanes<Sd>],
        next_r: &mut [Lanes<Sd>], multiplier: &mut [Lanes<Sd>],
    ) -> Constrained<Lanes<Sd>>;
}

/// The lanes' [`StepKernel`]: the system's lane forms and a [`LaneConstraint`].
struct Lanewise<'a, S: System, L, Sd: Simd> {
    system: &'a S,
    /// 0 in every lane.
    zero: Lanes<Sd>,
    constraint: L,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: &'a mut Vec<f64>,
}

impl<S: System, Sd: Simd, L: LaneConstraint<Sd>> StepKernel<Lanes<Sd>> for Lanewise<'_, S, L, Sd> {
    #[inline(always)]
    fn splat(&self, x: f64) -> Lanes<Sd> {
        self.zero.splat_like(x)
    }
    #[inline(always)]
    fn drift(&mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], out: &mut [Lanes<Sd>]) {
        drift_over_lanes(self.system, r, v, out, self.scratch);
    }
    #[inline(always)]
    fn add_noise(
        &mut self, r: &[Lanes<Sd>], v: &[Lanes<Sd>], dw: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        add_noise_over_lanes(self.system, r, v, dw, out, self.scratch);
    }
    #[inline(always)]
    fn apply_inverse_mass(&self, x: &mut [Lanes<Sd>]) {
        self.constraint.apply_inverse_mass(x);
    }
    #[inline(always)]
    fn constrain(
        &mut self, r: &[Lanes<Sd>], y: &[Lanes<Sd>], velocity: &mut [Lanes<Sd>],
        next_r: &mut [Lanes<Sd>], multiplier: &mut [Lanes<Sd>],
    ) -> Result<Constrained<Lanes<Sd>>, StepFailure> {
        Ok(self
            .constraint
            .constrain(r, y, velocity, next_r, multiplier))
    }
    #[inline(always)]
    fn check_finite(
        &self, _what: &'static str, x: &[Lanes<Sd>],
    ) -> Result<LaneMask<Sd>, StepFailure> {
        Ok(sum_squares(x).is_finite())
    }
}

/// The fixed-size closed form with a diagonal M^-1 ([`SphereRoot`]).
struct SphereConstraint<'a, E, const N: usize> {
    root: &'a SphereRoot<E, N>,
}

impl<Sd: Simd, E: Equations, const N: usize> LaneConstraint<Sd> for SphereConstraint<'_, E, N> {
    #[inline(always)]
    fn apply_inverse_mass(&self, x: &mut [Lanes<Sd>]) {
        for (xi, w) in x.iter_mut().zip(self.root.inverse_mass()) {
            *xi = *xi * *w;
        }
    }
    /// The closed-form root and the velocity at it ([`SphereRoot::velocity`]).
    #[inline(always)]
    fn constrain(
        &mut self, r: &[Lanes<Sd>], y: &[Lanes<Sd>], velocity: &mut [Lanes<Sd>],
        next_r: &mut [Lanes<Sd>], multiplier: &mut [Lanes<Sd>],
    ) -> Constrained<Lanes<Sd>> {
        let r = coordinates::<Sd, N>(r);
        let root = self.root.solve(r, coordinates::<Sd, N>(y));
        next_r.copy_from_slice(&root.x);
        let (lambda, v_new) = self.root.velocity(r, &root, coordinates::<Sd, N>(velocity));
        velocity.copy_from_slice(&v_new);
        multiplier[0] = lambda;
        Constrained {
            ok: root.ok,
            newton_iterations: lambda.splat_like(0.0),
            position_residual: root.residual,
            contraction: root.contraction,
            kappa_norm: root.norm,
        }
    }
}

/// The first N rows of `x`.
#[inline(always)]
fn coordinates<Sd: Simd, const N: usize>(x: &[Lanes<Sd>]) -> &[Lanes<Sd>; N] {
    x.first_chunk::<N>()
        .expect("a sphere kernel's rows have N coordinates")
}

/// Newton over a constraint's lane form ([`NewtonRoot`]).
struct NewtonConstraint<'a, Sd: Simd, C: Equations> {
    form: &'a LaneForm<C>,
    root: &'a mut NewtonRoot<Sd, C>,
    settings: &'a SolverSettings,
    radius: f64,
}

impl<Sd: Simd, C: Equations> LaneConstraint<Sd> for NewtonConstraint<'_, Sd, C> {
    #[inline(always)]
    fn apply_inverse_mass(&self, x: &mut [Lanes<Sd>]) {
        let w = self.form.inverse_mass();
        for (k, xi) in x.iter_mut().enumerate() {
            *xi = w.apply(k, *xi);
        }
    }
    /// The Newton root, lambda = J^-1 (-Dg(r') v~) with the factors at the root, and
    /// v' = v~ + M^-1 grad g(r) lambda.
    #[inline(always)]
    fn constrain(
        &mut self, r: &[Lanes<Sd>], y: &[Lanes<Sd>], velocity: &mut [Lanes<Sd>],
        next_r: &mut [Lanes<Sd>], multiplier: &mut [Lanes<Sd>],
    ) -> Constrained<Lanes<Sd>> {
        let root = self
            .root
            .solve(self.form, self.settings, self.radius, r, y, max_abs(y));
        self.root.point(&root, y);
        next_r.copy_from_slice(&self.root.x);
        let factor = self.root.root_factor(&root);
        self.form
            .negated_jacobian_mul(&self.root.x, velocity, multiplier);
        factor.forward_in_place(multiplier);
        factor.back_substitute(multiplier);
        // gamma's rows are free scratch once the root is known.
        let (finite, _) = self.form.finish_velocity(
            r,
            multiplier,
            &self.root.x,
            false,
            velocity,
            &mut self.root.gamma,
        );
        Constrained {
            ok: root.ok.and(finite),
            newton_iterations: root.iterations,
            position_residual: root.residual,
            contraction: root.contraction,
            kappa_norm: root.norm,
        }
    }
}

impl<K: KernelScheme> LaneScheme for Kernelized<K> {
    /// The sphere's closed form in lanes where the constraint is a sphere of dimension <= 3
    /// with a diagonal mass, Newton in lanes where it offers formulas over lanes; `false`
    /// (every path through the one-path step) otherwise.
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        let input = StepInput { h, dw };
        step_sphere_lanes(self, OnSphere, paths, width, input)
            || step_offered_newton_lanes(self, paths, width, input)
    }
}

/// A [`Kernelized`] scheme's kernels on a sphere ([`SphereKernels`](crate::engine::SphereKernels)).
pub(crate) struct OnSphere;

/// The constants of a step on a constraint of one quadratic equation in N coordinates.
pub(crate) struct SphereKernel<E, const N: usize> {
    h: f64,
    root: SphereRoot<E, N>,
}

impl<K: KernelScheme> SphereKernels<Kernelized<K>> for OnSphere {
    type Kernel<E: Equations, const N: usize> = SphereKernel<E, N>;
    /// The kernel, or `None` if the mass is not diagonal.
    fn kernel<E: Equations, const N: usize>(
        &self, scheme: &Kernelized<K>, constraint: &E, h: f64,
    ) -> Option<SphereKernel<E, N>> {
        let (settings, radius) = scheme.scheme.solver();
        let root = SphereRoot::for_mass(constraint, scheme.system().mass(), &settings, radius)?;
        Some(SphereKernel { h, root })
    }
}

impl<K: KernelScheme, E: Equations, const N: usize> LaneKernel<Kernelized<K>, N>
    for SphereKernel<E, N>
{
    #[inline(always)]
    fn step<Sd: Simd>(
        &self, scheme: &Kernelized<K>, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>> {
        let zero = r[0].splat_like(0.0);
        let mut scratch = Vec::new();
        let mut kernel = Lanewise {
            system: scheme.system(),
            zero,
            constraint: SphereConstraint { root: &self.root },
            scratch: &mut scratch,
        };
        let (mut next_r, mut next_v, mut dmu, mut work) = ([zero; N], [zero; N], [zero], [zero; N]);
        let next = KernelNext {
            r: &mut next_r,
            v: &mut next_v,
            dmu: &mut dmu,
            work: &mut work,
        };
        let state = KernelState { r, v, dw };
        let outcome = scheme.scheme.step(&mut kernel, self.h, state, next).ok()?;
        Some(LaneStep {
            ok: outcome.ok,
            r: next_r,
            v: next_v,
            dmu: dmu[0],
            record: lane_record(&outcome, radius(scheme)),
        })
    }
}

/// A [`Kernelized`] scheme's kernel for a constraint's lane form, with its buffers.
pub struct NewtonKernel<Sd: Simd, C: Equations> {
    h: f64,
    form: LaneForm<C>,
    root: NewtonRoot<Sd, C>,
    settings: SolverSettings,
    radius: f64,
    /// The step's scratch rows ([`KernelNext::work`]).
    work: LineVec<Lanes<Sd>>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
}

impl<K: KernelScheme> NewtonKernels for Kernelized<K> {
    type Kernel<Sd: Simd, C: Equations> = NewtonKernel<Sd, C>;
    fn kernel<Sd: Simd, C: Equations>(&self, simd: Sd, form: LaneForm<C>) -> NewtonKernel<Sd, C> {
        let (settings, radius) = self.scheme.solver();
        let (n, _) = form.dims();
        NewtonKernel {
            h: 0.0,
            root: NewtonRoot::new(simd, &form),
            form,
            settings,
            radius,
            work: LineVec::from_elem(Lanes::splat(simd, 0.0), n),
            scratch: Vec::new(),
        }
    }
    fn prepare<Sd: Simd, C: Equations>(&self, kernel: &mut NewtonKernel<Sd, C>, h: f64) {
        kernel.h = h;
    }
    fn lane_store(&mut self) -> &mut LaneStore {
        &mut self.lanes
    }
}

impl<K: KernelScheme, Sd: Simd, C: Equations> WideKernel<Kernelized<K>, Sd>
    for NewtonKernel<Sd, C>
{
    #[inline(always)]
    fn step(
        &mut self, scheme: &Kernelized<K>, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let Self {
            h,
            form,
            root,
            settings,
            radius,
            work,
            scratch,
        } = self;
        let mut kernel = Lanewise {
            system: scheme.system(),
            zero: Lanes::splat(rows.simd(), 0.0),
            constraint: NewtonConstraint {
                form,
                root,
                settings,
                radius: *radius,
            },
            scratch,
        };
        let next = KernelNext {
            r: &mut rows.r,
            v: &mut rows.v,
            dmu: &mut rows.dmu,
            work,
        };
        let state = KernelState {
            r: state.r,
            v: state.v,
            dw: state.dw,
        };
        let outcome = scheme.scheme.step(&mut kernel, *h, state, next).ok()?;
        Some((outcome.ok, lane_record(&outcome, *radius)))
    }
}
