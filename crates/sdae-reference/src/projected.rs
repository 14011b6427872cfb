//! Projected Euler-Maruyama: what a user of a general SDE suite would do with the inherent SDE.

use sdae_ift::{BallProblem, BallSolver, Factorize, SolverSettings};
use sdae_manifold::{Constraint, Mass, scratch_len};

use crate::error::{ReferenceError, check_finite};
use crate::euler::EulerCore;
use crate::inherent::{CurvedSystem, InherentSde};
use crate::path::{ReferenceSolver, ReferenceStepReport};

/// R(gamma) = g(y + M^-1 grad g(y) gamma): the point of the manifold on the normal line through
/// y (the kappa system of seed eq. 3.1 with eta = 0 and r = y), Jacobian Dg(x) M^-1 grad g(y).
/// After a successful solve `x` holds the projected point (the last evaluation is at the root).
struct NormalLine<'a, C, M> {
    constraint: &'a C,
    mass: &'a M,
    y: &'a [f64],
    x: &'a mut [f64],
    scratch: &'a mut [f64],
}

impl<C, M> BallProblem for NormalLine<'_, C, M>
where
    C: Constraint<Gram: Factorize>,
    M: Mass,
{
    type Matrix = C::Gram;
    fn dim(&self) -> usize {
        self.constraint.n_constraints()
    }
    fn new_matrix(&self) -> C::Gram {
        self.constraint.new_gram()
    }
    fn evaluate(&mut self, gamma: &[f64], residual: &mut [f64], jacobian: Option<&mut C::Gram>) {
        let c = self.constraint;
        c.displace(self.y, gamma, self.mass, self.y, self.x);
        match jacobian {
            Some(j) => c.value_and_cross_gram(self.x, self.y, self.mass, self.scratch, residual, j),
            None => c.value(self.x, residual),
        }
    }
    fn residual_floor(&self) -> f64 {
        self.constraint
            .value_roundoff(sdae_manifold::vector::max_abs(self.y))
    }
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
/// is not truncated, so large steps can still blow up ([`ReferenceError::NonFinite`]), and a
/// projection that finds no acceptable root gives [`ReferenceError::Projection`].
#[derive(Debug, Clone)]
pub struct ProjectedEulerMaruyama<S: CurvedSystem> {
    core: EulerCore<S>,
    solver: BallSolver<<S::Constraint as Constraint>::Gram>,
    /// The unprojected position r^.
    y: Vec<f64>,
    /// The projected position.
    x: Vec<f64>,
    scratch: Vec<f64>,
    work: Vec<f64>,
}

impl<S: CurvedSystem> ProjectedEulerMaruyama<S> {
    /// The solver for `system` with the default root-solver settings.
    pub fn new(system: S) -> Result<Self, ReferenceError> {
        Self::with_settings(system, SolverSettings::default())
    }

    /// The solver for `system` with the given settings of the position projection's root solver.
    pub fn with_settings(system: S, settings: SolverSettings) -> Result<Self, ReferenceError> {
        let core = EulerCore::new(system)?;
        let (n, m) = (core.sde.dim(), core.sde.n_constraints());
        let solver = BallSolver::new(core.sde.system().constraint().new_gram(), settings);
        Ok(Self {
            core,
            solver,
            y: vec![0.0; n],
            x: vec![0.0; n],
            scratch: vec![0.0; scratch_len(n, m)],
            work: vec![0.0; m],
        })
    }

    /// Projects the proposed state (`core.next_r`, `core.next_v`) onto the tangent bundle: r
    /// along the normal M^-1 grad g(r), then v M-orthogonally onto the tangent space at the
    /// new r. Returns the Newton iterations.
    fn project_proposal(&mut self) -> Result<usize, ReferenceError> {
        let core = &mut self.core;
        self.y.copy_from_slice(&core.next_r);
        let system = core.sde.system();
        let certificate = {
            let mut problem = NormalLine {
                constraint: system.constraint(),
                mass: system.mass(),
                y: &self.y,
                x: &mut self.x,
                scratch: &mut self.scratch,
            };
            self.solver
                .solve(&mut problem, f64::INFINITY)
                .map_err(|source| ReferenceError::Projection { source })?
        };
        check_finite("projected position", &self.x)?;
        core.next_r.copy_from_slice(&self.x);
        core.sde.prepare(&core.next_r)?;
        core.sde
            .project_velocity_prepared(&core.next_r, &mut core.next_v, &mut self.work);
        check_finite("projected velocity", &core.next_v)?;
        Ok(certificate.iterations)
    }
}

impl<S: CurvedSystem> ReferenceSolver for ProjectedEulerMaruyama<S> {
    type System = S;
    fn sde(&self) -> &InherentSde<S> {
        &self.core.sde
    }
    /// One Euler-Maruyama step of eq. 2.4, then the projection (see the type's documentation).
    /// (r, v) are unchanged on failure.
    fn step(
        &mut self,
        r: &mut [f64],
        v: &mut [f64],
        h: f64,
        dw: &[f64],
    ) -> Result<ReferenceStepReport, ReferenceError> {
        self.core.propose(r, v, h, dw, |_, _| 1.0)?;
        let projection_iterations = self.project_proposal()?;
        self.core.commit(r, v);
        Ok(ReferenceStepReport {
            projection_iterations,
            ..ReferenceStepReport::default()
        })
    }
    fn multiplier_increment(&self) -> &[f64] {
        &self.core.dmu
    }
}
