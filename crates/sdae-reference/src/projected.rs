//! Projected Euler-Maruyama: what a user of a general SDE suite would do with the inherent SDE.

use sdae_ift::SolverSettings;
use sdae_manifold::Constraint;
use sdae_model::TangentProjector;

use crate::error::{ReferenceError, check_finite};
use crate::euler::EulerCore;
use crate::inherent::{CurvedSystem, InherentSde};
use sdae_model::{StepFailure, StepOutcome, StepResult};

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
/// is not truncated, so large steps can still blow up ([`StepFailure::NonFinite`]), and a
/// projection that finds no acceptable root gives [`StepFailure::Root`]. The projection is
/// the [`TangentProjector`] shared with the initial-state projection.
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

    /// Projects the proposed state (`core.next_r`, `core.next_v`) onto the tangent bundle: r
    /// along the normal M^-1 grad g(r), then v M-orthogonally onto the tangent space at the
    /// new r. Returns the Newton iterations.
    fn project_proposal(&mut self) -> Result<usize, StepFailure> {
        let core = &mut self.core;
        let system = core.sde.system();
        let (constraint, mass) = (system.constraint(), system.mass());
        let certificate = self
            .projector
            .project_position(constraint, mass, &mut core.next_r)
            .map_err(|source| StepFailure::Root {
                what: "projection onto the manifold",
                source,
            })?;
        check_finite("projected position", &core.next_r)?;
        self.projector
            .project_velocity(constraint, mass, &core.next_r, &mut core.next_v)?;
        check_finite("projected velocity", &core.next_v)?;
        Ok(certificate.iterations)
    }
}

impl<S: CurvedSystem> ProjectedEulerMaruyama<S> {
    /// One Euler-Maruyama step of eq. 2.4, then the projection (see the type's
    /// documentation), proposed.
    fn propose(&mut self, r: &[f64], v: &[f64], h: f64, dw: &[f64]) -> StepResult {
        self.core.propose(r, v, h, dw, |_, _| 1.0)?;
        let newton_iterations = self.project_proposal()?;
        Ok(StepOutcome {
            newton_iterations,
            ..StepOutcome::PLAIN
        })
    }
}

inherent_scheme!(ProjectedEulerMaruyama);
