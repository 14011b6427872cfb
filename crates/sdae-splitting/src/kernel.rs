//! The splitting step B A O A B written once over the number type ([`Real`]): `f64` for one
//! path, `Lanes` for W paths in SIMD lanes ([`step`]). What differs between them, the force,
//! the two projections' solves and where their numbers live, is a [`SplittingKernel`]: the
//! general path of one path (any constraint and mass, the ball solver, typed failures,
//! `splitting.rs`), the sphere's closed forms over N lanes (`sphere.rs`) and Newton over a
//! constraint's lane form (`newton.rs`). Each path's floating-point operations are those of
//! the body in the same order whatever T, so a lane computes its path's numbers.

use pulp::Simd;
use sdae_lanes::{Lanes, PathMask, Real};
use sdae_manifold::vector::sum_squares;
use sdae_model::System;
use sdae_model::engine::LaneRecord;

use crate::config::StepSizes;
use crate::ou::OuFactors;

/// What a step over lanes cannot take: a system without a lane form of its force (its paths
/// then go through the scalar step).
#[derive(Debug, Clone, Copy)]
pub(crate) struct NoLaneForm;

/// What a step of size h holds the same for every path: h, tau = h / (2 K_r), 1 / tau and
/// K_r, the O step's factors per coordinate, and whether the step reports max |Dg(r) v|.
#[derive(Debug, Clone)]
pub(crate) struct StepNumbers {
    pub(crate) sizes: StepSizes,
    /// The O step's factors for h, per coordinate.
    pub(crate) ou: Vec<OuFactors>,
    /// Whether the step reports max |Dg(r) v| ([`SplittingKernel::velocity_residual`]).
    pub(crate) monitor_velocity: bool,
}

/// What a SHAKE projection found, per path.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shaken<T: Real> {
    /// The paths it decided (always, for one path).
    pub(crate) ok: T::Mask,
    /// Newton iterations (0 in closed form).
    pub(crate) iterations: T,
    /// max |g| at the projected point.
    pub(crate) residual: T,
}

/// What [`step`] calls on its paths: one path (`T = f64`) or W lanes.
pub(crate) trait SplittingKernel<T: Real> {
    /// A point or velocity of the paths (n coordinates).
    type Rows: AsRef<[T]> + AsMut<[T]>;
    /// A failure that ends the step: typed for one path; for lanes, a step they cannot take.
    type Failure;
    /// The step's sizes, O factors and monitor.
    fn numbers(&self) -> &StepNumbers;
    /// (M^-1)_kk x.
    fn inverse_mass(&self, k: usize, x: T) -> T;
    /// F(r) = a(r, 0) into [`SplittingKernel::force`].
    fn evaluate_force<S: System>(&mut self, system: &S, r: &[T]) -> Result<(), Self::Failure>;
    /// F(r) of the last evaluation (or the one a step resumed from).
    fn force(&self) -> &[T];
    /// The paths whose `x` is finite; one path overrides it with a failure naming `what`
    /// where `x` is not.
    #[inline(always)]
    fn check_finite(&self, _what: &'static str, x: &[T]) -> Result<T::Mask, Self::Failure> {
        Ok(sum_squares(x).finite())
    }
    /// lambda = G_M(r)^-1 (-Dg(r) v), G_M(r) = Dg(r) M^-1 grad g(r) factored anew if `refactor`
    /// (else as the last call left it, at this r); where G_M is 1 x 1, lambda = -Dg(r) v / G_M
    /// (a division, not a product with 1 / G_M). The paths where G_M(r) is finite and regular.
    fn rattle_multiplier(
        &mut self, r: &Self::Rows, v: &Self::Rows, refactor: bool, lambda: &mut [T],
    ) -> Result<T::Mask, Self::Failure>;
    /// v <- v + M^-1 grad g(r) z.
    fn displace(&mut self, r: &Self::Rows, z: &[T], v: &mut Self::Rows);
    /// SHAKE from r along v over tau: the root kappa of g(r + tau v + M^-1 grad g(r) kappa) =
    /// 0 connected to 0 (seed eq. 3.1 upper part with eta h = tau), and its impulse kappa / tau
    /// into `impulse` ([`shake_impulse`]); the point is kept for
    /// [`SplittingKernel::move_to_root`].
    fn shake(
        &mut self, r: &Self::Rows, v: &Self::Rows, impulse: &mut [T],
    ) -> Result<Shaken<T>, Self::Failure>;
    /// r <- the point of the last [`SplittingKernel::shake`].
    fn move_to_root(&mut self, r: &mut Self::Rows);
    /// max_i |(Dg(r) v)_i|, with m entries of scratch.
    fn velocity_residual(&mut self, r: &Self::Rows, v: &Self::Rows, scratch: &mut [T]) -> T;
    /// [`drift_and_thermostat`]; a kernel may compile it apart (once per instruction set).
    #[inline(always)]
    fn middle(
        &mut self, m: &mut Motion<'_, T, Self::Rows>, dw: &[T], factored: bool,
    ) -> Result<(), Self::Failure>
    where
        Self: Sized,
    {
        drift_and_thermostat(self, m, dw, factored)
    }
}

