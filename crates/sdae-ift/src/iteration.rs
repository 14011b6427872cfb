//! Newton's iteration with a convergence mask per path, and the root's certificate, written
//! once over [`Real`]: the one Newton loop of the workspace ([`newton_iterate`]), for one path
//! (`f64`: [`BallSolver`]'s path for one unknown, its general corrector for any m and the
//! homotopy's corrector) and for W paths in SIMD lanes (the ensemble's kappa root in
//! `sdae-model`). Lane i of the lane form computes exactly what the `f64` form computes for
//! path i. The root is that of R(gamma) = g(y + M^-1 grad g(r) gamma) = 0 (seed eq. 3.1 upper
//! part) connected to 0, or of the homotopy's F(tau, gamma) = R(gamma) + (tau - 1) R(0)
//! (eq. 3.10); the certificate is that of Thm 3.4 (the ball, the plausibility bound, the
//! contraction estimate).
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

/// A system R(gamma) = 0 of m equations that [`newton_from_zero`] and [`newton_iterate`]
/// solve: its evaluations with their factored Jacobians, and (as a [`ProbeMap`]) the map
/// J(0)^-1 J(gamma) of its last evaluation for the certificate. A trait rather than closures:
/// its methods are inlined into a lane kernel compiled for an instruction set, which a closure
/// would not inherit.
///
/// A system factors J either in the pass that evaluates R ([`NewtonSystem::evaluate_and_factor`],
/// the lanes' fused form) or once the iteration knows what the factorization is for
/// ([`NewtonSystem::factor`], one path: the last Newton step is not solved, and at the root the
/// factorization also solves the companion system and the certificate's first probe).
pub trait NewtonSystem<T: Real>: ProbeMap<T> {
    /// R(gamma) and J(gamma) at `gamma` (`None`: at gamma = 0, where the system may evaluate
    /// at its base point directly). A system that factors in this pass factors J (J(0)'s
    /// factors kept apart from the iterations') and leaves the first half of J^-1 R(gamma) in
    /// `step` (R itself where the factorization solves in one half). Returns max_i |R_i(gamma)|
    /// and the paths where R(gamma) is finite (and the factorization passed).
    fn evaluate_and_factor(&mut self, gamma: Option<&[T]>, step: &mut [T]) -> (T, T::Mask);
    /// Factors J of the last evaluation at `gamma`, for what `pass` says the iteration does
    /// next, where [`NewtonSystem::evaluate_and_factor`] did not; the paths of
    /// `pass.evaluated` where the factorization passed (none where no path's R is finite,
    /// without factoring). The default: nothing left to do.
    #[inline(always)]
    fn factor(&mut self, gamma: &[T], pass: FactorPass<T>, step: &mut [T]) -> T::Mask {
        let _ = (gamma, step);
        pass.evaluated
    }
    /// step <- J^-1 R from what the last factorization left in `step`, with its factors.
    fn back_substitute(&mut self, step: &mut [T]);
    /// The paths whose Newton step `step` (J^-1 R, about to be taken) shows that the iteration
    /// will not converge. The default: none.
    #[inline(always)]
    fn diverging(&mut self, step: &[T]) -> T::Mask {
        step[0].mask_like(false)
    }
}

/// What a factorization of J(gamma) is for ([`NewtonSystem::factor`]).
#[derive(Debug, Clone, Copy)]
pub struct FactorPass<T: Real> {
    /// The paths where R(gamma) is finite (and a fused factorization passed).
    pub evaluated: T::Mask,
    /// The paths that converged at gamma (J(gamma) is the root's).
    pub converged: T::Mask,
    /// Whether this is the last iteration allowed (no Newton step follows).
    pub last: bool,
    /// Whether gamma = 0 (iteration 0: the factors are J(0)'s, kept apart).
    pub at_zero: bool,
}

