//! Coverage of the study's 95% intervals, measured on samples of known law with fixed seeds.
//! With R replications the binomial standard error of a coverage c is sqrt(c (1 - c) / R)
//! (1.1 points at 95% and R = 400); each test states its band in these units.

use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_stats::Interval;
use sdae_stats::{
    INDICATIVE_BELOW, PathErrors, effective_paths, fit_order, lp_error, mean_interval,
};

/// `n` standard normals of replication `r` of experiment `seed`.
fn normals(seed: u64, r: u64, n: usize) -> Vec<f64> {
    let mut z = vec![0.0; n];
    GaussianIncrements::for_path(seed, r, n).next_increment(1.0, &mut z);
    z
}

/// Share of replications whose interval contains `truth`.
fn coverage(replications: u64, truth: f64, interval: impl Fn(u64) -> Option<Interval>) -> f64 {
    let hits = (0..replications)
        .filter(|&r| interval(r).is_some_and(|i| i.contains(truth)))
        .count();
    hits as f64 / replications as f64
}

#[test]
fn mean_intervals_hold_their_95_percent_at_every_sample_size() {
    let replications = 4000;
    for n in [2, 5, 20, 200] {
        let c = coverage(replications, 1.5, |r| {
            let x: Vec<f64> = normals(11, r, n).iter().map(|z| 1.5 + 2.0 * z).collect();
            mean_interval(&x)
        });
        println!("normal mean, n = {n}: coverage {c:.3}");
        assert!((c - 0.95).abs() <= 0.02, "n = {n}: {c}");
    }
}

/// The interval of the mean of d^p +- 1.96 s / sqrt(n) mapped through the p-th root: what the
/// study used before, for comparison.
fn clt_lp(d: &[f64], p: f64) -> Option<Interval> {
    let powered: Vec<f64> = d.iter().map(|x| x.powf(p)).collect();
    let n = powered.len() as f64;
    let m = powered.iter().sum::<f64>() / n;
    let s2 = powered.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    let half = 1.959_963_985 * (s2 / n).sqrt();
    let root = |t: f64| t.max(0.0).powf(1.0 / p);
    Some(Interval {
        estimate: root(m),
        ci_low: root(m - half),
        ci_high: root(m + half),
    })
}

#[test]
fn lp_intervals_of_skewed_errors_cover_far_better_than_the_clt() {
    // d = e^{Z/2} |Z'|: E d^2 = e^{1/2}, so the L^2 norm is e^{1/4}. d^2 is heavily skewed
    // (a log-normal times a chi-square): no interval from n samples alone can hold 95% for
    // such laws at small n; the bootstrap on the log scale gets much closer than the CLT.
    let truth = 0.25f64.exp();
    let sample = |r: u64, n: usize| -> Vec<f64> {
        let z = normals(21, r, 2 * n);
        (0..n)
            .map(|i| (z[i] / 2.0).exp() * z[n + i].abs())
            .collect()
    };
    // (n, replications, lower bound on the coverage).
    // Measured: 0.864, 0.884, 0.929 (the CLT interval: 0.634, 0.770, 0.905).
    for (n, replications, floor) in [(5, 2000, 0.83), (20, 2000, 0.85), (200, 1000, 0.91)] {
        let ours = coverage(replications, truth, |r| lp_error(&sample(r, n), 2.0));
        let clt = coverage(replications, truth, |r| clt_lp(&sample(r, n), 2.0));
        println!("skewed L^2, n = {n}: bootstrap {ours:.3}, CLT {clt:.3}");
        assert!(ours >= floor, "n = {n}: {ours}");
        assert!(ours >= clt + 0.01, "n = {n}: {ours} vs {clt}");
    }
    // Errors of moderate skew (d uniform on [0, 1], L^2 norm 1/sqrt(3)) are covered at 95%.
    let truth = (1.0f64 / 3.0).sqrt();
    let c = coverage(2000, truth, |r| {
        let z = normals(22, r, 40);
        // The angle of a pair of independent standard normals is uniform.
        let d: Vec<f64> = z
            .chunks_exact(2)
            .map(|p| 0.5 + (p[0]).atan2(p[1]) / (2.0 * std::f64::consts::PI))
            .collect();
        lp_error(&d, 2.0)
    });
    println!("uniform L^2, n = 20: coverage {c:.3}");
    assert!((c - 0.95).abs() <= 0.02, "{c}");
}

