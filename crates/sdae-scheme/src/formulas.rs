//! The half-explicit step's own formulas (seed eq. 3.1, 3.2), written once over [`Real`]: the
//! step written once (`step.rs`) calls them for one path (`f64`) and in lanes, so that lane i
//! computes what the scalar step computes for path i. The kappa root's tests and certificate are `sdae_ift::criteria`'s; a constraint's
//! formulas are its own (`sdae_manifold`).

use sdae_lanes::{PathMask, Real};
use sdae_manifold::motion_measure;

/// The truncation factor of eq. 3.2, eta = min(1, C_eta / (m h)), with m = max(|v|, |v|^2, |a|)
/// from `speed` = |v| and `acceleration` = |a|, or the constraint's `local` measure of the
/// motion in its place ([`Constraint::local_motion`](sdae_manifold::Constraint::local_motion));
/// 1 without truncation (`c_eta` = `None`).
#[inline(always)]
pub(crate) fn eta<T: Real>(
    c_eta: Option<f64>, h: f64, speed: T, acceleration: T, local: Option<T>,
) -> T {
    let one = speed.splat_like(1.0);
    let Some(c_eta) = c_eta else {
        return one;
    };
    let motion = match local {
        Some(local) => local,
        None => motion_measure(speed, acceleration),
    };
    let size = motion * h;
    let c = size.splat_like(c_eta);
    T::select(c.less(size), c / size, one)
}

/// y = r_k + eta h v_k of eq. 3.1, one coordinate.
#[inline(always)]
pub(crate) fn drifted<T: Real>(r: T, v: T, eta_h: T) -> T {
    r + eta_h * v
}

/// How eq. 3.1's force eta h a + B dw is formed: with rescaled noise and eta < 1 (in law a
/// step of eta h) as sqrt(eta) (sqrt(eta) h a + B dw) = eta h a + sqrt(eta) B dw, else as is.
pub(crate) struct ForceScale<T: Real> {
    /// The paths whose noise is rescaled and sqrt(eta) (1 elsewhere); `None` where no path's
    /// is (the default, with no square root taken).
    rescaled: Option<(T::Mask, T)>,
    /// The drift's factor: sqrt(eta) h where rescaled, eta h elsewhere.
    pub(crate) drift_h: T,
}

impl<T: Real> ForceScale<T> {
    /// The factors for the truncation factor `eta` and the step `h`.
    #[inline(always)]
    pub(crate) fn new(rescale_noise: bool, eta: T, h: f64) -> Self {
        let one = eta.splat_like(1.0);
        let rescaled = eta.less(one);
        if !rescale_noise || !rescaled.any() {
            return Self {
                rescaled: None,
                drift_h: eta * h,
            };
        }
        let scale = T::select(rescaled, eta.sqrt(), one);
        Self {
            rescaled: Some((rescaled, scale)),
            drift_h: T::select(rescaled, scale * h, eta * h),
        }
    }

    /// force <- sqrt(eta) force in the rescaled paths, once B dw is added to the drift's part.
    #[inline(always)]
    pub(crate) fn rescale(&self, force: &mut [T]) {
        if let Some((rescaled, scale)) = self.rescaled {
            for f in force.iter_mut() {
                *f = T::select(rescaled, *f * scale, *f);
            }
        }
    }
}