/// What Newton's iteration from 0 found, per path ([`newton_from_zero`]).
#[derive(Debug, Clone, Copy)]
pub struct NewtonIterates<T: Real> {
    /// The paths that converged with finite residuals and factorizations passed.
    pub ok: T::Mask,
    /// Whether any iteration ran (then the system's last evaluation, in every path, is at that
    /// path's root; else at the start).
    pub iterated: bool,
    /// The last iteration that ran (the start's, 0, where none did): on one path, the
    /// iteration at which it converged or failed.
    pub last_iteration: usize,
    /// The iteration at which a path converged (0 at a root of 0, R(0) within the tolerance).
    pub iterations: T,
    /// max_i |R_i(gamma*)|.
    pub residual: T,
    /// |J(0)^-1 R(0)|, the first Newton step's length.
    pub first_step: T,
}

/// Where Newton's iteration starts ([`start_from_zero`], [`start_at`]): the paths not failed
/// so far, those still iterating, what the finished ones converged with, and the first
/// iteration to run.
#[derive(Debug, Clone, Copy)]
pub struct NewtonStart<T: Real> {
    ok: T::Mask,
    active: T::Mask,
    iterations: T,
    residual: T,
    /// The residual of the last iteration of the paths still iterating (the stagnation test's
    /// reference; infinite before the first).
    previous: T,
    /// |J(0)^-1 R(0)| (NaN where iteration 0 did not run).
    first_step: T,
    first: usize,
}

impl<T: Real> NewtonStart<T> {
    /// The paths that failed at the start (R(0) not finite, J(0) singular).
    pub fn failed(&self) -> T::Mask {
        !self.ok
    }

    /// max_i |R_i| at the start (R(0) after [`start_from_zero`]).
    pub fn residual(&self) -> T {
        self.residual
    }

