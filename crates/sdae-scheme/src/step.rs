//! The half-explicit drift-truncated Euler step (seed eq. 3.1 with eta from eq. 3.2), written
//! once over [`Real`]: [`half_explicit_step`]. The stepper's step of one path (`f64`, the ball
//! solver, `stepper.rs`), the sphere's closed form over lanes (`ensemble/sphere.rs`, also one
//! path at W = 1) and Newton over a constraint's lane formulas (`ensemble/newton.rs`) are its
//! instances: each brings the system's drift and noise, the motion's local measure and the
//! constrained update of eq. 3.1 through a [`HalfExplicitKernel`], so that lane i computes what
//! the step of one path computes for path i, with the same floating-point operations in the
//! same order.

use sdae_lanes::{Lanes, PathMask, Real};
use sdae_model::engine::LaneRecord;

use crate::config::StepperConfig;
use crate::formulas::{self, ForceScale};

/// What [`half_explicit_step`] calls on its paths: one path (`T = f64`) or W lanes.
pub(crate) trait HalfExplicitKernel<T: Real> {
    /// Why a step stops before it decides any path: one path's typed failure, or a system
    /// without the lane form the kernel needs (its paths then take the one-path step).
    type Stop;
    /// |x|^2; one path: a failure naming `what` where it is not finite.
    fn norm2(&self, what: &'static str, x: &[T]) -> Result<T, Self::Stop>;
    /// out = a(r, v).
    fn drift(&mut self, r: &[T], v: &[T], out: &mut [T]) -> Result<(), Self::Stop>;
    /// out += B(r, v) dw.
    fn add_noise(&mut self, r: &[T], v: &[T], dw: &[T], out: &mut [T]) -> Result<(), Self::Stop>;
    /// The constraint's local measure of the motion in place of eq. 3.2's
    /// max(|v|, |v|^2, |a|), from r, v, a, |v| = `speed` and |a| = `acceleration`
    /// ([`Constraint::local_motion`](sdae_manifold::Constraint::local_motion)); `None` where it
    /// has none.
    fn local_motion(&self, r: &[T], v: &[T], a: &[T], speed: T, acceleration: T) -> Option<T>;
    /// force <- drift_h force (the drift's part of eq. 3.1's force), for the point
    /// y = r + eta_h v; a kernel may read y in the same pass (the default does not).
    #[inline(always)]
    fn scale_drift(&mut self, r: &[T], v: &[T], eta_h: T, drift_h: T, force: &mut [T]) {
        let _ = (r, v, eta_h);
        scale_force(drift_h, force);
    }
    /// The constrained update of eq. 3.1 from r and y = r + eta_h v with the force
    /// eta h a + B dw (`force`, rescaled where asked): v~ = v + M^-1 force, the kappa root
    /// r' = y + M^-1 grad g(r) kappa on g = 0 (in the ball of radius C_kappa), lambda from
    /// Dg(r') M^-1 grad g(r) lambda = -Dg(r') v~ into `dmu` and v' = v~ + M^-1 grad g(r)
    /// lambda, with max_i |(Dg(r') v')_i| if `monitor`. The kernel keeps r' and v' (in `force`
    /// or buffers of its own); one path: a failure where the root is not found or v' is not
    /// finite.
    fn constrain(
        &mut self, r: &[T], v: &[T], eta_h: T, force: &mut [T], dmu: &mut [T], monitor: bool,
    ) -> Result<Update<T>, Self::Stop>;
}

/// force <- drift_h force, the default of [`HalfExplicitKernel::scale_drift`].
#[inline(always)]
pub(crate) fn scale_force<T: Real>(drift_h: T, force: &mut [T]) {
    for f in force.iter_mut() {
        *f = drift_h * *f;
    }
}

/// What [`HalfExplicitKernel::constrain`] found, per path.
#[derive(Clone, Copy)]
pub(crate) struct Update<T: Real> {
    /// The paths it decided (always, for one path).
    pub(crate) ok: T::Mask,
    /// Newton iterations of the kappa root (0 in closed form).
    pub(crate) newton_iterations: T,
    /// |g(r')|.
    pub(crate) position_residual: T,
    /// max_i |(Dg(r') v')_i| where monitored.
    pub(crate) velocity_residual: Option<T>,
    /// The certificate's contraction estimate.
    pub(crate) contraction: T,
    /// |kappa|.
    pub(crate) kappa_norm: T,
}

/// What [`half_explicit_step`] decided, per path.
pub(crate) struct HalfExplicit<T: Real> {
    /// The paths it decided (the others take the one-path step).
    pub(crate) ok: T::Mask,
    /// eta of eq. 3.2.
    pub(crate) eta: T,
    /// The constrained update's numbers.
    pub(crate) update: Update<T>,
}

/// One step of seed eq. 3.1 with eta from eq. 3.2, from (r, v) with increments dw:
///
/// ```text
/// eta = min(1, C_eta / (max(|v|, |v|^2, |a(r, v)|) h))           (or the local measure)
/// r' = r + eta h v + M^-1 grad g(r) kappa,                        g(r') = 0
/// v' = v + M^-1 [eta h a(r, v) + B(r, v) dw + grad g(r) lambda],  Dg(r') v' = 0
/// ```
///
/// with rescaled noise and eta < 1 the force is eta h a + sqrt(eta) B dw ([`ForceScale`]).
/// `force` (n entries) is scratch for a, then the force; the kernel keeps r' and v'
/// ([`HalfExplicitKernel::constrain`]), lambda goes into `dmu`. Inlined into each kernel, so
/// that it compiles with the lanes' instruction set and fixed sizes.
#[inline(always)]
pub(crate) fn half_explicit_step<T: Real, K: HalfExplicitKernel<T>>(
    kernel: &mut K, config: &StepperConfig, h: f64, [r, v, dw]: [&[T]; 3], force: &mut [T],
    dmu: &mut [T],
) -> Result<HalfExplicit<T>, K::Stop> {
    let v_norm2 = kernel.norm2("velocity v_k", v)?;
    kernel.drift(r, v, force)?;
    let a_norm2 = kernel.norm2("drift a(r, v)", force)?;
    let ok = v_norm2.finite().and(a_norm2.finite());
    let eta = eta(kernel, config, h, [r, v, force], [v_norm2, a_norm2]);
    let eta_h = eta * h;
    let scale = ForceScale::new(config.rescale_noise, eta, h);
    kernel.scale_drift(r, v, eta_h, scale.drift_h, force);
    kernel.add_noise(r, v, dw, force)?;
    scale.rescale(force);
    let update = kernel.constrain(r, v, eta_h, force, dmu, config.monitor_velocity_constraint)?;
    Ok(HalfExplicit {
        ok: ok.and(update.ok),
        eta,
        update,
    })
}

/// eta of eq. 3.2 from r, v, a and [|v|^2, |a|^2]: 1 without truncation or where it surely
/// finds no truncation ([`surely_untruncated`]), else [`formulas::eta`] with the local measure
/// where asked.
#[inline(always)]
pub(crate) fn eta<T: Real, K: HalfExplicitKernel<T>>(
    kernel: &K, config: &StepperConfig, h: f64, [r, v, a]: [&[T]; 3], [v_norm2, a_norm2]: [T; 2],
) -> T {
    let one = v_norm2.splat_like(1.0);
    let Some(c_eta) = config.c_eta else {
        return one;
    };
    if surely_untruncated(config, v_norm2 + a_norm2, c_eta, h) {
        return one;
    }
    let (speed, acceleration) = (v_norm2.sqrt(), a_norm2.sqrt());
    let local = if config.local_size {
        kernel.local_motion(r, v, a, speed, acceleration)
    } else {
        None
    };
    formulas::eta(Some(c_eta), h, speed, acceleration, local)
}

/// Whether eq. 3.2 gives eta = 1 in every path, decided without the square roots and
/// divisions of the motion's measure: with B = |v|^2 + |a|^2 (`norms2`), the measure
/// max(w, w^2, alpha) is at most max(sqrt(B), B) to a few ulps, so B <= min(C_eta / (2h),
/// C_eta^2 / (4h^2)) keeps h times it below C_eta / 2 whatever the rounding, where the full
/// formula gives eta = 1 exactly. Not finite B, any path beyond the bound, or the constraint's
/// local measure ([`StepperConfig::local_size`], whose scale is its own) leaves it to the full
/// formula.
#[inline(always)]
pub(crate) fn surely_untruncated<T: Real>(
    config: &StepperConfig, norms2: T, c_eta: f64, h: f64,
) -> bool {
    if config.local_size {
        return false;
    }
    let half_step = 0.5 * c_eta / h;
    norms2
        .at_most(norms2.splat_like(half_step.min(half_step * half_step)))
        .all()
}

/// What a step in lanes adds to its lanes' diagnostics (|kappa| / C_kappa where the ball's
/// radius C_kappa is finite).
#[inline(always)]
pub(crate) fn lane_record<Sd: pulp::Simd>(
    step: &HalfExplicit<Lanes<Sd>>, c_kappa: f64,
) -> LaneRecord<Sd> {
    let update = &step.update;
    LaneRecord {
        eta: step.eta,
        newton_iterations: update.newton_iterations,
        position_residual: Some(update.position_residual),
        velocity_residual: update.velocity_residual,
        certificate: Some((
            update.contraction,
            c_kappa.is_finite().then(|| update.kappa_norm / c_kappa),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::surely_untruncated;
    use crate::StepperConfig;
    use crate::formulas;

    /// Wherever the shortcut says eta = 1, eq. 3.2 gives exactly 1; and it says so up to half
    /// the bound of the measure, while eq. 3.2 truncates within four times it (so a looser
    /// shortcut would fail here). With the constraint's local measure it never says so.
    #[test]
    fn the_untruncated_shortcut_agrees_with_eq_3_2() {
        let (mut passed, mut truncated) = (0, 0);
        for (h, c_eta) in [(1e-3, 1.0), (0.1, 0.05), (0.02, 3.0)] {
            let config = StepperConfig::new(c_eta, f64::INFINITY).unwrap();
            assert!(!surely_untruncated(&config.local(), 0.0, c_eta, h));
            let half = 0.5 * c_eta / h;
            let limit = half.min(half * half);
            for i in 0..=4000 {
                let b = limit * (0.25 + i as f64 / 1000.0);
                for share in [0.0, 0.3, 0.5, 0.9, 1.0] {
                    let (v2, a2): (f64, f64) = (b * share, b * (1.0 - share));
                    let eta = formulas::eta(Some(c_eta), h, v2.sqrt(), a2.sqrt(), None);
                    if surely_untruncated(&config, v2 + a2, c_eta, h) {
                        assert_eq!(eta, 1.0, "b = {b:e}, share {share}");
                        passed += 1;
                    }
                    if eta < 1.0 {
                        truncated += 1;
                    }
                }
            }
        }
        assert!(
            passed > 0 && truncated > 0,
            "{passed} passed, {truncated} truncated"
        );
    }
}
