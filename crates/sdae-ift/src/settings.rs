//! The solver's settings and the tests it makes with them, written once over [`Real`] for one
//! path (`f64`, [`BallSolver`](crate::BallSolver)) and for W paths in SIMD lanes (the
//! ensemble's Newton and closed-form kernels): Newton's stopping test and the checks of the
//! certificate (the ball's probes, the plausibility of the root against the first Newton step,
//! the contraction of the simplified Newton map, Thm 3.4).

use sdae_lanes::{PathMask, Real};

/// Settings of [`BallSolver`](crate::BallSolver).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Converged when max_i |R_i(gamma)| <= tolerance.
    pub tolerance: f64,
    /// Accept a residual up to this size once it stops decreasing (the roundoff floor of g,
    /// about eps |x| / length scale, can exceed `tolerance` for long chains).
    pub stagnation_tolerance: f64,
    /// Newton iterations before giving up (and falling back to the homotopy).
    pub max_iterations: usize,
    /// Whether to try the homotopy when Newton fails (a problem solved in closed form,
    /// [`BallProblem::quadratic`](crate::BallProblem::quadratic), does not iterate: its root is the homotopy's end point).
    pub homotopy: bool,
    /// Largest number of accepted plus rejected continuation steps.
    pub max_homotopy_steps: usize,
    /// Smallest continuation step in tau before declaring a fold.
    pub min_tau_step: f64,
    /// A root with |gamma| > factor x |first Newton step| is rejected as implausible
    /// (the theorem's contraction q <= 1/2 gives |gamma| <= 2 |step|); `f64::INFINITY` disables.
    pub plausibility_factor: f64,
    /// Power-iteration steps for the contraction estimate of a root in a finite ball (one
    /// step where the radius is infinite: the estimate is then a diagnostic); 0 skips it.
    pub contraction_probes: usize,
    /// A root in a finite ball whose contraction estimate reaches this is rejected
    /// ([`IftError::NotContracting`](crate::IftError::NotContracting)): Thm 3.4, Step 3 certifies uniqueness only below 1/2.
    /// Not applied where the radius is infinite (no certificate is claimed); `f64::INFINITY`
    /// disables it.
    pub max_contraction: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            stagnation_tolerance: 1e-10,
            max_iterations: 25,
            homotopy: true,
            max_homotopy_steps: 400,
            min_tau_step: 1e-7,
            plausibility_factor: 4.0,
            contraction_probes: 4,
            max_contraction: 0.5,
        }
    }
}

impl SolverSettings {
    /// Whether Newton stops with the residual `residual` = max_i |R_i| after `previous`: at the
    /// tolerance, or (unless this is the `last` iteration) at the roundoff floor, where the
    /// residual no longer halves as it would while Newton converges and lies within the
    /// stagnation tolerance.
    #[inline(always)]
    pub fn converged<T: Real>(self, residual: T, previous: T, tolerance: T, last: bool) -> T::Mask {
        let at_tolerance = residual.at_most(tolerance);
        if last {
            return at_tolerance;
        }
        let floor = residual.splat_like(self.stagnation_tolerance);
        let stagnated = (previous * 0.5).less(residual).and(residual.at_most(floor));
        at_tolerance.or(stagnated)
    }

    /// The largest plausible |gamma*|: `plausibility_factor` x |first Newton step|.
    #[inline(always)]
    pub fn plausibility_bound<T: Real>(self, first_step: T) -> T {
        first_step * self.plausibility_factor
    }

    /// Whether a root of norm `norm` lies beyond `bound` ([`SolverSettings::plausibility_bound`])
    /// and above rounding size (64 eps): a root the first Newton step does not justify.
    #[inline(always)]
    pub fn implausible<T: Real>(self, norm: T, bound: T) -> T::Mask {
        let rounding = norm.splat_like(64.0 * f64::EPSILON);
        bound.less(norm).and(rounding.less(norm))
    }

    /// Whether a root of norm `norm` lies in the ball of `radius` (Thm 3.4):
    /// |gamma*| - rounding < radius, with `rounding` the part of gamma* that only corrects
    /// residuals below the tolerance ([`Certificate::rounding`](crate::Certificate::rounding);
    /// the lanes pass 0 and leave a root on the ball's edge to the one-path solver). A NaN norm
    /// is outside.
    #[inline(always)]
    pub fn in_ball<T: Real>(self, norm: T, rounding: T, radius: f64) -> T::Mask {
        (norm - rounding).less(norm.splat_like(radius))
    }

    /// The root's acceptance, the one rule for Newton's roots and the closed form's, for one
    /// path and for lanes (Thm 3.4): in the ball ([`SolverSettings::in_ball`]), plausible
    /// against the first Newton step ([`SolverSettings::implausible`]) and contracting
    /// ([`SolverSettings::not_contracting`]; a NaN estimate, no probes, passes). The one-path
    /// solver tests the three in this order and reports the first that fails as its error.
    #[inline(always)]
    pub fn accepts<T: Real>(
        self, radius: f64, norm: T, rounding: T, first_step: T, contraction: T,
    ) -> T::Mask {
        let bound = self.plausibility_bound(first_step);
        self.in_ball(norm, rounding, radius)
            .and(!self.implausible(norm, bound))
            .and(!self.not_contracting(contraction, radius))
    }

    /// Whether a root in a ball of `radius` fails the contraction check: a finite radius and an
    /// estimate at or above `max_contraction` (Thm 3.4, Step 3). A NaN estimate (no probes)
    /// passes.
    #[inline(always)]
    pub fn not_contracting<T: Real>(self, contraction: T, radius: f64) -> T::Mask {
        let limit = contraction.splat_like(self.max_contraction);
        limit
            .at_most(contraction)
            .and(contraction.mask_like(radius.is_finite()))
    }

    /// The power-iteration steps of the contraction estimate for a root in a ball of `radius`:
    /// `contraction_probes`, at most one where the radius is infinite.
    #[inline(always)]
    pub fn probes(self, radius: f64) -> usize {
        if radius.is_finite() {
            self.contraction_probes
        } else {
            self.contraction_probes.min(1)
        }
    }
}