    /// |J(0)^-1 R(0)|, the first Newton step's length (NaN after [`start_at`]).
    pub fn first_step(&self) -> T {
        self.first_step
    }

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

/// Iteration 0 of Newton's method from gamma = 0: R(0) with J(0) factored and the first step
/// J(0)^-1 R(0); a path whose |R(0)| is within `tolerance` has the root 0 (left in `gamma`),
/// the others start [`newton_iterate`] at iteration 1 from gamma = -J(0)^-1 R(0).
#[inline(always)]
pub fn start_from_zero<T: Real, P: NewtonSystem<T>>(
    system: &mut P, tolerance: T, gamma: &mut [T], step: &mut [T],
) -> NewtonStart<T> {
    let zero = tolerance.splat_like(0.0);
    let (residual_at_zero, evaluated) = system.evaluate_and_factor(None, step);
    let pass = FactorPass {
        evaluated,
        converged: zero.mask_like(false),
        last: false,
        at_zero: true,
    };
    let ok = system.factor(gamma, pass, step);
    system.back_substitute(step);
    let first_step = sum_squares(step).sqrt();
    let at_zero = residual_at_zero.at_most(tolerance);
    for (g, s) in gamma.iter_mut().zip(step.iter()) {
        *g = T::select(at_zero, zero, zero - *s);
    }
    NewtonStart {
        ok,
        active: ok.and(!at_zero),
        iterations: zero,
        residual: residual_at_zero,
        previous: residual_at_zero,
        first_step,
        first: 1,
    }
}

/// Newton's method from the `gamma` at hand (the homotopy's corrector, a warm start):
/// [`newton_iterate`] runs from iteration 0 at gamma, whose residual is never taken as
/// stagnating (the previous one is infinite).
#[inline(always)]
pub fn start_at<T: Real>(like: T) -> NewtonStart<T> {
    NewtonStart {
        ok: like.mask_like(true),
        active: like.mask_like(true),
        iterations: like.splat_like(0.0),
        residual: like.splat_like(f64::INFINITY),
        previous: like.splat_like(f64::INFINITY),
        first_step: like.splat_like(f64::NAN),
        first: 0,
    }
}

/// Newton's iteration on `system` from gamma = 0 to `tolerance` (per path: the settings' or
/// the residual floor of g): [`start_from_zero`], then [`newton_iterate`]. The root is left in
/// `gamma`; `step` is scratch of m entries.
#[inline(always)]
pub fn newton_from_zero<T: Real, P: NewtonSystem<T>>(
    system: &mut P, settings: &SolverSettings, tolerance: T, gamma: &mut [T], step: &mut [T],
) -> NewtonIterates<T> {
    let start = start_from_zero(system, tolerance, gamma, step);
    newton_iterate(system, settings, tolerance, gamma, step, start)
}

/// Newton's iteration gamma <- gamma - J(gamma)^-1 R(gamma) from `start` to `tolerance`, at
/// most up to iteration `settings.max_iterations`, with the stagnation test of
/// [`SolverSettings::converged`]: the one Newton loop of the workspace, for one path and for
/// lanes, at tau = 1 and on the homotopy's F(tau, .) (seed eq. 3.10). Each iteration evaluates
/// R with J, tests convergence, factors J for what comes next ([`FactorPass`]), and solves the
/// next step only where a path goes on. A path fails where R is not finite, the
/// factorization fails, its step is [`NewtonSystem::diverging`], or the last iteration does
/// not converge; the general path decides it (one path: with the typed errors and the
/// homotopy). The root is left in `gamma`; `step` is scratch of m entries.
#[inline(always)]
pub fn newton_iterate<T: Real, P: NewtonSystem<T>>(
    system: &mut P, settings: &SolverSettings, tolerance: T, gamma: &mut [T], step: &mut [T],
    mut paths: NewtonStart<T>,
) -> NewtonIterates<T> {
    let zero = tolerance.splat_like(0.0);
    let (mut iterated, mut last_iteration) = (false, paths.first.saturating_sub(1));
    let max_iterations = settings.max_iterations;
    for k in paths.first..=max_iterations {
        if !paths.active.any() {
            break;
        }
        (iterated, last_iteration) = (true, k);
        let last = k == max_iterations;
        let (r_k, evaluated) = system.evaluate_and_factor(Some(gamma), step);
        let converged = settings.converged(r_k, paths.previous, tolerance, last);
        let pass = FactorPass {
            evaluated,
            converged,
            last,
            at_zero: false,
        };
        let factored = system.factor(gamma, pass, step);
        // The next Newton step only if a path goes on (most often none does: one iteration
        // converges); the factors at the root are kept either way.
        let goes_on = paths.active.and(!converged);
        let mut fails = !factored;
        if goes_on.any() {
            system.back_substitute(step);
            if !last {
                fails = fails.or(goes_on.and(system.diverging(step)));
            }
        }
        // A path that fails now (no finite residual, a failed factorization, a diverging
        // step, the last iteration without convergence) is left to the general path.
        if last {
            fails = fails.or(!converged);
        }
        paths.record(zero.splat_like(k as f64), r_k, converged, fails);
        newton_update(paths.active, gamma, step);
    }
    NewtonIterates {
        ok: paths.ok.and(!paths.active),
        iterated,
        last_iteration,
        iterations: paths.iterations,
        residual: paths.residual,
        first_step: paths.first_step,
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

/// The root's certificate in the paths `ok` (Thm 3.4): the contraction estimate
/// ([`power_iteration`] with `probes` steps on `map`, the system at the root; NaN without
/// probes), then the one acceptance rule ([`SolverSettings::accepts`]) with no rounding
/// allowance: |gamma*| below `radius` (infinite: no ball), within the plausibility bound of
/// the `first_step`, and contracting where the radius is finite. `probe` holds gamma* on
/// entry and, like `image`, is scratch afterwards. Returns the paths that pass, |gamma*| and
/// the contraction estimate.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn certify<T: Real>(
    map: &mut impl ProbeMap<T>, settings: &SolverSettings, radius: f64, probes: usize,
    first_step: T, ok: T::Mask, probe: &mut [T], image: &mut [T],
) -> (T::Mask, T, T) {
    let norm = sum_squares(probe).sqrt();
    let contraction = if probes == 0 {
        norm.splat_like(f64::NAN)
    } else {
        for p in probe.iter_mut() {
            *p = *p / norm;
        }
        power_iteration(norm, probes, probe, image, false, map)
    };
    let rounding = norm.splat_like(0.0);
    let accepted = settings.accepts(radius, norm, rounding, first_step, contraction);
    (ok.and(accepted), norm, contraction)
}
