//! A scheme's own step of one path on a sphere through its lane kernel at W = 1
//! ([`step_one_lane`]): the ensemble's code in plain f64, so that a path stepped alone has,
//! bit for bit, the numbers its lane has in an ensemble. Each scheme translates the lane-0
//! values ([`OneLaneStep`]) into its own [`StepOutcome`](crate::StepOutcome).

use pulp::Scalar;
use sdae_lanes::Lanes;
use sdae_manifold::lane_form::LaneFormVisitor;
use sdae_manifold::{Constraint, Equations, Mass};

use crate::scheme::Scheme;
use crate::sphere_lanes::SphereKernels;
use crate::system::System;

/// Lane 0 of a step that the lane form decided at W = 1 ([`step_one_lane`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneLaneStep {
    /// The step's eta (1 for a scheme that does not truncate).
    pub eta: f64,
    /// mu_{k+1} - mu_k.
    pub dmu: f64,
    /// |g(r_{k+1})|, where the kernel measures it.
    pub position_residual: Option<f64>,
    /// |Dg(r_{k+1}) v_{k+1}|, where the kernel measures it.
    pub velocity_residual: Option<f64>,
    /// The kappa root of the step, where the kernels report it
    /// ([`SphereKernels::step_with_root`]).
    pub root: Option<OneLaneRoot>,
}

/// Lane 0 of the closed-form kappa root of a step ([`RootLanes`](crate::engine::RootLanes)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneLaneRoot {
    /// gamma, the root.
    pub gamma: f64,
    /// |R(0) / R'(0)|, the first Newton step's length.
    pub first_step: f64,
    /// |R''(0) gamma / R'(0)|, the contraction of the Newton map.
    pub contraction: f64,
    /// |R(gamma)|.
    pub residual: f64,
}

/// A scheme's step of one path (checked input) through the kernels `kernels` at W = 1, where
/// its system is a sphere of dimension 2 or 3 with a diagonal mass and at most as many noise
/// components as coordinates: r, v and dw as lanes of one path in plain f64
/// ([`pulp::Scalar`]), the kernel's step ([`SphereKernels::step_with_root`]), and on a decided
/// lane (r, v) <- (r_{k+1}, v_{k+1}) with lane 0 of the step. `None` where the lane form does
/// not apply (another constraint or mass, no kernel) or does not decide the step; (r, v) are
/// then unchanged and the scheme's general path decides, with its errors.
#[inline]
pub fn step_one_lane<Sch, K>(
    scheme: &Sch, kernels: K, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64],
) -> Option<OneLaneStep>
where
    Sch: Scheme,
    K: SphereKernels<Sch>,
{
    if !<<Sch::System as System>::Mass as Mass>::DIAGONAL {
        return None;
    }
    let system = scheme.system();
    let step = OneLane {
        scheme,
        kernels,
        r,
        v,
        h,
        dw,
    };
    system.constraint().lane_form(system.mass(), step)
}

/// [`step_one_lane`] where the constraint offers the closed form
/// ([`LaneFormVisitor::closed_form`]): the kernels are compiled only for constraints that do.
struct OneLane<'a, Sch, K> {
    scheme: &'a Sch,
    kernels: K,
    r: &'a mut [f64],
    v: &'a mut [f64],
    h: f64,
    dw: &'a [f64],
}

impl<Sch: Scheme, K: SphereKernels<Sch>> LaneFormVisitor for OneLane<'_, Sch, K> {
    type Output = Option<OneLaneStep>;
    fn none(self) -> Option<OneLaneStep> {
        None
    }
    #[inline(always)]
    fn closed_form<E: Equations>(self, constraint: &E) -> Option<OneLaneStep> {
        let n = Equations::dim(constraint);
        match (n, self.dw.len() <= n) {
            (2, true) => self.step::<E, 2>(constraint),
            (3, true) => self.step::<E, 3>(constraint),
            _ => None,
        }
    }
}

impl<Sch: Scheme, K: SphereKernels<Sch>> OneLane<'_, Sch, K> {
    /// The kernel's step for N coordinates at W = 1.
    #[inline(always)]
    fn step<E: Equations, const N: usize>(self, constraint: &E) -> Option<OneLaneStep> {
        let kernel = self
            .kernels
            .kernel::<E, N>(self.scheme, constraint, self.h)?;
        let lanes = |x: &[f64]| -> [Lanes<Scalar>; N] {
            std::array::from_fn(|i| Lanes::splat(Scalar, x.get(i).copied().unwrap_or(0.0)))
        };
        let (r, v, dw) = (lanes(self.r), lanes(self.v), lanes(self.dw));
        let dw = &dw[..self.dw.len()];
        let (step, root) = self
            .kernels
            .step_with_root(&kernel, self.scheme, &r, &v, dw)?;
        if !step.ok.lane(0) {
            return None;
        }
        for i in 0..N {
            self.r[i] = step.r[i].lane(0);
            self.v[i] = step.v[i].lane(0);
        }
        Some(OneLaneStep {
            eta: step.record.eta.lane(0),
            dmu: step.dmu.lane(0),
            position_residual: step.record.position_residual.map(|x| x.lane(0)),
            velocity_residual: step.record.velocity_residual.map(|x| x.lane(0)),
            root: root.map(|root| OneLaneRoot {
                gamma: root.gamma.lane(0),
                first_step: root.first_step.lane(0),
                contraction: root.contraction.lane(0),
                residual: root.residual.lane(0),
            }),
        })
    }
}
