//! Projected Euler-Maruyama: what a user of a general SDE suite would do with the inherent SDE.

use sdae_ift::SolverSettings;
use sdae_lanes::{PathMask, Real};
use sdae_manifold::Constraint;
use sdae_model::{KernelState, StepOutcome, StepResult, TangentProjector};

use crate::error::ReferenceError;
use crate::euler::{EulerCore, euler_step};
use crate::inherent::{CurvedSystem, InherentSde};
use crate::kernel::{Next, Parts, Projecting, ProjectionKernel, Stepped};

/// One projected Euler-Maruyama step (see [`ProjectedEulerMaruyama`]), written once over
/// [`Real`]: the Euler-Maruyama step to (y, u) into `next` ([`euler_step`]), then in place
///
/// ```text
/// r' = y + M^-1 grad g(y) gamma,  g(r') = 0
/// v' = u - M^-1 grad g(r') G_M(r')^-1 Dg(r') u
/// ```
///
/// ([`ProjectionKernel::project_position`], [`ProjectionKernel::project_velocity`]) with dmu
/// that of the Euler-Maruyama step. The paths where the step and both projections
/// are defined and finite are decided.
#[inline(always)]
pub(crate) fn projected_step<T: Real, K: ProjectionKernel<T>>(
    kernel: &mut K, state: KernelState<'_, T>, h: f64, parts: &mut Parts<'_, T>,
    next: &mut Next<'_, T>,
) -> Result<Stepped<T>, K::Error> {
    let stepped = euler_step(kernel, state, h, None, parts, next)?;
    let (placed, newton_iterations) = kernel.project_position(next.r)?;
    let position = kernel.finite("projected position", next.r)?;
    let tangent = kernel.project_velocity(next.r, next.v)?;
    let velocity = kernel.finite("projected velocity", next.v)?;
    Ok(Stepped {
        ok: stepped
            .ok
            .and(placed)
            .and(position)
            .and(tangent)
            .and(velocity),
        newton_iterations,
        ..stepped
    })
}

/// Euler-Maruyama on the inherent SDE (seed eq. 2.4, see [`crate::EulerMaruyama`]) followed by
/// projection onto the tangent bundle:
///
/// ```text
/// (r^, v^) = Euler-Maruyama step of eq. 2.4 from (r, v)
/// r'  = r^ + M^-1 grad g(r^) gamma,   g(r') = 0              (root in gamma by BallSolver)
/// v'  = v^ - M^-1 grad g(r') G_M(r')^-1 Dg(r') v^            (M-orthogonal projection)
/// dmu = eq. 2.3 at (r, v), as for Euler-Maruyama
/// ```
///
/// The state stays on the tangent bundle to the solver's tolerance. The projection does not
/// improve the order of Euler-Maruyama; it removes the O(h) drift off the manifold. The drift
/// is not truncated, so large steps can still blow up
/// ([`sdae_model::StepFailure::NonFinite`]), and a projection that finds no acceptable root
/// gives [`sdae_model::StepFailure::Root`]. The projection is the [`TangentProjector`] shared
/// with the initial-state projection.
#[derive(Debug, Clone)]
pub struct ProjectedEulerMaruyama<S: CurvedSystem> {
    core: EulerCore<S>,
    projector: TangentProjector<<S::Constraint as Constraint>::Gram>,
}

impl<S: CurvedSystem> ProjectedEulerMaruyama<S> {
    /// The solver for `system` with the default root-solver settings.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        Self::with_settings(system, SolverSettings::default())
    }

    /// The solver for `system` with the given settings of the position projection's root solver.
    pub fn with_settings(system: S, settings: SolverSettings) -> Result<Self, ReferenceError> {
        let core = EulerCore::new(system)?;
        let projector = TangentProjector::new(core.sde.system().constraint(), settings);
        Ok(Self { core, projector })
    }

    /// The settings of the position projection's root solver.
    pub fn projection_settings(&self) -> &SolverSettings {
        self.projector.settings()
    }
}

impl<S: CurvedSystem> ProjectedEulerMaruyama<S> {
    /// One Euler-Maruyama step of eq. 2.4, then the projection (see the type's
    /// documentation), proposed.
    fn propose(&mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> StepResult {
        let (kernel, mut parts, mut next) = self.core.checked(r, v, h, dw)?;
        let mut kernel = Projecting {
            kernel,
            projection: &mut self.projector,
        };
        let state = KernelState { r, v, dw };
        let stepped = projected_step(&mut kernel, state, h, &mut parts, &mut next)?;
        Ok(StepOutcome {
            newton_iterations: stepped.newton_iterations as usize,
            ..StepOutcome::PLAIN
        })
    }
}

inherent_scheme!(ProjectedEulerMaruyama);