/// Per-path errors d_ij = C h_j^q (1 + a h_j) W_i V_ij at levels h_j = 2^-j (j = 1..=6), with a
/// path factor W_i = e^{Z_i / 2} shared by the levels and level noise V_ij = e^{0.3 Z'_ij}.
/// With a = 0 the L^2 norm is an exact power law of order q.
fn model(r: u64, n: usize, q: f64, a: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let h: Vec<f64> = (1..=6).map(|j| 0.5f64.powi(j)).collect();
    let z = normals(31, r, n * (1 + h.len()));
    let errors = h
        .iter()
        .enumerate()
        .map(|(j, hj)| {
            (0..n)
                .map(|i| {
                    let w = (z[i] / 2.0).exp();
                    let v = (0.3 * z[n * (1 + j) + i]).exp();
                    3.0 * hj.powf(q) * (1.0 + a * hj) * w * v
                })
                .collect()
        })
        .collect();
    (h, errors)
}

/// Per-path errors d_ij = h_j^q W_i |Z'_ij| at h_j = 2^-j (j = 1..=6) with a heavier path
/// factor W_i = e^{Z_i} (d^2 has a log-normal factor of log-variance 4) and half-normal level
/// noise: E d_j^2 = h_j^{2q} e^2, an exact power law of order q.
fn heavy_model(r: u64, n: usize, q: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let h: Vec<f64> = (1..=6).map(|j| 0.5f64.powi(j)).collect();
    let z = normals(41, r, n * (1 + h.len()));
    let errors = h
        .iter()
        .enumerate()
        .map(|(j, hj)| {
            (0..n)
                .map(|i| hj.powf(q) * z[i].exp() * z[n * (1 + j) + i].abs())
                .collect()
        })
        .collect();
    (h, errors)
}

/// Geometric Brownian motion dX = a X dt + b X dW, X(0) = 1, on [0, 1] with (a, b) = (1.5, 1):
/// multiplicative noise, errors with log-normal tails.
const GBM: (f64, f64) = (1.5, 1.0);

/// Fine steps of a GBM path: the finest level.
const GBM_FINE: usize = 256;

/// Per-path errors |X_N - X(1)| of Euler-Maruyama X_{k+1} = X_k (1 + a h + b dW_k) at
/// N = 2^3..2^8 against the exact solution X(1) = exp(a - b^2 / 2 + b W(1)) on the same
/// Brownian path, for n paths of replication r: every level is driven by the path's 2^8 fine
/// increments (a coarse increment is the sum of the fine ones it spans), as the convergence
/// study couples its levels. Returns the step sizes (coarse to fine) and the errors by level.
fn gbm(seed: u64, r: u64, n: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (a, b) = GBM;
    let root_dt = (1.0 / GBM_FINE as f64).sqrt();
    let h: Vec<f64> = (3..=8).map(|k| 0.5f64.powi(k)).collect();
    let z = normals(seed, r, n * GBM_FINE);
    let mut errors = vec![Vec::with_capacity(n); h.len()];
    for path in z.chunks_exact(GBM_FINE) {
        let exact = (a - b * b / 2.0 + b * path.iter().sum::<f64>() * root_dt).exp();
        for (level, hj) in errors.iter_mut().zip(&h) {
            let span = (hj * GBM_FINE as f64).round() as usize;
            let x = path.chunks_exact(span).fold(1.0, |x, dz| {
                x * (1.0 + a * hj + b * dz.iter().sum::<f64>() * root_dt)
            });
            level.push((x - exact).abs());
        }
    }
    (h, errors)
}

