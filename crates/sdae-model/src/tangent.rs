//! Points of the manifold along a normal line, and the projection onto the tangent bundle.
//!
//! One root problem serves the step and the projections: the kappa system of seed eq. 3.1
//! (upper part), R(gamma) = g(y + M^-1 grad g(r) gamma) = 0, solved by the ball solver of
//! `sdae-ift` (closed form where the constraint has one). With r = y it is the projection of y
//! onto the manifold along its own normal line.

use sdae_ift::{BallProblem, BallSolver, Certificate, IftError, SolverSettings};
use sdae_manifold::{Constraint, Factorize, LinearError, Mass, Solve, scratch_len};

use crate::error::ModelError;

/// The kappa system R(gamma) = g(y + M^-1 grad g(r) gamma), y = r + eta v h, with Jacobian
/// Dg(x) M^-1 grad g(r) at x = y + M^-1 grad g(r) gamma (seed eq. 3.1 upper part, eq. 3.10).
/// After a successful solve the root's point is `y` if `at_y` and `x` otherwise (the solver's
/// last evaluation is at the root; at gamma = 0 the point is y itself and is not copied).
pub struct KappaProblem<'a, C, M> {
    /// The constraint g.
    pub constraint: &'a C,
    /// The mass M.
    pub mass: &'a M,
    /// The point r whose normals M^-1 grad g(r) span the line.
    pub r: &'a [f64],
    /// The point y the line passes through.
    pub y: &'a [f64],
    /// The point x = y + M^-1 grad g(r) gamma of the last evaluation.
    pub x: &'a mut [f64],
    /// Workspace of length [`scratch_len`].
    pub scratch: &'a mut [f64],
    /// The residual floor of g near y ([`Constraint::roundoff`]).
    pub floor: f64,
    /// Whether the last evaluation was at gamma = 0, i.e. at x = y.
    pub at_y: bool,
    /// v~ of the lambda system Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ (seed eq. 3.1, lower
    /// part), whose matrix is the Jacobian at the root: given, the solver may solve it while
    /// it factors that Jacobian ([`BallSolver::companion`]).
    pub velocity: Option<&'a [f64]>,
}

impl<C, M> BallProblem for KappaProblem<'_, C, M>
where
    C: Constraint,
    M: Mass,
{
    type Matrix = C::Gram;
    fn dim(&self) -> usize {
        self.constraint.n_constraints()
    }
    #[inline(always)]
    fn evaluate(&mut self, gamma: &[f64], residual: &mut [f64], jacobian: Option<&mut C::Gram>) {
        let c = self.constraint;
        self.at_y = gamma.iter().all(|&g| g == 0.0);
        let x: &[f64] = if self.at_y {
            self.y
        } else {
            c.displace(self.r, gamma, self.mass, self.y, self.x);
            self.x
        };
        match jacobian {
            Some(j) => c.value_and_cross_gram(x, self.r, self.mass, self.scratch, residual, j),
            None => c.value(x, residual),
        }
    }
    /// The closed form of the kappa system where the constraint has one
    /// (`Constraint::kappa_quadratic`, e.g. the sphere with a diagonal mass).
    #[inline]
    fn quadratic(&mut self) -> Option<[f64; 3]> {
        self.constraint.kappa_quadratic(self.r, self.y, self.mass)
    }
    fn residual_floor(&self) -> f64 {
        self.floor
    }
    /// -Dg(x) v~ at the last evaluation's point, the lambda system's right-hand side.
    #[inline]
    fn companion_rhs(&mut self, out: &mut [f64]) -> bool {
        let Some(velocity) = self.velocity else {
            return false;
        };
        let x: &[f64] = if self.at_y { self.y } else { self.x };
        lambda_right_hand_side(self.constraint, x, velocity, out);
        true
    }
}

/// out = -Dg(x) v~, the right-hand side of the lambda system Dg(x) M^-1 grad g(r) lambda =
/// -Dg(x) v~ at the new position x (seed eq. 3.1, lower part).
#[inline]
pub fn lambda_right_hand_side<C: Constraint>(
    constraint: &C, x: &[f64], velocity: &[f64], out: &mut [f64],
) {
    constraint.jacobian_mul(x, velocity, out);
    for o in out.iter_mut() {
        *o = -*o;
    }
}

/// Projection onto the tangent bundle {(r, v) : g(r) = 0, Dg(r) v = 0}, with buffers created
/// once: r along its normal line M^-1 grad g(r) onto the manifold, then v M-orthogonally onto
/// the tangent space at the new r.
#[derive(Debug, Clone)]
pub struct TangentProjector<G: Factorize> {
    solver: BallSolver<G>,
    gram: G,
    factor: G::Factor,
    y: Vec<f64>,
    x: Vec<f64>,
    scratch: Vec<f64>,
    lambda: Vec<f64>,
}

