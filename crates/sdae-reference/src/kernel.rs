//! What the solvers' steps, written once over [`Real`] (`euler.rs`, `heun.rs`,
//! `projected.rs`), call on their paths: the coefficients of the inherent SDE (seed eq. 2.4)
//! and of the multiplier (eq. 2.3) at a point, and the projection onto the tangent bundle.
//! One path (`T = f64`, [`OnePath`]) evaluates them with [`InherentSde`] for any constraint and
//! reports a failure as a typed error; W lanes (`lanes.rs`) use the closed forms of a sphere
//! with a diagonal mass and return the lanes they decided.

use sdae_lanes::Real;
use sdae_manifold::Constraint;
use sdae_model::{StepFailure, TangentProjector};

use crate::error::check_finite;
use crate::inherent::{CurvedSystem, InherentSde};

/// The coefficients of one Euler step at (r, v): drift and noise parts of dv and dmu, in
/// storage `A` for n entries and `M` for m entries (vectors for one path, arrays in lanes).
#[derive(Debug, Clone)]
pub(crate) struct EulerParts<A, M = A> {
    /// Velocity drift of eq. 2.4 (Lemma 4.2, second block).
    pub accel: A,
    /// Drift of mu, eq. 2.3.
    pub mu_rate: M,
    /// M^-1 P_M B dw (eq. 2.4).
    pub noise_v: A,
    /// -G_M^-1 Dg M^-1 B dw (eq. 2.3).
    pub noise_mu: M,
}

impl<A, M> EulerParts<A, M> {
    /// The parts as slices.
    #[inline(always)]
    pub fn view<T>(&mut self) -> Parts<'_, T>
    where
        A: AsMut<[T]>,
        M: AsMut<[T]>,
    {
        Parts {
            accel: self.accel.as_mut(),
            mu_rate: self.mu_rate.as_mut(),
            noise_v: self.noise_v.as_mut(),
            noise_mu: self.noise_mu.as_mut(),
        }
    }
}

impl EulerParts<Vec<f64>> {
    /// Zeroed parts of one path: n coordinates, m constraints.
    pub fn new(n: usize, m: usize) -> Self {
        Self {
            accel: vec![0.0; n],
            mu_rate: vec![0.0; m],
            noise_v: vec![0.0; n],
            noise_mu: vec![0.0; m],
        }
    }
}

/// [`EulerParts`] as slices: n entries of `accel` and `noise_v`, m of `mu_rate` and
/// `noise_mu`.
pub(crate) struct Parts<'a, T> {
    /// Velocity drift of eq. 2.4.
    pub accel: &'a mut [T],
    /// Drift of mu, eq. 2.3.
    pub mu_rate: &'a mut [T],
    /// M^-1 P_M B dw.
    pub noise_v: &'a mut [T],
    /// -G_M^-1 Dg M^-1 B dw.
    pub noise_mu: &'a mut [T],
}

/// Where a step leaves r_{k+1}, v_{k+1} (n entries) and mu_{k+1} - mu_k (m entries).
pub(crate) struct Next<'a, T> {
    /// r_{k+1}.
    pub r: &'a mut [T],
    /// v_{k+1}.
    pub v: &'a mut [T],
    /// mu_{k+1} - mu_k.
    pub dmu: &'a mut [T],
}

/// What a step decided, per path.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stepped<T: Real> {
    /// The paths the step decided (always, for one path: a failure is an error).
    pub ok: T::Mask,
    /// The drift truncation factor theta (1 for an untruncated step).
    pub eta: T,
    /// The Newton iterations of a position projection (0 without one or in closed form).
    pub newton_iterations: T,
}

