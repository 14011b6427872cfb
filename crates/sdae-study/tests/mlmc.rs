//! Multilevel Monte Carlo checks that can fail: the rates of Euler-Maruyama on scalar linear
//! SDEs with a known mean, the closed form of E[cos(phi_T - phi_0)] for a particle on a circle
//! with friction, the coverage of the interval over seeded runs, and sums that do not depend
//! on the thread count or the sharding.

use std::ops::Range;

use sdae_noise::{PathStreams, StandardNormals};
use sdae_study::StudyError;
use sdae_study::mlmc::algorithm::{AdaptiveSettings, Plan, adaptive, run_plan};
use sdae_study::mlmc::fit::fit_rates;
use sdae_study::mlmc::shard::{Identity, merge, run_shard};
use sdae_study::mlmc::study::{MlmcSettings, SamplerTask, run_study, with_sampler};
use sdae_study::mlmc::sums::{LevelStats, level_stats};
use sdae_study::mlmc::{LevelSampler, LevelSums, MlmcError, MlmcSpec, RunControl, Sample};
use sdae_study::scene::Scene;
use sdae_study::weak::circle_cos_turn;

/// dX = a X dt + b X^m dW (m = 1 multiplicative, m = 0 additive), X_0 = 1, by Euler-Maruyama
/// on h_l = T 2^-(k0 + l) (k0 >= 1): E[X_T] = e^(a T) exactly for both.
struct Linear {
    a: f64,
    b: f64,
    multiplicative: bool,
    t_end: f64,
    coarsest: u32,
    seed: u64,
}

