//! Newton's iteration from gamma = 0 with a convergence mask per path, and the root's
//! certificate, written once over [`Real`]: for one path (`f64`, [`BallSolver`]'s path for one
//! unknown) and for W paths in SIMD lanes (the ensemble's kappa root in `sdae-model`). Lane i of
//! the lane form computes exactly what the `f64` form computes for path i. The root is that of
//! R(gamma) = g(y + M^-1 grad g(r) gamma) = 0 (seed eq. 3.1 upper part) connected to 0; the
//! certificate is that of Thm 3.4 (the ball, the plausibility bound, the contraction estimate).
//!
//! A path the iteration does not decide (no convergence within the iteration limit, a
//! factorization that fails, a root outside the ball, implausible or not contracting, a
//! non-finite value) is left out of `ok`: [`BallSolver`]'s general path then decides it, with
//! the homotopy of eq. 3.10 and its typed errors.
//!
//! [`BallSolver`]: crate::BallSolver

use sdae_lanes::{PathMask, Real};
use sdae_manifold::vector::sum_squares;

use crate::criteria::{ProbeMap, power_iteration};
use crate::settings::SolverSettings;

/// A system R(gamma) = 0 of m equations that [`newton_from_zero`] solves: its evaluations with
/// their factored Jacobians, and (as a [`ProbeMap`]) the map J(0)^-1 J(gamma) of its last
/// evaluation for the certificate. A trait rather than closures: its methods are inlined into
/// a lane kernel compiled for an instruction set, which a closure would not inherit.
pub trait NewtonSystem<T: Real>: ProbeMap<T> {
    /// R(gamma) and J(gamma) at `gamma` (`None`: at gamma = 0, where the system may evaluate
    /// at its base point directly), J factored (J(0)'s factors kept apart from the
    /// iterations'), and the first half of J^-1 R(gamma) into `step` (R itself where the
    /// factorization solves in one half). Returns max_i |R_i(gamma)| and the paths where
    /// R(gamma) is finite and the factorization passed.
    fn evaluate_and_factor(&mut self, gamma: Option<&[T]>, step: &mut [T]) -> (T, T::Mask);
    /// step <- J^-1 R from the first half that the last evaluation left in `step`, with its
    /// factors.
    fn back_substitute(&mut self, step: &mut [T]);
}

/// What Newton's iteration from 0 found, per path ([`newton_from_zero`]).
#[derive(Debug, Clone, Copy)]
pub struct NewtonIterates<T: Real> {
    /// The paths that converged with finite residuals and factorizations passed.
    pub ok: T::Mask,
    /// Whether any iteration ran (then the system's last evaluation, in every path, is at that
    /// path's root; else at 0).
    pub iterated: bool,
    /// The iteration at which a path converged (0 at a root of 0, R(0) within the tolerance).
    pub iterations: T,
    /// max_i |R_i(gamma*)|.
    pub residual: T,
    /// |J(0)^-1 R(0)|, the first Newton step's length.
    pub first_step: T,
}

/// The paths not failed so far, those still iterating, and what the finished ones converged
/// with.
struct Iterates<T: Real> {
    ok: T::Mask,
    active: T::Mask,
    iterations: T,
    residual: T,
    /// The residual of the last iteration of the paths still iterating.
    previous: T,
}

impl<T: Real> Iterates<T> {
    /// Iteration k with residual `r_k`: the active paths that `fails` drop out of `ok`, those
    /// `converged` (and not failed) record k and r_k, the rest go on.
    #[inline(always)]
    fn record(&mut self, k: T, r_k: T, converged: T::Mask, fails: T::Mask) {
        self.ok = self.ok.and(!self.active.and(fails));
        let finished = self.active.and(converged).and(!fails);
        self.iterations = T::select(finished, k, self.iterations);
        self.residual = T::select(finished, r_k, self.residual);
        self.active = self.active.and(!converged).and(!fails);
        self.previous = T::select(self.active, r_k, self.previous);
    }
}