/// What the steps of the inherent SDE's solvers call on their paths: one path (`T = f64`)
/// or W lanes.
pub(crate) trait InherentKernel<T: Real> {
    /// Why a step is not taken here: one path's typed failure; for lanes, a system without a
    /// lane form (the group then steps through the scalar solver).
    type Error;
    /// The parts of an Euler step at (r, v) into `parts`: the drift parts
    /// `accel = M^-1 [P_M(r) a(r, v) - grad g(r) G_M(r)^-1 D^2 g(r)(v, v)]` (eq. 2.4) and
    /// `mu_rate = -G_M(r)^-1 { Dg(r) M^-1 a(r, v) + D^2 g(r)(v, v) }` (eq. 2.3), and with
    /// increments `dw` (none: zero noise) the noise parts `noise_v = M^-1 P_M(r) B(r, v) dw`
    /// and `noise_mu = -G_M(r)^-1 Dg(r) M^-1 B(r, v) dw`. Returns the paths where G_M(r)
    /// was factored and `accel`, `noise_v` are finite.
    fn parts(
        &mut self, r: &[T], v: &[T], dw: &[T], parts: &mut Parts<'_, T>,
    ) -> Result<T::Mask, Self::Error>;
    /// The paths whose `x` is finite; one path: a failure naming `what` where it is not.
    fn finite(&self, what: &'static str, x: &[T]) -> Result<T::Mask, Self::Error>;
}

/// The projection onto the tangent bundle of projected Euler-Maruyama.
pub(crate) trait ProjectionKernel<T: Real>: InherentKernel<T> {
    /// r <- y + M^-1 grad g(y) gamma with g(r) = 0, from y = r: the paths where the root was
    /// found, and its Newton iterations.
    fn project_position(&mut self, r: &mut [T]) -> Result<(T::Mask, T), Self::Error>;
    /// v <- v - M^-1 grad g(r) G_M(r)^-1 Dg(r) v (the M-orthogonal projection onto the tangent
    /// space at r): the paths where G_M(r) was factored.
    fn project_velocity(&mut self, r: &[T], v: &mut [T]) -> Result<T::Mask, Self::Error>;
}

/// A kernel with the projection of projected Euler-Maruyama: the [`ProjectionKernel`] of the
/// pair is implemented for each kind of path.
pub(crate) struct Projecting<K, P> {
    /// The coefficients.
    pub kernel: K,
    /// What projects.
    pub projection: P,
}

impl<T: Real, K: InherentKernel<T>, P> InherentKernel<T> for Projecting<K, P> {
    type Error = K::Error;
    #[inline(always)]
    fn parts(
        &mut self, r: &[T], v: &[T], dw: &[T], parts: &mut Parts<'_, T>,
    ) -> Result<T::Mask, Self::Error> {
        self.kernel.parts(r, v, dw, parts)
    }
    #[inline(always)]
    fn finite(&self, what: &'static str, x: &[T]) -> Result<T::Mask, Self::Error> {
        self.kernel.finite(what, x)
    }
}

/// One path's [`InherentKernel`]: [`InherentSde`] for any constraint.
pub(crate) struct OnePath<'a, S: CurvedSystem>(pub &'a mut InherentSde<S>);

impl<S: CurvedSystem> InherentKernel<f64> for OnePath<'_, S> {
    type Error = StepFailure;
    /// Factors G_M(r) ([`InherentSde::prepare`]) and evaluates the drift parts, and the noise
    /// parts if `dw` is not empty (a scene without noise pays nothing for it).
    #[inline(always)]
    fn parts(
        &mut self, r: &[f64], v: &[f64], dw: &[f64], parts: &mut Parts<'_, f64>,
    ) -> Result<bool, StepFailure> {
        let sde = &mut *self.0;
        sde.prepare(r)?;
        sde.drift_prepared(r, v, parts.accel, parts.mu_rate);
        check_finite("inherent drift", parts.accel)?;
        if dw.is_empty() {
            parts.noise_v.fill(0.0);
            parts.noise_mu.fill(0.0);
        } else {
            sde.noise_prepared(r, v, dw, parts.noise_v, parts.noise_mu);
            check_finite("inherent diffusion", parts.noise_v)?;
        }
        Ok(true)
    }

    #[inline(always)]
    fn finite(&self, what: &'static str, x: &[f64]) -> Result<bool, StepFailure> {
        check_finite(what, x)?;
        Ok(true)
    }
}

/// One path's projection: the [`TangentProjector`] shared with the initial-state projection.
type OnePathProjector<'a, S> =
    &'a mut TangentProjector<<<S as sdae_model::System>::Constraint as Constraint>::Gram>;

impl<S: CurvedSystem> ProjectionKernel<f64>
    for Projecting<OnePath<'_, S>, OnePathProjector<'_, S>>
{
    /// The projector's root along the normal M^-1 grad g (a failure where it finds none).
    fn project_position(&mut self, r: &mut [f64]) -> Result<(bool, f64), StepFailure> {
        let system = self.kernel.0.system();
        let certificate = self
            .projection
            .project_position(system.constraint(), system.mass(), r)
            .map_err(|source| StepFailure::Root {
                what: "projection onto the manifold",
                source,
            })?;
        Ok((true, certificate.iterations as f64))
    }

    /// The projector's velocity projection (a failure where G_M(r) is singular).
    fn project_velocity(&mut self, r: &[f64], v: &mut [f64]) -> Result<bool, StepFailure> {
        let system = self.kernel.0.system();
        self.projection
            .project_velocity(system.constraint(), system.mass(), r, v)?;
        Ok(true)
    }
}
