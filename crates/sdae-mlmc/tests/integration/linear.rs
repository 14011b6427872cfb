//! Scalar linear SDEs by Euler-Maruyama, whose level means and variances are known in closed
//! form: a model to check the MLMC machinery against (shared with the study crate's suite).

use std::ops::Range;

use sdae_mlmc::{LevelSampler, MlmcError, Sample};
use sdae_noise::{PathStreams, StandardNormals};

/// dX = a X dt + b X^m dW (m = 1 multiplicative, m = 0 additive), X_0 = 1, by Euler-Maruyama
/// on h_l = T 2^-(k0 + l) (k0 >= 1): E[X_T] = e^(a T) exactly for both.
pub struct Linear {
    pub a: f64,
    pub b: f64,
    pub multiplicative: bool,
    pub t_end: f64,
    pub coarsest: u32,
    pub seed: u64,
}

impl Linear {
    /// The Ornstein-Uhlenbeck process dX = -X / 2 dt + dW / 2 from level 0 on 2 steps, T = 1.
    pub fn ou(seed: u64) -> Self {
        Linear {
            a: -0.5,
            b: 0.5,
            multiplicative: false,
            t_end: 1.0,
            coarsest: 1,
            seed,
        }
    }

    /// The same SDE and levels with the paths of `seed`'s streams.
    pub fn with_seed(&self, seed: u64) -> Self {
        Linear { seed, ..*self }
    }

    fn step(&self, x: f64, h: f64, dw: f64) -> f64 {
        let noise = if self.multiplicative {
            self.b * x
        } else {
            self.b
        };
        x + self.a * x * h + noise * dw
    }
}

impl LevelSampler for Linear {
    type Worker = ();
    fn worker(&self) -> Result<(), MlmcError> {
        Ok(())
    }
    fn run_block(
        &self, _: &mut (), level: u32, indices: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        let steps = 1u64 << (self.coarsest + level);
        let h = self.t_end / steps as f64;
        Ok(indices
            .map(|i| {
                let mut normals = PathStreams::for_path(self.seed, (u64::from(level) << 48) + i);
                let (mut fine, mut coarse) = (1.0, 1.0);
                for _ in 0..steps / 2 {
                    let dw1 = h.sqrt() * normals.next_normal();
                    let dw2 = h.sqrt() * normals.next_normal();
                    fine = self.step(self.step(fine, h, dw1), h, dw2);
                    coarse = self.step(coarse, 2.0 * h, dw1 + dw2);
                }
                let paired = coupled && level > 0;
                Sample::Value {
                    fine,
                    coarse: if paired { coarse } else { 0.0 },
                }
            })
            .collect())
    }
    fn path_steps(&self, level: u32) -> u64 {
        1 << (self.coarsest + level)
    }
    fn pair_steps(&self, level: u32) -> u64 {
        let fine = self.path_steps(level);
        if level == 0 { fine } else { fine + fine / 2 }
    }
}

impl Linear {
    /// E[P_l] and E[P_l^2] exactly: with u = 1 + a h, X_N = prod (u + b X^m dW / X) gives
    /// E[X_N] = u^N for both noises; E[X_N^2] = (u^2 + b^2 h)^N (multiplicative) or by the
    /// recursion E[x'^2] = u^2 E[x^2] + b^2 h (additive).
    pub fn moments(&self, level: u32) -> (f64, f64, f64, f64, f64) {
        let n = 1u64 << (self.coarsest + level);
        let h = self.t_end / n as f64;
        let (u, w, b2) = (1.0 + self.a * h, 1.0 + 2.0 * self.a * h, self.b * self.b);
        let (nf, nc) = (n as i32, (n / 2) as i32);
        if self.multiplicative {
            // E[F C] over one coarse step: E[(u + bA)(u + bB)(w + b(A + B))] = u^2 w + 2 u b^2 h.
            (
                u.powi(nf),
                w.powi(nc),
                (u * u + b2 * h).powi(nf),
                (w * w + 2.0 * b2 * h).powi(nc),
                (u * u * w + 2.0 * u * b2 * h).powi(nc),
            )
        } else {
            // Second moments of the (F, C) pair over coarse steps: F' = u^2 F + b(u A + B),
            // C' = w C + b(A + B).
            let (mut ff, mut cc, mut fc) = (1.0f64, 1.0f64, 1.0f64);
            for _ in 0..nc {
                let (f_lin, c_lin) = (u * u, w);
                ff = f_lin * f_lin * ff + b2 * h * (u * u + 1.0);
                cc = c_lin * c_lin * cc + 2.0 * b2 * h;
                fc = f_lin * c_lin * fc + b2 * h * (u + 1.0);
            }
            (u.powi(nf), w.powi(nc), ff, cc, fc)
        }
    }

    /// The exact slopes -d log2 |E[Y_l]| / dl over `alpha_levels` and -d log2 V[Y_l] / dl over
    /// `beta_levels`, fitted like the estimates (least squares on log2).
    pub fn exact_rates(&self, alpha_levels: &[u32], beta_levels: &[u32]) -> (f64, f64) {
        let slope = |levels: &[u32], y: &dyn Fn(u32) -> f64| {
            let x: Vec<f64> = levels.iter().map(|&l| f64::from(l)).collect();
            let y: Vec<f64> = levels.iter().map(|&l| y(l)).collect();
            -sdae_mlmc::fit::fit_slope(&x, &y, None).unwrap().estimate
        };
        let mean = |l: u32| {
            let (ef, ec, ..) = self.moments(l);
            (ef - ec).abs().log2()
        };
        let variance = |l: u32| {
            let (ef, ec, ff, cc, fc) = self.moments(l);
            (ff - 2.0 * fc + cc - (ef - ec).powi(2)).log2()
        };
        (slope(alpha_levels, &mean), slope(beta_levels, &variance))
    }
}
