//! The initial state (r0, v0): lengths and finiteness, the rank of Dg(r0), and r0 on the
//! manifold and v0 on its tangent space, checked or projected (Newton on g = 0 along
//! M^-1 grad g, then the M-orthogonal projection of v0).

use sdae_manifold::{DEFAULT_STATE_TOLERANCE, DiagonalMass, Mass};

use crate::constraint::ConstraintPrograms;
use crate::error::{SpecError, SpecErrorKind};
use crate::spec::ExpressionSpec;

/// Pivots below this fraction of the largest entry of Dg count as zero in its rank.
pub const RANK_TOLERANCE: f64 = 1e-10;

/// Newton iterations of the projection onto g = 0 at most.
const PROJECTION_ITERATIONS: usize = 50;

/// (r0, v0) of `spec`, checked or projected.
pub(crate) fn initial_state(
    spec: &ExpressionSpec, c: &ConstraintPrograms, mass: &DiagonalMass,
) -> Result<(Vec<f64>, Vec<f64>), SpecError> {
    let n = c.n;
    let mut r = spec.position.clone();
    let mut v = spec.velocity.clone().unwrap_or_else(|| vec![0.0; n]);
    for (key, x) in [("position", &r), ("velocity", &v)] {
        if x.len() != n {
            return Err(SpecError::length(
                key,
                "one value per coordinate",
                n,
                x.len(),
            ));
        }
        if let Some(index) = x.iter().position(|x| !x.is_finite()) {
            let rule = "must be finite";
            let kind = SpecErrorKind::Value {
                value: x[index],
                index,
                rule,
            };
            return Err(SpecError::new(key, kind));
        }
    }
    check_rank(c, &r)?;
    if spec.project {
        project_position(c, mass, &mut r)?;
        check_rank(c, &r)?;
        project_velocity(c, mass, &r, &mut v)?;
    }
    let mut g = vec![0.0; c.m];
    crate::scratch::eval(&c.value, &[&r[..]], &mut g);
    within_tolerance("position", "|g(r0)|", &g)?;
    crate::scratch::eval(&c.jacobian_mul, &[&r[..], &[], &v[..]], &mut g);
    within_tolerance("velocity", "|Dg(r0) v0|", &g)?;
    Ok((r, v))
}

/// Refuses residuals beyond [`DEFAULT_STATE_TOLERANCE`] (NaN included).
fn within_tolerance(key: &str, what: &'static str, residuals: &[f64]) -> Result<(), SpecError> {
    let (index, residual) = largest(residuals);
    if residual <= DEFAULT_STATE_TOLERANCE {
        return Ok(());
    }
    let tolerance = DEFAULT_STATE_TOLERANCE;
    let kind = SpecErrorKind::OffManifold {
        what,
        residual,
        index,
        tolerance,
    };
    Err(SpecError::new(key, kind))
}

/// The index and size of the largest |x_i| (NaN counts as largest).
fn largest(x: &[f64]) -> (usize, f64) {
    x.iter()
        .map(|x| x.abs())
        .enumerate()
        .fold((0, 0.0), |(bi, bv), (i, a)| {
            if a > bv || a.is_nan() && !bv.is_nan() {
                (i, a)
            } else {
                (bi, bv)
            }
        })
}

/// Refuses a Jacobian of rank below m at `r` (Gaussian elimination with complete pivoting).
fn check_rank(c: &ConstraintPrograms, r: &[f64]) -> Result<(), SpecError> {
    let jacobian = c.dense_jacobian(r);
    if let Some(k) = jacobian.iter().position(|x| !x.is_finite()) {
        let (i, j) = (k / c.n, k % c.n);
        let message = format!(
            "the derivative of constraints[{i}] by coordinate {j} is {} at the initial position",
            jacobian[k]
        );
        return Err(SpecError::conflict(format!("constraints[{i}]"), message));
    }
    let (rank, largest, pivot) = rank(jacobian, c.m, c.n);
    if rank == c.m {
        return Ok(());
    }
    let kind = SpecErrorKind::RankDeficient {
        rank,
        m: c.m,
        largest,
        pivot,
    };
    Err(SpecError::new("constraints", kind))
}

/// The rank of the m x n row-major matrix `a`, its largest entry and the first pivot below
/// [`RANK_TOLERANCE`] times it (0 for full rank).
pub(crate) fn rank(mut a: Vec<f64>, m: usize, n: usize) -> (usize, f64, f64) {
    let largest = a.iter().fold(0.0f64, |s, x| s.max(x.abs()));
    if !largest.is_finite() || largest == 0.0 {
        return (0, largest, largest);
    }
    let tolerance = RANK_TOLERANCE * largest;
    let (mut rows, mut cols): (Vec<usize>, Vec<usize>) = ((0..m).collect(), (0..n).collect());
    for k in 0..m.min(n) {
        // The largest remaining entry.
        let (mut bi, mut bj, mut best) = (k, k, 0.0);
        for i in k..m {
            for j in k..n {
                let x = a[rows[i] * n + cols[j]].abs();
                if x > best {
                    (bi, bj, best) = (i, j, x);
                }
            }
        }
        if best <= tolerance {
            return (k, largest, best);
        }
        rows.swap(k, bi);
        cols.swap(k, bj);
        let (pr, pc) = (rows[k], cols[k]);
        for &row in &rows[k + 1..] {
            let factor = a[row * n + pc] / a[pr * n + pc];
            for &col in &cols[k..] {
                a[row * n + col] -= factor * a[pr * n + col];
            }
        }
    }
    (m.min(n), largest, 0.0)
}

