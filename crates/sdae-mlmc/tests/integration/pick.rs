//! The expectation helper runs the estimator its pilot predicts cheapest, and each of the four
//! is the cheapest on a constructed model.
//!
//! The model: one uniform u per path, P_l(u) = e^u + c 2^-l u on level l (E\[P_l\] = e - 1 +
//! c 2^-l / 2, alpha = 1), a path of level l taking 2^l steps. Its two switches make each
//! estimator win:
//!
//! - `coupled`: the coarse value of a pair is P_{l-1} at the same u (V\[Y_l\] ~ 4^-l: the
//!   multilevel methods gain), or at an independent u (V\[Y_l\] ~ 2 V\[P\]: they lose);
//! - `points`: the quasi-random points are a randomly shifted van der Corput sequence (the
//!   variance of a mean of n points falls as n^-2 for this smooth P_l: QMC gains),
//!   pseudo-random uniforms (n^-1: QMC does not gain, and R n_0 points per level is its
//!   floor), or one shift repeated (the mean of a randomization does not improve with n: QMC
//!   loses).

use std::ops::Range;

use crate::uniform::{mix, no_worker, rule, unit};

use sdae_mlmc::expectation::{CostMeasure, Method, cheapest};
use sdae_mlmc::{
    Expectation, ExpectationSettings, LevelSampler, MlmcError, QuasiSampler, RunControl, Sample,
    expectation_quasi,
};

/// The quasi-random points of a randomization.
#[derive(Clone, Copy, PartialEq)]
enum Points {
    /// A randomly shifted van der Corput sequence.
    Spread,
    /// Pseudo-random uniforms.
    Pseudo,
    /// The shift alone, at every point.
    Flat,
}

struct Model {
    c: f64,
    coupled: bool,
    points: Points,
    seed: u64,
}

impl Model {
    fn p(&self, level: u32, u: f64) -> f64 {
        rule(self.c, level, u)
    }

    /// The pair of a path with uniform `u`, its independent coarse uniform from `other`.
    fn sample(&self, level: u32, u: f64, other: u64, coupled: bool) -> Sample {
        let coarse = match (coupled && level > 0, self.coupled) {
            (false, _) => 0.0,
            (true, true) => self.p(level - 1, u),
            (true, false) => self.p(level - 1, unit(mix(other ^ 0xC0A5E))),
        };
        Sample::Value {
            fine: self.p(level, u),
            coarse,
        }
    }

    fn key(&self, level: u32, stream: u64, i: u64) -> u64 {
        mix(mix(mix(self.seed) ^ u64::from(level)) ^ stream) ^ i.wrapping_mul(0x9E37)
    }
}

impl LevelSampler for Model {
    no_worker!();
    fn run_block(
        &self, _: &mut (), level: u32, indices: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        Ok(indices
            .map(|i| {
                let k = mix(self.key(level, u64::MAX, i));
                self.sample(level, unit(k), k, coupled)
            })
            .collect())
    }
    fn path_steps(&self, level: u32) -> u64 {
        1 << level
    }
    fn pair_steps(&self, level: u32) -> u64 {
        if level == 0 { 1 } else { 3 << (level - 1) }
    }
}

impl QuasiSampler for Model {
    no_worker!();
    fn run_points(
        &self, _: &mut (), level: u32, randomization: u32, points: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        let shift = unit(mix(self.key(level, u64::from(randomization), 0)));
        Ok(points
            .map(|i| {
                let k = mix(self.key(level, u64::from(randomization) + 1, i));
                let u = match self.points {
                    Points::Spread => (unit(i.reverse_bits()) + shift).fract(),
                    Points::Pseudo => unit(k),
                    Points::Flat => shift,
                };
                self.sample(level, u, k, coupled)
            })
            .collect())
    }
    fn path_steps(&self, level: u32) -> u64 {
        1 << level
    }
    fn pair_steps(&self, level: u32) -> u64 {
        LevelSampler::pair_steps(self, level)
    }
}

/// A pilot of `test_samples` pairs per level on up to levels 0..=10.
fn settings(eps: f64, test_samples: u64) -> ExpectationSettings {
    ExpectationSettings {
        test_samples,
        test_levels: 10,
        ..ExpectationSettings::new(eps)
    }
}

/// Checks that the estimator that ran is the cheapest offered prediction by work, below every
/// other offered one, and returns it.
fn picked(model: &Model, settings: &ExpectationSettings) -> Expectation {
    let control = RunControl::new(2).unwrap();
    let found = expectation_quasi(model, &control, settings).unwrap();
    let pick = cheapest(&found.predicted, CostMeasure::Work).unwrap();
    assert_eq!(found.method, pick.method, "{:#?}", found.predicted);
    for p in found.predicted.iter().filter(|p| p.offered) {
        assert!(pick.work <= p.work, "{p:?} against {pick:?}");
    }
    assert!(!found.asked);
    found
}

fn describe(found: &Expectation) -> String {
    found
        .predicted
        .iter()
        .map(|p| format!("{}: {:.3e} {:?} ({})", p.method, p.work, p.rates, p.note))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Coupled levels with c = 1 (about ten levels at these eps): MLMC where QMC does not gain,
/// MLQMC where it does. Independent levels with c = 0 (the levels' means agree, so level 2
/// passes the bias test once the pilot's 2^18 pairs resolve their means): standard Monte Carlo
/// where QMC loses, randomized QMC where it gains. Every estimate is within 3 eps of e - 1.
#[test]
fn each_estimator_is_picked_where_it_is_predicted_cheapest() {
    let cases = [
        (
            true,
            Points::Pseudo,
            1.0,
            settings(1e-3, 2048),
            Method::Mlmc,
        ),
        (
            true,
            Points::Spread,
            1.0,
            settings(3e-4, 2048),
            Method::Mlqmc,
        ),
        (
            false,
            Points::Flat,
            0.0,
            settings(1e-2, 1 << 18),
            Method::Standard,
        ),
        (
            false,
            Points::Spread,
            0.0,
            settings(1e-2, 1 << 18),
            Method::Rqmc,
        ),
    ];
    for (coupled, points, c, settings, method) in cases {
        let model = Model {
            c,
            coupled,
            points,
            seed: 5,
        };
        let found = picked(&model, &settings);
        assert_eq!(found.method, method, "{}", describe(&found));
        // A single level needs the bias resolved.
        assert!(coupled || found.resolved, "{}", describe(&found));
        let exact = std::f64::consts::E - 1.0;
        let miss = (found.with_bias.estimate - exact).abs();
        let eps = settings.eps;
        assert!(
            miss < 3.0 * eps,
            "{method}: {} misses {exact}",
            found.with_bias.estimate
        );
    }
}
