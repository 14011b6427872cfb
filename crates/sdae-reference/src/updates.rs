//! The updates of the Euler-type solvers of the inherent SDE (seed eq. 2.4, multiplier eq.
//! 2.3), one coordinate at a time, written once over [`Real`]: the solvers' step bodies
//! (`euler_step`, `heun_step`, themselves written once over [`Real`]) call them.

use sdae_lanes::Real;
use sdae_manifold::vector::sum_squares;

/// r' = r + dt v of an Euler-Maruyama step.
#[inline(always)]
pub(crate) fn euler_position<T: Real>(r: T, v: T, dt: T) -> T {
    r + dt * v
}

/// v' = v + (dt a + noise_v) of an Euler-Maruyama step, with a the inherent drift and noise_v
/// M^-1 P_M B dw.
#[inline(always)]
pub(crate) fn euler_velocity<T: Real>(v: T, accel: T, noise: T, dt: T) -> T {
    v + (dt * accel + noise)
}

/// The multiplier's increment dmu = dt mu_rate + noise_mu of eq. 2.3.
#[inline(always)]
pub(crate) fn euler_multiplier<T: Real>(rate: T, noise: T, dt: T) -> T {
    dt * rate + noise
}

/// r' = r + h/2 (v + v~) of stochastic Heun, with v~ the predictor's velocity.
#[inline(always)]
pub(crate) fn heun_position<T: Real>(r: T, v: T, predicted_v: T, half_h: T) -> T {
    r + (v + predicted_v) * half_h
}

/// v' = v + h/2 (a + a~) + noise_v of stochastic Heun, with a~ the drift at the predictor.
#[inline(always)]
pub(crate) fn heun_velocity<T: Real>(v: T, accel: T, predicted_accel: T, noise: T, half_h: T) -> T {
    v + (accel + predicted_accel) * half_h + noise
}

/// dmu = h/2 (mu_rate + mu_rate~) + noise_mu of stochastic Heun.
#[inline(always)]
pub(crate) fn heun_multiplier<T: Real>(rate: T, predicted_rate: T, noise: T, half_h: T) -> T {
    (rate + predicted_rate) * half_h + noise
}

/// |(v, a)| = sqrt(|v|^2 + |a|^2), the size of the drift truncated Euler-Maruyama bounds.
#[inline(always)]
pub(crate) fn drift_norm<T: Real>(v: &[T], accel: &[T]) -> T {
    (sum_squares(v) + sum_squares(accel)).sqrt()
}

/// The truncation factor theta = min(1, c / (|(v, a)| h)) of truncated Euler-Maruyama (seed
/// Remark 3.3) with scale c.
#[inline(always)]
pub(crate) fn truncation<T: Real>(scale: f64, h: f64, drift_norm: T) -> T {
    let size = drift_norm * h;
    let c = size.splat_like(scale);
    T::select(c.less(size), c / size, size.splat_like(1.0))
}
