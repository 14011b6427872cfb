//! The cells and tables the reports of an MLMC study share: intervals, ratios and bias cells
//! in the MLMC, MLQMC and plan reports, and the Markdown table of levels.

use sdae_mlmc::sums::LevelStats;
use sdae_stats::Interval;

/// An estimate with its interval to six decimals, "estimate [low, high]".
pub fn interval(i: &Interval) -> String {
    format!("{:.6} [{:.6}, {:.6}]", i.estimate, i.ci_low, i.ci_high)
}

/// An interval for E[f(X_T)] with the bias estimate it holds, "estimate [low, high] (95% +
/// bias b)": the sampling interval of E\[P_L\] widened by the bias estimate b on each side.
pub fn with_bias(i: &Interval, bias: f64) -> String {
    format!("{} (95% + bias {bias:.1e})", interval(i))
}

/// A ratio of times or works, "2.5x" ("1.6e-2x" below 0.1), or "- (too short to compare)"
/// where it is not a finite positive number (seconds that round to 0).
pub fn ratio(x: f64) -> String {
    if x.is_finite() && x >= 0.1 {
        format!("{x:.1}x")
    } else if x.is_finite() && x > 0.0 {
        format!("{x:.1e}x")
    } else {
        "- (too short to compare)".into()
    }
}

/// An estimate with its interval as three CSV fields, "estimate,low,high".
pub fn csv_interval(i: &Interval) -> String {
    format!("{:e},{:e},{:e}", i.estimate, i.ci_low, i.ci_high)
}

/// The bias estimate with the weak rate it used, "bias (alpha)", and " (not converged)" after
/// a run that stopped at its finest level allowed with the bias still too large.
pub fn bias_cell(bias: f64, alpha: f64, converged: bool) -> String {
    let note = if converged { "" } else { " (not converged)" };
    format!("{bias:.2e} ({alpha:.2}){note}")
}

/// A column of a Markdown table of levels ([`level_table`]).
#[derive(Debug, Clone, Copy)]
pub enum LevelColumn {
    /// l.
    Level,
    /// Steps of the fine path.
    Steps,
    /// Samples with a value.
    Samples,
    /// mean Y_l.
    MeanY,
    /// var Y_l.
    VarY,
    /// mean P_l.
    MeanP,
    /// var P_l.
    VarP,
    /// Kurtosis of Y_l.
    Kurtosis,
    /// The consistency check.
    Check,
    /// Work per sample in steps.
    Work,
    /// Measured seconds per sample.
    Seconds,
    /// Failed fine and coarse paths.
    Failed,
}

impl LevelColumn {
    /// The column's header.
    fn header(self) -> &'static str {
        match self {
            Self::Level => "l",
            Self::Steps => "steps",
            Self::Samples => "samples",
            Self::MeanY => "mean Y_l",
            Self::VarY => "var Y_l",
            Self::MeanP => "mean P_l",
            Self::VarP => "var P_l",
            Self::Kurtosis => "kurtosis",
            Self::Check => "check",
            Self::Work => "work/sample (steps)",
            Self::Seconds => "seconds/sample",
            Self::Failed => "failed (fine/coarse)",
        }
    }

    /// The cell of level `l`.
    fn cell(self, l: &LevelStats) -> String {
        match self {
            Self::Level => l.level.to_string(),
            Self::Steps => l.steps.to_string(),
            Self::Samples => l.samples.to_string(),
            Self::MeanY => format!("{:.4e}", l.mean_y),
            Self::VarY => format!("{:.4e}", l.var_y),
            Self::MeanP => format!("{:.6}", l.mean_p),
            Self::VarP => format!("{:.4e}", l.var_p),
            Self::Kurtosis => format!("{:.2}", l.kurtosis),
            Self::Check => format!("{:.2}", l.consistency),
            Self::Work => l.work_per_sample.to_string(),
            Self::Seconds => format!("{:.3e}", l.seconds_per_sample),
            Self::Failed => format!("{}/{}", l.failed_fine, l.failed_coarse),
        }
    }
}

/// A Markdown table of `levels`, one row per level, with `columns`.
pub fn level_table(columns: &[LevelColumn], levels: &[LevelStats]) -> String {
    let row = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
    let mut s = row(columns.iter().map(|c| c.header().to_string()).collect());
    s += &format!("|{}\n", "---|".repeat(columns.len()));
    for l in levels {
        s += &row(columns.iter().map(|c| c.cell(l)).collect());
    }
    s
}