impl<G: Factorize> TangentProjector<G> {
    /// Buffers for `constraint`, with the given settings of the position's root solver.
    pub fn new<C: Constraint<Gram = G>>(constraint: &C, settings: SolverSettings) -> Self {
        let (n, m) = (constraint.dim(), constraint.n_constraints());
        let gram = constraint.new_gram();
        Self {
            solver: BallSolver::new(constraint.new_gram(), settings),
            factor: gram.new_factor(),
            gram,
            y: vec![0.0; n],
            x: vec![0.0; n],
            scratch: vec![0.0; scratch_len(n, m)],
            lambda: vec![0.0; m],
        }
    }

    /// The settings of the position projection's root solver.
    pub fn settings(&self) -> &SolverSettings {
        self.solver.settings()
    }

    /// r <- the root of g(r + M^-1 grad g(r) gamma) = 0 (the kappa system with eta = 0 and
    /// y = r): the point of the manifold on the normal line through r. Returns the solver's
    /// certificate; r is unchanged on failure.
    ///
    /// Inlined, so that a caller that reads only part of the certificate does not have it built
    /// in memory and copied back: out of line, the copy read fields just written one by one,
    /// a stalled store-to-load forward each step (projected Euler-Maruyama measured 138 ns per
    /// step of one path against 131 ns inlined, docs/performance.md).
    #[inline]
    pub fn project_position<C, M>(
        &mut self, constraint: &C, mass: &M, r: &mut [f64],
    ) -> Result<Certificate, IftError>
    where
        C: Constraint<Gram = G>,
        M: Mass,
    {
        self.y.copy_from_slice(r);
        let floor = constraint
            .roundoff()
            .floor(sdae_manifold::vector::max_abs(&self.y));
        let mut problem = KappaProblem {
            constraint,
            mass,
            r: &self.y,
            y: &self.y,
            x: &mut self.x,
            scratch: &mut self.scratch,
            floor,
            at_y: false,
            velocity: None,
        };
        let certificate = self.solver.solve(&mut problem, f64::INFINITY)?;
        if !problem.at_y {
            r.copy_from_slice(&self.x);
        }
        Ok(certificate)
    }

    /// v <- v - M^-1 grad g(r) G_M(r)^-1 Dg(r) v: the M-orthogonal projection onto the tangent
    /// space at r (seed Section 2.1, P_M(r)^T applied to the momentum).
    pub fn project_velocity<C, M>(
        &mut self, constraint: &C, mass: &M, r: &[f64], v: &mut [f64],
    ) -> Result<(), LinearError>
    where
        C: Constraint<Gram = G>,
        M: Mass,
    {
        constraint.cross_gram(r, r, mass, &mut self.scratch, &mut self.gram);
        self.gram.factor_into(&mut self.factor)?;
        constraint.jacobian_mul(r, v, &mut self.lambda);
        self.factor.solve_in_place(&mut self.lambda);
        constraint.jacobian_transpose_mul(r, &self.lambda, &mut self.x);
        mass.apply_inverse(&mut self.x);
        for (vi, xi) in v.iter_mut().zip(&self.x) {
            *vi -= xi;
        }
        Ok(())
    }
}

/// Moves (r, v) onto the tangent bundle with a [`TangentProjector`]: for states that are nearly
/// on it (an initial state written with a few digits, say). Returns the position's displacement
/// |r_new - r|.
pub fn project_state<C, M>(
    constraint: &C, mass: &M, r: &mut [f64], v: &mut [f64],
) -> Result<f64, ModelError>
where
    C: Constraint,
    M: Mass,
{
    let n = constraint.dim();
    sdae_manifold::check_len("position r", n, r)?;
    sdae_manifold::check_len("velocity v", n, v)?;
    sdae_manifold::check_finite("position r", r)?;
    sdae_manifold::check_finite("velocity v", v)?;
    mass.check_order(n)?;
    let mut projector = TangentProjector::new(constraint, SolverSettings::default());
    let start = r.to_vec();
    projector
        .project_position(constraint, mass, r)
        .map_err(|e| ModelError::InvalidSetting {
            name: "initial state",
            value: f64::NAN,
            reason: match e {
                IftError::NoRoot { .. } => "no point of the manifold along M^-1 grad g(r) from r",
                _ => "projection onto the manifold did not converge",
            },
        })?;
    projector
        .project_velocity(constraint, mass, r, v)
        .map_err(|_| ModelError::InvalidSetting {
            name: "initial state",
            value: f64::NAN,
            reason: "Gram matrix G_M(r) is singular: Dg(r) does not have full rank",
        })?;
    Ok(start
        .iter()
        .zip(r.iter())
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt())
}
