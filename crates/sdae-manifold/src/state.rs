//! Checks that a state (r, v) lies on the tangent bundle TM = {g(r) = 0, Dg(r) v = 0}.

use crate::constraint::Constraint;
use crate::error::{ManifoldError, check_finite, check_len};

/// Sizes of the constraint residuals of a state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateResiduals {
    /// max_i |g_i(r)|.
    pub position: f64,
    /// max_i |(Dg(r) v)_i|.
    pub velocity: f64,
}

/// Default tolerance of [`check_state`] for |g(r)| and |Dg(r) v|.
pub const DEFAULT_STATE_TOLERANCE: f64 = 1e-10;

fn max_abs(values: &[f64]) -> (usize, f64) {
    values.iter().enumerate().fold(
        (0, 0.0),
        |(bi, bv), (i, v)| if v.abs() > bv { (i, v.abs()) } else { (bi, bv) },
    )
}

/// Measures max |g(r)| and max |Dg(r) v| after checking lengths and finiteness.
pub fn state_residuals<C: Constraint + ?Sized>(
    constraint: &C, r: &[f64], v: &[f64],
) -> Result<(StateResiduals, usize, usize), ManifoldError> {
    let n = constraint.dim();
    check_len("position r", n, r)?;
    check_len("velocity v", n, v)?;
    check_finite("position r", r)?;
    check_finite("velocity v", v)?;
    let mut g = vec![0.0; constraint.n_constraints()];
    constraint.value(r, &mut g);
    let (ig, position) = max_abs(&g);
    constraint.jacobian_mul(r, v, &mut g);
    let (iv, velocity) = max_abs(&g);
    Ok((StateResiduals { position, velocity }, ig, iv))
}

/// Fails with [`ManifoldError::OffManifold`] or [`ManifoldError::OffTangent`] unless
/// |g(r)| <= tolerance and |Dg(r) v| <= tolerance (max norms).
pub fn check_state<C: Constraint + ?Sized>(
    constraint: &C, r: &[f64], v: &[f64], tolerance: f64,
) -> Result<StateResiduals, ManifoldError> {
    let (res, ig, iv) = state_residuals(constraint, r, v)?;
    if res.position > tolerance {
        return Err(ManifoldError::OffManifold {
            residual: res.position,
            index: ig,
            tolerance,
        });
    }
    if res.velocity > tolerance {
        return Err(ManifoldError::OffTangent {
            residual: res.velocity,
            index: iv,
            tolerance,
        });
    }
    Ok(res)
}
