//! Projecting an initial state onto the tangent bundle, on explicit request.

use sdae_ift::{BallSolver, Factorize, IftError, Solve, SolverSettings};
use sdae_manifold::{Constraint, Mass, scratch_len};

use crate::error::SchemeError;
use crate::stepper::KappaProblem;

/// Moves r onto the manifold along M^-1 grad g(r) and then v onto the tangent space at the new r
/// (v <- v - M^-1 grad g(r) G_M(r)^-1 Dg(r) v, the M-orthogonal projection). For states that are
/// nearly on the manifold; the projection's displacement is returned.
pub fn project_state<C, M>(
    constraint: &C,
    mass: &M,
    r: &mut [f64],
    v: &mut [f64],
) -> Result<f64, SchemeError>
where
    C: Constraint,
    C::Gram: Factorize,
    M: Mass,
{
    let (n, m) = (constraint.dim(), constraint.n_constraints());
    sdae_manifold::check_len("position r", n, r)?;
    sdae_manifold::check_len("velocity v", n, v)?;
    sdae_manifold::check_finite("position r", r)?;
    sdae_manifold::check_finite("velocity v", v)?;
    mass.check_order(n)?;
    let mut x = vec![0.0; n];
    let mut scratch = vec![0.0; scratch_len(n, m)];
    let mut solver = BallSolver::new(constraint.new_gram(), SolverSettings::default());
    let project_error = |e: IftError| SchemeError::InvalidSetting {
        name: "initial state",
        value: f64::NAN,
        reason: match e {
            IftError::NoRoot { .. } => "no point of the manifold along M^-1 grad g(r) from r",
            _ => "projection onto the manifold did not converge",
        },
    };
    // The kappa system with y = r: g(r + M^-1 grad g(r) gamma) = 0.
    let y = r.to_vec();
    let mut problem = KappaProblem {
        constraint,
        mass,
        r,
        y: &y,
        x: &mut x,
        scratch: &mut scratch,
        floor: 0.0,
        at_y: false,
    };
    solver
        .solve(&mut problem, f64::INFINITY)
        .map_err(project_error)?;
    if problem.at_y {
        x.copy_from_slice(&y);
    }
    let displacement = x
        .iter()
        .zip(r.iter())
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    r.copy_from_slice(&x);
    // Velocity: solve G_M(r) lambda = Dg(r) v, v <- v - M^-1 grad g(r) lambda.
    let mut gram = constraint.new_gram();
    constraint.cross_gram(r, r, mass, &mut scratch, &mut gram);
    let mut factor = gram.new_factor();
    gram.factor_into(&mut factor)
        .map_err(|_| SchemeError::InvalidSetting {
            name: "initial state",
            value: f64::NAN,
            reason: "Gram matrix G_M(r) is singular: Dg(r) does not have full rank",
        })?;
    let mut lambda = vec![0.0; m];
    constraint.jacobian_mul(r, v, &mut lambda);
    factor.solve_in_place(&mut lambda);
    constraint.jacobian_transpose_mul(r, &lambda, &mut x);
    mass.apply_inverse(&mut x);
    for (vi, xi) in v.iter_mut().zip(&x) {
        *vi -= xi;
    }
    Ok(displacement)
}
