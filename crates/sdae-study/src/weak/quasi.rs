//! Randomized quasi-Monte Carlo in the weak study: the per-path values of each randomization
//! averaged into one sample ([`randomization_means`]), on which the weak statistics run.
//!
//! With R randomizations of n scrambled Sobol' points (path p is point p % n of randomization
//! p / n, [`QuasiPaths`](crate::lockstep::QuasiPaths)), the n paths of one randomization are
//! not independent (they are a stratified point set), but the R point-set means are i.i.d. with
//! the expectation of one path's value. Every statistic of the weak study is a mean over paths
//! of a linear combination of a path's values (differences against the basis, the reference's
//! extrapolation f_R + (f_R - f_(R-1)) / (2^p - 1), Richardson's 2 f_h/2 - f_h), so averaging a
//! randomization's values first gives the same estimates, and the intervals, bias bounds, order
//! fits and bootstrap then rest on the R means as on R independent paths (a t interval with
//! R - 1 degrees of freedom, the design of Giles and Waterhouse).

use serde::Serialize;

use crate::lockstep::{PathRecord, TrackOutcome};

/// The randomized QMC design of a weak report and the samples its statistics rest on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QmcSamples {
    /// Randomizations R of the run.
    pub randomizations: usize,
    /// Points n of each randomization.
    pub points: usize,
    /// The randomizations whose n paths all finished with their reference: one sample each,
    /// the intervals rest on them.
    pub samples: usize,
    /// The randomizations left out (a path's reference failed, or a path is missing from the
    /// records), by index.
    pub left_out: Vec<usize>,
}

impl QmcSamples {
    /// One sentence for the report: what the estimate is and what its intervals rest on.
    pub fn describe(&self) -> String {
        let mut s = format!(
            "Randomized quasi-Monte Carlo: R = {} randomizations (scrambled Sobol' points, \
             Brownian bridge) of n = {} points each; the values of each randomization's n paths \
             are averaged into one sample before any statistic, so every interval, bias bound, \
             order fit and bootstrap rests on the {} samples of the randomizations (the paths \
             column counts them), not on the {} paths. A path's first {} coordinates (noise \
             components times fine steps) are quasi-random, any further ones pseudo-random.",
            self.randomizations,
            self.points,
            self.samples,
            self.randomizations * self.points,
            sdae_noise::MAX_SOBOL_DIMS,
        );
        if !self.left_out.is_empty() {
            let left: Vec<String> = self.left_out.iter().map(usize::to_string).collect();
            s += &format!(
                " Randomizations left out (a path's reference failed or a path is missing): {}.",
                left.join(", ")
            );
        }
        s
    }
}

/// The mean of `rows` element by element (`None` if their lengths differ or there are none).
fn mean_of<'a>(rows: impl Iterator<Item = &'a [f64]> + Clone) -> Vec<f64> {
    let count = rows.clone().count();
    let Some(len) = rows.clone().next().map(<[f64]>::len) else {
        return Vec::new();
    };
    if rows.clone().any(|r| r.len() != len) {
        // Paths that stopped early at this level: the sample is marked failed by its caller.
        return Vec::new();
    }
    let mut sum = vec![0.0; len];
    for row in rows {
        for (s, x) in sum.iter_mut().zip(row) {
            *s += x;
        }
    }
    sum.iter().map(|s| s / count as f64).collect()
}

/// One sample of randomization r from its n paths (all with a finished reference): the mean
/// of each value, the first failure of a track where a path failed (the level is then lost),
/// the mean run time.
fn sample(r: usize, members: &[&PathRecord]) -> PathRecord {
    let n = members.len() as f64;
    let tracks = (0..members[0].tracks.len())
        .map(|t| {
            let failure = members.iter().find_map(|m| m.tracks[t].failure);
            TrackOutcome {
                failure,
                seconds: members.iter().map(|m| m.tracks[t].seconds).sum::<f64>() / n,
                steps: members[0].tracks[t].steps,
                observed: if failure.is_some() {
                    Vec::new()
                } else {
                    mean_of(members.iter().map(|m| &m.tracks[t].observed[..]))
                },
                ..TrackOutcome::default()
            }
        })
        .collect();
    PathRecord {
        index: r,
        reference_failure: None,
        reference_seconds: members.iter().map(|m| m.reference_seconds).sum::<f64>() / n,
        tracks,
        reference_observed: mean_of(members.iter().map(|m| &m.reference_observed[..])),
        reference_coarse_observed: mean_of(
            members.iter().map(|m| &m.reference_coarse_observed[..]),
        ),
    }
}

/// The R samples of a randomized QMC run from its records (`records` sorted by index, those of
/// global paths p = r n + i): one per randomization whose n paths are all there with a finished
/// reference (the others are left out whole: their mean over fewer points would weigh the
/// points unequally), and the paths of the randomizations kept (for counting the failures of
/// the levels in paths).
pub fn randomization_means<'a>(
    records: &[&'a PathRecord], randomizations: usize, points: usize,
) -> (Vec<PathRecord>, Vec<&'a PathRecord>, QmcSamples) {
    let mut samples = Vec::new();
    let mut kept = Vec::new();
    let mut left_out = Vec::new();
    let points = points.max(1);
    for r in 0..randomizations {
        let range = r * points..(r + 1) * points;
        let members: Vec<&PathRecord> = records
            .iter()
            .copied()
            .filter(|p| range.contains(&p.index))
            .collect();
        let whole =
            members.len() == points && members.iter().all(|m| m.reference_failure.is_none());
        if whole {
            samples.push(sample(r, &members));
            kept.extend(members);
        } else {
            left_out.push(r);
        }
    }
    let design = QmcSamples {
        randomizations,
        points,
        samples: samples.len(),
        left_out,
    };
    (samples, kept, design)
}
