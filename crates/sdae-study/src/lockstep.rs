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
//!
//! Every stretch of steps is taken by the one path driver of `sdae-model` ([`advance`]), with
//! an observer that writes the states the comparison needs; any [`Scheme`] runs here.

use std::time::Instant;

use sdae_manifold::vector::{dot, max_abs};
use sdae_manifold::{Constraint, Mass};
use sdae_model::{
    FailureKind, GaussianIncrements, IncrementSource, ModelError, Observer, PathState,
    RecordedIncrements, Scheme, System, TimeGrid, advance,
};
use serde::{Deserialize, Serialize};

/// Fine steps per chunk (fewer when the state is large, see [`chunk_len`]).
const CHUNK: usize = 4096;
/// Floats the chunk's buffers may hold (64 MiB).
const CHUNK_BUDGET: usize = 1 << 23;

/// Bounds beyond which a path counts as failed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// |r_i| or |v_i| above this is a blow-up.
    #[serde(with = "crate::real")]
    pub blow_up: f64,
    /// |g(r)| or |Dg(r) v| above this is a failure (`None`: not checked, as for the
    /// convergence of unprojected schemes, which drift off the manifold by O(h)).
    #[serde(with = "crate::real::option", default)]
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
    #[serde(with = "crate::real::option_triple", default)]
    pub distances: Option<[f64; 3]>,
    /// Why the path stopped early.
    pub failure: Option<FailureKind>,
    /// Wall-clock seconds spent stepping.
    #[serde(with = "crate::real")]
    pub seconds: f64,
    /// Steps done.
    pub steps: usize,
    /// Steps with a truncated drift.
    pub truncated_steps: usize,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Steps that needed the homotopy.
    pub homotopy_steps: usize,
    /// Steps whose kappa was certified with its rounding part set aside.
    #[serde(default)]
    pub rounding_certified_steps: usize,
    /// The clock lag sum_k (1 - eta_k) h of the truncated drift.
    #[serde(default, with = "crate::real")]
    pub clock_lag: f64,
    /// Largest |g(r_k)| on the grid.
    #[serde(with = "crate::real")]
    pub max_position_residual: f64,
    /// Largest |Dg(r_k) v_k| on the grid.
    #[serde(with = "crate::real")]
    pub max_velocity_residual: f64,
    /// Time average of v^T M v / 2 after the plan's `kinetic_after`.
    #[serde(with = "crate::real::option", default)]
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
    #[serde(with = "crate::real")]
    pub reference_seconds: f64,
    /// Outcomes, scheme-major: `tracks[s * levels + j]` is scheme s at level j.
    pub tracks: Vec<TrackOutcome>,
}

/// The chunk length: a power of two that keeps the buffers within [`CHUNK_BUDGET`], whatever
/// the distance between the reference and the finest level. A chunk may be shorter than a step
/// of the finest level: the levels then sum their increments across chunks, and the reference
/// records its one state per finest step in the chunk that ends on it.
fn chunk_len(fine_steps: usize, record_stride: usize, row: usize, l: usize) -> usize {
    let by_records = record_stride.saturating_mul(CHUNK_BUDGET / row.max(1));
    let by_noise = CHUNK_BUDGET / (2 * l.max(1));
    let cap = CHUNK.min(by_records).min(by_noise).max(1);
    let mut chunk = 1;
    while chunk * 2 <= cap {
        chunk *= 2;
    }
    chunk.min(fine_steps)
}

/// The schemes of a path, all stepping one system.
pub type Schemes<S> = [Box<dyn Scheme<System = S>>];

/// The state and running statistics of one scheme at one level.
struct Track {
    r: Vec<f64>,
    v: Vec<f64>,
    path: PathState,
    /// Sum of the fine increments of the current step when it spans several chunks.
    pending: Vec<f64>,
    pending_fine: usize,
    sup: [f64; 3],
    kinetic: (f64, usize),
    outcome: TrackOutcome,
}

impl Track {
    fn new((r0, v0): (&[f64], &[f64]), dims: Dims) -> Self {
        Self {
            r: r0.to_vec(),
            v: v0.to_vec(),
            path: PathState::new(dims.m, dims.mu > 0, false),
            pending: vec![0.0; dims.l],
            pending_fine: 0,
            sup: [0.0; 3],
            kinetic: (0.0, 0),
            outcome: TrackOutcome::default(),
        }
    }

