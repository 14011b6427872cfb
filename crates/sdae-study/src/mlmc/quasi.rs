//! Randomized quasi-Monte Carlo in the MLMC study (`mlmc --qmc`): path i of randomization r
//! of a level is driven by point i of the r-th scrambled Sobol' sequence, laid out by a
//! Brownian bridge ([`CoupledSampler`](super::CoupledSampler) as a
//! [`QuasiSampler`]).
//!
//! - Multilevel QMC (Giles and Waterhouse 2009, [`sdae_mlmc::qmc::mlqmc`]) at every eps of the
//!   complexity table, beside the MLMC run at the same eps: sum_l V_l <= eps^2 / 2 with V_l
//!   the variance of level l's mean over R randomizations, and the bias test of MLMC.
//! - The cost exponent c of work ~ eps^-c, fitted over the eps for MLQMC and for MLMC (2 for
//!   MLMC when beta > gamma; QMC's gain shows as a smaller c).
//! - A direct single-level randomized QMC run on the level of the direct standard Monte Carlo
//!   run, to the same accuracy (R n paths, n doubled until the variance V of the estimate is at
//!   most eps^2 / 2), its work capped as standard Monte Carlo's is.

use serde::Serialize;

use sdae_mlmc::MlmcError;
use sdae_mlmc::qmc::{
    MlqmcEstimate, QuasiLevel, QuasiSampler, QuasiSettings, cost_exponent, cost_exponent_of, mlqmc,
};
use sdae_mlmc::sampler::RunControl;
use sdae_stats::Interval;

use super::rows::{ComplexityRow, StandardRun};
use super::run_settings::{MlmcSettings, QmcSettings};

/// An MLQMC run beside the MLMC run at the same eps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QuasiRow {
    /// The MLQMC run.
    pub run: MlqmcEstimate,
    /// The MLMC run's work at this eps (steps).
    #[serde(with = "sdae_stats::json_f64")]
    pub mlmc_work: f64,
    /// mlmc_work / the MLQMC run's work.
    #[serde(with = "sdae_stats::json_f64")]
    pub savings: f64,
    /// The MLMC run's measured seconds (all threads).
    #[serde(with = "sdae_stats::json_f64")]
    pub mlmc_seconds: f64,
}

/// The direct single-level randomized QMC run: the level and accuracy of the direct standard
/// Monte Carlo run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QuasiStandardRun {
    /// The accuracy asked for (the standard run's).
    #[serde(with = "sdae_stats::json_f64")]
    pub target_eps: f64,
    /// The accuracy reached, sqrt(2 V) with V the variance of the estimate (at most
    /// `target_eps` unless the cap stopped the doubling).
    #[serde(with = "sdae_stats::json_f64")]
    pub eps: f64,
    /// The level, its R sums and statistics (Y = P_l).
    pub level: QuasiLevel,
    /// E\[P_l\] with its t interval over the R randomizations (the bias is not in it: see
    /// `with_bias`).
    pub estimate: Interval,
    /// The bias estimate |E\[P - P_l\]| of level l, the standard run's.
    #[serde(with = "sdae_stats::json_f64")]
    pub bias: f64,
    /// The interval for E\[P\] the reports print: `estimate` widened by `bias` on each side.
    pub with_bias: Interval,
    /// Its work, R n path_steps(l).
    #[serde(with = "sdae_stats::json_f64")]
    pub work: f64,
    /// Standard Monte Carlo's work to the accuracy reached, 2 V\[P_l\] / eps^2 paths.
    #[serde(with = "sdae_stats::json_f64")]
    pub standard_work: f64,
    /// standard_work / work.
    #[serde(with = "sdae_stats::json_f64")]
    pub savings: f64,
    /// Measured seconds (all threads).
    #[serde(with = "sdae_stats::json_f64")]
    pub seconds: f64,
}

/// The coordinates of the points one path of a level takes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PathCoordinates {
    /// Level l.
    pub level: u32,
    /// Coordinates per path: l 2^(k0 + l) (noise components times steps).
    pub coordinates: u64,
    /// How many of them are quasi-random (the Sobol' dimensions); the rest are pseudo-random
    /// padding.
    pub quasi: u64,
}

/// The randomized QMC part of an MLMC report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QmcReport {
    /// Its settings.
    pub settings: QmcSettings,
    /// Per level run, the coordinates of a path and how many were quasi-random.
    pub coordinates: Vec<PathCoordinates>,
    /// The MLQMC runs, one per eps of the complexity table.
    pub runs: Vec<QuasiRow>,
    /// The cost exponent c of MLQMC's work ~ eps^-c, with its interval (three eps or more).
    pub cost_exponent: Option<Interval>,
    /// The same fit of the MLMC runs' work.
    pub mlmc_cost_exponent: Option<Interval>,
    /// The direct single-level run, beside the direct standard Monte Carlo run.
    pub standard: Option<QuasiStandardRun>,
}

