//! An estimate with its 95% confidence interval, and the Student t quantile of t intervals.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// An estimate with a 95% confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// Point estimate.
    #[serde(with = "crate::json_f64")]
    pub estimate: f64,
    /// Lower end.
    #[serde(with = "crate::json_f64")]
    pub ci_low: f64,
    /// Upper end.
    #[serde(with = "crate::json_f64")]
    pub ci_high: f64,
}

impl Interval {
    /// Whether `x` lies in [ci_low, ci_high].
    pub fn contains(&self, x: f64) -> bool {
        self.ci_low <= x && x <= self.ci_high
    }

    /// The interval with `margin` added on each side, [ci_low - margin, ci_high + margin], the
    /// estimate unchanged: a sampling interval for E\[P_L\] widened by a bound on the bias
    /// |E\[P\] - E\[P_L\]| is an interval for E\[P\]. A NaN margin gives NaN ends (nothing
    /// bounds the bias), never the narrower interval.
    pub fn widened(&self, margin: f64) -> Interval {
        Interval {
            estimate: self.estimate,
            ci_low: self.ci_low - margin,
            ci_high: self.ci_high + margin,
        }
    }
}

/// The two-sided 95% quantile t_{0.975, dof} of Student's t distribution (NaN for dof = 0).
pub fn t975(dof: usize) -> f64 {
    if dof == 0 {
        return f64::NAN;
    }
    StudentsT::new(0.0, 1.0, dof as f64).map_or(f64::NAN, |t| t.inverse_cdf(0.975))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_published_values() {
        let table = [
            (1, 12.706),
            (2, 4.303),
            (4, 2.776),
            (19, 2.093),
            (39, 2.023),
            (199, 1.972),
            (100_000, 1.960),
        ];
        for (dof, value) in table {
            assert!((t975(dof) - value).abs() < 5e-4, "dof {dof}: {}", t975(dof));
        }
        assert!(t975(0).is_nan());
    }

    #[test]
    fn a_widened_interval_keeps_its_estimate_and_never_narrows_on_nan() {
        let i = Interval {
            estimate: 1.0,
            ci_low: 0.5,
            ci_high: 1.25,
        };
        let w = i.widened(0.25);
        assert_eq!((w.estimate, w.ci_low, w.ci_high), (1.0, 0.25, 1.5));
        assert!(!i.contains(1.4) && w.contains(1.4));
        let nan = i.widened(f64::NAN);
        assert!(nan.ci_low.is_nan() && nan.ci_high.is_nan() && !nan.contains(1.0));
    }
}
