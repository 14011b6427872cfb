//! The predicted cost of each estimator from a pilot: standard Monte Carlo and randomized QMC
//! on the finest level L the bias needs, MLMC and multilevel QMC on levels 0..=L.
//!
//! - **Standard Monte Carlo**: N = 2 V\[P_L\] / eps^2 paths (whole blocks) of C_L steps, V\[P_L\]
//!   from the convergence test.
//! - **MLMC**: the optimal N_l = 2 eps^-2 sqrt(V_l / C_l) sum_k sqrt(V_k C_k) (whole blocks) of
//!   the test's V_l and the work per sample C_l.
//! - **Randomized QMC** on level L: R randomizations of n points, n the first power of two (from
//!   the pilot's n_p) with V(n) <= eps^2 / 2, where V(n) = V(n_p) (n_p / n)^p: the variance of
//!   the mean of P_L over the randomizations measured by the pilot at n_p / 8, n_p / 4, n_p / 2
//!   and n_p points, p its fitted decay rate ([`PilotLevel::rate`]).
//! - **MLQMC**: the doublings the adaptive algorithm would make ([`level_to_double`]) under the
//!   same model per level (V_l(n) = V_l(n_p) (n_p / n)^(p_l)), until sum_l V_l <= eps^2 / 2.
//!
//! Each prediction is in work (steps) and in seconds: the work times the seconds per step the
//! pilot measured for that kind of path (pseudo-random pairs and paths from the test,
//! quasi-random ones from the QMC pilot), all threads together. The estimators are named by
//! [`Method`].

use serde::Serialize;

use crate::algorithm::{optimal_counts, whole_blocks};
use crate::qmc::{QuasiLevel, level_to_double};
use crate::sums::LevelStats;

/// What the cheapest is judged by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CostMeasure {
    /// Work in steps: the same choice on every machine and thread count.
    Work,
    /// Work times the measured seconds per step of each kind of path: quasi-random paths cost
    /// more to make than pseudo-random ones; near ties may fall differently between runs.
    Seconds,
}

impl std::fmt::Display for CostMeasure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CostMeasure::Work => "work",
            CostMeasure::Seconds => "seconds",
        })
    }
}

impl std::str::FromStr for CostMeasure {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "work" => Ok(CostMeasure::Work),
            "seconds" => Ok(CostMeasure::Seconds),
            other => Err(format!("'{other}' is not work or seconds")),
        }
    }
}

/// The estimator that ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Multilevel Monte Carlo (Giles's adaptive algorithm).
    Mlmc,
    /// Multilevel randomized QMC (Giles and Waterhouse).
    Mlqmc,
    /// Standard Monte Carlo on one level.
    Standard,
    /// Randomized QMC on one level.
    Rqmc,
}

impl Method {
    /// Every estimator, in the order of preference on equal costs.
    pub const ALL: [Method; 4] = [Method::Mlmc, Method::Mlqmc, Method::Standard, Method::Rqmc];

    /// Its name: `mlmc`, `mlqmc`, `standard`, `rqmc`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Mlmc => "mlmc",
            Method::Mlqmc => "mlqmc",
            Method::Standard => "standard",
            Method::Rqmc => "rqmc",
        }
    }

    /// Its name in words.
    pub fn words(self) -> &'static str {
        match self {
            Method::Mlmc => "multilevel Monte Carlo",
            Method::Mlqmc => "multilevel quasi-Monte Carlo",
            Method::Standard => "standard Monte Carlo",
            Method::Rqmc => "randomized quasi-Monte Carlo",
        }
    }

    /// Whether its paths are quasi-random.
    pub fn quasi(self) -> bool {
        matches!(self, Method::Mlqmc | Method::Rqmc)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("'{s}' is not one of mlmc, mlqmc, standard, rqmc"))
    }
}

