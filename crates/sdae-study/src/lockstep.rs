//! One Monte Carlo path of a study: every scheme at every level, and the fine reference, driven
//! in lockstep by one Brownian path.
//!
//! The finest increments are drawn once, a chunk at a time, and summed pairwise into the
//! increments of the coarser levels (a level of 2^k steps uses sums of 2^(fine - k) fine
//! increments), so every level sees the same Brownian path. The reference runs first over a
//! chunk and records its state on the finest level's grid; then each scheme and level steps
//! through the chunk in a tight, timed loop, and its states at its grid points are compared with
//! the reference's afterwards. Memory per path is bounded by the chunk, not by the number of
//! fine steps.

use std::time::Instant;

use sdae_scheme::{GaussianIncrements, IncrementSource};
use serde::{Deserialize, Serialize};

use crate::integrator::{FailureKind, Integrator, StepInfo};

/// Fine steps per chunk (fewer when the state is large, see [`chunk_len`]).
const CHUNK: usize = 4096;
/// Floats the chunk's buffers may hold (64 MiB).
const CHUNK_BUDGET: usize = 1 << 23;

/// Bounds beyond which a path counts as failed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// |r_i| or |v_i| above this is a blow-up.
    pub blow_up: f64,
    /// |g(r)| or |Dg(r) v| above this is a failure (`None`: not checked, as for the
    /// convergence of unprojected schemes, which drift off the manifold by O(h)).
    pub drift_tolerance: Option<f64>,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            blow_up: 1e8,
            drift_tolerance: None,
        }
    }
}

/// What one path runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PathPlan {
    /// Final time T.
    pub t_end: f64,
    /// Increments are drawn on 2^`fine` steps; the reference (if any) runs on them.
    pub fine: u32,
    /// Level exponents k (N = 2^k steps), ascending, at most `fine` (below it with a reference).
    pub levels: Vec<u32>,
    /// Accumulate mu (only when an output needs it).
    pub want_mu: bool,
    /// Failure bounds.
    pub limits: Limits,
    /// Average the kinetic energy v^T M v / 2 over the grid points with t >= this time.
    pub kinetic_after: Option<f64>,
}

/// What one scheme at one level did on one path.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackOutcome {
    /// sup over the level's grid of |r - r_ref|, |v - v_ref|, |mu - mu_ref| (0 for mu when it is
    /// not accumulated); `None` if the path failed or there is no reference.
    pub distances: Option<[f64; 3]>,
    /// Why the path stopped early.
    pub failure: Option<FailureKind>,
    /// Wall-clock seconds spent stepping.
    pub seconds: f64,
    /// Steps done.
    pub steps: usize,
    /// Steps with a truncated drift.
    pub truncated_steps: usize,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Steps that needed the homotopy.
    pub homotopy_steps: usize,
    /// Largest |g(r_k)| on the grid.
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| on the grid.
    pub max_velocity_residual: f64,
    /// Time average of v^T M v / 2 after the plan's `kinetic_after`.
    pub kinetic_energy: Option<f64>,
}

/// One path: the reference's fate and the outcome of every scheme at every level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathRecord {
    /// Path index i (its stream is derived from (seed, i)).
    pub index: usize,
    /// Why the reference failed, if it did (the path is then left out of the errors).
    pub reference_failure: Option<FailureKind>,
    /// Wall-clock seconds of the reference.
    pub reference_seconds: f64,
    /// Outcomes, scheme-major: `tracks[s * levels + j]` is scheme s at level j.
    pub tracks: Vec<TrackOutcome>,
}

/// The chunk length: a power of two that holds at least one point of the finest level's grid
/// and keeps the buffers within [`CHUNK_BUDGET`].
fn chunk_len(fine_steps: usize, record_stride: usize, row: usize, l: usize) -> usize {
    let by_records = record_stride.saturating_mul(CHUNK_BUDGET / row.max(1));
    let by_noise = CHUNK_BUDGET / (2 * l.max(1));
    let cap = CHUNK.min(by_records).min(by_noise).max(1);
    let mut chunk = 1;
    while chunk * 2 <= cap {
        chunk *= 2;
    }
    chunk.max(record_stride).min(fine_steps)
}

/// The state and running statistics of one scheme at one level.
struct Track {
    r: Vec<f64>,
    v: Vec<f64>,
    mu: Vec<f64>,
    /// Sum of the fine increments of the current step when it spans several chunks.
    pending: Vec<f64>,
    pending_fine: usize,
    /// Coarse steps done.
    k: usize,
    sup: [f64; 3],
    kinetic: (f64, usize),
    outcome: TrackOutcome,
}

