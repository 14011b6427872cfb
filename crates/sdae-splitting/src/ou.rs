//! The O step: the exact Ornstein-Uhlenbeck update of the velocity over a step h,
//! M dv = -gamma v dt + sigma dw with M diagonal, coordinate by coordinate.

use sdae_model::LangevinForm;

/// The factors of the O step for one coordinate with (M^-1)_ii = w over h: with c = gamma w,
///
/// ```text
/// v_i <- exp(-c h) v_i + sigma w sqrt((1 - exp(-2 c h)) / (2 c h)) dw_i
/// ```
///
/// which is the exact law of the velocity (variance sigma^2 w^2 (1 - exp(-2 c h)) / (2 c) =
/// kT w (1 - exp(-2 c h)) with kT = sigma^2 / (2 gamma)) when dw_i ~ N(0, h). Without
/// friction (c = 0) the factor is sigma w: the Euler step, which is then exact too.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OuFactors {
    /// exp(-gamma w h).
    pub decay: f64,
    /// The factor of dw_i.
    pub noise: f64,
}

impl OuFactors {
    /// The factors of one coordinate with inverse mass `w` over h.
    pub fn new(form: &LangevinForm, w: f64, h: f64) -> Self {
        let x = 2.0 * form.friction * w * h;
        // (1 - exp(-x)) / x, 1 at x = 0.
        let share = if x > 0.0 { -(-x).exp_m1() / x } else { 1.0 };
        Self {
            decay: (-form.friction * w * h).exp(),
            noise: form.noise * w * share.sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factors give the closed-form mean and variance of the OU velocity, and the Euler
    /// step without friction.
    #[test]
    fn factors_match_the_ornstein_uhlenbeck_law() {
        let form = LangevinForm {
            friction: 0.7,
            noise: (2.0f64 * 0.7 * 1.3).sqrt(),
        };
        let (w, h) = (0.5, 0.3);
        let f = OuFactors::new(&form, w, h);
        let c = form.friction * w;
        assert!((f.decay - (-c * h).exp()).abs() < 1e-15);
        // Variance of noise * dw with dw ~ N(0, h): kT w (1 - exp(-2 c h)), kT = 1.3.
        let variance = f.noise * f.noise * h;
        let exact = 1.3 * w * (1.0 - (-2.0 * c * h).exp());
        assert!(
            (variance - exact).abs() < 1e-14 * exact,
            "{variance} {exact}"
        );
        let free = OuFactors::new(
            &LangevinForm {
                friction: 0.0,
                noise: 2.0,
            },
            w,
            h,
        );
        assert_eq!((free.decay, free.noise), (1.0, 1.0));
    }
}
