//! The way a scheme steps the paths of a system on a sphere (dimension 2 or 3, a diagonal mass)
//! in lanes, shared by the schemes whose lane form is a [`LaneKernel`] per sphere dimension:
//! take the sphere the constraint offers ([`LaneFormVisitor::sphere`], so that the kernels are
//! compiled only for systems on a sphere), choose the instruction set of the width and the
//! dimension, build the kernel and step every group of lanes
//! ([`LanePaths::step_groups`]). A scheme's own step of one path runs the same kernels at W = 1
//! ([`step_one_lane`](crate::engine::step_one_lane)).

use std::marker::PhantomData;

use pulp::{Scalar, Simd, WithSimd};
use sdae_lanes::{LaneWidth, Lanes};
use sdae_manifold::lane_form::LaneFormVisitor;
use sdae_manifold::{Constraint, Mass, Sphere};

use crate::lane_ensemble::{LaneKernel, LanePaths, LaneStep, StepInput};
use crate::scheme::Scheme;
use crate::sphere_root::RootLanes;
use crate::system::System;

/// The largest sphere dimension stepped in lanes (the planar and the spherical pendulum).
pub const SPHERE_LANES_MAX_DIM: usize = 3;

/// A scheme's lane kernels on a sphere: the kernel of one step of size h for a sphere of N = 2
/// or 3 coordinates, or `None` where the scheme has none (every path then goes through the
/// scalar step).
pub trait SphereKernels<Sch: ?Sized> {
    /// The kernel for N coordinates.
    type Kernel<const N: usize>: LaneKernel<Sch, N>;
    /// The kernel of a step of size h on `sphere`.
    fn kernel<const N: usize>(
        &self, scheme: &Sch, sphere: &Sphere, h: f64,
    ) -> Option<Self::Kernel<N>>;
    /// The kernel's step of one path at W = 1
    /// ([`step_one_lane`](crate::engine::step_one_lane)), with its kappa root where the scheme
    /// reads it: [`LaneKernel::step`] and no root unless overridden.
    #[inline(always)]
    fn step_with_root<const N: usize>(
        &self, kernel: &Self::Kernel<N>, scheme: &Sch, r: &[Lanes<Scalar>; N],
        v: &[Lanes<Scalar>; N], dw: &[Lanes<Scalar>],
    ) -> Option<(LaneStep<Scalar, N>, Option<RootLanes<Scalar, N>>)> {
        kernel.step(scheme, r, v, dw).map(|step| (step, None))
    }
}

/// Steps every path of `paths` through the kernels of `kernels` where the scheme's system is a
/// sphere of dimension at most [`SPHERE_LANES_MAX_DIM`] with a diagonal mass and at most as many
/// noise components; `false`, having changed nothing, otherwise.
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
        SphereOnly::<'_, Sch, K>(PhantomData, PhantomData),
    );
    let Some((sphere, step_all)) = choice else {
        return false;
    };
    step_all(
        StepAll {
            scheme,
            kernels,
            paths,
            sphere,
            input,
        },
        width,
    )
}

/// [`step_sphere_lanes`] for a scheme that has taken the sphere from its constraint itself:
/// `false`, having changed nothing, beyond [`SPHERE_LANES_MAX_DIM`] coordinates, with more
/// noise components than coordinates or where the kernels give none.
#[inline(always)]
pub fn step_sphere_groups<Sch, K>(
    scheme: &mut Sch, kernels: K, paths: &mut LanePaths, width: LaneWidth, sphere: Sphere,
    input: StepInput<'_>,
) -> bool
where
    Sch: Scheme,
    K: SphereKernels<Sch>,
{
    let all = StepAll {
        scheme,
        kernels,
        paths,
        sphere,
        input,
    };
    all.checked(width)
}

/// Takes the sphere a constraint offers with the step for it.
struct SphereOnly<'a, Sch, K>(PhantomData<&'a mut Sch>, PhantomData<K>);

/// [`StepAll`] at the instruction set of a width.
type SphereStep<'a, Sch, K> = fn(StepAll<'a, Sch, K>, LaneWidth) -> bool;

impl<'a, Sch: Scheme, K: SphereKernels<Sch>> LaneFormVisitor for SphereOnly<'a, Sch, K> {
    type Output = Option<(Sphere, SphereStep<'a, Sch, K>)>;
    fn none(self) -> Self::Output {
        None
    }
    fn sphere(self, sphere: &Sphere) -> Self::Output {
        Some((*sphere, StepAll::checked))
    }
}

/// One step of every path.
struct StepAll<'a, Sch, K> {
    scheme: &'a mut Sch,
    kernels: K,
    paths: &'a mut LanePaths,
    sphere: Sphere,
    input: StepInput<'a>,
}

impl<Sch: Scheme, K: SphereKernels<Sch>> WithSimd for StepAll<'_, Sch, K> {
    type Output = bool;
    #[inline(always)]
    fn with_simd<Sd: Simd>(self, simd: Sd) -> bool {
        match self.sphere.dim() {
            2 => self.step::<Sd, 2>(simd),
            _ => self.step::<Sd, 3>(simd),
        }
    }
}

impl<Sch: Scheme, K: SphereKernels<Sch>> StepAll<'_, Sch, K> {
    /// Every group at the instruction set of `width`, if the dimensions fit.
    #[inline(always)]
    fn checked(self, width: LaneWidth) -> bool {
        let n = self.sphere.dim();
        if n > SPHERE_LANES_MAX_DIM || self.paths.noise_dim() > n {
            return false;
        }
        width.dispatch(self)
    }

    #[inline(always)]
    fn step<Sd: Simd, const N: usize>(self, simd: Sd) -> bool {
        let Some(kernel) = self
            .kernels
            .kernel::<N>(self.scheme, &self.sphere, self.input.h)
        else {
            return false;
        };
        self.paths
            .step_groups(simd, self.scheme, self.input, &kernel)
    }
}