    /// The outcome of the whole path: step statistics from the driver's diagnostics, the
    /// distances if it finished against a reference, the kinetic energy's time average.
    fn finish(self, has_reference: bool) -> TrackOutcome {
        let d = &self.path.diagnostics;
        let mut o = self.outcome;
        o.steps = d.steps;
        o.truncated_steps = d.truncated_steps;
        o.newton_iterations = d.newton_iterations;
        o.homotopy_steps = d.homotopy_steps;
        o.rounding_certified_steps = d.rounding_certified_steps;
        o.clock_lag = d.clock_lag;
        if o.failure.is_none() && has_reference {
            o.distances = Some(self.sup);
        }
        if self.kinetic.1 > 0 {
            o.kinetic_energy = Some(self.kinetic.0 / self.kinetic.1 as f64);
        }
        o
    }
}

/// The dimensions of a path: n, m, l, the length of the recorded mu (m or 0), and the row
/// length 2n + mu of a recorded state.
#[derive(Clone, Copy)]
struct Dims {
    n: usize,
    m: usize,
    l: usize,
    mu: usize,
}

impl Dims {
    fn of<S: System>(system: &S, want_mu: bool) -> Self {
        let c = system.constraint();
        let m = c.n_constraints();
        Self {
            n: c.dim(),
            m,
            l: system.noise_dim(),
            mu: if want_mu { m } else { 0 },
        }
    }
    fn row(self) -> usize {
        2 * self.n + self.mu
    }
}

/// Writes (r, v, mu) at every `stride`-th step after step `start` into consecutive rows
/// (`stride` a power of two).
struct Rows<'a> {
    rows: &'a mut [f64],
    n: usize,
    start: usize,
    stride: usize,
}

impl Observer for Rows<'_> {
    #[inline]
    fn wants_step(&self, k: usize) -> bool {
        k & (self.stride - 1) == 0
    }
    /// Row j holds step k = start + (j + 1) stride when the stretch spans whole strides, and
    /// row 0 the one point of the stride grid a shorter stretch ends on.
    fn observe(&mut self, k: usize, _t: f64, r: &[f64], v: &[f64], mu: &[f64]) {
        let row = 2 * self.n + mu.len();
        let j = (k - 1 - self.start) / self.stride;
        let out = &mut self.rows[j * row..(j + 1) * row];
        out[..self.n].copy_from_slice(r);
        out[self.n..2 * self.n].copy_from_slice(v);
        out[2 * self.n..].copy_from_slice(mu);
    }
}