/// The predicted cost of one estimator at the accuracy asked for.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// The estimator.
    pub method: Method,
    /// Whether it could run: a single-level method needs the finest level the bias needs,
    /// which only a test that resolved the bias gives; a quasi-random one a sampler of
    /// quasi-random paths and a pilot of them.
    pub offered: bool,
    /// Its finest level L.
    pub level: u32,
    /// Predicted work in steps (infinite where not offered or beyond the points a sequence has).
    #[serde(with = "sdae_stats::json_f64")]
    pub work: f64,
    /// Predicted seconds, all threads together: the work at the measured seconds per step.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds: f64,
    /// Samples per level 0..=L: N_l (MLMC; standard Monte Carlo's paths on L, 0 below), or
    /// points per randomization n_l (the QMC methods; randomized QMC's on L).
    pub samples: Vec<u64>,
    /// The QMC variance decay rate p of V(n) ~ n^-p used (per level for MLQMC, level L's for
    /// randomized QMC).
    #[serde(with = "sdae_stats::json_f64::vec")]
    pub rates: Vec<f64>,
    /// Why it is not offered, or on what the prediction rests.
    pub note: String,
}

impl Prediction {
    /// An estimator that cannot run here, and why.
    pub fn not_offered(method: Method, level: u32, note: String) -> Self {
        Prediction {
            method,
            offered: false,
            level,
            work: f64::INFINITY,
            seconds: f64::INFINITY,
            samples: Vec::new(),
            rates: Vec::new(),
            note,
        }
    }

    /// Its cost by `by`.
    pub fn cost(&self, by: CostMeasure) -> f64 {
        match by {
            CostMeasure::Work => self.work,
            CostMeasure::Seconds => self.seconds,
        }
    }
}

/// The estimator to run: the offered prediction of least cost by `by`, the first of equals (in
/// the order given), `None` if none is offered or none has a finite cost.
pub fn cheapest(predictions: &[Prediction], by: CostMeasure) -> Option<&Prediction> {
    predictions
        .iter()
        .filter(|p| p.offered && p.cost(by).is_finite())
        .fold(None, |best: Option<&Prediction>, p| match best {
            Some(b) if b.cost(by) <= p.cost(by) => Some(b),
            _ => Some(p),
        })
}

/// The decay rate p of V(n) ~ n^-p from `(n, V)` pairs: the least-squares slope of -log2 V
/// against log2 n less twice its standard error (from the residuals), kept within \[1, 2\]. A rate
/// extrapolates: the pilot's noise in it multiplies the points predicted by 2^(error x the
/// doublings), so it is taken at the low end of what the pilot shows. Scrambled nets never do
/// worse than Monte Carlo's 1 asymptotically, and the pilot's few counts cannot tell a decay
/// faster than 2 from noise. 1 where it cannot be judged (fewer than three pairs with a
/// variance above 0).
pub fn decay_rate(history: &[(u64, f64)]) -> f64 {
    let usable: Vec<&(u64, f64)> = history.iter().filter(|(_, v)| *v > 0.0).collect();
    let x: Vec<f64> = usable.iter().map(|(n, _)| (*n as f64).log2()).collect();
    let y: Vec<f64> = usable.iter().map(|(_, v)| -v.log2()).collect();
    if x.len() < 3 {
        return 1.0;
    }
    let count = x.len() as f64;
    let (xm, ym) = (x.iter().sum::<f64>() / count, y.iter().sum::<f64>() / count);
    let sxx: f64 = x.iter().map(|x| (x - xm) * (x - xm)).sum();
    let slope = x
        .iter()
        .zip(&y)
        .map(|(x, y)| (x - xm) * (y - ym))
        .sum::<f64>()
        / sxx;
    let residuals: f64 = x
        .iter()
        .zip(&y)
        .map(|(x, y)| (y - ym - slope * (x - xm)).powi(2))
        .sum();
    let se = (residuals / (count - 2.0) / sxx).sqrt();
    let rate = slope - 2.0 * se;
    if rate.is_finite() {
        rate.clamp(1.0, 2.0)
    } else {
        1.0
    }
}

