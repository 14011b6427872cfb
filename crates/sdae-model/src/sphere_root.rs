//! The kappa root of a sphere over W lanes: the root gamma connected to 0 of
//! R(gamma) = g(y + M^-1 grad g(r) gamma) (seed eq. 3.1 upper part, Appendix B) for a sphere
//! with a diagonal mass, in closed form, with the floating-point operations of the ball
//! solver's closed form (`BallSolver::solve` of `sdae-ift` with `Sphere::kappa_quadratic`).
//! With r = y it is the projection of y onto the sphere along its own normal line
//! ([`TangentProjector::project_position`](crate::TangentProjector::project_position)).
//!
//! A lane the closed form does not certify (no real root, a root outside the ball, not
//! plausible, not contracting, a residual above the tolerance, a non-finite value) is left
//! out of `ok`; the scalar solver decides it (Newton, the homotopy, or the error).

use pulp::Simd;
use sdae_ift::{SolverSettings, quadratic_root};
use sdae_lanes::{LaneMask, Lanes};
use sdae_manifold::{Constraint, Mass, Roundoff, Sphere};

/// The constants of the root: the sphere's, the diagonal of M^-1, the solver's settings and
/// the radius of the ball the root must lie in (C_kappa, or infinite).
#[derive(Debug, Clone, Copy)]
pub struct SphereRoot<const N: usize> {
    settings: SolverSettings,
    radius: f64,
    sphere: Sphere,
    /// The sphere's rounding floor (`Constraint::roundoff`).
    roundoff: Roundoff,
    inverse_mass: [f64; N],
}

/// The root of W lanes and the numbers of its certificate.
#[derive(Debug, Clone, Copy)]
pub struct RootLanes<Sd: Simd, const N: usize> {
    /// The lanes the closed form certified.
    pub ok: LaneMask<Sd>,
    /// gamma, the root.
    pub gamma: Lanes<Sd>,
    /// The root's point x = y + M^-1 grad g(r) gamma.
    pub x: [Lanes<Sd>; N],
    /// |gamma|.
    pub norm: Lanes<Sd>,
    /// |R(0) / R'(0)|, the first Newton step's length.
    pub first_step: Lanes<Sd>,
    /// |R''(0) gamma / R'(0)|, the contraction of the Newton map.
    pub contraction: Lanes<Sd>,
    /// |R(gamma)|.
    pub residual: Lanes<Sd>,
    /// R'(gamma) = Dg(x) M^-1 grad g(r) = x^T M^-1 r / rho^4.
    pub gram: Lanes<Sd>,
}

impl<const N: usize> SphereRoot<N> {
    /// The root's constants for `sphere` (of dimension N) with M^-1 = diag(`inverse_mass`).
    pub fn new(
        sphere: &Sphere, inverse_mass: [f64; N], settings: &SolverSettings, radius: f64,
    ) -> Self {
        Self {
            settings: *settings,
            radius,
            sphere: *sphere,
            roundoff: sphere.roundoff(),
            inverse_mass,
        }
    }

    /// [`SphereRoot::new`] with the diagonal of `mass`'s inverse, or `None` if `mass` is not
    /// diagonal.
    pub fn for_mass<M: Mass>(
        sphere: &Sphere, mass: &M, settings: &SolverSettings, radius: f64,
    ) -> Option<Self> {
        if !M::DIAGONAL {
            return None;
        }
        let inverse_mass = std::array::from_fn(|k| mass.inverse_diagonal_entry(k).unwrap_or(0.0));
        Some(Self::new(sphere, inverse_mass, settings, radius))
    }

    /// The radius of the ball.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The sphere.
    pub fn sphere(&self) -> &Sphere {
        &self.sphere
    }

    /// The diagonal of M^-1.
    pub fn inverse_mass(&self) -> &[f64; N] {
        &self.inverse_mass
    }

    /// The constrained velocity of seed eq. 3.1 (lower part) at the root `root` of r and y:
    /// lambda = -Dg(x) v~ / (Dg(x) M^-1 grad g(r)) with the root's Gram value, and
    /// v' = v~ + M^-1 grad g(r) lambda, from v~ (`free`); the ball solver's closed form with
    /// the same floating-point operations.
    #[inline(always)]
    pub fn velocity<Sd: Simd>(
        &self, r: &[Lanes<Sd>; N], root: &RootLanes<Sd, N>, free: &[Lanes<Sd>],
    ) -> (Lanes<Sd>, [Lanes<Sd>; N]) {
        let one = root.gram.splat_like(1.0);
        let lambda = -self.sphere.normal_rate(&root.x, free) * (one / root.gram);
        let mut v = [lambda; N];
        let w = &self.inverse_mass;
        self.sphere
            .displace_diagonal(r, lambda, |k| w[k], free, &mut v);
        (lambda, v)
    }

    /// The root of R(gamma) = g(y + M^-1 grad g(r) gamma) in each lane.
    #[inline(always)]
    pub fn solve<Sd: Simd>(&self, r: &[Lanes<Sd>; N], y: &[Lanes<Sd>; N]) -> RootLanes<Sd, N> {
        let zero = r[0].splat_like(0.0);
        let mut max_abs_y = zero;
        for yi in y {
            max_abs_y = max_abs_y.max(yi.abs());
        }
        let floor = self.roundoff.floor(max_abs_y);
        let tolerance = zero.splat_like(self.settings.tolerance).max(floor);

        // The quadratic R(gamma) = c0 + c1 gamma + c2 gamma^2 (`Sphere::kappa_quadratic`) and
        // its root connected to 0 (`BallSolver::solve_quadratic`).
        let coefficients = self
            .sphere
            .kappa_coefficients(r, y, |k| self.inverse_mass[k]);
        let root = quadratic_root(coefficients, tolerance);
        let (gamma, norm, contraction) = (root.gamma, root.norm, root.contraction);
        let settings = &self.settings;
        let bound = settings.plausibility_bound(root.first_step);
        let mut ok = root
            .usable
            .and(root.real)
            .and(norm.lt(zero.splat_like(self.radius)))
            .and(!settings.implausible(norm, bound));

        // The root's point x = y + M^-1 grad g(r) gamma, its residual and J(gamma).
        let mut x = [zero; N];
        self.sphere
            .displace_diagonal(r, gamma, |k| self.inverse_mass[k], y, &mut x);
        let [value, gram] = self.sphere.value_and_gram(&x, r, |k| self.inverse_mass[k]);
        let residual = value.abs();
        ok = ok.and(residual.le(tolerance));
        ok = ok.and(gram.is_finite()).and(!gram.eq(zero));
        ok = ok.and(!settings.not_contracting(contraction, self.radius));
        RootLanes {
            ok,
            gamma,
            x,
            norm,
            first_step: root.first_step,
            contraction,
            residual,
            gram,
        }
    }
}
