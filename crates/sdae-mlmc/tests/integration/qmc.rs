//! Multilevel randomized QMC against a one-dimensional rule with closed-form answers.
//!
//! Point i of randomization r of level l is u = frac(phi(i) + s), phi the van der Corput
//! sequence (base 2 radical inverse) and s a uniform shift drawn from (seed, l, r): the first
//! n = 2^m points are the grid {(k + delta) / n} with delta uniform, so the mean of any h over
//! them is unbiased, and for smooth h its variance falls as n^-2 ((h(1) - h(0))^2 / (12 n^2)
//! asymptotically). The levels are P_l(u) = e^u + c 2^-l u, so
//!
//!   E[P_L] = e - 1 + c 2^-L / 2,   E[Y_0] = e - 1 + c / 2,   E[Y_l] = -c 2^-l / 2 (l >= 1),
//!
//! alpha = 1, and the limit is e - 1.

use std::ops::Range;

use crate::uniform::{mix, no_worker, rule, unit};
use std::sync::Mutex;
use std::time::Instant;

use sdae_mlmc::qmc::level::QuasiLevel;
use sdae_mlmc::{
    MlmcError, MlqmcEstimate, QuasiSampler, QuasiSettings, RunControl, Sample, cost_exponent,
    cost_exponent_of, mlqmc, standard_quasi_monte_carlo,
};

const LIMIT: f64 = std::f64::consts::E - 1.0;

/// What the synthetic sampler does besides the plain rule.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Plain,
    /// Every point fails.
    FailAll,
    /// Points i = 3 mod 7 fail on the fine path.
    FailSome,
    /// Level 1 gives NaN.
    NotANumber,
    /// Each randomization's points all sit at its shift: no variance reduction with n.
    Flat,
}

struct Shifted {
    c: f64,
    seed: u64,
    /// Y_l += k (u - 1/2) on level l (mean unchanged, variance raised).
    extra: Option<(u32, f64)>,
    mode: Mode,
    max_points: u64,
    /// (level, first point) of each block of randomization 0 that starts at 0 or a power of
    /// two: the levels' first points and their doublings, in the order they ran.
    log: Option<Mutex<Vec<(u32, u64)>>>,
}

impl Shifted {
    fn new(c: f64, seed: u64) -> Self {
        Self {
            c,
            seed,
            extra: None,
            mode: Mode::Plain,
            max_points: 1 << 32,
            log: None,
        }
    }

    fn exact(&self, level: u32) -> f64 {
        LIMIT + self.c * 0.5f64.powi(level as i32) / 2.0
    }

    fn p(&self, level: u32, u: f64) -> f64 {
        rule(self.c, level, u)
    }
}

impl QuasiSampler for Shifted {
    no_worker!();
    fn run_points(
        &self, _: &mut (), level: u32, randomization: u32, points: Range<u64>, coupled: bool,
    ) -> Result<Vec<Sample>, MlmcError> {
        if let Some(log) = &self.log
            && randomization == 0
            && (points.start == 0 || points.start.is_power_of_two())
        {
            log.lock().unwrap().push((level, points.start));
        }
        let shift = unit(mix(
            mix(self.seed) ^ (u64::from(level) << 32 | u64::from(randomization))
        ));
        Ok(points
            .map(|i| {
                let phi = if self.mode == Mode::Flat {
                    0.0
                } else {
                    unit(i.reverse_bits())
                };
                let u = (phi + shift).fract();
                let fail = match self.mode {
                    Mode::FailAll => true,
                    Mode::FailSome => i % 7 == 3,
                    _ => false,
                };
                if fail {
                    return Sample::Failed {
                        fine: true,
                        coarse: false,
                    };
                }
                let mut fine = self.p(level, u);
                if self.mode == Mode::NotANumber && level == 1 {
                    fine = f64::NAN;
                }
                if let Some((l, k)) = self.extra
                    && l == level
                {
                    fine += k * (u - 0.5);
                }
                let coarse = if coupled && level > 0 {
                    self.p(level - 1, u)
                } else {
                    0.0
                };
                Sample::Value { fine, coarse }
            })
            .collect())
    }
    fn path_steps(&self, level: u32) -> u64 {
        1 << level
    }
    fn pair_steps(&self, level: u32) -> u64 {
        if level == 0 { 1 } else { 3 << (level - 1) }
    }
    fn max_points(&self) -> u64 {
        self.max_points
    }
}