/// MLMC on levels 0..=L of `test` (L its last level): the optimal N_l in whole blocks.
pub fn mlmc(test: &[LevelStats], eps: f64) -> Prediction {
    let variances: Vec<f64> = test.iter().map(|s| s.var_y).collect();
    let costs: Vec<f64> = test.iter().map(|s| s.work_per_sample as f64).collect();
    let samples: Vec<u64> = optimal_counts(&variances, &costs, eps)
        .iter()
        .map(|&n| whole_blocks((n.ceil() as u64).max(2)))
        .collect();
    let work = samples.iter().zip(&costs).map(|(&n, c)| n as f64 * c).sum();
    let seconds = samples
        .iter()
        .zip(test)
        .map(|(&n, s)| n as f64 * s.seconds_per_sample)
        .sum();
    Prediction {
        method: Method::Mlmc,
        offered: true,
        level: (test.len() - 1) as u32,
        work,
        seconds,
        samples,
        rates: Vec::new(),
        note: "optimal N_l of the test's variances".into(),
    }
}

/// Standard Monte Carlo on the last level L of `test`: 2 V\[P_L\] / eps^2 paths (at least 2,
/// whole blocks) of `path_steps` steps, at the test's seconds per step of level L.
pub fn standard(test: &[LevelStats], path_steps: u64, eps: f64) -> Prediction {
    let top = test.last().expect("the test has levels");
    let paths = whole_blocks(((2.0 * top.var_p / (eps * eps)).max(2.0)).ceil() as u64);
    let work = paths as f64 * path_steps as f64;
    let mut samples = vec![0; test.len()];
    samples[test.len() - 1] = paths;
    Prediction {
        method: Method::Standard,
        offered: true,
        level: top.level,
        work,
        seconds: work * top.seconds_per_sample / top.work_per_sample as f64,
        samples,
        rates: Vec::new(),
        note: "2 V[P_L] / eps^2 paths".into(),
    }
}

/// One level of the QMC pilot: its variances at the point counts it ran, and its cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PilotLevel {
    /// Level l.
    pub level: u32,
    /// Steps of a pair C_l.
    pub pair_steps: u64,
    /// Steps of the fine path alone.
    pub path_steps: u64,
    /// Per point count n run: (n, V_l(n), the variance of the mean of P_l over the
    /// randomizations at n points).
    pub history: Vec<(u64, f64, f64)>,
    /// At the last count: what the variances of the two means would be with as many
    /// independent paths, V\[Y_l\] / (R n) and V\[P_l\] / (R n) from the points' values.
    pub monte_carlo: (f64, f64),
    /// Measured seconds per step of its quasi-random pairs, all threads together.
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds_per_step: f64,
}

impl PilotLevel {
    /// The history of V_l (`fine = false`) or of the variance of the fine mean (`fine`).
    fn series(&self, fine: bool) -> Vec<(u64, f64)> {
        self.history
            .iter()
            .map(|&(n, vy, vp)| (n, if fine { vp } else { vy }))
            .collect()
    }

    /// The last point count and its variance of `series`.
    fn last(&self, fine: bool) -> (u64, f64) {
        *self.series(fine).last().expect("the pilot ran points")
    }

    /// The decay rate of `series`: [`decay_rate`] where the quasi-random points have shown a
    /// gain, their variance at the last count at most half what as many independent paths
    /// give (a variance from 32 randomizations is within about 25% of its value), else 1 (a
    /// rate fitted to noise around Monte Carlo's would extrapolate a gain that is not there).
    pub fn rate(&self, fine: bool) -> f64 {
        let independent = if fine {
            self.monte_carlo.1
        } else {
            self.monte_carlo.0
        };
        if 2.0 * self.last(fine).1 <= independent {
            decay_rate(&self.series(fine))
        } else {
            1.0
        }
    }
}

/// The least number of doublings k >= 0 with `variance` 2^(-k `rate`) <= `target`.
fn doublings(variance: f64, target: f64, rate: f64) -> u32 {
    if variance <= target {
        return 0;
    }
    ((variance / target).log2() / rate).ceil().clamp(0.0, 64.0) as u32
}

