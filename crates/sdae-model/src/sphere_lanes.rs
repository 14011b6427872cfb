//! The way a scheme steps the paths of a system whose constraint is one quadratic equation in
//! 2 or 3 coordinates (the sphere) with a diagonal mass in lanes, on arrays of that size,
//! shared by the schemes whose lane form is a [`LaneKernel`] per dimension: take the
//! constraint that offers the closed form ([`LaneFormVisitor::closed_form`], so that the
//! kernels are compiled only for the constraints that do), choose the instruction set of the
//! width and the dimension, build the kernel and step every group of lanes
//! ([`LanePaths::step_groups`]). A scheme's own step of one path runs the same kernels at W = 1
//! ([`step_one_lane`](crate::engine::step_one_lane)).

use std::any::Any;
use std::marker::PhantomData;

use pulp::{Scalar, Simd, WithSimd};
use sdae_lanes::{LaneWidth, Lanes};
use sdae_manifold::lane_form::LaneFormVisitor;
use sdae_manifold::{Constraint, Equations, Mass};

use crate::lane_ensemble::{LaneKernel, LanePaths, LaneStep, StepInput};
use crate::scheme::Scheme;
use crate::sphere_root::RootLanes;
use crate::system::System;

/// The largest sphere dimension stepped in lanes (the planar and the spherical pendulum).
pub const SPHERE_LANES_MAX_DIM: usize = 3;

/// A scheme's fixed-size lane kernels: the kernel of one step of size h for a constraint of
/// one quadratic equation in N = 2 or 3 coordinates, or `None` where the scheme has none (every
/// path then goes through the scalar step).
pub trait SphereKernels<Sch: ?Sized> {
    /// The kernel for constraint E in N coordinates.
    type Kernel<E: Equations, const N: usize>: LaneKernel<Sch, N>;
    /// The kernel of a step of size h on `constraint`.
    fn kernel<E: Equations, const N: usize>(
        &self, scheme: &Sch, constraint: &E, h: f64,
    ) -> Option<Self::Kernel<E, N>>;
    /// The kernel's step of one path at W = 1
    /// ([`step_one_lane`](crate::engine::step_one_lane)), with its kappa root where the scheme
    /// reads it: [`LaneKernel::step`] and no root unless overridden.
    #[inline(always)]
    fn step_with_root<E: Equations, const N: usize>(
        &self, kernel: &Self::Kernel<E, N>, scheme: &Sch, r: &[Lanes<Scalar>; N],
        v: &[Lanes<Scalar>; N], dw: &[Lanes<Scalar>],
    ) -> Option<(LaneStep<Scalar, N>, Option<RootLanes<Scalar, N>>)> {
        kernel.step(scheme, r, v, dw).map(|step| (step, None))
    }
}

/// Steps every path of `paths` through the kernels of `kernels` where the scheme's constraint
/// offers the closed form ([`LaneFormVisitor::closed_form`]: one quadratic equation in at most
/// [`SPHERE_LANES_MAX_DIM`] coordinates) with a diagonal mass and at most as many noise
/// components; `false`, having changed nothing, otherwise.
pub fn step_sphere_lanes<Sch, K>(
    scheme: &mut Sch, kernels: K, paths: &mut LanePaths, width: LaneWidth, input: StepInput<'_>,
) -> bool
where
    Sch: Scheme,
    K: SphereKernels<Sch>,
{
    if !<<Sch::System as System>::Mass as Mass>::DIAGONAL {
        return false;
    }
    let system = scheme.system();
    let choice = system.constraint().lane_form(
        system.mass(),
        ClosedFormOnly::<'_, Sch, K>(PhantomData, PhantomData),
    );
    let Some(step_all) = choice else {
        return false;
    };
    step_all(
        StepAll {
            scheme,
            kernels,
            paths,
            input,
        },
        width,
    )
}

/// Takes the constraint that offers the closed form, with the step for it.
struct ClosedFormOnly<'a, Sch, K>(PhantomData<&'a mut Sch>, PhantomData<K>);

/// [`StepAll`] for the offered constraint at the instruction set of a width.
type ClosedFormStep<'a, Sch, K> = fn(StepAll<'a, Sch, K>, LaneWidth) -> bool;

impl<'a, Sch: Scheme, K: SphereKernels<Sch>> LaneFormVisitor for ClosedFormOnly<'a, Sch, K> {
    type Output = Option<ClosedFormStep<'a, Sch, K>>;
    fn none(self) -> Self::Output {
        None
    }
    fn closed_form<E: Equations>(self, constraint: &E) -> Self::Output {
        let _ = constraint;
        Some(StepAll::offered::<E>)
    }
}

/// The offered constraint of type E itself, a copy (the scheme is borrowed again to step).
struct Fetch<E>(PhantomData<E>);

impl<E: Equations> LaneFormVisitor for Fetch<E> {
    type Output = Option<E>;
    fn none(self) -> Option<E> {
        None
    }
    fn closed_form<O: Equations>(self, constraint: &O) -> Option<E> {
        (constraint as &dyn Any).downcast_ref::<E>().cloned()
    }
}

/// One step of every path.
struct StepAll<'a, Sch, K> {
    scheme: &'a mut Sch,
    kernels: K,
    paths: &'a mut LanePaths,
    input: StepInput<'a>,
}

/// [`StepAll`] with the constraint of the kernels.
struct WithConstraint<'a, 'c, Sch, K, E> {
    all: StepAll<'a, Sch, K>,
    constraint: &'c E,
}

impl<Sch: Scheme, K: SphereKernels<Sch>, E: Equations> WithSimd
    for WithConstraint<'_, '_, Sch, K, E>
{
    type Output = bool;
    #[inline(always)]
    fn with_simd<Sd: Simd>(self, simd: Sd) -> bool {
        match Equations::dim(self.constraint) {
            2 => self.step::<Sd, 2>(simd),
            _ => self.step::<Sd, 3>(simd),
        }
    }
}

impl<Sch: Scheme, K: SphereKernels<Sch>> StepAll<'_, Sch, K> {
    /// [`StepAll::checked`] with the constraint of type E the system offers (`false` if it
    /// offers none of that type after all).
    fn offered<E: Equations>(self, width: LaneWidth) -> bool {
        let system = self.scheme.system();
        let fetched = system
            .constraint()
            .lane_form(system.mass(), Fetch::<E>(PhantomData));
        match fetched {
            Some(constraint) => self.checked(&constraint, width),
            None => false,
        }
    }

    /// Every group at the instruction set of `width`, if the dimensions fit.
    #[inline(always)]
    fn checked<E: Equations>(self, constraint: &E, width: LaneWidth) -> bool {
        let n = Equations::dim(constraint);
        if n > SPHERE_LANES_MAX_DIM || self.paths.noise_dim() > n {
            return false;
        }
        width.dispatch(WithConstraint {
            all: self,
            constraint,
        })
    }
}

impl<Sch: Scheme, K: SphereKernels<Sch>, E: Equations> WithConstraint<'_, '_, Sch, K, E> {
    #[inline(always)]
    fn step<Sd: Simd, const N: usize>(self, simd: Sd) -> bool {
        let StepAll {
            scheme,
            kernels,
            paths,
            input,
        } = self.all;
        let Some(kernel) = kernels.kernel::<E, N>(scheme, self.constraint, input.h) else {
            return false;
        };
        paths.step_groups(simd, scheme, input, &kernel)
    }
}