fn run(sampler: &Shifted, control: &RunControl<'_>, settings: &QuasiSettings) -> MlqmcEstimate {
    mlqmc(sampler, control, settings).unwrap()
}

/// 100 seeded runs at eps = 1e-3 (levels 0..=2 to start; the bias c 2^-L / 2 with c = 1 needs
/// L of about 10). With true coverage 95%, fewer than 88 of 100 intervals covering E[P_L] has
/// probability 4.6e-4 (binomial).
#[test]
fn intervals_cover_and_the_error_is_below_eps() {
    let start = Instant::now();
    let control = RunControl::new(2).unwrap();
    let eps = 1e-3;
    let settings = QuasiSettings::new(eps);
    let (mut covered, mut square_error) = (0, 0.0);
    for seed in 0..100 {
        let sampler = Shifted::new(1.0, seed);
        let r = run(&sampler, &control, &settings);
        let top = r.levels.len() as u32 - 1;
        assert!(r.converged);
        assert!(r.variance <= eps * eps / 2.0);
        assert!(r.bias <= eps / 2f64.sqrt());
        assert!(r.estimate.ci_low < r.estimate.ci_high);
        covered += usize::from(r.estimate.contains(sampler.exact(top)));
        square_error += (r.estimate.estimate - LIMIT).powi(2);
        // The work is sum_l R n_l C_l, n_l a power of two.
        let work: f64 = r
            .levels
            .iter()
            .map(|q| 32.0 * q.points as f64 * q.cost as f64)
            .sum();
        assert_eq!(r.work, work);
        assert!(r.levels.iter().all(|q| q.points.is_power_of_two()));
    }
    let rmse = (square_error / 100.0).sqrt();
    assert!(covered >= 88, "{covered} of 100 intervals cover E[P_L]");
    assert!(rmse < eps, "root mean square error {rmse:e}");
    eprintln!(
        "coverage {covered}/100, rmse {:.3} eps, {:.2} s",
        rmse / eps,
        start.elapsed().as_secs_f64()
    );
}

#[test]
fn levels_are_added_until_the_bias_test_passes() {
    let control = RunControl::new(2).unwrap();
    let eps = 1e-3;
    let r = run(&Shifted::new(1.0, 7), &control, &QuasiSettings::new(eps));
    let top = r.levels.len() - 1;
    // c 2^-L / 2 <= eps / sqrt(2) needs L >= 9.
    assert!(top >= 9, "stopped at level {top}");
    assert!(r.converged && r.bias <= eps / 2f64.sqrt());
    // One level fewer would have failed the test.
    let means: Vec<(f64, f64)> = r.levels[..top]
        .iter()
        .map(|q| (q.mean, q.variance.sqrt()))
        .collect();
    assert!(sdae_mlmc::algorithm::bias_estimate(&means).0 > eps / 2f64.sqrt());
    // Each level's mean is within 4 standard errors of -c 2^-l / 2.
    for q in &r.levels[1..] {
        let exact = -0.5f64.powi(q.level as i32) / 2.0;
        assert!(
            (q.mean - exact).abs() <= 4.0 * q.variance.sqrt() + 1e-15,
            "{q:?}"
        );
    }
    // A low L_max: the run stops there, not converged.
    let capped = QuasiSettings {
        max_level: 4,
        ..QuasiSettings::new(eps)
    };
    let r = run(&Shifted::new(1.0, 7), &control, &capped);
    assert_eq!((r.levels.len(), r.converged), (5, false));
    assert!(r.bias > eps / 2f64.sqrt());
    assert!(r.variance <= eps * eps / 2.0);
}

