//! The way a scheme steps the paths of a system whose constraint offers formulas over lanes
//! ([`Equations`]: bead chains, rigid bonds, a user's constraint) with a diagonal mass,
//! shared by the schemes whose lane form is a [`WideKernel`] per lane form: build the lane form
//! when the ensemble first steps, keep it with the kernel's buffers in the scheme's
//! [`LaneStore`] between steps, and step every group of lanes
//! ([`LanePaths::step_wide_groups`]) at the width's instruction set.

use std::marker::PhantomData;

use pulp::{Simd, WithSimd};
use sdae_lanes::LaneWidth;
use sdae_manifold::Constraint;
use sdae_manifold::lane_form::{LaneForm, LaneFormVisitor};
use sdae_manifold::{Equations, Mass};

use crate::lane_ensemble::{LanePaths, LaneRows, LaneStore, StepInput, WideKernel};
use crate::newton_root::build_lane_form;
use crate::scheme::Scheme;
use crate::system::System;

/// A scheme with a [`WideKernel`] for every lane form of a constraint.
pub trait NewtonKernels: Scheme + Sized {
    /// The kernel for the lane form C at the instruction set Sd, with its buffers.
    type Kernel<Sd: Simd, C: Equations>: WideKernel<Self, Sd> + Send + Sync + 'static;
    /// The kernel for `constraint`'s lane form.
    fn kernel<Sd: Simd, C: Equations>(
        &self, simd: Sd, constraint: LaneForm<C>,
    ) -> Self::Kernel<Sd, C>;
    /// Sets the kernel's numbers for a step of size h (before each step).
    fn prepare<Sd: Simd, C: Equations>(&self, kernel: &mut Self::Kernel<Sd, C>, h: f64);
    /// Where the scheme keeps the kernel and its buffers between steps.
    fn lane_store(&mut self) -> &mut LaneStore;
}

/// One step of every path of `paths` through the scheme's kernel for the lane form C that its
/// system's constraint offered ([`LaneFormVisitor::newton`](sdae_manifold::lane_form::LaneFormVisitor::newton)),
/// at the instruction set of `width`: `false`, having changed nothing, if the constraint
/// offers no such form for this mass after all.
pub fn step_newton_lanes<Sch: NewtonKernels, C: Equations>(
    scheme: &mut Sch, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool {
    width.dispatch(StepAll {
        scheme,
        paths,
        input,
        constraint: PhantomData::<C>,
    })
}

/// [`step_newton_lanes`] at the instruction set Sd.
struct StepAll<'a, Sch, C> {
    scheme: &'a mut Sch,
    paths: &'a mut LanePaths,
    input: StepInput<'a>,
    constraint: PhantomData<C>,
}

impl<Sch: NewtonKernels, C: Equations> WithSimd for StepAll<'_, Sch, C> {
    type Output = bool;
    #[inline(always)]
    fn with_simd<Sd: Simd>(self, simd: Sd) -> bool {
        let mut store = std::mem::take(self.scheme.lane_store());
        let kept = store
            .take::<(Sch::Kernel<Sd, C>, LaneRows<Sd>)>()
            .or_else(|| {
                let system = self.scheme.system();
                let constraint = build_lane_form::<C, _>(system)?;
                let (n, m) = constraint.dims();
                let rows = LaneRows::new(simd, n, m, system.noise_dim());
                Some(Box::new((self.scheme.kernel(simd, constraint), rows)))
            });
        let Some(mut buffers) = kept else {
            *self.scheme.lane_store() = store;
            return false;
        };
        let (kernel, rows) = &mut *buffers;
        self.scheme.prepare(kernel, self.input.h);
        self.paths
            .step_wide_groups(self.scheme, self.input, kernel, rows);
        store.put(buffers);
        *self.scheme.lane_store() = store;
        true
    }
}

/// One step of every path of `paths` through the scheme's Newton kernel for the lane form its
/// system's constraint offers ([`step_newton_lanes`], compiled only for the constraints that
/// offer one); `false`, having changed nothing, where it offers none for its mass.
pub fn step_offered_newton_lanes<Sch: NewtonKernels>(
    scheme: &mut Sch, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool {
    let system = scheme.system();
    match system
        .constraint()
        .lane_form(system.mass(), Offered(PhantomData))
    {
        Some(step_all) => step_all(scheme, paths, width, input),
        None => false,
    }
}

/// [`step_newton_lanes`] for one constraint's lane form.
type NewtonStep<Sch> = fn(&mut Sch, &mut LanePaths, LaneWidth, StepInput<'_>) -> bool;

/// Asks a constraint for its lane form ([`step_offered_newton_lanes`]).
struct Offered<Sch>(PhantomData<Sch>);

impl<Sch: NewtonKernels> LaneFormVisitor for Offered<Sch> {
    type Output = Option<NewtonStep<Sch>>;
    fn none(self) -> Self::Output {
        None
    }
    fn newton<L: Equations, M: Mass>(self, constraint: &L, mass: &M) -> Self::Output {
        let _ = (constraint, mass);
        Some(step_newton_lanes::<Sch, L>)
    }
}