/// Newton's iteration on `system` from gamma = 0 to `tolerance` (per path: the settings' or
/// the residual floor of g), at most `settings.max_iterations` steps, with the stagnation test
/// of [`SolverSettings::converged`]: iteration 0 is R(0) with J(0) factored and the first step
/// J(0)^-1 R(0); a path whose |R(0)| is within the tolerance has the root 0; the others take
/// gamma <- gamma - J(gamma)^-1 R(gamma) while they iterate. The root is left in `gamma`;
/// `step` is scratch of m entries.
#[inline(always)]
pub fn newton_from_zero<T: Real, P: NewtonSystem<T>>(
    system: &mut P, settings: &SolverSettings, tolerance: T, gamma: &mut [T], step: &mut [T],
) -> NewtonIterates<T> {
    let zero = tolerance.splat_like(0.0);
    let (residual_at_zero, ok) = system.evaluate_and_factor(None, step);
    system.back_substitute(step);
    let first_step = sum_squares(step).sqrt();
    let at_zero = residual_at_zero.at_most(tolerance);
    for (g, s) in gamma.iter_mut().zip(step.iter()) {
        *g = T::select(at_zero, zero, zero - *s);
    }
    let mut paths = Iterates {
        ok,
        active: ok.and(!at_zero),
        iterations: zero,
        residual: residual_at_zero,
        previous: residual_at_zero,
    };
    let mut iterated = false;
    let max_iterations = settings.max_iterations;
    for k in 1..=max_iterations {
        if !paths.active.any() {
            break;
        }
        iterated = true;
        let last = k == max_iterations;
        let (r_k, evaluated) = system.evaluate_and_factor(Some(gamma), step);
        let converged = settings.converged(r_k, paths.previous, tolerance, last);
        // The next Newton step only if a path goes on (most often none does: one iteration
        // converges); the factors at the root are kept either way.
        if paths.active.and(!converged).any() {
            system.back_substitute(step);
        }
        // A path that fails now (no finite residual, a failed factorization, the last
        // iteration without convergence) is left to the general path.
        let fails = (!evaluated).or(if last {
            !converged
        } else {
            zero.mask_like(false)
        });
        paths.record(zero.splat_like(k as f64), r_k, converged, fails);
        newton_update(paths.active, gamma, step);
    }
    NewtonIterates {
        ok: paths.ok,
        iterated,
        iterations: paths.iterations,
        residual: paths.residual,
        first_step,
    }
}

/// gamma <- gamma - step in the `active` paths (the Newton update).
#[inline(always)]
fn newton_update<T: Real>(active: T::Mask, gamma: &mut [T], step: &[T]) {
    if active.all() {
        for (g, s) in gamma.iter_mut().zip(step) {
            *g = *g - *s;
        }
    } else if active.any() {
        for (g, s) in gamma.iter_mut().zip(step) {
            *g = *g - T::select(active, *s, s.splat_like(0.0));
        }
    }
}

/// The root's certificate in the paths `ok` (Thm 3.4): |gamma*| below `radius` (infinite: no
/// ball), within the plausibility bound of the `first_step`, and a contraction estimate
/// ([`power_iteration`] with `probes` steps on `map`, the system at the root) below its
/// maximum where the radius is finite. `probe` holds gamma* on entry and, like `image`, is
/// scratch afterwards. Returns the paths that pass, |gamma*| and the contraction estimate
/// (NaN without probes).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn certify<T: Real>(
    map: &mut impl ProbeMap<T>, settings: &SolverSettings, radius: f64, probes: usize,
    first_step: T, mut ok: T::Mask, probe: &mut [T], image: &mut [T],
) -> (T::Mask, T, T) {
    let norm = sum_squares(probe).sqrt();
    ok = ok.and(norm.less(norm.splat_like(radius)));
    ok = ok.and(!settings.implausible(norm, settings.plausibility_bound(first_step)));
    if probes == 0 {
        return (ok, norm, norm.splat_like(f64::NAN));
    }
    for p in probe.iter_mut() {
        *p = *p / norm;
    }
    let contraction = power_iteration(norm, probes, probe, image, false, map);
    ok = ok.and(!settings.not_contracting(contraction, radius));
    (ok, norm, contraction)
}