/// The population L^2 error of [`gbm`] at step h = 1 / N, in closed form: the steps' factors
/// are independent, so with A = E X_N^2 = ((1 + a h)^2 + b^2 h)^N,
/// B = E X_N X(1) = (e^{a h} (1 + a h + b^2 h))^N (from E[dW e^{b dW}] = b h e^{b^2 h / 2}) and
/// C = E X(1)^2 = e^{2 a + b^2}: E |X_N - X(1)|^2 = A - 2 B + C.
fn gbm_l2(h: f64) -> f64 {
    let (a, b) = GBM;
    let steps = (1.0 / h).round() as i32;
    let moment_a = ((1.0 + a * h).powi(2) + b * b * h).powi(steps);
    let moment_b = ((a * h).exp() * (1.0 + a * h + b * b * h)).powi(steps);
    let moment_c = (2.0 * a + b * b).exp();
    (moment_a - 2.0 * moment_b + moment_c).sqrt()
}

/// The least-squares slope of log E(h_j) against log h_j over `levels`.
fn population_slope(h: &[f64], levels: &[usize], error: impl Fn(f64) -> f64) -> f64 {
    let x: Vec<f64> = levels.iter().map(|&j| h[j].ln()).collect();
    let y: Vec<f64> = levels.iter().map(|&j| error(h[j]).ln()).collect();
    let mx = x.iter().sum::<f64>() / x.len() as f64;
    let my = y.iter().sum::<f64>() / y.len() as f64;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

/// What the order intervals of a law show over replications: the share of fits marked
/// indicative, and the coverage of the order and of the finest local slope among the fits not
/// so marked (`None` when fewer than 40 are) and among all fits. The order's truth is the
/// population slope over the levels each fit kept (coarse levels it flags as pre-asymptotic
/// are left out of both).
#[derive(Debug)]
struct OrderCoverage {
    indicative: f64,
    order: Option<f64>,
    local: Option<f64>,
    order_all: f64,
    local_all: f64,
}

fn order_coverage(
    replications: u64, law: impl Fn(u64) -> (Vec<f64>, Vec<Vec<f64>>), error: impl Fn(f64) -> f64,
) -> OrderCoverage {
    // (indicative, order covers, local slope covers) per replication.
    let mut fits = Vec::new();
    for r in 0..replications {
        let (h, errors) = law(r);
        let data = PathErrors {
            h: &h,
            errors: &errors,
            p: 2.0,
        };
        let Some(fit) = fit_order(data, 0.05) else {
            continue;
        };
        let order = fit
            .order
            .contains(population_slope(&h, &fit.fitted, &error));
        let finest = fit.local_slopes.last().unwrap();
        let truth = population_slope(&h, &[finest.coarse, finest.fine], &error);
        fits.push((fit.indicative, order, finest.slope.contains(truth)));
    }
    let share = |hits: usize, of: usize| hits as f64 / of as f64;
    let firm: Vec<_> = fits.iter().filter(|f| !f.0).collect();
    let firm_share = |covers: fn(&(bool, bool, bool)) -> bool| {
        (firm.len() >= 40).then(|| share(firm.iter().filter(|f| covers(f)).count(), firm.len()))
    };
    OrderCoverage {
        indicative: share(fits.len() - firm.len(), fits.len()),
        order: firm_share(|f| f.1),
        local: firm_share(|f| f.2),
        order_all: share(fits.iter().filter(|f| f.1).count(), fits.len()),
        local_all: share(fits.iter().filter(|f| f.2).count(), fits.len()),
    }
}

/// The binomial standard error of a coverage c measured over R replications.
fn binomial_se(c: f64, replications: u64) -> f64 {
    (c * (1.0 - c) / replications as f64).sqrt()
}

/// The targets: at least 93% from 200 paths on, at least 88% at 20.
fn target(n: usize) -> f64 {
    if n >= 200 { 0.93 } else { 0.88 }
}

/// The laws of the order tests, at n paths: name, sampler of replication r, population L^2
/// error at h.
type Law = (
    &'static str,
    Box<dyn Fn(u64) -> (Vec<f64>, Vec<Vec<f64>>)>,
    fn(f64) -> f64,
);

fn laws(n: usize) -> [Law; 3] {
    [
        (
            "GBM Euler-Maruyama",
            Box::new(move |r| gbm(51, r, n)),
            gbm_l2,
        ),
        (
            "log-normal path factor",
            Box::new(move |r| model(r, n, 0.5, 0.0)),
            f64::sqrt,
        ),
        (
            "heavy path factor",
            Box::new(move |r| heavy_model(r, n, 1.0)),
            |h| h,
        ),
    ]
}

/// The coverage of `law` at `n` paths over `replications`, printed.
fn measured(name: &str, n: usize, replications: u64) -> OrderCoverage {
    let (_, law, error) = laws(n).into_iter().find(|l| l.0 == name).unwrap();
    let c = order_coverage(replications, law, error);
    println!("{name}, n = {n}: {c:?}");
    c
}

/// The floor of a coverage measured over `replications`: the target (or, where the method
/// does not reach it, the coverage measured over 1000 replications by the thorough variant),
/// less 2 binomial standard errors (1.3 points at 93% and 400 replications). A method that
/// holds the floor's base exactly fails 2.3% of the time; one 4 standard errors short of it
/// passes 2.3% of the time.
fn floor(n: usize, measured: f64, replications: u64) -> f64 {
    let base = target(n).min(measured);
    base - 2.0 * binomial_se(base, replications)
}

/// Checks the coverage of each law at each (paths, largest share of indicative fits, smallest
/// share, the order's and the local slope's coverage among the fits not marked indicative, or
/// among all fits where every fit is), returning the failures.
fn check(cases: &[Case], replications: u64) -> Vec<String> {
    let mut failures = Vec::new();
    for &(name, n, (fewest, most), (order, local)) in cases {
        let c = measured(name, n, replications);
        if c.indicative < fewest || c.indicative > most {
            failures.push(format!(
                "{name}, n = {n}: {:.3} of the fits indicative, not in [{fewest}, {most}]",
                c.indicative
            ));
        }
        for (what, covered, all, base) in [
            ("order", c.order, c.order_all, order),
            ("local slope", c.local, c.local_all, local),
        ] {
            let c = covered.unwrap_or(all);
            let floor = floor(n, base, replications);
            if c < floor || c > 0.99 {
                failures.push(format!(
                    "{name}: {what}, n = {n}: {c:.3} (floor {floor:.3})"
                ));
            }
        }
    }
    failures
}

/// (law, paths, the share of fits marked indicative: at least, at most; the coverage of the
/// order and of the finest local slope measured over 1000 replications by the thorough
/// variant, among the firm fits where at least 40 are, else among all).
type Case = (&'static str, usize, (f64, f64), (f64, f64));

/// The measured cases. The log-normal path factor reaches the targets with firm intervals
/// from 200 paths on; the heavier factor reaches them too, though its fits are marked
/// indicative (few effective paths: a conservative mark there). GBM falls short at every n
/// (its heavy paths shift the slope, not only its spread: the misses lie above the interval),
/// and its fits are marked. At 20 paths every fit is marked (20 effective paths need equal
/// shares); coverage there is of all fits.
const CASES: [Case; 9] = [
    ("GBM Euler-Maruyama", 20, (1.0, 1.0), (0.778, 0.895)),
    ("GBM Euler-Maruyama", 200, (0.95, 1.0), (0.795, 0.917)),
    ("GBM Euler-Maruyama", 2000, (0.95, 1.0), (0.850, 0.925)),
    ("log-normal path factor", 20, (1.0, 1.0), (0.931, 0.931)),
    ("log-normal path factor", 200, (0.0, 0.1), (0.948, 0.954)),
    ("log-normal path factor", 2000, (0.0, 0.01), (0.954, 0.953)),
    ("heavy path factor", 20, (1.0, 1.0), (0.896, 0.897)),
    ("heavy path factor", 200, (0.95, 1.0), (0.944, 0.945)),
    ("heavy path factor", 2000, (0.9, 1.0), (0.953, 0.962)),
];

#[test]
fn order_intervals_cover_or_say_they_are_indicative() {
    // 400 replications of the cases up to 200 paths (a few seconds).
    let cases: Vec<Case> = CASES.into_iter().filter(|c| c.1 <= 200).collect();
    let failures = check(&cases, 400);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The thorough variant: 1000 replications of every case (about 30 s in the test profile):
/// `cargo test -p sdae-stats --test integration -- --ignored --nocapture`.
#[test]
#[ignore]
fn order_intervals_cover_or_say_they_are_indicative_thoroughly() {
    let failures = check(&CASES, 1000);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Coverage of the L^2 error interval at the finest level (N = 256) of the GBM law, and the
/// share of the intervals marked indicative (fewer than 20 effective paths) with the coverage
/// of the others (`None` when fewer than 40 are).
fn gbm_lp_coverage(n: usize, replications: u64) -> (f64, f64, Option<f64>) {
    let truth = gbm_l2(1.0 / GBM_FINE as f64);
    let intervals: Vec<(bool, bool)> = (0..replications)
        .map(|r| {
            let (_, errors) = gbm(52, r, n);
            let finest = errors.last().unwrap();
            let covers = lp_error(finest, 2.0).is_some_and(|i| i.contains(truth));
            let indicative = effective_paths(finest, 2.0) < INDICATIVE_BELOW as f64;
            (covers, indicative)
        })
        .collect();
    let share = |hits: usize, of: usize| hits as f64 / of as f64;
    let firm: Vec<bool> = intervals.iter().filter(|i| !i.1).map(|i| i.0).collect();
    (
        share(intervals.iter().filter(|i| i.0).count(), intervals.len()),
        share(intervals.len() - firm.len(), intervals.len()),
        (firm.len() >= 40).then(|| share(firm.iter().filter(|&&c| c).count(), firm.len())),
    )
}

#[test]
fn lp_intervals_on_multiplicative_noise() {
    // (paths, coverage measured over these 400 replications). The targets are not reached:
    // d^2 has a log-normal factor of log-variance 4, and the floors guard the measured
    // coverage of the studentized bootstrap. What the report says instead: every one of
    // these intervals is marked indicative (measured: all of them, at 20, 200 and 2000 paths;
    // the effective paths are about n e^-4, under 40 of 2000).
    let mut failures = Vec::new();
    for (n, measured) in [(20, 0.792), (200, 0.848), (2000, 0.875)] {
        let (c, indicative, firm) = gbm_lp_coverage(n, 400);
        let floor = floor(n, measured, 400);
        println!(
            "GBM L^2 error at N = 256, n = {n}: coverage {c:.3} (floor {floor:.3}), indicative {indicative:.3}, firm {firm:?}"
        );
        if c < floor || c > 0.99 {
            failures.push(format!("n = {n}: {c:.3} (floor {floor:.3})"));
        }
        if indicative < 0.95 {
            failures.push(format!("n = {n}: only {indicative:.3} marked indicative"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn curvature_is_flagged_not_hidden_in_the_interval() {
    // E ~ h (1 + 8 h): the local slope falls from ~1.7 at the coarsest pair towards 1.
    let (h, errors) = model(0, 4000, 1.0, 8.0);
    let data = PathErrors {
        h: &h,
        errors: &errors,
        p: 2.0,
    };
    let fit = fit_order(data, 0.05).unwrap();
    assert!(!fit.pre_asymptotic.is_empty(), "{fit:?}");
    assert!(
        fit.local_slopes[0].slope.ci_low > fit.local_slopes[4].slope.ci_high,
        "{fit:?}"
    );
    // Without curvature nothing is flagged.
    let (h, errors) = model(0, 4000, 1.0, 0.0);
    let data = PathErrors {
        h: &h,
        errors: &errors,
        p: 2.0,
    };
    let fit = fit_order(data, 0.05).unwrap();
    assert!(
        fit.pre_asymptotic.is_empty() && fit.curvature.is_empty(),
        "{fit:?}"
    );
}