/// MLQMC at every eps of `complexity`, the cost exponents and, beside `standard`, the direct
/// single-level run (its work capped by `cap_work` steps, as standard Monte Carlo's).
pub fn run_qmc<Q: QuasiSampler>(
    sampler: &Q, settings: &MlmcSettings, qmc: &QmcSettings, control: &RunControl<'_>,
    complexity: &[ComplexityRow], standard: Option<(&StandardRun, f64)>,
) -> Result<QmcReport, MlmcError> {
    qmc.validate()?;
    let mut runs = Vec::with_capacity(complexity.len());
    for row in complexity {
        let run = mlqmc(
            sampler,
            control,
            &QuasiSettings {
                eps: row.run.eps,
                randomizations: qmc.randomizations,
                initial_points: qmc.initial_points,
                min_levels: 2,
                max_level: settings.spec.max_level,
            },
        )?;
        runs.push(QuasiRow {
            mlmc_work: row.mlmc_work,
            savings: row.mlmc_work / run.work,
            mlmc_seconds: row.run.seconds,
            run,
        });
    }
    let estimates: Vec<MlqmcEstimate> = runs.iter().map(|r| r.run.clone()).collect();
    let mlmc: Vec<(f64, f64)> = complexity
        .iter()
        .map(|r| (r.run.eps, r.mlmc_work))
        .collect();
    let standard = standard
        .map(|(run, cap)| single_level(sampler, qmc, control, run, cap))
        .transpose()?;
    let top = runs
        .iter()
        .map(|r| r.run.levels.len() as u32)
        .chain(standard.as_ref().map(|s| s.level.level + 1))
        .max()
        .unwrap_or(0);
    let coordinates = (0..top)
        .filter_map(|level| {
            let (coordinates, quasi) = sampler.coordinates(level)?;
            Some(PathCoordinates {
                level,
                coordinates,
                quasi,
            })
        })
        .collect();
    Ok(QmcReport {
        settings: *qmc,
        coordinates,
        cost_exponent: cost_exponent_of(&estimates),
        mlmc_cost_exponent: cost_exponent(&mlmc),
        runs,
        standard,
    })
}

/// Single-level randomized QMC on the standard run's level: n doubled from n_0 until the
/// variance of the estimate is at most eps^2 / 2 at the standard run's target eps, or until
/// the next doubling would pass `cap_work` steps.
fn single_level<Q: QuasiSampler>(
    sampler: &Q, qmc: &QmcSettings, control: &RunControl<'_>, standard: &StandardRun, cap_work: f64,
) -> Result<QuasiStandardRun, MlmcError> {
    let (level, target_eps) = (standard.level, standard.target_eps);
    let steps = sampler.path_steps(level) as f64;
    let r = f64::from(qmc.randomizations);
    let mut q = QuasiLevel::new(level, qmc.randomizations, sampler.path_steps(level));
    let mut points = qmc.initial_points;
    loop {
        q.extend_to(sampler, control, points, false)?;
        let next = points.saturating_mul(2);
        let affordable = r * next as f64 * steps <= cap_work && next <= sampler.max_points();
        if q.variance <= target_eps * target_eps / 2.0 || !affordable {
            break;
        }
        points = next;
    }
    let estimate = q.interval().ok_or_else(|| MlmcError::Levels {
        reason: format!("{} randomizations give no interval", qmc.randomizations),
    })?;
    let eps = (2.0 * q.variance).sqrt();
    // Standard Monte Carlo to the accuracy reached: 2 V[P_l] / eps^2 paths, V[P_l] the
    // variance of one path's value, which the randomizations' sums give.
    let var_p = q.randomizations.iter().map(|s| s.var_p()).sum::<f64>() / r;
    // Two paths at least; with no variance at all (every path alike) no more.
    let paths = if var_p == 0.0 {
        2.0
    } else {
        (2.0 * var_p / (eps * eps)).max(2.0)
    };
    let standard_work = paths * steps;
    Ok(QuasiStandardRun {
        target_eps,
        eps,
        estimate,
        bias: standard.bias,
        with_bias: estimate.widened(standard.bias),
        work: q.work,
        standard_work,
        savings: standard_work / q.work,
        seconds: q.seconds(),
        level: q,
    })
}