/// Randomized QMC on the pilot's last level L with `randomizations` randomizations, its points
/// limited to `max_points` per randomization.
pub fn rqmc(pilot: &[PilotLevel], randomizations: u32, max_points: u64, eps: f64) -> Prediction {
    let top = pilot.last().expect("the pilot has levels");
    let rate = top.rate(true);
    let (n, v) = top.last(true);
    let k = doublings(v, eps * eps / 2.0, rate);
    let points = n.checked_shl(k).filter(|&p| p <= max_points && k < 64);
    let Some(points) = points else {
        return Prediction::not_offered(
            Method::Rqmc,
            top.level,
            format!(
                "level {} would need {n} x 2^{k} points per randomization, more than the \
                 {max_points} its sequences offer",
                top.level
            ),
        );
    };
    let work = f64::from(randomizations) * points as f64 * top.path_steps as f64;
    let mut samples = vec![0; pilot.len()];
    samples[pilot.len() - 1] = points;
    Prediction {
        method: Method::Rqmc,
        offered: true,
        level: top.level,
        work,
        seconds: work * top.seconds_per_step,
        samples,
        rates: vec![rate],
        note: format!("V(n) ~ n^-{rate:.2} from the pilot's {n} points"),
    }
}

/// MLQMC on the pilot's levels 0..=L: the adaptive algorithm's doublings under the fitted
/// variance model, until sum_l V_l <= eps^2 / 2.
pub fn mlqmc(pilot: &[PilotLevel], randomizations: u32, max_points: u64, eps: f64) -> Prediction {
    let rates: Vec<f64> = pilot.iter().map(|p| p.rate(false)).collect();
    let mut levels: Vec<QuasiLevel> = pilot
        .iter()
        .map(|p| {
            let mut q = QuasiLevel::new(p.level, 2, p.pair_steps);
            (q.points, q.variance) = p.last(false);
            q
        })
        .collect();
    let top = (pilot.len() - 1) as u32;
    while levels.iter().map(|q| q.variance).sum::<f64>() > eps * eps / 2.0 {
        let l = level_to_double(&levels);
        let q = &mut levels[l];
        if q.points >= max_points || q.variance == 0.0 {
            return Prediction::not_offered(
                Method::Mlqmc,
                top,
                format!(
                    "level {l} would need more than the {max_points} points its sequences offer"
                ),
            );
        }
        q.points *= 2;
        q.variance *= 2f64.powf(-rates[l]);
    }
    let r = f64::from(randomizations);
    let work = levels
        .iter()
        .map(|q| r * q.points as f64 * q.cost as f64)
        .sum();
    let seconds = levels
        .iter()
        .zip(pilot)
        .map(|(q, p)| r * q.points as f64 * q.cost as f64 * p.seconds_per_step)
        .sum();
    Prediction {
        method: Method::Mlqmc,
        offered: true,
        level: top,
        work,
        seconds,
        samples: levels.iter().map(|q| q.points).collect(),
        rates,
        note: "the adaptive doublings under V_l(n) ~ n^-p_l fitted per level".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prediction(method: Method, work: f64, seconds: f64) -> Prediction {
        Prediction {
            method,
            offered: true,
            level: 3,
            work,
            seconds,
            samples: Vec::new(),
            rates: Vec::new(),
            note: String::new(),
        }
    }

    #[test]
    fn the_cheapest_offered_estimator_is_picked_by_the_measure_asked() {
        let mut all = vec![
            prediction(Method::Mlmc, 4.0, 1.0),
            prediction(Method::Mlqmc, 2.0, 3.0),
            prediction(Method::Standard, 8.0, 0.5),
            prediction(Method::Rqmc, 1.0, 9.0),
        ];
        let pick = |all: &[Prediction], by| cheapest(all, by).map(|p| p.method);
        assert_eq!(pick(&all, CostMeasure::Work), Some(Method::Rqmc));
        assert_eq!(pick(&all, CostMeasure::Seconds), Some(Method::Standard));
        all[3].offered = false;
        assert_eq!(pick(&all, CostMeasure::Work), Some(Method::Mlqmc));
        // Equal costs: the first in order.
        all[1].work = 4.0;
        assert_eq!(pick(&all, CostMeasure::Work), Some(Method::Mlmc));
        assert_eq!(pick(&[], CostMeasure::Work), None);
    }

    #[test]
    fn decay_rates_are_fitted_and_kept_within_one_and_two() {
        let law = |p: f64| -> Vec<(u64, f64)> {
            [8u64, 16, 32]
                .iter()
                .map(|&n| (n, 3.0 * (n as f64).powf(-p)))
                .collect()
        };
        assert!((decay_rate(&law(1.5)) - 1.5).abs() < 1e-12);
        assert_eq!(decay_rate(&law(0.5)), 1.0);
        assert_eq!(decay_rate(&law(3.0)), 2.0);
        assert_eq!(decay_rate(&[(8, 1.0), (16, 0.2)]), 1.0);
        assert_eq!(decay_rate(&[(8, 0.0), (16, 0.0), (32, 1.0)]), 1.0);
        // Noise lowers the rate by twice the slope's standard error: -log2 V = 3, 4.5, 6.5 at
        // log2 n = 3, 4, 5 gives the slope 1.75, residuals 1/12, -1/6, 1/12 (one degree of
        // freedom) and the standard error sqrt((1/24) / 2) = 0.144.
        let noisy = [
            (8u64, 2f64.powf(-3.0)),
            (16, 2f64.powf(-4.5)),
            (32, 2f64.powf(-6.5)),
        ];
        let se = (1.0f64 / 48.0).sqrt();
        assert!(
            (decay_rate(&noisy) - (1.75 - 2.0 * se)).abs() < 1e-12,
            "{}",
            decay_rate(&noisy)
        );
    }

    fn pilot_level(level: u32, cost: u64, v: f64, p: f64) -> PilotLevel {
        PilotLevel {
            level,
            pair_steps: cost,
            path_steps: cost,
            history: [8u64, 16, 32]
                .iter()
                .map(|&n| {
                    (
                        n,
                        v * (n as f64 / 32.0).powf(-p),
                        v * (n as f64 / 32.0).powf(-p),
                    )
                })
                .collect(),
            seconds_per_step: 1e-6,
            monte_carlo: (1.0, 1.0),
        }
    }

    #[test]
    fn quasi_predictions_follow_the_fitted_variance_law() {
        // One level at V(32) = 1e-2 decaying as n^-2: eps^2 / 2 = 5e-5 needs 2^k with
        // 1e-2 4^-k <= 5e-5, k = ceil(log2(200) / 2) = 4, so 512 points.
        let pilot = [pilot_level(0, 10, 1e-2, 2.0)];
        let r = rqmc(&pilot, 16, 1 << 32, 1e-2);
        assert_eq!(r.samples, vec![512]);
        assert_eq!(r.work, 16.0 * 512.0 * 10.0);
        assert!((r.seconds - r.work * 1e-6).abs() < 1e-15);
        let m = mlqmc(&pilot, 16, 1 << 32, 1e-2);
        assert_eq!((m.samples.clone(), m.work), (vec![512], r.work));
        // The sequence's end: not offered.
        // No gain over independent paths shown: Monte Carlo's rate 1.
        let mut flat = pilot.clone();
        flat[0].monte_carlo = (1.5e-2, 1.5e-2);
        assert_eq!(flat[0].rate(true), 1.0);
        assert_eq!(rqmc(&flat, 16, 1 << 32, 1e-2).samples, vec![32 << 8]);
        let short = rqmc(&pilot, 16, 256, 1e-2);
        assert!(!short.offered && short.work.is_infinite(), "{short:?}");
        assert!(!mlqmc(&pilot, 16, 256, 1e-2).offered);
    }
}