/// Takes `count` steps of `grid` with the increments `rows` (l each), recording the state after
/// every `stride`-th step into `out`; returns the steps done and the failure that stopped it.
fn step_through<S: System>(
    scheme: &mut dyn Scheme<System = S>,
    track: &mut Track,
    (grid, count): (TimeGrid, usize),
    rows: &[f64],
    l: usize,
    (out, stride): (&mut [f64], usize),
) -> (usize, Option<FailureKind>) {
    let start = track.path.k;
    let mut increments = RecordedIncrements::new(rows, l);
    let mut observer = Rows {
        rows: out,
        n: track.r.len(),
        start,
        stride,
    };
    let result = advance(
        scheme,
        &mut track.r,
        &mut track.v,
        &mut track.path,
        (grid, count),
        &mut increments,
        &mut observer,
    );
    (track.path.k - start, result.err().map(|e| e.failure.kind()))
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Compares snapshot rows 0..count of a track with the reference records (snapshot j is record
/// `(j + 1) * per - 1`), updates residuals and kinetic energy, and checks the limits.
struct Compare<'a, S> {
    system: &'a S,
    plan: &'a PathPlan,
    dims: Dims,
    /// Records per coarse step.
    per: usize,
    /// Coarse step size.
    h: f64,
    has_reference: bool,
}

impl<S: System> Compare<'_, S> {
    fn run(
        &self,
        track: &mut Track,
        (snapshots, records): (&[f64], &[f64]),
        count: usize,
        buffers: (&mut [f64], &mut [f64]),
    ) -> Option<FailureKind> {
        let (n, row) = (self.dims.n, self.dims.row());
        let (scratch_m, scratch_n) = buffers;
        let first = track.path.k - count;
        for j in 0..count {
            let snap = &snapshots[j * row..(j + 1) * row];
            let (r, v, mu) = (&snap[..n], &snap[n..2 * n], &snap[2 * n..]);
            let (g, dgv) = residuals(self.system.constraint(), r, v, scratch_m);
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
            if let Some(tol) = self.plan.limits.drift_tolerance
                && g.max(dgv) > tol
            {
                return Some(FailureKind::ConstraintDrift);
            }
            if let Some(after) = self.plan.kinetic_after
                && (first + j + 1) as f64 * self.h >= after * (1.0 - 1e-12)
            {
                track.kinetic.0 += kinetic_energy(self.system.mass(), v, scratch_n);
                track.kinetic.1 += 1;
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

/// (max |g(r)|, max |Dg(r) v|); `scratch` has length m.
fn residuals<C: Constraint>(c: &C, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64) {
    c.value(r, scratch);
    let position = max_abs(scratch);
    c.jacobian_mul(r, v, scratch);
    (position, max_abs(scratch))
}

/// The kinetic energy v^T M v / 2; `scratch` has length n.
fn kinetic_energy<M: Mass>(mass: &M, v: &[f64], scratch: &mut [f64]) -> f64 {
    mass.apply(v, scratch);
    0.5 * dot(v, scratch)
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

/// One path in lockstep: the plan, its dimensions and the buffers reused from chunk to chunk.
struct Lockstep<'a> {
    plan: &'a PathPlan,
    /// `grids[k]`: N = 2^k steps over [0, T], for k up to the fine level.
    grids: Vec<TimeGrid>,
    dims: Dims,
    /// Fine steps per chunk.
    chunk: usize,
    /// Fine steps per record of the reference (one record per step of the finest level).
    record_stride: usize,
    /// pyramid[j]: sums of 2^j consecutive fine increments of the chunk (rows of l).
    pyramid: Vec<Vec<f64>>,
    /// The reference at the finest level's grid points of the chunk (rows r, v, mu).
    records: Vec<f64>,
    /// A track's states at its grid points of the chunk (rows r, v, mu).
    snapshots: Vec<f64>,
    scratch_m: Vec<f64>,
    scratch_n: Vec<f64>,
}

impl<'a> Lockstep<'a> {
    /// Fails if T is not finite and > 0.
    fn new(plan: &'a PathPlan, dims: Dims) -> Result<Self, ModelError> {
        let grids = (0..=plan.fine)
            .map(|k| TimeGrid::new(plan.t_end, 1usize << k))
            .collect::<Result<_, _>>()?;
        let fine_steps = 1usize << plan.fine;
        let finest = plan.levels.last().copied().unwrap_or(plan.fine);
        let record_stride = 1usize << (plan.fine - finest);
        let chunk = chunk_len(fine_steps, record_stride, dims.row(), dims.l);
        let depth = chunk.trailing_zeros() as usize;
        // A chunk shorter than a step of the finest level holds at most one record.
        let rows = (chunk / record_stride).max(1) * dims.row();
        Ok(Self {
            plan,
            grids,
            dims,
            chunk,
            record_stride,
            pyramid: (0..=depth)
                .map(|j| vec![0.0; (chunk >> j) * dims.l])
                .collect(),
            records: vec![0.0; rows],
            snapshots: vec![0.0; rows],
            scratch_m: vec![0.0; dims.m],
            scratch_n: vec![0.0; dims.n],
        })
    }

    /// Runs the reference over the chunk's fine increments, recording the state at the finest
    /// level's grid points; returns the failure that stopped it.
    fn reference_chunk<S: System>(
        &mut self,
        reference: &mut dyn Scheme<System = S>,
        state: &mut Track,
    ) -> Option<FailureKind> {
        let grid = self.grids[self.plan.fine as usize];
        let (_, failure) = step_through(
            reference,
            state,
            (grid, self.chunk),
            &self.pyramid[0],
            self.dims.l,
            (&mut self.records, self.record_stride),
        );
        failure
    }

    /// Steps one scheme at one level through the chunk and compares it with the reference.
    fn level_chunk<S: System>(
        &mut self,
        scheme: &mut dyn Scheme<System = S>,
        track: &mut Track,
        level: u32,
        has_reference: bool,
    ) {
        let (plan, chunk, l) = (self.plan, self.chunk, self.dims.l);
        let stride = 1usize << (plan.fine - level);
        let depth = self.pyramid.len() - 1;
        // The coarse increments of this chunk, and records per coarse step.
        let per = if stride <= chunk {
            stride / self.record_stride
        } else {
            for (p, x) in track.pending.iter_mut().zip(&self.pyramid[depth]) {
                *p += x;
            }
            track.pending_fine += chunk;
            if track.pending_fine < stride {
                return;
            }
            track.pending_fine = 0;
            // The step ends at the chunk's end: compare with the chunk's last record (its only
            // one when the chunk is shorter than a step of the finest level).
            (chunk / self.record_stride).max(1)
        };
        let count = (chunk / stride).max(1);
        let pending = std::mem::take(&mut track.pending);
        let rows = if stride <= chunk {
            &self.pyramid[stride.trailing_zeros() as usize][..]
        } else {
            &pending[..]
        };
        let grid = self.grids[level as usize];
        let start = Instant::now();
        let (done, failure) = step_through(
            scheme,
            track,
            (grid, count),
            rows,
            l,
            (&mut self.snapshots[..count * self.dims.row()], 1),
        );
        track.outcome.seconds += start.elapsed().as_secs_f64();
        track.pending = pending;
        track.pending.fill(0.0);
        let compare = Compare {
            system: scheme.system(),
            plan,
            dims: self.dims,
            per,
            h: grid.h(),
            has_reference,
        };
        let scratch = (&mut self.scratch_m[..], &mut self.scratch_n[..]);
        let checked = compare.run(track, (&self.snapshots, &self.records), done, scratch);
        track.outcome.failure = failure.or(checked);
    }
}

/// Runs path `index` of a study: every scheme at every level of `plan`, against `reference` on
/// the fine grid if given, from (r0, v0), with the Brownian path of stream (seed, index).
/// Fails only if the plan's T is not finite and > 0; the schemes' failures are in the record.
pub fn run_path<S: System>(
    plan: &PathPlan,
    schemes: &mut Schemes<S>,
    mut reference: Option<&mut Box<dyn Scheme<System = S>>>,
    start: (&[f64], &[f64]),
    seed: u64,
    index: usize,
) -> Result<PathRecord, ModelError> {
    let system = match (schemes.first(), reference.as_deref()) {
        (Some(s), _) | (None, Some(s)) => s.system(),
        (None, None) => {
            return Ok(PathRecord {
                index,
                reference_failure: None,
                reference_seconds: 0.0,
                tracks: Vec::new(),
            });
        }
    };
    let dims = Dims::of(system, plan.want_mu);
    let mut lockstep = Lockstep::new(plan, dims)?;
    let mut tracks: Vec<Track> = (0..schemes.len() * plan.levels.len())
        .map(|_| Track::new(start, dims))
        .collect();
    let mut reference_state = Track::new(start, dims);
    let mut record = PathRecord {
        index,
        reference_failure: None,
        reference_seconds: 0.0,
        tracks: Vec::new(),
    };
    let mut noise = GaussianIncrements::for_path(seed, index as u64, dims.l);
    let h_fine = plan.t_end / (1usize << plan.fine) as f64;
    for _ in 0..(1usize << plan.fine) / lockstep.chunk {
        fill_pyramid(&mut lockstep.pyramid, &mut noise, h_fine, dims.l);
        if let Some(reference) = reference.as_deref_mut() {
            let clock = Instant::now();
            let failure = lockstep.reference_chunk(reference.as_mut(), &mut reference_state);
            record.reference_seconds += clock.elapsed().as_secs_f64();
            if failure.is_some() {
                record.reference_failure = failure;
                return Ok(record);
            }
        }
        for (s, scheme) in schemes.iter_mut().enumerate() {
            for (j, &level) in plan.levels.iter().enumerate() {
                let track = &mut tracks[s * plan.levels.len() + j];
                if track.outcome.failure.is_none() {
                    lockstep.level_chunk(scheme.as_mut(), track, level, reference.is_some());
                }
            }
        }
    }
    let has_reference = reference.is_some();
    record.tracks = tracks
        .into_iter()
        .map(|t| t.finish(has_reference))
        .collect();
    Ok(record)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_powers_of_two_within_the_path() {
        assert_eq!(chunk_len(1 << 15, 32, 5, 2), CHUNK);
        assert_eq!(chunk_len(64, 1, 5, 2), 64);
        // A huge state shrinks the chunk.
        let chunk = chunk_len(1 << 10, 1, 3 * 10_000 * 2, 30_000);
        assert!(chunk.is_power_of_two() && chunk < CHUNK);
        // A reference far above the finest level does not stretch the chunk to a whole
        // finest step: the chunk stays within the budget.
        assert_eq!(chunk_len(1 << 26, 1 << 18, 120, 60), CHUNK);
        assert_eq!(chunk_len(1 << 20, 1 << 12, 1 << 24, 2), 1);
    }
}