/// The paths inside a step: (r, v), mu's increment (the sum of the step's constraint
/// impulses, m entries), a projection's multiplier (m entries), and what the step reports.
pub(crate) struct Motion<'a, T: Real, R> {
    pub(crate) r: &'a mut R,
    pub(crate) v: &'a mut R,
    pub(crate) impulse: &'a mut [T],
    pub(crate) lambda: &'a mut [T],
    /// The paths decided so far.
    pub(crate) ok: T::Mask,
    /// Newton iterations of the SHAKE projections so far.
    pub(crate) iterations: T,
    /// max |g| after the last SHAKE projection.
    pub(crate) residual: T,
}

impl<'a, T: Real, R> Motion<'a, T, R> {
    /// From (r, v) with a zero impulse; `zero` is 0 in every path.
    #[inline(always)]
    pub(crate) fn new(
        r: &'a mut R, v: &'a mut R, impulse: &'a mut [T], lambda: &'a mut [T], zero: T,
    ) -> Self {
        impulse.fill(zero);
        Self {
            r,
            v,
            impulse,
            lambda,
            ok: zero.mask_like(true),
            iterations: zero,
            residual: zero,
        }
    }
}

impl<Sd: Simd, R> Motion<'_, Lanes<Sd>, R> {
    /// What a step over lanes records once [`step`] returned `velocity_residual`: no
    /// truncation (eta = 1), the SHAKE projections' Newton iterations and max |g|, no
    /// certificate.
    #[inline(always)]
    pub(crate) fn record(&self, velocity_residual: Option<Lanes<Sd>>) -> LaneRecord<Sd> {
        LaneRecord {
            eta: self.iterations.splat_like(1.0),
            newton_iterations: self.iterations,
            position_residual: Some(self.residual),
            velocity_residual,
            certificate: None,
        }
    }
}

/// One step of [`Splitting`](crate::Splitting) (B A O A B, K_r geodesic substeps per A) from
/// (r, v) in `m` with the increments dw: r, v and the impulses are left in `m`, max |Dg(r) v|
/// at the end returned if the kernel monitors it. With `resumed`, the kernel's force and
/// G_M(r)'s factors are those at r (the last step's end), evaluated by no one anew.
#[inline(always)]
pub(crate) fn step<T: Real, S: System, K: SplittingKernel<T>>(
    system: &S, kernel: &mut K, m: &mut Motion<'_, T, K::Rows>, dw: &[T], resumed: bool,
) -> Result<Option<T>, K::Failure> {
    if !resumed {
        checked_force(system, kernel, m)?;
    }
    kick(kernel, m);
    kernel.middle(m, dw, resumed)?;
    checked_force(system, kernel, m)?;
    kick(kernel, m);
    rattle(kernel, m, false)?;
    let finite = kernel.check_finite("velocity after the step", m.v.as_ref())?;
    m.ok = m.ok.and(finite);
    // Written out, not `then`: a closure would not inherit the instruction set.
    Ok(if kernel.numbers().monitor_velocity {
        Some(kernel.velocity_residual(m.r, m.v, m.lambda))
    } else {
        None
    })
}

/// RATTLE after the first kick (factoring G_M(r) unless it is `factored`), A, O with its
/// RATTLE, A: the part of the step between the force's evaluations.
#[inline(always)]
pub(crate) fn drift_and_thermostat<T: Real, K: SplittingKernel<T>>(
    kernel: &mut K, m: &mut Motion<'_, T, K::Rows>, dw: &[T], factored: bool,
) -> Result<(), K::Failure> {
    rattle(kernel, m, !factored)?;
    for _ in 0..kernel.numbers().sizes.substeps {
        geodesic_drift(kernel, m)?;
    }
    ornstein_uhlenbeck(kernel, m.v.as_mut(), dw);
    rattle(kernel, m, false)?;
    for _ in 0..kernel.numbers().sizes.substeps {
        geodesic_drift(kernel, m)?;
    }
    Ok(())
}