/// Buffers of a path, reused from chunk to chunk.
struct Buffers {
    /// pyramid[j]: sums of 2^j consecutive fine increments of the chunk (rows of l).
    pyramid: Vec<Vec<f64>>,
    /// The reference at the finest level's grid points of the chunk (rows r, v, mu).
    records: Vec<f64>,
    /// A track's states at its grid points of the chunk (rows r, v, mu).
    snapshots: Vec<f64>,
    dmu: Vec<f64>,
    scratch_m: Vec<f64>,
    scratch_n: Vec<f64>,
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

fn record_step(outcome: &mut TrackOutcome, info: StepInfo) {
    outcome.steps += 1;
    outcome.truncated_steps += usize::from(info.truncated);
    outcome.newton_iterations += info.newton_iterations;
    outcome.homotopy_steps += usize::from(info.homotopy);
}

/// The dimensions of a path: n, m and l, and the row length 2n + m of a recorded state.
#[derive(Clone, Copy)]
struct Dims {
    n: usize,
    m: usize,
    l: usize,
}

impl Dims {
    fn row(self) -> usize {
        2 * self.n + self.m
    }
}

/// Steps `integrator` through `rows` (coarse increments of step h), writing the state after each
/// step to `snapshots`; returns the number of steps done and the failure that stopped it.
#[allow(clippy::too_many_arguments)]
fn step_rows(
    integrator: &mut dyn Integrator,
    track: &mut Track,
    rows: &[f64],
    dims: Dims,
    h: f64,
    want_mu: bool,
    dmu: &mut [f64],
    snapshots: &mut [f64],
) -> (usize, Option<FailureKind>) {
    let (n, l, row) = (dims.n, dims.l, dims.row());
    let count = rows.len().checked_div(l).unwrap_or(snapshots.len() / row);
    for j in 0..count {
        let dw = if l == 0 {
            &[][..]
        } else {
            &rows[j * l..(j + 1) * l]
        };
        match integrator.step(&mut track.r, &mut track.v, h, dw, dmu) {
            Ok(info) => record_step(&mut track.outcome, info),
            Err(kind) => return (j, Some(kind)),
        }
        if want_mu {
            for (acc, d) in track.mu.iter_mut().zip(dmu.iter()) {
                *acc += d;
            }
        }
        let snap = &mut snapshots[j * row..(j + 1) * row];
        snap[..n].copy_from_slice(&track.r);
        snap[n..2 * n].copy_from_slice(&track.v);
        snap[2 * n..].copy_from_slice(&track.mu);
    }
    (count, None)
}

/// Compares snapshot rows 0..count of a track with the reference records (snapshot j is record
/// `(j + 1) * per - 1`), updates residuals and kinetic energy, and checks the limits.
struct Compare<'a> {
    integrator: &'a dyn Integrator,
    plan: &'a PathPlan,
    dims: Dims,
    /// Records per coarse step.
    per: usize,
    /// Coarse step size.
    h: f64,
    has_reference: bool,
}

impl Compare<'_> {
    fn run(
        &self,
        track: &mut Track,
        snapshots: &[f64],
        records: &[f64],
        count: usize,
        buffers: (&mut [f64], &mut [f64]),
    ) -> Option<FailureKind> {
        let (n, row) = (self.dims.n, self.dims.row());
        let (scratch_m, scratch_n) = buffers;
        for j in 0..count {
            let snap = &snapshots[j * row..(j + 1) * row];
            let (r, v, mu) = (&snap[..n], &snap[n..2 * n], &snap[2 * n..]);
            track.k += 1;
            let (g, dgv) = self.integrator.residuals(r, v, scratch_m);
            let o = &mut track.outcome;
            o.max_position_residual = o.max_position_residual.max(g);
            o.max_velocity_residual = o.max_velocity_residual.max(dgv);
            let size = r.iter().chain(v).fold(0.0_f64, |a, x| a.max(x.abs()));
            if !size.is_finite() {
                return Some(FailureKind::NonFinite);
            }
            if size > self.plan.limits.blow_up {
                return Some(FailureKind::BlowUp);
            }
            if let Some(tol) = self.plan.limits.drift_tolerance {
                if g.max(dgv) > tol {
                    return Some(FailureKind::ConstraintDrift);
                }
            }
            if let Some(after) = self.plan.kinetic_after {
                if track.k as f64 * self.h >= after * (1.0 - 1e-12) {
                    track.kinetic.0 += self.integrator.kinetic_energy(v, scratch_n);
                    track.kinetic.1 += 1;
                }
            }
            if self.has_reference {
                let rec = &records[((j + 1) * self.per - 1) * row..((j + 1) * self.per) * row];
                let d = [
                    distance(r, &rec[..n]),
                    distance(v, &rec[n..2 * n]),
                    distance(mu, &rec[2 * n..]),
                ];
                for (s, x) in track.sup.iter_mut().zip(d) {
                    *s = s.max(x);
                }
            }
        }
        None
    }
}

