//! The rows of an MLMC study that its randomized QMC part is set beside: an adaptive run of
//! the complexity table and the direct standard Monte Carlo run.

use serde::Serialize;

use sdae_mlmc::algorithm::MlmcEstimate;
use sdae_stats::Interval;

/// One row of the complexity table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ComplexityRow {
    /// The adaptive run.
    pub run: MlmcEstimate,
    /// N_l attempted per level.
    pub samples: Vec<u64>,
    /// MLMC work in steps, sum_l N_l C_l with C_l the work per sample of level l.
    pub mlmc_work: f64,
    /// Standard Monte Carlo's work for the same eps on the finest level L: 2 V\[P_L\] / eps^2
    /// paths of 2^(k0 + L) steps.
    pub standard_work: f64,
    /// standard_work / mlmc_work.
    pub savings: f64,
    /// MLMC cost in seconds, sum_l N_l c_l with c_l the test's measured seconds per sample
    /// (beside the work: not used by anything).
    pub mlmc_cost: f64,
    /// Standard Monte Carlo's cost in seconds, its paths at the test's measured seconds per
    /// path.
    pub standard_cost: f64,
}

/// A direct standard Monte Carlo run next to the MLMC run of the largest eps.
///
/// Its work is capped by the MLMC part's (the convergence test and the adaptive runs, in
/// steps): it runs 2 V\[P_L\] / eps^2 paths of 2^(k0 + L) steps at the largest eps when that
/// work is within the cap, else at the accuracy the cap affords,
/// eps_run = eps sqrt(work(eps) / cap) (as many paths as the cap's steps allow). The cap
/// counts steps rather than seconds so that a resumed run makes the same choice as an
/// uninterrupted one; its predicted seconds, at the test's measured seconds per path on level
/// L (all threads together: the wall-clock time is at most that), are printed with it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StandardRun {
    /// The accuracy of the MLMC run compared (the largest of the list).
    pub target_eps: f64,
    /// The accuracy run: `target_eps`, or the larger one the cap affords.
    pub eps: f64,
    /// The level run (the MLMC run's finest).
    pub level: u32,
    /// Paths run, 2 V\[P_L\] / eps^2 rounded up to whole blocks.
    pub samples: u64,
    /// Paths that failed.
    pub failed: u64,
    /// E\[P_L\] with its 95% sampling interval (the bias is not in it: see `with_bias`).
    pub estimate: Interval,
    /// The bias estimate |E\[P - P_L\]| of level L: the MLMC run's at `target_eps`, whose
    /// finest level L is.
    pub bias: f64,
    /// The interval for E\[P\] the reports print: `estimate` widened by `bias` on each side.
    pub with_bias: Interval,
    /// Work in steps that standard Monte Carlo needs at `target_eps`.
    pub target_work: f64,
    /// The cap on the work: the MLMC part's steps.
    pub cap_work: f64,
    /// Predicted seconds at `target_eps`: its paths at the test's measured seconds per path
    /// (the seconds of all threads together, which bound the wall-clock time).
    pub predicted_seconds: f64,
    /// The cap in predicted seconds (all threads together).
    pub cap_seconds: f64,
    /// Measured seconds (all threads).
    pub seconds: f64,
    /// The MLMC run's measured seconds at `target_eps`.
    pub mlmc_seconds: f64,
    /// The measured seconds scaled to `target_eps` by the 1 / eps^2 law,
    /// seconds (eps / target_eps)^2, over mlmc_seconds.
    pub speedup: f64,
}