/// F(r) = a(r, 0), and the paths where it is finite.
#[inline(always)]
fn checked_force<T: Real, S: System, K: SplittingKernel<T>>(
    system: &S, kernel: &mut K, m: &mut Motion<'_, T, K::Rows>,
) -> Result<(), K::Failure> {
    kernel.evaluate_force(system, m.r.as_ref())?;
    let finite = kernel.check_finite("force F(r)", kernel.force())?;
    m.ok = m.ok.and(finite);
    Ok(())
}

/// B: v <- v + (h/2) M^-1 F(r).
#[inline(always)]
fn kick<T: Real, K: SplittingKernel<T>>(kernel: &K, m: &mut Motion<'_, T, K::Rows>) {
    let half_h = 0.5 * kernel.numbers().sizes.h;
    for (k, (vi, &fi)) in m.v.as_mut().iter_mut().zip(kernel.force()).enumerate() {
        *vi = *vi + kernel.inverse_mass(k, fi) * half_h;
    }
}

/// RATTLE at r: v <- P_M(r) v = v + M^-1 grad g(r) lambda with G_M(r) lambda = -Dg(r) v
/// (seed Section 2.1), lambda added to the impulses.
#[inline(always)]
fn rattle<T: Real, K: SplittingKernel<T>>(
    kernel: &mut K, m: &mut Motion<'_, T, K::Rows>, refactor: bool,
) -> Result<(), K::Failure> {
    let regular = kernel.rattle_multiplier(m.r, m.v, refactor, m.lambda)?;
    m.ok = m.ok.and(regular);
    add(m.impulse, m.lambda);
    kernel.displace(m.r, m.lambda, m.v);
    Ok(())
}

/// A geodesic substep of length tau: SHAKE r' = r + tau v + M^-1 grad g(r) kappa onto
/// g(r') = 0, the velocity v + M^-1 grad g(r) kappa / tau (= (r' - r) / tau) with the impulse
/// kappa / tau, RATTLE at r'.
#[inline(always)]
fn geodesic_drift<T: Real, K: SplittingKernel<T>>(
    kernel: &mut K, m: &mut Motion<'_, T, K::Rows>,
) -> Result<(), K::Failure> {
    let shaken = kernel.shake(m.r, m.v, m.lambda)?;
    m.ok = m.ok.and(shaken.ok);
    m.iterations = m.iterations + shaken.iterations;
    m.residual = shaken.residual;
    add(m.impulse, m.lambda);
    kernel.displace(m.r, m.lambda, m.v);
    kernel.move_to_root(m.r);
    rattle(kernel, m, true)
}

/// The impulse kappa / tau of a SHAKE projection's root kappa, as kappa (1 / tau), into
/// `impulse`: written by each kernel's [`SplittingKernel::shake`] from where its root is, in
/// the pass that reads it.
#[inline(always)]
pub(crate) fn shake_impulse<T: Real>(kappa: &[T], inverse_tau: f64, impulse: &mut [T]) {
    for (l, k) in impulse.iter_mut().zip(kappa) {
        *l = *k * inverse_tau;
    }
}

/// O: v_i <- exp(-gamma w_i h) v_i + sigma w_i sqrt((1 - exp(-2 gamma w_i h)) / (2 gamma w_i
/// h)) dw_i ([`OuFactors`]; no noise term without increments).
#[inline(always)]
fn ornstein_uhlenbeck<T: Real, K: SplittingKernel<T>>(kernel: &K, v: &mut [T], dw: &[T]) {
    for (vi, ou) in v.iter_mut().zip(&kernel.numbers().ou) {
        *vi = *vi * ou.decay;
    }
    for ((vi, ou), &w) in v.iter_mut().zip(&kernel.numbers().ou).zip(dw) {
        *vi = *vi + w * ou.noise;
    }
}

/// sum <- sum + x.
#[inline(always)]
fn add<T: Real>(sum: &mut [T], x: &[T]) {
    for (s, xi) in sum.iter_mut().zip(x) {
        *s = *s + *xi;
    }
}