/// Fills the pyramid of a chunk: level 0 from the noise, level j from pairwise sums of j - 1.
fn fill_pyramid(pyramid: &mut [Vec<f64>], noise: &mut impl IncrementSource, h_fine: f64, l: usize) {
    if l == 0 {
        return;
    }
    for dw in pyramid[0].chunks_exact_mut(l) {
        noise.next_increment(h_fine, dw);
    }
    for j in 1..pyramid.len() {
        let (lower, upper) = pyramid.split_at_mut(j);
        let (below, here) = (&lower[j - 1], &mut upper[0]);
        for (i, out) in here.chunks_exact_mut(l).enumerate() {
            let (a, b) = (
                &below[2 * i * l..(2 * i + 1) * l],
                &below[(2 * i + 1) * l..],
            );
            for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
                *o = x + y;
            }
        }
    }
}

/// Runs the reference over the chunk's fine increments, recording every `stride`-th state;
/// returns the failure that stopped it.
fn run_reference(
    reference: &mut dyn Integrator,
    state: &mut Track,
    fine: &[f64],
    dims: Dims,
    (h, stride, chunk): (f64, usize, usize),
    want_mu: bool,
    buffers: &mut Buffers,
) -> Option<FailureKind> {
    let (n, l, row) = (dims.n, dims.l, dims.row());
    for i in 0..chunk {
        let dw = if l == 0 {
            &[][..]
        } else {
            &fine[i * l..(i + 1) * l]
        };
        if let Err(kind) = reference.step(&mut state.r, &mut state.v, h, dw, &mut buffers.dmu) {
            return Some(kind);
        }
        if want_mu {
            for (acc, d) in state.mu.iter_mut().zip(&buffers.dmu) {
                *acc += d;
            }
        }
        if (i + 1) % stride == 0 {
            let j = (i + 1) / stride - 1;
            let rec = &mut buffers.records[j * row..(j + 1) * row];
            rec[..n].copy_from_slice(&state.r);
            rec[n..2 * n].copy_from_slice(&state.v);
            rec[2 * n..].copy_from_slice(&state.mu);
        }
    }
    None
}