/// Solves the m x m system `a` x = b in place of b (partial pivoting); `None` where a pivot is 0.
pub(crate) fn solve(mut a: Vec<f64>, m: usize, b: &mut [f64]) -> Option<()> {
    for k in 0..m {
        let p = (k..m).max_by(|&i, &j| a[i * m + k].abs().total_cmp(&a[j * m + k].abs()))?;
        if a[p * m + k] == 0.0 || !a[p * m + k].is_finite() {
            return None;
        }
        if p != k {
            for j in 0..m {
                a.swap(k * m + j, p * m + j);
            }
            b.swap(k, p);
        }
        for i in k + 1..m {
            let factor = a[i * m + k] / a[k * m + k];
            for j in k..m {
                a[i * m + j] -= factor * a[k * m + j];
            }
            b[i] -= factor * b[k];
        }
    }
    for k in (0..m).rev() {
        let sum: f64 = (k + 1..m).map(|j| a[k * m + j] * b[j]).sum();
        b[k] = (b[k] - sum) / a[k * m + k];
    }
    Some(())
}

/// x <- x - M^-1 J^T (J M^-1 J^T)^-1 y for J = Dg(at): the M-orthogonal correction that maps
/// the residual y of J away. `None` where J M^-1 J^T is singular.
fn correct(
    c: &ConstraintPrograms, mass: &DiagonalMass, at: &[f64], y: &mut [f64], x: &mut [f64],
) -> Option<()> {
    let (m, n) = (c.m, c.n);
    let j = c.dense_jacobian(at);
    let mut weighted = j.clone();
    for row in weighted.chunks_mut(n) {
        mass.apply_inverse(row);
    }
    let gram: Vec<f64> = (0..m * m)
        .map(|ik| {
            let (i, k) = (ik / m, ik % m);
            (0..n).map(|l| j[i * n + l] * weighted[k * n + l]).sum()
        })
        .collect();
    solve(gram, m, y)?;
    for (l, xl) in x.iter_mut().enumerate() {
        *xl -= (0..m).map(|i| weighted[i * n + l] * y[i]).sum::<f64>();
    }
    Some(())
}

/// Newton's iteration r <- r - M^-1 J^T (J M^-1 J^T)^-1 g(r) until |g| stops decreasing.
fn project_position(
    c: &ConstraintPrograms, mass: &DiagonalMass, r: &mut [f64],
) -> Result<(), SpecError> {
    let mut g = vec![0.0; c.m];
    crate::scratch::eval(&c.value, &[&r[..]], &mut g);
    let mut residual = largest(&g).1;
    let mut iterations = 0;
    while residual > 0.0 && iterations < PROJECTION_ITERATIONS {
        let mut next = r.to_vec();
        let at = r.to_vec();
        if correct(c, mass, &at, &mut g, &mut next).is_none() {
            break;
        }
        crate::scratch::eval(&c.value, &[&next[..]], &mut g);
        let next_residual = largest(&g).1;
        iterations += 1;
        // NaN or no decrease: stop at the best point found.
        if next_residual.partial_cmp(&residual) != Some(std::cmp::Ordering::Less) {
            break;
        }
        r.copy_from_slice(&next);
        residual = next_residual;
    }
    if residual <= DEFAULT_STATE_TOLERANCE {
        return Ok(());
    }
    let tolerance = DEFAULT_STATE_TOLERANCE;
    let kind = SpecErrorKind::Projection {
        residual,
        iterations,
        tolerance,
    };
    Err(SpecError::new("position", kind))
}

/// v <- v - M^-1 J^T (J M^-1 J^T)^-1 J v, J = Dg(r), twice (the second pass takes off the
/// first's rounding).
fn project_velocity(
    c: &ConstraintPrograms, mass: &DiagonalMass, r: &[f64], v: &mut [f64],
) -> Result<(), SpecError> {
    for _ in 0..2 {
        let mut jv = vec![0.0; c.m];
        crate::scratch::eval(&c.jacobian_mul, &[r, &[], &v[..]], &mut jv);
        if correct(c, mass, r, &mut jv, v).is_none() {
            let (rank, largest, pivot) = rank(c.dense_jacobian(r), c.m, c.n);
            let kind = SpecErrorKind::RankDeficient {
                rank,
                m: c.m,
                largest,
                pivot,
            };
            return Err(SpecError::new("constraints", kind));
        }
    }
    Ok(())
}