#[test]
fn points_are_doubled_on_the_level_that_pays() {
    let control = RunControl::new(2).unwrap();
    let eps = 1e-3;
    let settings = QuasiSettings::new(eps);
    let plain = run(&Shifted::new(1.0, 3), &control, &settings);
    let loud = Shifted {
        extra: Some((1, 50.0)),
        log: Some(Mutex::new(Vec::new())),
        ..Shifted::new(1.0, 3)
    };
    let r = run(&loud, &control, &settings);
    let n = |r: &MlqmcEstimate| r.levels.iter().map(|q| q.points).collect::<Vec<_>>();
    let (n_plain, n_loud) = (n(&plain), n(&r));
    eprintln!("n_l plain {n_plain:?}, level 1 raised {n_loud:?}");
    // Without the extra term level 0 has the largest variance and the most points; with it,
    // level 1's variance is ~(50 - 0.5)^2 / (e - 1 + 1)^2 ~ 180 times level 0's: it takes
    // the most points, though it costs 3 times as much per point.
    assert!(n_plain[0] > n_plain[1], "{n_plain:?}");
    assert!(n_loud[1] > n_plain[1], "{n_plain:?} {n_loud:?}");
    assert!(
        n_loud[1] > n_loud[0] && n_loud.iter().all(|&k| k <= n_loud[1]),
        "{n_loud:?}"
    );
    // Replay the run from its log: each doubling went to the level with the largest
    // V_l / (C_l n_l), and only while sum_l V_l > eps^2 / 2.
    let log = loud.log.as_ref().unwrap().lock().unwrap().clone();
    let mut levels: Vec<QuasiLevel> = Vec::new();
    let mut doublings = 0;
    for (level, start) in log {
        if start == 0 {
            assert_eq!(level as usize, levels.len());
            let mut q = QuasiLevel::new(level, 32, loud.pair_steps(level));
            q.extend_to(&loud, &control, 1, true).unwrap();
            levels.push(q);
            continue;
        }
        let total: f64 = levels.iter().map(|q| q.variance).sum();
        assert!(total > eps * eps / 2.0);
        let ratio = |q: &QuasiLevel| q.variance / (q.cost as f64 * q.points as f64);
        let best = (0..levels.len())
            .max_by(|&a, &b| ratio(&levels[a]).total_cmp(&ratio(&levels[b])))
            .unwrap();
        assert_eq!((level as usize, levels[best].points), (best, start));
        let q = &mut levels[best];
        q.extend_to(&loud, &control, 2 * start, true).unwrap();
        doublings += 1;
    }
    assert!(doublings >= 8, "{doublings} doublings");
    assert_eq!(n(&r), levels.iter().map(|q| q.points).collect::<Vec<_>>());
    assert!(r.variance <= eps * eps / 2.0);
}