/// Runs path `index` of a study: every integrator at every level of `plan`, against `reference`
/// on the fine grid if given, from (r0, v0), with the Brownian path of stream (seed, index).
pub fn run_path(
    plan: &PathPlan,
    integrators: &mut [Box<dyn Integrator>],
    mut reference: Option<&mut Box<dyn Integrator>>,
    (r0, v0): (&[f64], &[f64]),
    seed: u64,
    index: usize,
) -> PathRecord {
    let (n, m, l) = match (integrators.first(), reference.as_deref()) {
        (Some(i), _) | (None, Some(i)) => i.dims(),
        (None, None) => (r0.len(), 0, 0),
    };
    let mu_len = if plan.want_mu { m } else { 0 };
    let dims_rec = Dims { n, m: mu_len, l };
    let row = dims_rec.row();
    let fine_steps = 1usize << plan.fine;
    let h_fine = plan.t_end / fine_steps as f64;
    let finest = plan.levels.last().copied().unwrap_or(plan.fine);
    let record_stride = 1usize << (plan.fine - finest);
    let chunk = chunk_len(fine_steps, record_stride, row, l);
    let depth = chunk.trailing_zeros() as usize;
    let new_track = || Track {
        r: r0.to_vec(),
        v: v0.to_vec(),
        mu: vec![0.0; mu_len],
        pending: vec![0.0; l],
        pending_fine: 0,
        k: 0,
        sup: [0.0; 3],
        kinetic: (0.0, 0),
        outcome: TrackOutcome::default(),
    };
    let mut buffers = Buffers {
        pyramid: (0..=depth).map(|j| vec![0.0; (chunk >> j) * l]).collect(),
        records: vec![0.0; (chunk / record_stride) * row],
        snapshots: vec![0.0; (chunk / record_stride) * row],
        dmu: vec![0.0; m],
        scratch_m: vec![0.0; m],
        scratch_n: vec![0.0; n],
    };
    let mut tracks: Vec<Track> = (0..integrators.len() * plan.levels.len())
        .map(|_| new_track())
        .collect();
    let mut reference_state = new_track();
    let mut record = PathRecord {
        index,
        reference_failure: None,
        reference_seconds: 0.0,
        tracks: Vec::new(),
    };
    let mut noise = GaussianIncrements::for_path(seed, index as u64, l);
    for _ in 0..fine_steps / chunk {
        fill_pyramid(&mut buffers.pyramid, &mut noise, h_fine, l);
        if let Some(reference) = reference.as_deref_mut() {
            let start = Instant::now();
            let fine = std::mem::take(&mut buffers.pyramid[0]);
            let failure = run_reference(
                reference.as_mut(),
                &mut reference_state,
                &fine,
                dims_rec,
                (h_fine, record_stride, chunk),
                plan.want_mu,
                &mut buffers,
            );
            buffers.pyramid[0] = fine;
            record.reference_seconds += start.elapsed().as_secs_f64();
            if failure.is_some() {
                record.reference_failure = failure;
                return record;
            }
        }
        for (s, integrator) in integrators.iter_mut().enumerate() {
            for (j, &level) in plan.levels.iter().enumerate() {
                let track = &mut tracks[s * plan.levels.len() + j];
                if track.outcome.failure.is_some() {
                    continue;
                }
                let stride = 1usize << (plan.fine - level);
                let h = plan.t_end / (1usize << level) as f64;
                // The coarse increments of this chunk, and records per coarse step.
                let (rows, per): (&[f64], usize) = if stride <= chunk {
                    let rows = &buffers.pyramid[stride.trailing_zeros() as usize];
                    (rows, stride / record_stride)
                } else {
                    for (p, x) in track.pending.iter_mut().zip(&buffers.pyramid[depth]) {
                        *p += x;
                    }
                    track.pending_fine += chunk;
                    if track.pending_fine < stride {
                        continue;
                    }
                    track.pending_fine = 0;
                    // The step ends at the chunk's end: compare with the chunk's last record.
                    (&[], chunk / record_stride)
                };
                let count = (chunk / stride).max(1);
                let pending = std::mem::take(&mut track.pending);
                let rows = if stride <= chunk { rows } else { &pending[..] };
                let start = Instant::now();
                let (done, failure) = step_rows(
                    integrator.as_mut(),
                    track,
                    rows,
                    dims_rec,
                    h,
                    plan.want_mu,
                    &mut buffers.dmu,
                    &mut buffers.snapshots[..count * row],
                );
                track.outcome.seconds += start.elapsed().as_secs_f64();
                track.pending = pending;
                track.pending.fill(0.0);
                let compare = Compare {
                    integrator: integrator.as_ref(),
                    plan,
                    dims: dims_rec,
                    per,
                    h,
                    has_reference: reference.is_some(),
                };
                let scratch = (&mut buffers.scratch_m[..], &mut buffers.scratch_n[..]);
                let checked =
                    compare.run(track, &buffers.snapshots, &buffers.records, done, scratch);
                let failure = failure.or(checked);
                track.outcome.failure = failure;
            }
        }
    }
    let has_reference = reference.is_some();
    record.tracks = tracks
        .into_iter()
        .map(|t| {
            let mut o = t.outcome;
            if o.failure.is_none() && has_reference {
                o.distances = Some(t.sup);
            }
            if t.kinetic.1 > 0 {
                o.kinetic_energy = Some(t.kinetic.0 / t.kinetic.1 as f64);
            }
            o
        })
        .collect();
    record
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_powers_of_two_within_the_path() {
        assert_eq!(chunk_len(1 << 15, 32, 5, 2), CHUNK);
        assert_eq!(chunk_len(64, 1, 5, 2), 64);
        // A huge state shrinks the chunk, but never below one point of the finest grid.
        let chunk = chunk_len(1 << 10, 1, 3 * 10_000 * 2, 30_000);
        assert!(chunk.is_power_of_two() && chunk < CHUNK);
        assert_eq!(chunk_len(1 << 20, 1 << 12, 1 << 24, 2), 1 << 12);
    }
}
