//! Multilevel Monte Carlo of scenes, checks that can fail: the closed form of
//! E[cos(phi_T - phi_0)] for a particle on a circle with friction, the coverage of the
//! interval over seeded runs, sums that do not depend on the thread count or the sharding, and
//! the direct standard run capped by the MLMC work.

use sdae_mlmc::algorithm::{AdaptiveSettings, Plan, adaptive, run_plan};
use sdae_mlmc::fit::fit_rates;
use sdae_mlmc::sampler::level_stats;
use sdae_mlmc::sums::LevelStats;
use sdae_mlmc::{LevelSampler, LevelSums, MlmcError, RunControl};
use sdae_study::StudyError;
use sdae_study::mlmc::shard::{Identity, merge, run_shard};
use sdae_study::mlmc::study::{MlmcSettings, SamplerTask, run_study, with_sampler};
use sdae_study::mlmc::{MlmcSpec, scene_expectation};
use sdae_study::scene::Scene;
use sdae_study::weak::circle_cos_turn;

use crate::linear::Linear;

/// A unit point mass on a circle with friction, no gravity, started at the bottom with
/// tangential speed `speed`: the angle turned, phi_T - phi_0, is the integral of an OU angular
/// velocity, Gaussian, and E[cos_angle] = E[cos(phi_T - phi_0)] has the closed form
/// [`circle_cos_turn`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Circle {
    pub(crate) radius: f64,
    pub(crate) friction: f64,
    pub(crate) noise: f64,
    pub(crate) speed: f64,
    pub(crate) t_end: f64,
}

/// The unit circle, unit friction, noise and speed, T = 1.
pub(crate) const UNIT_CIRCLE: Circle = Circle {
    radius: 1.0,
    friction: 1.0,
    noise: 1.0,
    speed: 1.0,
    t_end: 1.0,
};

/// The scene of a circle and its exact E[cos_angle].
pub(crate) fn circle(c: Circle) -> (Scene, f64) {
    let Circle {
        radius,
        friction,
        noise,
        speed,
        t_end,
    } = c;
    let text = format!(
        "name = \"circle\"\nT = {t_end}\noutputs = [\"position\", \"velocity\"]\n\
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

pub(crate) fn circle_settings(scene: &Scene, seed: u64, threads: usize) -> MlmcSettings {
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
    type Output = sdae_mlmc::MlmcEstimate;
    fn run<L: LevelSampler>(self, sampler: &L) -> Result<Self::Output, MlmcError> {
        adaptive(sampler, self.control, &self.settings)
    }
}

fn circle_run(
    scene: &Scene, seed: u64, eps: f64, control: &RunControl<'_>,
) -> sdae_mlmc::MlmcEstimate {
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
            sdae_study::mlmc::study_error(&err),
            Some(StudyError::UnknownObservable { nearest: Some(n), .. }) if n == "energy"
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

/// E[cos_angle] of the circle by the expectation helper: the estimator the convergence test
/// predicts cheaper, its interval (widened by the bias estimate) covering the closed form.
#[test]
fn the_expectation_helper_covers_the_closed_form_of_the_circle() {
    let (scene, exact) = circle(UNIT_CIRCLE);
    let settings = circle_settings(&scene, 2026, 2);
    let control = RunControl::new(2).unwrap();
    let got = scene_expectation(&scene, &settings, 1e-2, &control).unwrap();
    assert_eq!(
        (got.scene.as_str(), got.observable.as_str()),
        ("circle", "cos_angle")
    );
    let found = &got.found;
    assert!(found.resolved, "the test's levels reach the bias");
    let pick = sdae_mlmc::expectation::cheapest(&found.predicted, found.by).unwrap();
    assert_eq!(found.method, pick.method);
    let i = &found.estimate;
    let bias = found.bias.abs();
    assert!(
        i.ci_low - bias <= exact && exact <= i.ci_high + bias,
        "{i:?} (bias {bias:e}) against {exact}"
    );
    assert_eq!(found.failed, 0);
    let json = serde_json::to_value(&got).unwrap();
    assert_eq!(json["method"], found.method.to_string().as_str());
}

#[test]
fn the_expectation_helper_refuses_an_unknown_observable_naming_it() {
    let (scene, _) = circle(UNIT_CIRCLE);
    let mut settings = circle_settings(&scene, 2026, 1);
    settings.spec.observable = "cos_angel".into();
    let control = RunControl::new(1).unwrap();
    let e = scene_expectation(&scene, &settings, 1e-2, &control).unwrap_err();
    assert!(e.to_string().contains("cos_angel"), "{e}");
}