#[test]
fn the_bits_do_not_depend_on_the_thread_count() {
    let settings = QuasiSettings {
        initial_points: 2,
        ..QuasiSettings::new(5e-4)
    };
    let sampler = Shifted::new(1.0, 11);
    let one = run(&sampler, &RunControl::new(1).unwrap(), &settings);
    let two = run(&sampler, &RunControl::new(2).unwrap(), &settings);
    // Blocks of several points (level 0 goes past one block of 32).
    assert!(one.levels[0].points > 64);
    let bits = |r: &MlqmcEstimate| {
        let mut b = vec![
            r.estimate.estimate,
            r.estimate.ci_low,
            r.estimate.ci_high,
            r.bias,
        ];
        b.extend(&r.totals);
        b.into_iter().map(f64::to_bits).collect::<Vec<_>>()
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(one.levels.len(), two.levels.len());
    for (a, b) in one.levels.iter().zip(&two.levels) {
        assert!(a.same_samples(b), "{a:?}\n{b:?}");
    }
}

#[test]
fn bad_settings_and_failing_samplers_are_typed_errors() {
    let control = RunControl::new(2).unwrap();
    let sampler = Shifted::new(1.0, 1);
    let with = |f: &dyn Fn(&mut QuasiSettings)| {
        let mut s = QuasiSettings::new(1e-3);
        f(&mut s);
        mlqmc(&sampler, &control, &s).unwrap_err()
    };
    assert_eq!(with(&|s| s.eps = 0.0), MlmcError::Eps { value: 0.0 });
    assert_eq!(with(&|s| s.eps = -1e-3), MlmcError::Eps { value: -1e-3 });
    let key = |f: &dyn Fn(&mut QuasiSettings)| with(f).setting_key();
    assert_eq!(key(&|s| s.randomizations = 1), Some("mlqmc.randomizations"));
    // More randomizations of more points than the memory holds: refused before anything runs.
    let huge = with(&|s| {
        s.randomizations = u32::MAX;
        s.initial_points = 1 << 20;
    });
    assert!(huge.to_string().contains("available"), "{huge}");
    assert_eq!(huge.setting_key(), Some("mlqmc.randomizations"));
    assert_eq!(key(&|s| s.initial_points = 3), Some("mlqmc.initial_points"));
    assert_eq!(key(&|s| s.initial_points = 0), Some("mlqmc.initial_points"));
    assert!(matches!(
        with(&|s| s.min_levels = 1),
        MlmcError::Levels { .. }
    ));
    let standard_key = |randomizations, points| {
        standard_quasi_monte_carlo(&sampler, &control, 0, randomizations, points)
            .unwrap_err()
            .setting_key()
    };
    assert_eq!(standard_key(1, 4), Some("mlqmc.randomizations"));
    assert_eq!(standard_key(8, 6), Some("mlqmc.points"));
    let settings = QuasiSettings::new(1e-3);
    let failing = |mode| Shifted {
        mode,
        ..Shifted::new(1.0, 1)
    };
    let err = mlqmc(&failing(Mode::FailAll), &control, &settings).unwrap_err();
    assert!(
        matches!(&err, MlmcError::Levels { reason } if reason.contains("level 0")),
        "{err}"
    );
    let err = mlqmc(&failing(Mode::NotANumber), &control, &settings).unwrap_err();
    assert!(
        matches!(&err, MlmcError::Levels { reason } if reason.contains("level 1") && reason.contains("NaN")),
        "{err}"
    );
    // A rule whose variance does not fall with n runs into the end of its sequences.
    let flat = Shifted {
        max_points: 64,
        ..failing(Mode::Flat)
    };
    let err = mlqmc(&flat, &control, &settings).unwrap_err();
    assert_eq!(err.setting_key(), Some("mlqmc.eps"), "{err}");
    assert!(err.to_string().contains("64"), "{err}");
}

#[test]
fn failed_points_are_counted_and_left_out_of_the_means() {
    let control = RunControl::new(2).unwrap();
    let sampler = Shifted {
        mode: Mode::FailSome,
        ..Shifted::new(1.0, 5)
    };
    let settings = QuasiSettings {
        initial_points: 16,
        ..QuasiSettings::new(2e-3)
    };
    let r = run(&sampler, &control, &settings);
    for q in &r.levels {
        // Points 3, 10, 17, ... of each randomization's n_l fail.
        let per_randomization = (q.points + 3) / 7;
        assert_eq!(q.failed, 32 * per_randomization, "{q:?}");
        assert!(
            q.randomizations
                .iter()
                .all(|s| s.failed == per_randomization)
        );
    }
    assert!(r.converged);
}

#[test]
fn standard_randomized_qmc_on_one_level() {
    let control = RunControl::new(2).unwrap();
    let level = 3;
    let mut covered = 0;
    let mut variances = Vec::new();
    for seed in 0..40 {
        let sampler = Shifted::new(1.0, 100 + seed);
        let q = standard_quasi_monte_carlo(&sampler, &control, level, 32, 256).unwrap();
        covered += usize::from(q.estimate.contains(sampler.exact(level)));
        assert_eq!(q.level.work, 32.0 * 256.0 * 8.0);
        assert_eq!(q.level.randomizations.len(), 32);
        // The interval is mean +- t_{0.975, 31} sqrt(V).
        let half = sdae_stats::t975(31) * q.level.variance.sqrt();
        assert!(
            (q.estimate.ci_high - q.estimate.estimate - half).abs() <= 1e-12 * half.max(1e-300)
        );
        variances.push(q.level.variance_per_randomization);
    }
    // With true coverage 95%, fewer than 33 of 40 has probability 4e-3 (binomial).
    assert!(covered >= 33, "{covered} of 40");
    // The variance of a randomization's mean is ~ (h(1) - h(0))^2 / (12 n^2), h = P_3.
    let h = |u: f64| u.exp() + u / 8.0;
    let predicted = (h(1.0) - h(0.0)).powi(2) / (12.0 * 256.0 * 256.0);
    let mean = variances.iter().sum::<f64>() / 40.0;
    assert!(
        (mean / predicted - 1.0).abs() < 0.15,
        "{mean:e} against {predicted:e}"
    );
}

#[test]
fn doubling_adds_the_next_points_of_the_same_sequences() {
    let control = RunControl::new(2).unwrap();
    let sampler = Shifted::new(1.0, 4);
    let (mut doubled, mut direct) = (QuasiLevel::new(2, 4, 6), QuasiLevel::new(2, 4, 6));
    let mut n = 1;
    while n <= 128 {
        doubled.extend_to(&sampler, &control, n, true).unwrap();
        n *= 2;
    }
    direct.extend_to(&sampler, &control, 128, true).unwrap();
    assert_eq!((doubled.points, doubled.work), (128, 4.0 * 128.0 * 6.0));
    for (a, b) in doubled.randomizations.iter().zip(&direct.randomizations) {
        assert_eq!(a.samples, 128);
        // The same points; the sums differ only in the order of the additions.
        assert!((a.y1 - b.y1).abs() <= 1e-14 * b.y1.abs() && (a.y2 - b.y2).abs() <= 1e-14 * b.y2);
    }
}

#[test]
fn serialized_runs_read_back() {
    let control = RunControl::new(1).unwrap();
    let r = run(&Shifted::new(1.0, 2), &control, &QuasiSettings::new(1e-2));
    let json = serde_json::to_string(&r).unwrap();
    let back: MlqmcEstimate = serde_json::from_str(&json).unwrap();
    assert_eq!(back, r);
    let level: QuasiLevel =
        serde_json::from_str(&serde_json::to_string(&r.levels[1]).unwrap()).unwrap();
    assert_eq!(level, r.levels[1]);
}

#[test]
fn the_cost_exponent_is_recovered() {
    // work = K eps^-1.5 with a 3% deterministic wobble.
    let pairs: Vec<(f64, f64)> = (0..8)
        .map(|k| {
            let eps = 0.1 * 0.6f64.powi(k);
            (
                eps,
                40.0 * eps.powf(-1.5) * (1.0 + 0.03 * (k as f64 * 2.1).sin()),
            )
        })
        .collect();
    let c = cost_exponent(&pairs).unwrap();
    assert!((c.estimate - 1.5).abs() < 0.02, "{c:?}");
    assert!(c.contains(1.5) && c.ci_high - c.ci_low < 0.1, "{c:?}");
    // MLQMC on the smooth rule: level 0's points grow as 1 / eps and the finest level's
    // cost as 2^L ~ 1 / eps, so the exponent is about 1, well below MLMC's 2.
    let control = RunControl::new(2).unwrap();
    let runs: Vec<MlqmcEstimate> = [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]
        .iter()
        .map(|&eps| run(&Shifted::new(1.0, 9), &control, &QuasiSettings::new(eps)))
        .collect();
    let c = cost_exponent_of(&runs).unwrap();
    eprintln!("MLQMC cost exponent on the shifted rule: {c:?}");
    assert!(c.estimate > 0.9 && c.estimate < 1.4, "{c:?}");
}
