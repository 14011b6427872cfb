//! The certificate's contraction estimate and the closed-form root of a quadratic kappa
//! system (Appendix B, Thm B.2), written once over [`Real`] for one path (`f64`,
//! [`BallSolver`](crate::BallSolver)) and for W paths in SIMD lanes (the ensemble's Newton and
//! closed-form kernels in `sdae-scheme` and `sdae-model`); the tests they feed are
//! [`SolverSettings`](crate::SolverSettings)'. Lane i of a lane form computes exactly what the
//! `f64` form computes for path i.

use sdae_lanes::{PathMask, Real};
use sdae_manifold::vector::sum_squares;

use crate::SolverSettings;

/// The map J(0)^-1 J(gamma*) that [`power_iteration`] applies to its probe. A trait rather than
/// a closure: its method is inlined into a lane kernel compiled for an instruction set, which a
/// closure would not inherit.
pub trait ProbeMap<T> {
    /// image = J(0)^-1 J(gamma*) probe.
    fn apply(&mut self, probe: &[T], image: &mut [T]);
}

/// The contraction estimate of the certificate: power iteration on A = J(0)^-1 J(gamma*) - I
/// started at the unit `probe` p = gamma* / |gamma*| (`norm` = |gamma*|), a lower bound of |A|
/// that approaches it as the `probes` grow. Each step forms image = A p with `map` (which
/// writes J(0)^-1 J(gamma*) p into `image`, unless `first_image` says the first one is there
/// already), the estimate |image| and the next probe image / |image|; a path stops at
/// an estimate of 0. The estimate is 0 where gamma* = 0 and NaN without probes. `probe` and
/// `image` are scratch afterwards.
#[inline(always)]
pub fn power_iteration<T: Real>(
    norm: T, probes: usize, probe: &mut [T], image: &mut [T], mut first_image: bool,
    map: &mut impl ProbeMap<T>,
) -> T {
    let zero = norm.splat_like(0.0);
    if probes == 0 {
        return norm.splat_like(f64::NAN);
    }
    let at_zero = norm.equal(zero);
    if at_zero.all() {
        return zero;
    }
    let mut estimate = zero;
    let mut stopped = zero.mask_like(false);
    for k in 1..=probes {
        if !std::mem::take(&mut first_image) {
            map.apply(probe, image);
        }
        for (s, p) in image.iter_mut().zip(probe.iter()) {
            *s = *s - *p;
        }
        estimate = T::select(stopped, estimate, sum_squares(image).sqrt());
        stopped = stopped.or(estimate.equal(zero));
        if k == probes || stopped.all() {
            break;
        }
        for (p, s) in probe.iter_mut().zip(image.iter()) {
            *p = *s / estimate;
        }
    }
    T::select(at_zero, zero, estimate)
}

/// The root of R(gamma) = c0 + c1 gamma + c2 gamma^2 connected to 0, per path
/// ([`quadratic_root`]).
#[derive(Debug, Clone, Copy)]
pub struct QuadraticRoot<T: Real> {
    /// The paths whose coefficients are finite with c1 = J(0) != 0 (elsewhere the iterative
    /// path decides, with its errors).
    pub usable: T::Mask,
    /// The paths whose discriminant c1^2 - 4 c0 c2 is not negative: the homotopy's path from
    /// (0, 0) reaches tau = 1 (elsewhere it folds before, seed Fig. 1b).
    pub real: T::Mask,
    /// |c0 / c1|, the first Newton step's length.
    pub first_step: T,
    /// gamma* = -2 c0 / (c1 + sign(c1) sqrt(c1^2 - 4 c0 c2)), or 0 where |c0| is within the
    /// tolerance.
    pub gamma: T,
    /// |gamma*|.
    pub norm: T,
    /// |J(0)^-1 J(gamma*) - 1| = |2 c2 gamma* / c1|, exact for a quadratic.
    pub contraction: T,
}

impl<T: Real> QuadraticRoot<T> {
    /// The paths whose root is accepted before it is evaluated: usable, real, and accepted by
    /// the one rule of every root ([`SolverSettings::accepts`]) with its exact contraction and
    /// no rounding allowance (a root on the ball's edge is the one-path solver's to decide).
    /// Its residual at the root's point is the caller's to check.
    #[inline(always)]
    pub fn accepted(&self, settings: &SolverSettings, radius: f64) -> T::Mask {
        let rounding = self.norm.splat_like(0.0);
        let accepted = settings.accepts(
            radius,
            self.norm,
            rounding,
            self.first_step,
            self.contraction,
        );
        self.usable.and(self.real).and(accepted)
    }
}

/// The root of the quadratic kappa system R(gamma) = c0 + c1 gamma + c2 gamma^2 (m = 1)
/// connected to 0, free of cancellation, with the numbers of its certificate: the homotopy of
/// seed eq. 3.10 from (0, 0) follows the root of smaller modulus while the discriminant stays
/// positive, so the root the theorem certifies (Thm 3.4; Appendix B, Thm B.2) is, at tau = 1,
/// gamma* = -2 c0 / (c1 + sign(c1) sqrt(c1^2 - 4 c0 c2)). A residual |c0| within `tolerance`
/// gives 0, as Newton's iteration 0 would accept.
#[inline(always)]
pub fn quadratic_root<T: Real>([c0, c1, c2]: [T; 3], tolerance: T) -> QuadraticRoot<T> {
    let zero = c0.splat_like(0.0);
    let usable = c0
        .finite()
        .and(c1.finite())
        .and(c2.finite())
        .and(!c1.equal(zero));
    let first_step = (c0 / c1).abs();
    let discriminant = c1 * c1 - c0 * 4.0 * c2;
    let real = !discriminant.less(zero);
    let root = discriminant.sqrt();
    let signed_root = T::select(c1.less(zero), -root, root);
    let gamma = T::select(
        c0.abs().at_most(tolerance),
        zero,
        c0 * -2.0 / (c1 + signed_root),
    );
    QuadraticRoot {
        usable,
        real,
        first_step,
        gamma,
        norm: gamma.abs(),
        contraction: (c2 * 2.0 * gamma / c1).abs(),
    }
}