impl Linear {
    /// The Ornstein-Uhlenbeck process dX = -X / 2 dt + dW / 2 from level 0 on 2 steps, T = 1.
    fn ou(seed: u64) -> Self {
        Linear {
            a: -0.5,
            b: 0.5,
            multiplicative: false,
            t_end: 1.0,
            coarsest: 1,
            seed,
        }
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

/// The convergence test's rates on levels 0..=8 with 20 000 samples each, fitted from l = 2.
fn rates_of(model: &Linear) -> sdae_study::mlmc::Rates {
    let control = RunControl::new(2).unwrap();
    let sums = run_plan(model, &control, &[20_000; 9]).unwrap();
    let stats = level_stats(&sums, model);
    fit_rates(&stats, 2)
}

impl Linear {
    /// E[P_l] and E[P_l^2] exactly: with u = 1 + a h, X_N = prod (u + b X^m dW / X) gives
    /// E[X_N] = u^N for both noises; E[X_N^2] = (u^2 + b^2 h)^N (multiplicative) or by the
    /// recursion E[x'^2] = u^2 E[x^2] + b^2 h (additive).
    fn moments(&self, level: u32) -> (f64, f64, f64, f64, f64) {
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
    fn exact_rates(&self, alpha_levels: &[u32], beta_levels: &[u32]) -> (f64, f64) {
        let slope = |levels: &[u32], y: &dyn Fn(u32) -> f64| {
            let x: Vec<f64> = levels.iter().map(|&l| f64::from(l)).collect();
            let y: Vec<f64> = levels.iter().map(|&l| y(l)).collect();
            -sdae_study::mlmc::fit::fit_slope(&x, &y, None)
                .unwrap()
                .estimate
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

/// The fitted alpha and beta cover the exact slopes of the closed forms over the levels they
/// were fitted on (levels 2..=8 less those left out as pre-asymptotic or unresolved), and those
/// are near the asymptotic rates.
fn check_rates(model: &Linear, alpha_limit: f64, beta_limit: f64) {
    let rates = rates_of(model);
    let (alpha, beta) = (rates.alpha.unwrap(), rates.beta.unwrap());
    let kept = |out: &[&Vec<u32>]| -> Vec<u32> {
        (2..=8)
            .filter(|l| out.iter().all(|o| !o.contains(l)))
            .collect()
    };
    let (exact_alpha, exact_beta) = model.exact_rates(
        &kept(&[&rates.alpha_pre_asymptotic, &rates.unresolved]),
        &kept(&[&rates.beta_pre_asymptotic]),
    );
    assert!((exact_alpha - alpha_limit).abs() < 0.05, "{exact_alpha}");
    assert!((exact_beta - beta_limit).abs() < 0.05, "{exact_beta}");
    assert!(
        alpha.contains(exact_alpha),
        "alpha {alpha:?}, exact {exact_alpha}"
    );
    assert!(
        beta.contains(exact_beta),
        "beta {beta:?}, exact {exact_beta}"
    );
    assert!(
        beta.ci_high - beta.ci_low < 0.3,
        "beta {beta:?} is not resolved"
    );
    // gamma is the work per sample's: 1.5 2^(k0 + l) steps, exactly 1.
    let gamma = rates.gamma.unwrap();
    assert!(
        [gamma.estimate, gamma.ci_low, gamma.ci_high]
            .iter()
            .all(|g| (g - 1.0).abs() < 1e-12),
        "{gamma:?}"
    );
}

#[test]
fn euler_maruyama_has_alpha_1_and_beta_1_on_geometric_brownian_motion() {
    let gbm = Linear {
        a: 0.5,
        b: 0.5,
        multiplicative: true,
        t_end: 1.0,
        coarsest: 1,
        seed: 11,
    };
    check_rates(&gbm, 1.0, 1.0);
}

#[test]
fn euler_maruyama_has_alpha_1_and_beta_2_on_additive_noise() {
    let ou = Linear::ou(12);
    check_rates(&ou, 1.0, 2.0);
}

#[test]
fn the_adaptive_estimate_of_geometric_brownian_motion_covers_its_mean() {
    let gbm = Linear {
        a: 0.5,
        b: 0.5,
        multiplicative: true,
        t_end: 1.0,
        coarsest: 1,
        seed: 13,
    };
    let control = RunControl::new(2).unwrap();
    let run = adaptive(
        &gbm,
        &control,
        &AdaptiveSettings {
            eps: 2e-3,
            initial_samples: 1000,
            min_levels: 2,
            max_level: 12,
        },
    )
    .unwrap();
    assert!(run.converged);
    assert!(run.estimate.contains(0.5f64.exp()), "{:?}", run.estimate);
    // The sampling error is within its share eps^2 / 2 of the mean square error.
    let half = run.estimate.ci_high - run.estimate.estimate;
    assert!(half / 1.96 <= 2e-3 / 2f64.sqrt() * 1.01, "{half}");
}

/// A unit point mass on a circle with friction, no gravity, started at the bottom with
/// tangential speed `speed`: the angle turned, phi_T - phi_0, is the integral of an OU angular
/// velocity, Gaussian, and E[cos_angle] = E[cos(phi_T - phi_0)] has the closed form
/// [`circle_cos_turn`].
#[derive(Clone, Copy, Debug)]
struct Circle {
    radius: f64,
    friction: f64,
    noise: f64,
    speed: f64,
    t_end: f64,
}

/// The unit circle, unit friction, noise and speed, T = 1.
const UNIT_CIRCLE: Circle = Circle {
    radius: 1.0,
    friction: 1.0,
    noise: 1.0,
    speed: 1.0,
    t_end: 1.0,
};

/// The scene of a circle and its exact E[cos_angle].
fn circle(c: Circle) -> (Scene, f64) {
    let Circle {
        radius,
        friction,
        noise,
        speed,
        t_end,
    } = c;
    let text = format!(
        "name = \"circle\"\nT = {t_end}\noutputs = [\"position\"]\n\
         [system.pendulum]\ndim = 2\nlength = {radius}\ngravity = 0.0\nnoise = {noise}\nfriction = {friction}\n\
         [initial]\nposition = [0.0, -{radius}]\nvelocity = [{speed}, 0.0]\n\
         [scheme]\npractical_c_eta = 1.0\n"
    );
    let scene = Scene::from_toml(&text).unwrap();
    (
        scene,
        circle_cos_turn(speed / radius, friction, noise / radius, t_end),
    )
}

fn circle_settings(scene: &Scene, seed: u64, threads: usize) -> MlmcSettings {
    let mut settings = MlmcSettings::for_scene(scene);
    settings.spec = MlmcSpec {
        coarsest: 2,
        ..MlmcSpec::default()
    };
    settings.seed = seed;
    settings.threads = threads;
    settings
}

/// Runs the adaptive algorithm on a scene's sampler.
struct Adaptive<'a, 'b> {
    control: &'a RunControl<'b>,
    settings: AdaptiveSettings,
}

impl SamplerTask for Adaptive<'_, '_> {
    type Output = sdae_study::mlmc::MlmcEstimate;
    fn run<L: LevelSampler>(self, sampler: &L) -> Result<Self::Output, MlmcError> {
        adaptive(sampler, self.control, &self.settings)
    }
}

fn circle_run(
    scene: &Scene, seed: u64, eps: f64, control: &RunControl<'_>,
) -> sdae_study::mlmc::MlmcEstimate {
    let settings = circle_settings(scene, seed, control.threads());
    let task = Adaptive {
        control,
        settings: AdaptiveSettings {
            eps,
            initial_samples: 512,
            min_levels: 2,
            max_level: 10,
        },
    };
    with_sampler(scene, &settings, task).unwrap()
}

#[test]
fn mlmc_on_the_circle_with_friction_covers_the_closed_form() {
    let (scene, exact) = circle(UNIT_CIRCLE);
    let control = RunControl::new(2).unwrap();
    let run = circle_run(&scene, 2026, 2e-3, &control);
    assert!(run.converged);
    assert!(
        run.estimate.contains(exact),
        "{:?} against {exact}",
        run.estimate
    );
    assert!(run.levels.iter().all(|l| l.failed == 0));
}

/// 100 seeded runs at eps = 2e-2: a 95% interval should cover the closed form in about 95 of
/// them; fewer than 90 (4.6 binomial standard deviations below 95 would be 85) means the bias
/// or the interval is off.
#[test]
fn mlmc_intervals_cover_the_closed_form_in_at_least_90_of_100_runs() {
    let (scene, exact) = circle(UNIT_CIRCLE);
    let control = RunControl::new(2).unwrap();
    let covered = (0..100)
        .filter(|&seed| {
            circle_run(&scene, 1000 + seed, 2e-2, &control)
                .estimate
                .contains(exact)
        })
        .count();
    assert!(covered >= 90, "{covered} of 100 intervals cover {exact}");
}

/// The sums of a plan on one thread and on two, and merged from three shards.
struct Sums<'a, 'b> {
    control: &'a RunControl<'b>,
    plan: Plan,
    shards: Option<(Identity, u64)>,
}

impl SamplerTask for Sums<'_, '_> {
    type Output = Vec<LevelSums>;
    fn run<L: LevelSampler>(self, sampler: &L) -> Result<Vec<LevelSums>, MlmcError> {
        match self.shards {
            None => run_plan(sampler, self.control, &self.plan.samples),
            Some((identity, n)) => {
                let shards: Vec<_> = (0..n)
                    .map(|i| {
                        run_shard(
                            sampler,
                            self.control,
                            identity.clone(),
                            self.plan.clone(),
                            (i, n),
                        )
                    })
                    .collect::<Result<_, _>>()?;
                Ok(merge(&shards)?.2)
            }
        }
    }
}

#[test]
fn sums_do_not_depend_on_threads_or_shards() {
    let (scene, _) = circle(UNIT_CIRCLE);
    let plan = Plan {
        eps: 1e-2,
        samples: vec![200, 100, 70],
    };
    let sums = |threads: usize, shards: Option<u64>| {
        let control = RunControl::new(threads).unwrap();
        let settings = circle_settings(&scene, 7, threads);
        let task = Sums {
            control: &control,
            plan: plan.clone(),
            shards: shards.map(|n| (Identity::of("circle", &settings), n)),
        };
        with_sampler(&scene, &settings, task).unwrap()
    };
    let one = sums(1, None);
    let two = sums(2, None);
    let sharded = sums(2, Some(3));
    assert_eq!(one.len(), 3);
    for ((a, b), c) in one.iter().zip(&two).zip(&sharded) {
        assert!(a.same_samples(b), "{a:?}\n{b:?}");
        assert!(a.same_samples(c), "{a:?}\n{c:?}");
        // Whole blocks of 32.
        assert_eq!(a.attempted() % 32, 0);
    }
}

#[test]
fn bad_settings_are_named_errors() {
    let (scene, _) = circle(UNIT_CIRCLE);
    let mut settings = circle_settings(&scene, 1, 1);
    settings.spec.eps = vec![1e-2, 0.0];
    assert_eq!(settings.validate(), Err(MlmcError::Eps { value: 0.0 }));
    settings.spec.eps = vec![f64::NAN];
    assert!(matches!(settings.validate(), Err(MlmcError::Eps { .. })));
    settings.spec.eps = vec![1e-2];
    settings.spec.coarsest = 20;
    assert!(matches!(
        settings.validate(),
        Err(MlmcError::Setting {
            key: "mlmc.max_level",
            ..
        })
    ));
    // Step exponents that would wrap in u32 are refused, not wrapped.
    let max_level = settings.spec.max_level;
    settings.spec.coarsest = u32::MAX;
    settings.spec.max_level = 2;
    let err = settings.validate().unwrap_err();
    assert!(err.to_string().contains("2^4294967297 steps"), "{err}");
    settings.spec.max_level = max_level;
    settings.spec.coarsest = 2;
    settings.spec.observable = "energie".into();
    let control = RunControl::new(1).unwrap();
    let err = sdae_study::mlmc::run_mlmc(&scene, &settings, &control).unwrap_err();
    assert!(
        matches!(
            &err,
            MlmcError::Study(StudyError::UnknownObservable { nearest: Some(n), .. }) if n == "energy"
        ),
        "{err}"
    );
}

/// A circle whose parameters no other test uses (radius 1.5, friction 0.5, noise 1.2, unit
/// speed, T = 2). Over 100 seeded runs at eps = 1e-2 the mean square error against the
/// closed form, mean of e_i^2, must stay below (0.9 eps)^2 by two of its standard errors
/// (sd(e_i^2) / 10). Giles's bias estimate (the largest of the last three means scaled by
/// alpha from all levels) stops too early here: its root mean square error is 1.44 eps, its
/// bias estimate 0.58 eps on average against a mean error of -1.14 eps.
#[test]
fn mlmc_on_a_circle_meets_its_accuracy_over_100_seeds() {
    let (scene, exact) = circle(Circle {
        radius: 1.5,
        friction: 0.5,
        noise: 1.2,
        speed: 1.0,
        t_end: 2.0,
    });
    let eps = 1e-2;
    let control = RunControl::new(2).unwrap();
    let squares: Vec<f64> = (0..100)
        .map(|seed| {
            let run = circle_run(&scene, 5000 + seed, eps, &control);
            assert!(run.converged, "seed {seed}: {run:?}");
            ((run.estimate.estimate - exact) / eps).powi(2)
        })
        .collect();
    let n = squares.len() as f64;
    let mse = squares.iter().sum::<f64>() / n;
    let sd = (squares.iter().map(|e| (e - mse).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        mse + 2.0 * sd / n.sqrt() <= 0.81,
        "root mean square error {:.3} eps, mean square error {mse:.3} +- {:.3} eps^2",
        mse.sqrt(),
        sd / n.sqrt()
    );
}

/// The convergence test's statistics on levels 0..samples.len() of a scene's sampler.
struct ConvergenceTest<'a, 'b> {
    control: &'a RunControl<'b>,
    samples: Vec<u64>,
}

impl SamplerTask for ConvergenceTest<'_, '_> {
    type Output = Vec<LevelStats>;
    fn run<L: LevelSampler>(self, sampler: &L) -> Result<Vec<LevelStats>, MlmcError> {
        let sums = run_plan(sampler, self.control, &self.samples)?;
        Ok(level_stats(&sums, sampler))
    }
}

/// On the default pendulum the coarse levels' variances drop faster (log2 ratios about 3.2
/// and 2.7 from level 1, then about 2.0): fitted over levels 1..=6 with them, beta was 2.3.
/// Over the asymptotic levels it is within 0.1 of beta over levels 1..=10 (a test of 4096
/// samples a level, the default's; the standard error of a level's log2 V is
/// sqrt((kurt - 1) / N) / ln 2, about 0.05 at kurtosis 5, so 0.1 is two standard errors of a
/// slope over a few levels).
#[test]
fn beta_over_the_default_levels_matches_beta_over_ten_levels_on_the_pendulum() {
    let scene = Scene::built_in("pendulum").unwrap();
    let mut settings = MlmcSettings::for_scene(&scene);
    settings.threads = 2;
    let control = RunControl::new(2).unwrap();
    let test = |levels: usize| {
        let task = ConvergenceTest {
            control: &control,
            samples: vec![settings.spec.test_samples; levels + 1],
        };
        fit_rates(&with_sampler(&scene, &settings, task).unwrap(), 1)
    };
    let (six, ten) = (test(6), test(10));
    let (b6, b10) = (six.beta.unwrap(), ten.beta.unwrap());
    assert!(
        (b6.estimate - b10.estimate).abs() < 0.1,
        "beta {b6:?} over 1..=6, {b10:?} over 1..=10"
    );
    assert!(six.beta_pre_asymptotic.contains(&1), "{six:?}");
    assert!((b10.estimate - 2.0).abs() < 0.1, "{b10:?}");
    let gamma = six.gamma.unwrap();
    assert!((gamma.estimate - 1.0).abs() < 1e-12, "{gamma:?}");
}

/// Standard Monte Carlo at eps = 2e-4 on Euler-Maruyama's OU process costs about 100 times
/// MLMC's work: the direct run is capped by the MLMC part's work (the convergence test and
/// the adaptive run) and runs at the accuracy that cap affords.
#[test]
fn the_direct_standard_run_is_capped_by_the_mlmc_work() {
    let ou = Linear::ou(14);
    let mut settings = circle_settings(&circle(UNIT_CIRCLE).0, 3, 2);
    settings.spec.eps = vec![2e-4];
    settings.spec.test_levels = 5;
    settings.spec.test_samples = 2048;
    let control = RunControl::new(2).unwrap();
    let report = run_study("ou", &ou, &settings, &control).unwrap();
    let d = report.standard.unwrap();
    let row = &report.complexity[0];
    assert!(row.standard_work > 10.0 * row.mlmc_work, "{row:?}");
    assert!(d.target_work > d.cap_work && d.eps > d.target_eps, "{d:?}");
    let steps = ou.path_steps(d.level) as f64;
    // Whole blocks of 32 paths within the cap.
    assert!(
        d.samples as f64 * steps <= d.cap_work + 32.0 * steps,
        "{d:?}"
    );
    assert!(d.samples as f64 * steps > 0.9 * d.cap_work, "{d:?}");
    // The accuracy afforded: eps_run^2 = eps^2 work(eps) / cap.
    let afforded = d.target_eps * (d.target_work / d.cap_work).sqrt();
    assert!((d.eps - afforded).abs() < 1e-12 * afforded);
    // The MLMC part: the test's work (no path fails here) and the adaptive run's.
    let test_work: f64 = report
        .test
        .iter()
        .map(|l| l.samples as f64 * l.work_per_sample as f64)
        .sum();
    assert!((d.cap_work - test_work - row.mlmc_work).abs() < 1e-6 * d.cap_work);
}
