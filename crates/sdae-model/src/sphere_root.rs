//! The kappa root over W lanes of a constraint of one quadratic equation in N coordinates
//! (the sphere; [`LaneFormVisitor::closed_form`](sdae_manifold::LaneFormVisitor::closed_form)):
//! the root gamma connected to 0 of R(gamma) = g(y + M^-1 grad g(r) gamma) (seed eq. 3.1
//! upper part, Appendix B) with a diagonal mass, in closed form on arrays of N, with the
//! floating-point operations of the ball solver's closed form (`BallSolver::solve` of
//! `sdae-ift` with `Constraint::kappa_quadratic`): the constraint's own [`Equations`] forms.
//! With r = y it is the projection of y onto the sphere along its own normal line
//! ([`TangentProjector::project_position`](crate::TangentProjector::project_position)).
//!
//! A lane the closed form does not certify (no real root, a root outside the ball, not
//! plausible, not contracting, a residual above the tolerance, a non-finite value) is left
//! out of `ok`; the scalar solver decides it (Newton, the homotopy, or the error).

use pulp::Simd;
use sdae_ift::{SolverSettings, quadratic_root};
use sdae_lanes::Real;
use sdae_lanes::{LaneMask, Lanes};

/// Scratch entries of the constraint's forms at N <= 3 coordinates and one equation (n + 2m).
const SCRATCH: usize = 8;
use sdae_manifold::{Equations, GramShape, Mass, Roundoff, SquareMatrix};

/// The constants of the root: the constraint, the diagonal of M^-1, the solver's settings and
/// the radius of the ball the root must lie in (C_kappa, or infinite).
#[derive(Debug, Clone)]
pub struct SphereRoot<E, const N: usize> {
    settings: SolverSettings,
    radius: f64,
    constraint: E,
    /// The constraint's rounding floor (`Equations::roundoff`).
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

impl<E: Equations, const N: usize> SphereRoot<E, N> {
    /// The root's constants for `constraint` (one quadratic equation in N coordinates) with
    /// M^-1 = diag(`inverse_mass`).
    pub fn new(
        constraint: &E, inverse_mass: [f64; N], settings: &SolverSettings, radius: f64,
    ) -> Self {
        Self {
            settings: *settings,
            radius,
            constraint: constraint.clone(),
            roundoff: Equations::roundoff(constraint),
            inverse_mass,
        }
    }

    /// [`SphereRoot::new`] with the diagonal of `mass`'s inverse, or `None` if `mass` is not
    /// diagonal.
    pub fn for_mass<M: Mass>(
        constraint: &E, mass: &M, settings: &SolverSettings, radius: f64,
    ) -> Option<Self> {
        if !M::DIAGONAL {
            return None;
        }
        let inverse_mass = std::array::from_fn(|k| mass.inverse_diagonal_entry(k).unwrap_or(0.0));
        Some(Self::new(constraint, inverse_mass, settings, radius))
    }

    /// The radius of the ball.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The constraint.
    pub fn constraint(&self) -> &E {
        &self.constraint
    }

    /// The diagonal of M^-1.
    pub fn inverse_mass(&self) -> &[f64; N] {
        &self.inverse_mass
    }

    /// Dg(x) u (its one entry).
    #[inline(always)]
    pub fn normal_rate<T: Real>(&self, x: &[T; N], u: &[T; N]) -> T {
        let mut out = [x[0]];
        Equations::jacobian_mul(&self.constraint, x, u, &mut out);
        out[0]
    }

    /// D^2 g(x)(u, w) (its one entry).
    #[inline(always)]
    pub fn curvature_rate<T: Real>(&self, x: &[T; N], u: &[T; N], w: &[T; N]) -> T {
        let mut out = [x[0]];
        Equations::second_derivative(&self.constraint, x, u, w, &mut out);
        out[0]
    }

    /// [g(x), Dg(x) M^-1 grad g(r)] (`Equations::value_and_cross_gram`).
    #[inline(always)]
    pub fn value_and_gram<T: Real>(&self, x: &[T; N], r: &[T; N]) -> [T; 2] {
        let zero = x[0].splat_like(0.0);
        let mut gram = <<E::Shape as GramShape>::Matrix<T> as SquareMatrix<T>>::zeros_like(zero, 1);
        let (mut value, mut scratch) = ([zero], [zero; SCRATCH]);
        Equations::value_and_cross_gram(
            &self.constraint,
            &self.inverse_mass,
            x,
            r,
            &mut scratch,
            &mut value,
            &mut gram,
        );
        // The one entry, as its product with 1 (exact).
        let mut entry = [zero];
        gram.product(&[zero.splat_like(1.0)], &mut entry);
        [value[0], entry[0]]
    }

    /// out = y + M^-1 grad g(r) z (`Equations::displace`).
    #[inline(always)]
    pub fn displace<T: Real>(&self, r: &[T; N], z: T, y: &[T; N], out: &mut [T; N]) {
        let mut scratch = [z; SCRATCH];
        Equations::displace(
            &self.constraint,
            &self.inverse_mass,
            r,
            &[z],
            Some(y),
            out,
            &mut scratch,
        );
    }

    /// The constrained velocity of seed eq. 3.1 (lower part) at the root `root` of r and y:
    /// lambda = -Dg(x) v~ / (Dg(x) M^-1 grad g(r)) with the root's Gram value, and
    /// v' = v~ + M^-1 grad g(r) lambda, from v~ (`free`); the ball solver's closed form with
    /// the same floating-point operations.
    #[inline(always)]
    pub fn velocity<Sd: Simd>(
        &self, r: &[Lanes<Sd>; N], root: &RootLanes<Sd, N>, free: &[Lanes<Sd>; N],
    ) -> (Lanes<Sd>, [Lanes<Sd>; N]) {
        let one = root.gram.splat_like(1.0);
        let lambda = -self.normal_rate(&root.x, free) * (one / root.gram);
        let mut v = [lambda; N];
        self.displace(r, lambda, free, &mut v);
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

        // The quadratic R(gamma) = c0 + c1 gamma + c2 gamma^2 (`Equations::kappa_quadratic`;
        // `None`, which a constraint that offers the closed form does not give: no lane
        // decided) and its root connected to 0 (`BallSolver::solve_quadratic`).
        let mut scratch = [zero; SCRATCH];
        let w = &self.inverse_mass;
        let coefficients = Equations::kappa_quadratic(&self.constraint, w, r, y, &mut scratch);
        let usable = coefficients.is_some();
        let root = quadratic_root(coefficients.unwrap_or([zero; 3]), tolerance);
        let (gamma, norm, contraction) = (root.gamma, root.norm, root.contraction);
        let mut ok = root.accepted(&self.settings, self.radius);
        if !usable {
            ok = ok.and(zero.lt(zero));
        }

        // The root's point x = y + M^-1 grad g(r) gamma, its residual and J(gamma).
        let mut x = [zero; N];
        self.displace(r, gamma, y, &mut x);
        let [value, gram] = self.value_and_gram(&x, r);
        let residual = value.abs();
        ok = ok.and(residual.le(tolerance));
        ok = ok.and(gram.is_finite()).and(!gram.eq(zero));
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
