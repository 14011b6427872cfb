//! The block runner: every scheme at every level and the reference step a block of paths
//! through the chunks of one Brownian path per path, compared after each step with the
//! reference's records.

use std::time::Instant;

use sdae_lanes::{LineVec, lane_stride};
use sdae_manifold::vector::{dot, max_abs};
use sdae_manifold::{Constraint, Mass};
use sdae_model::{FailureKind, ModelError, PathDiagnostics, PathEnsemble, System, TimeGrid};
use sdae_noise::{EnsembleIncrements, EnsembleNoise};

use crate::BoxedEnsemble;
use crate::noise::PathNoise;
use crate::plan::{PathPlan, PathRecord, TrackOutcome};

/// Fine steps per chunk (fewer when the state is large, see [`chunk_len`]).
const CHUNK: usize = 4096;
/// Floats the chunk's buffers may hold (64 MiB).
const CHUNK_BUDGET: usize = 1 << 23;

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

/// Paths stepped together in one block (a multiple of the widest SIMD width).
pub const BLOCK_PATHS: usize = 64;

/// The ensembles a block of paths runs: `tracks[s * levels + j]` is scheme s at level j (each
/// with as many paths as the block), and the reference, if any.
pub struct BlockEnsembles<S> {
    /// Scheme-major, one per scheme and level.
    pub tracks: Vec<BoxedEnsemble<S>>,
    /// Per track, whether its scheme is a time change (a step of size h is in law an
    /// untruncated step of size eta h, as with rescaled noise), so that its time averages run
    /// over its own clock sum_k eta_k h = k h - clock lag; otherwise over the grid's time.
    pub own_clock: Vec<bool>,
    /// The fine reference.
    pub reference: Option<BoxedEnsemble<S>>,
    /// The reference's scheme at half its steps ([`PathPlan::paired_reference`]).
    pub coarse_reference: Option<BoxedEnsemble<S>>,
}

/// What one path of one scheme at one level gathered so far.
#[derive(Default)]
struct Track {
    /// sup over the grid of |r - r_ref|^2, |v - v_ref|^2, |mu - mu_ref|^2.
    squared_sup: [f64; 3],
    /// The weighted sum of v^T M v / 2 and the sum of its weights.
    kinetic: (f64, f64),
    /// The weighted sum of the plan's time-averaged observable (weights as `kinetic`).
    averaged: f64,
    /// The track's time after its last step (its own clock where a time average reads it,
    /// else the grid's).
    time: f64,
    /// The steps the path has taken (its diagnostics' count, kept here so that a step reads
    /// no diagnostics).
    steps: usize,
    outcome: TrackOutcome,
}

impl Track {
    /// The outcome of the whole path: step statistics from the ensemble's diagnostics, the
    /// distances if it finished against a reference, the kinetic energy's time average.
    fn finish(self, d: &PathDiagnostics, has_reference: bool, averaging: bool) -> TrackOutcome {
        let mut o = self.outcome;
        o.steps = d.steps;
        o.truncated_steps = d.truncated_steps;
        o.newton_iterations = d.newton_iterations;
        o.homotopy_steps = d.homotopy_steps;
        o.rounding_certified_steps = d.rounding_certified_steps;
        o.clock_lag = d.clock_lag;
        if o.failure.is_none() && has_reference {
            o.distances = Some(self.squared_sup.map(f64::sqrt));
        }
        if self.kinetic.1 > 0.0 {
            o.kinetic_energy = Some(self.kinetic.0 / self.kinetic.1);
            if averaging {
                o.time_average = Some(self.averaged / self.kinetic.1);
            }
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

/// The diagnostics of path p of `ensemble` (its steps, its clock lag).
fn diagnostics_of<S: System>(ensemble: &dyn PathEnsemble<System = S>, p: usize) -> PathDiagnostics {
    ensemble.diagnostics(p).expect("p is a path of the block")
}

/// The dimension n of the states a stretch compares: a constant for the small systems, so
/// that the per-path loops of [`Compare`] have constant lengths, or read at run time.
trait StateDim: Copy {
    fn n(self, dims: Dims) -> usize;
}

/// n = N.
#[derive(Clone, Copy)]
struct Fixed<const N: usize>;

impl<const N: usize> StateDim for Fixed<N> {
    #[inline(always)]
    fn n(self, _: Dims) -> usize {
        N
    }
}

/// n as the system gives it.
#[derive(Clone, Copy)]
struct RunTime;

impl StateDim for RunTime {
    fn n(self, dims: Dims) -> usize {
        dims.n
    }
}

/// How a track's steps are compared: with the reference's records where there is a reference,
/// and on the track's own clock (the truncated drift's time) where its scheme keeps one.
#[derive(Debug, Clone, Copy)]
struct Clocks {
    has_reference: bool,
    own_clock: bool,
}

/// The steps of one level through a chunk (a stretch): `count` steps of level `level`, each
/// compared with the reference's records `per` apart.
#[derive(Clone, Copy)]
struct Stretch<'a> {
    /// The increments, one row of l * stride per step.
    rows: &'a [f64],
    /// Records of the reference per step.
    per: usize,
    /// The level's exponent k (2^k steps over [0, T]).
    level: u32,
    /// Steps to take.
    count: usize,
}

/// The paths of one track (a scheme at a level) that go on after a step.
struct ActivePaths<'a, S: System> {
    /// The ensemble that steps the track's paths.
    ensemble: &'a dyn PathEnsemble<System = S>,
    /// What each path of the block gathered so far, by path.
    tracks: &'a mut [Track],
    /// The paths that go on.
    active: &'a [usize],
}

/// Step t of a stretch: records `per` apart, of size h, observed every `observe_every` steps
/// (0 for never).
#[derive(Debug, Clone, Copy)]
struct StepAt {
    t: usize,
    per: usize,
    h: f64,
    observe_every: usize,
}

/// Where a track is in time after a step, and the step's weight in time averages.
#[derive(Clone, Copy)]
struct Clock {
    /// The track's time: the grid's k h, or its own clock k h - clock lag.
    time: f64,
    /// 1 on the grid's clock (a plain mean over grid points), the step's eta h on its own.
    weight: f64,
}

/// |a - b|^2 (the sup of distances is taken on squares: sqrt is monotone and correctly
/// rounded, so sqrt(max d^2) is max d exactly, with one square root per path instead of one per
/// grid point).
#[inline(always)]
fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>()
}

/// The buffers [`Compare::run`] works in, kept from step to step.
struct Scratch {
    /// m floats: g(r), then Dg(r) v.
    residuals: Vec<f64>,
    /// n floats: M v.
    momentum: Vec<f64>,
}

/// Compares a track's state after a step with the reference's record at the same time,
/// updates residuals and kinetic energy, and checks the limits; returns the first limit broken.
struct Compare<'a, S> {
    system: &'a S,
    plan: &'a PathPlan,
    dims: Dims,
}

impl<S: System> Compare<'_, S> {
    /// `snapshot` is the state (r, v, mu) after a step that ends at `clock`, `record` the
    /// reference's state at that time (`None` without a reference). Inlined into the loop over
    /// a block's paths, where n may be a constant.
    #[inline(always)]
    fn run(
        &self, track: &mut Track, snapshot: &[f64], record: Option<&[f64]>, clock: Clock,
        scratch: &mut Scratch,
    ) -> Option<FailureKind> {
        let n = self.dims.n;
        let (r, v, mu) = (&snapshot[..n], &snapshot[n..2 * n], &snapshot[2 * n..]);
        let (g, dgv) = residuals(self.system.constraint(), r, v, &mut scratch.residuals);
        let o = &mut track.outcome;
        o.max_position_residual = o.max_position_residual.max(g);
        o.max_velocity_residual = o.max_velocity_residual.max(dgv);
        // Every |coordinate| within the blow-up bound (and finite: NaN fails the comparison),
        // checked without a chain of maxima; which limit broke only when one did.
        let bound = self.plan.limits.blow_up.min(f64::MAX);
        if !r.iter().chain(v).all(|x| x.abs() <= bound) {
            let finite = r.iter().chain(v).all(|x| x.is_finite());
            return Some(if finite {
                FailureKind::BlowUp
            } else {
                FailureKind::NonFinite
            });
        }
        if let Some(tol) = self.plan.limits.drift_tolerance
            && g.max(dgv) > tol
        {
            return Some(FailureKind::ConstraintDrift);
        }
        if let Some(after) = self.plan.kinetic_after
            && clock.time >= after * (1.0 - 1e-12)
        {
            track.kinetic.0 +=
                clock.weight * kinetic_energy(self.system.mass(), v, &mut scratch.momentum);
            track.kinetic.1 += clock.weight;
            if let Some(f) = &self.plan.time_averaged {
                track.averaged += clock.weight * f.value(r, v);
            }
        }
        if let Some(rec) = record {
            let d = [
                squared_distance(r, &rec[..n]),
                squared_distance(v, &rec[n..2 * n]),
                squared_distance(mu, &rec[2 * n..]),
            ];
            for (s, x) in track.squared_sup.iter_mut().zip(d) {
                *s = s.max(x);
            }
        }
        None
    }
}

/// (max |g(r)|, max |Dg(r) v|); `scratch` has length m. Inlined into the loop over a block's
/// paths, where n may be a constant.
#[inline(always)]
fn residuals<C: Constraint>(c: &C, r: &[f64], v: &[f64], scratch: &mut [f64]) -> (f64, f64) {
    c.value(r, scratch);
    let position = largest_magnitude(scratch);
    c.jacobian_mul(r, v, scratch);
    (position, largest_magnitude(scratch))
}

/// max_i |x_i| as [`max_abs`] gives it (NaN if an entry is NaN); one constraint's |x_0|
/// directly, which is the same value.
#[inline(always)]
fn largest_magnitude(x: &[f64]) -> f64 {
    match x {
        [one] => one.abs(),
        _ => max_abs(x),
    }
}

/// The kinetic energy v^T M v / 2; `scratch` has length n.
fn kinetic_energy<M: Mass>(mass: &M, v: &[f64], scratch: &mut [f64]) -> f64 {
    mass.apply(v, scratch);
    0.5 * dot(v, scratch)
}

/// Fills the pyramid of a chunk for a block of paths (rows of l * stride, component j of path
/// p at `j * stride + p`): level 0 from each path's own stream, level j from pairwise sums of
/// j - 1 (the sums of a path's fine increments, whatever the block).
fn fill_pyramid(
    pyramid: &mut [LineVec<f64>], noise: &mut dyn EnsembleNoise, h_fine: f64,
) -> Result<(), ModelError> {
    if noise.dim() == 0 {
        return Ok(());
    }
    let width = noise.dim() * noise.stride();
    noise.fill(h_fine, &mut pyramid[0])?;
    for j in 1..pyramid.len() {
        let (lower, upper) = pyramid.split_at_mut(j);
        let (below, here) = (&lower[j - 1], &mut upper[0]);
        for (i, out) in here.chunks_exact_mut(width).enumerate() {
            let (a, b) = (
                &below[2 * i * width..(2 * i + 1) * width],
                &below[(2 * i + 1) * width..(2 * i + 2) * width],
            );
            for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
                *o = x + y;
            }
        }
    }
    Ok(())
}

/// A block of paths in lockstep: the plan, the dimensions and the buffers reused from chunk to
/// chunk.
struct Lockstep<'a> {
    plan: &'a PathPlan,
    /// `grids[k]`: N = 2^k steps over [0, T], for k up to the fine level.
    grids: Vec<TimeGrid>,
    dims: Dims,
    /// Paths of the block (the ensembles' further lanes are idle) and the ensembles' stride.
    live: usize,
    stride: usize,
    /// Paths whose reference failed: left out of the errors, their schemes stop.
    dropped: Vec<bool>,
    /// Fine steps per chunk.
    chunk: usize,
    /// Fine steps per record of the reference (one record per step of the finest level).
    record_stride: usize,
    /// pyramid[j]: sums of 2^j consecutive fine increments of the chunk (rows of l * stride).
    pyramid: Vec<LineVec<f64>>,
    /// The reference at the finest level's grid points of the chunk (rows r, v, mu), time-major:
    /// record j of path p at row `j * paths + p`, so that the comparison after a step reads the
    /// block's records in order.
    records: Vec<f64>,
    /// Paths of the ensembles (the records' rows per time).
    paths: usize,
    /// The block's paths 0..live.
    block: Vec<usize>,
    /// Per path, one row: a track's state after its last step.
    snapshot: Vec<f64>,
    /// Sums of the fine increments of the current step of each track whose steps span several
    /// chunks (l * stride each), and the fine steps summed so far.
    pending: Vec<LineVec<f64>>,
    pending_fine: Vec<usize>,
    /// The comparison's buffers.
    scratch: Scratch,
    /// Fine steps the reference has taken (whole chunks).
    fine_done: usize,
    /// Per path, the reference's observed values (see [`PathPlan::observing`]).
    reference_observed: Vec<Vec<f64>>,
    /// Per path, the observed values of the reference at half its steps.
    reference_coarse_observed: Vec<Vec<f64>>,
}

impl<'a> Lockstep<'a> {
    /// The first `live` paths of ensembles of `paths` paths, stepped by `tracks` ensembles (one
    /// per scheme and level). Fails if T is not finite and > 0.
    fn new(
        plan: &'a PathPlan, dims: Dims, paths: usize, live: usize, tracks: usize,
    ) -> Result<Self, ModelError> {
        let grids = (0..=plan.fine)
            .map(|k| TimeGrid::new(plan.t_end, 1usize << k))
            .collect::<Result<_, _>>()?;
        let fine_steps = 1usize << plan.fine;
        let finest = plan.levels.last().copied().unwrap_or(plan.fine);
        let record_stride = 1usize << (plan.fine - finest);
        let stride = lane_stride(paths);
        // The paired reference steps on sums of two fine increments within a chunk.
        let chunk = chunk_len(
            fine_steps,
            record_stride,
            dims.row() * stride,
            dims.l * stride,
        )
        .max(if plan.paired_reference { 2 } else { 1 })
        .min(fine_steps);
        let depth = chunk.trailing_zeros() as usize;
        // A chunk shorter than a step of the finest level holds at most one record.
        let record_rows = (chunk / record_stride).max(1);
        let rows = record_rows * dims.row() * paths;
        Ok(Self {
            plan,
            grids,
            dims,
            live,
            stride,
            dropped: vec![false; paths],
            chunk,
            record_stride,
            pyramid: (0..=depth)
                .map(|j| LineVec::from_elem(0.0, (chunk >> j) * dims.l * stride))
                .collect(),
            records: vec![0.0; rows],
            paths,
            block: (0..live).collect(),
            snapshot: vec![0.0; dims.row() * live],
            pending: vec![LineVec::from_elem(0.0, dims.l * stride); tracks],
            pending_fine: vec![0; tracks],
            scratch: Scratch {
                residuals: vec![0.0; dims.m],
                momentum: vec![0.0; dims.n],
            },
            fine_done: 0,
            reference_observed: vec![Vec::new(); live],
            reference_coarse_observed: vec![Vec::new(); live],
        })
    }

    /// Runs the reference over the chunk's fine increments, recording each path's state at
    /// the finest level's grid points; returns the paths that have stopped (if any stopped in
    /// this chunk).
    fn reference_chunk<S: System>(
        &mut self, reference: &mut dyn PathEnsemble<System = S>,
    ) -> Vec<usize> {
        let (row, width) = (self.dims.row(), self.dims.l * self.stride);
        let h = self.grids[self.plan.fine as usize].h();
        // One record per finest step, or one at the chunk's end when the chunk is shorter
        // (only a chunk that ends on a finest step is compared with).
        let every = self.record_stride.min(self.chunk);
        let mut any_failed = false;
        for t in 0..self.chunk {
            let dw = &self.pyramid[0][t * width..(t + 1) * width];
            any_failed |= reference.step(h, dw).expect("the block's increments fit") > 0;
            if (t + 1) % every == 0 {
                // Record j of paths 0..live: rows j * paths + p, one after another.
                let j = (t + 1) / every - 1;
                let at = j * self.paths * row;
                reference
                    .read_rows(
                        &self.block,
                        self.dims.mu,
                        &mut self.records[at..at + self.live * row],
                    )
                    .expect("the block's rows fit its ensembles");
                self.observe_reference(self.fine_done + t + 1, at);
            }
        }
        self.fine_done += self.chunk;
        let failed = |p: &usize| reference.failure(*p).is_ok_and(|f| f.is_some());
        if any_failed {
            (0..self.live).filter(failed).collect()
        } else {
            Vec::new()
        }
    }

    /// Runs the paired reference ([`PathPlan::paired_reference`]) over the chunk on sums of two
    /// fine increments, evaluating the observables on its state at the points of the observed
    /// grid; returns the paths that have stopped (if any stopped in this chunk). Called after
    /// [`Lockstep::reference_chunk`] (whose count of fine steps already includes the chunk).
    fn coarse_reference_chunk<S: System>(
        &mut self, coarse: &mut dyn PathEnsemble<System = S>,
    ) -> Vec<usize> {
        let Some(observing) = &self.plan.observing else {
            return Vec::new();
        };
        let width = self.dims.l * self.stride;
        let h = self.grids[self.plan.fine as usize - 1].h();
        let every = 1usize << (self.plan.fine - 1 - observing.grid_level);
        let done = (self.fine_done - self.chunk) / 2;
        let n = self.dims.n;
        let mut any_failed = false;
        for t in 0..self.chunk / 2 {
            let dw = &self.pyramid[1][t * width..(t + 1) * width];
            any_failed |= coarse.step(h, dw).expect("the block's increments fit") > 0;
            if !(done + t + 1).is_multiple_of(every) {
                continue;
            }
            let states = &mut self.snapshot[..self.live * 2 * n];
            coarse
                .read_rows(&self.block, 0, states)
                .expect("the block's rows fit its ensembles");
            for p in (0..self.live).filter(|&p| !self.dropped[p]) {
                let state = &states[p * 2 * n..(p + 1) * 2 * n];
                observing.evaluate(
                    &state[..n],
                    &state[n..],
                    &mut self.reference_coarse_observed[p],
                );
            }
        }
        let failed = |p: &usize| coarse.failure(*p).is_ok_and(|f| f.is_some());
        if any_failed {
            (0..self.live).filter(failed).collect()
        } else {
            Vec::new()
        }
    }

    /// After `fine_steps` fine steps, when they end on a point of the observed grid: evaluates
    /// the observables on the reference's rows just recorded at `at` (paths that go on).
    fn observe_reference(&mut self, fine_steps: usize, at: usize) {
        let Some(observing) = &self.plan.observing else {
            return;
        };
        if !fine_steps.is_multiple_of(1usize << (self.plan.fine - observing.grid_level)) {
            return;
        }
        let (n, row) = (self.dims.n, self.dims.row());
        for p in (0..self.live).filter(|&p| !self.dropped[p]) {
            let state = &self.records[at + p * row..at + (p + 1) * row];
            observing.evaluate(
                &state[..n],
                &state[n..2 * n],
                &mut self.reference_observed[p],
            );
        }
    }

    /// Steps one scheme at one level (track `index`) through the chunk for every path that
    /// goes on, and compares each with the reference.
    fn level_chunk<S: System>(
        &mut self, ensemble: &mut dyn PathEnsemble<System = S>, tracks: &mut [Track], index: usize,
        level: u32, clocks: Clocks,
    ) {
        let (plan, chunk) = (self.plan, self.chunk);
        let stride = 1usize << (plan.fine - level);
        let depth = self.pyramid.len() - 1;
        // The coarse increments of this chunk, and records per coarse step.
        let per = if stride <= chunk {
            stride / self.record_stride
        } else {
            for (p, x) in self.pending[index].iter_mut().zip(&self.pyramid[depth]) {
                *p += x;
            }
            self.pending_fine[index] += chunk;
            if self.pending_fine[index] < stride {
                return;
            }
            self.pending_fine[index] = 0;
            // The step ends at the chunk's end: compare with the chunk's last record (its only
            // one when the chunk is shorter than a step of the finest level).
            (chunk / self.record_stride).max(1)
        };
        let count = (chunk / stride).max(1);
        let active: Vec<usize> = (0..self.live)
            .filter(|&p| !self.dropped[p] && tracks[p].outcome.failure.is_none())
            .collect();
        // The increments, taken out of the buffers for the stretch and put back after it.
        let at = stride.trailing_zeros() as usize;
        let rows = if stride <= chunk {
            std::mem::take(&mut self.pyramid[at])
        } else {
            std::mem::take(&mut self.pending[index])
        };
        let stretch = Stretch {
            rows: &rows,
            per,
            level,
            count,
        };
        self.stretch(ensemble, tracks, active, stretch, clocks);
        if stride <= chunk {
            self.pyramid[at] = rows;
        } else {
            self.pending[index] = rows;
            self.pending[index].fill(0.0);
        }
    }

    /// Takes `count` steps of level `level` of the active paths with the increments `rows`
    /// (the steps timed, their share of the time charged to each path). After each step every
    /// path's state is compared with the reference at once, and a path stops at the first step
    /// that fails or breaks a limit, so where a path stops does not depend on the chunks.
    fn stretch<S: System>(
        &mut self, ensemble: &mut dyn PathEnsemble<System = S>, tracks: &mut [Track],
        mut active: Vec<usize>, stretch: Stretch<'_>, clocks: Clocks,
    ) {
        let Stretch {
            rows,
            per,
            level,
            count,
        } = stretch;
        let width = self.dims.l * self.stride;
        let h = self.grids[level as usize].h();
        // Steps between observations (the observed grid's spacing in this level's steps).
        let observe_every = self
            .plan
            .observing
            .as_ref()
            .map_or(0, |o| 1usize << level.saturating_sub(o.grid_level));
        // The run time charged to a path that took every step so far (each step's time shared
        // by the paths that took it), added to a track when it stops or the stretch ends.
        let mut charged = 0.0;
        for t in 0..count {
            if active.is_empty() {
                break;
            }
            let start = Instant::now();
            let failed = ensemble
                .step(h, &rows[t * width..(t + 1) * width])
                .expect("the block's increments fit");
            charged += start.elapsed().as_secs_f64() / active.len() as f64;
            if failed > 0 {
                // The paths whose step failed have stopped at their last good state.
                active.retain(|&p| {
                    let failure = ensemble.failure(p).expect("p is a path of the block");
                    let outcome = &mut tracks[p].outcome;
                    outcome.failure = failure.map(|f| f.kind());
                    if failure.is_some() {
                        outcome.seconds += charged;
                    }
                    failure.is_none()
                });
            }
            let step = StepAt {
                t,
                per,
                h,
                observe_every,
            };
            let paths = ActivePaths {
                ensemble: &*ensemble,
                tracks: &mut *tracks,
                active: &active,
            };
            // Small systems get loops of constant length.
            let stopped = match self.dims.n {
                2 => self.compare_step(Fixed::<2>, paths, step, clocks, charged),
                3 => self.compare_step(Fixed::<3>, paths, step, clocks, charged),
                _ => self.compare_step(RunTime, paths, step, clocks, charged),
            };
            if stopped > 0 {
                // The paths that broke a limit stop where they are.
                active.retain(|&p| {
                    let goes_on = tracks[p].outcome.failure.is_none();
                    if !goes_on {
                        ensemble.stop(p).expect("p is a path of the block");
                    }
                    goes_on
                });
            }
        }
        for &p in &active {
            tracks[p].outcome.seconds += charged;
        }
    }

    /// After step t of a stretch (its records `per` apart, of size h; observed every
    /// `observe_every` steps, 0 for never): reads every path that
    /// goes on (`active`) in one call, compares each with the reference and marks the tracks
    /// that broke a limit, charging them the stretch's time so far; returns how many did.
    fn compare_step<S: System, D: StateDim>(
        &mut self, dim: D, paths: ActivePaths<'_, S>, step: StepAt, clocks: Clocks, charged: f64,
    ) -> usize {
        let ActivePaths {
            ensemble,
            tracks,
            active,
        } = paths;
        let StepAt {
            t,
            per,
            h,
            observe_every,
        } = step;
        let Clocks {
            has_reference,
            own_clock,
        } = clocks;
        let dims = Dims {
            n: dim.n(self.dims),
            ..self.dims
        };
        let row = dims.row();
        // Every path that goes on, one row each (in the order of `active`).
        let snapshots = &mut self.snapshot[..active.len() * row];
        ensemble
            .read_rows(active, dims.mu, snapshots)
            .expect("the block's rows fit its ensembles");
        let compare = Compare {
            system: ensemble.system(),
            plan: self.plan,
            dims,
        };
        let mut stopped = 0;
        for (&p, snapshot) in active.iter().zip(snapshots.chunks_exact(row)) {
            let track = &mut tracks[p];
            // A path that goes on took one more step.
            track.steps += 1;
            let steps = track.steps;
            debug_assert_eq!(steps, diagnostics_of(ensemble, p).steps);
            // The record at the end of step t: the reference's record (t + 1) per - 1.
            let record = has_reference.then(|| {
                let at = (((t + 1) * per - 1) * self.paths + p) * row;
                &self.records[at..at + row]
            });
            let grid_time = steps as f64 * h;
            // Only time averages read the clock: the clock lag (the path's diagnostics) only
            // where they are taken.
            let clock = if own_clock && self.plan.kinetic_after.is_some() {
                let time = grid_time - diagnostics_of(ensemble, p).clock_lag;
                let weight = time - track.time;
                Clock { time, weight }
            } else {
                Clock {
                    time: grid_time,
                    weight: 1.0,
                }
            };
            track.time = clock.time;
            if let Some(kind) = compare.run(track, snapshot, record, clock, &mut self.scratch) {
                track.outcome.failure = Some(kind);
                track.outcome.seconds += charged;
                stopped += 1;
            } else if let Some(observing) = &self.plan.observing
                && steps.is_multiple_of(observe_every)
            {
                let n = dims.n;
                let (r, v) = (&snapshot[..n], &snapshot[n..2 * n]);
                observing.evaluate(r, v, &mut track.outcome.observed);
            }
        }
        stopped
    }
}

/// Runs the paths `indices` of a study (at most the ensembles' number of paths) as one block:
/// every scheme at every level of `plan`, against the reference on the fine grid if given,
/// from (r0, v0), each path with the Brownian path of stream (seed, index). A path's numbers
/// do not depend on the block it runs in. Fails only if the plan's T is not finite and > 0 or
/// the block is larger than the ensembles; the schemes' failures are in the records.
pub fn run_block<S: System>(
    plan: &PathPlan, ensembles: &mut BlockEnsembles<S>, start: (&[f64], &[f64]), seed: u64,
    indices: &[usize],
) -> Result<Vec<PathRecord>, ModelError> {
    let records = run_block_until(plan, ensembles, start, seed, indices, &|| false)?;
    Ok(records.unwrap_or_default())
}

/// [`run_block`], abandoned between two chunks of fine steps once `abandon()` is true: `None`
/// then comes back and no path of the block is recorded (each path is whole or absent). A stop
/// thus takes effect within one chunk, whatever the block's length.
pub fn run_block_until<S: System>(
    plan: &PathPlan, ensembles: &mut BlockEnsembles<S>, start: (&[f64], &[f64]), seed: u64,
    indices: &[usize], abandon: &dyn Fn() -> bool,
) -> Result<Option<Vec<PathRecord>>, ModelError> {
    let noise = PathNoise::Pseudo { seed };
    run_block_with(plan, ensembles, start, noise, indices, abandon)
}

/// [`run_block_until`] with the Brownian paths of `noise`: each path's own pseudo-random
/// streams, or its point of a randomization of scrambled Sobol' points
/// ([`QuasiPaths`](crate::QuasiPaths)).
pub fn run_block_with<S: System>(
    plan: &PathPlan, ensembles: &mut BlockEnsembles<S>, start: (&[f64], &[f64]),
    noise: PathNoise<'_>, indices: &[usize], abandon: &dyn Fn() -> bool,
) -> Result<Option<Vec<PathRecord>>, ModelError> {
    let mut records: Vec<PathRecord> = indices.iter().map(|&i| PathRecord::empty(i)).collect();
    let BlockEnsembles {
        tracks,
        own_clock,
        reference,
        coarse_reference,
    } = ensembles;
    let Some(first) = tracks.first().or(reference.as_ref()) else {
        return Ok(Some(records));
    };
    let (paths, live) = (first.paths(), indices.len());
    if live > paths {
        return Err(ModelError::DimensionMismatch {
            what: "paths of a block (at most the ensembles' paths)",
            expected: paths,
            found: live,
        });
    }
    let dims = Dims::of(first.system(), plan.want_mu);
    let mut lockstep = Lockstep::new(plan, dims, paths, live, tracks.len())?;
    let (r0, v0) = start;
    for ensemble in tracks
        .iter_mut()
        .chain(reference.as_mut())
        .chain(coarse_reference.as_mut())
    {
        lockstep.restart(ensemble.as_mut(), r0, v0)?;
    }
    let mut states: Vec<Vec<Track>> = (0..tracks.len())
        .map(|_| (0..live).map(|_| Track::default()).collect())
        .collect();
    let mut noise: Box<dyn EnsembleNoise> = match noise {
        PathNoise::Pseudo { seed } => {
            // Lanes beyond the block's paths repeat its first path's stream (drawn, never used).
            let streams: Vec<u64> = (0..paths)
                .map(|p| indices.get(p).or(indices.first()).map_or(0, |&i| i as u64))
                .collect();
            Box::new(EnsembleIncrements::for_paths(seed, &streams, dims.l))
        }
        PathNoise::Quasi(quasi) => Box::new(quasi.block(indices, paths, dims.l, plan.fine)?),
    };
    let h_fine = plan.t_end / (1usize << plan.fine) as f64;
    let has_reference = reference.is_some();
    for _ in 0..(1usize << plan.fine) / lockstep.chunk {
        if abandon() {
            return Ok(None);
        }
        fill_pyramid(&mut lockstep.pyramid, noise.as_mut(), h_fine)?;
        if let Some(reference) = reference.as_deref_mut() {
            let references = References {
                fine: reference,
                coarse: coarse_reference.as_deref_mut(),
            };
            lockstep.run_reference(references, tracks, &mut records)?;
        }
        for (index, (ensemble, track)) in tracks.iter_mut().zip(&mut states).enumerate() {
            let level = plan.levels[index % plan.levels.len()];
            let clocks = Clocks {
                has_reference,
                own_clock: own_clock.get(index).copied().unwrap_or(false),
            };
            lockstep.level_chunk(ensemble.as_mut(), track, index, level, clocks);
        }
    }
    lockstep.finish_records(&mut records, tracks, &mut states, has_reference);
    Ok(Some(records))
}

/// The reference of a block and, where the plan pairs it, the same scheme at half its steps.
struct References<'a, S> {
    fine: &'a mut dyn PathEnsemble<System = S>,
    coarse: Option<&'a mut (dyn PathEnsemble<System = S> + 'static)>,
}

impl Lockstep<'_> {
    /// Restarts `ensemble` at (r0, v0) and stops its lanes beyond the block's paths (they stay
    /// idle).
    fn restart<S: System>(
        &self, ensemble: &mut dyn PathEnsemble<System = S>, r0: &[f64], v0: &[f64],
    ) -> Result<(), ModelError> {
        ensemble.restart(r0, v0)?;
        for p in self.live..self.paths {
            ensemble.stop(p)?;
        }
        Ok(())
    }

    /// Runs the reference (and its pair at half the steps) over the chunk and charges each
    /// path of the block its share of the time; a path whose reference (or pair) failed gets
    /// the failure in its record and is left out of the errors: its schemes (`tracks`) stop
    /// there.
    fn run_reference<S: System>(
        &mut self, references: References<'_, S>, tracks: &mut [BoxedEnsemble<S>],
        records: &mut [PathRecord],
    ) -> Result<(), ModelError> {
        let References { fine, mut coarse } = references;
        let clock = Instant::now();
        let mut failed = self.reference_chunk(fine);
        let mut failed_coarse = Vec::new();
        if let Some(coarse) = coarse.as_deref_mut() {
            failed_coarse = self.coarse_reference_chunk(coarse);
        }
        let seconds = clock.elapsed().as_secs_f64() / self.live as f64;
        for record in records.iter_mut() {
            record.reference_seconds += seconds;
        }
        failed.extend(&failed_coarse);
        for p in failed {
            if !self.dropped[p] {
                let fine_failure = fine.failure(p)?;
                let failure = match (fine_failure, coarse.as_deref()) {
                    (None, Some(c)) => c.failure(p)?,
                    (f, _) => f,
                };
                records[p].reference_failure = failure.map(|f| f.kind());
                self.dropped[p] = true;
                for ensemble in tracks.iter_mut() {
                    ensemble.stop(p)?;
                }
            }
        }
        Ok(())
    }

    /// At the end of the block: fills in the record of every path whose reference finished,
    /// its observed values and the outcome of each track (`states`, one per ensemble).
    fn finish_records<S: System>(
        &mut self, records: &mut [PathRecord], tracks: &[BoxedEnsemble<S>],
        states: &mut [Vec<Track>], has_reference: bool,
    ) {
        for (p, record) in records.iter_mut().enumerate() {
            if record.reference_failure.is_some() {
                continue;
            }
            record.reference_observed = std::mem::take(&mut self.reference_observed[p]);
            record.reference_coarse_observed =
                std::mem::take(&mut self.reference_coarse_observed[p]);
            record.tracks = tracks
                .iter()
                .zip(states.iter_mut())
                .map(|(ensemble, track)| {
                    let diagnostics = ensemble.diagnostics(p).expect("p is a path of the block");
                    let averaging = self.plan.time_averaged.is_some();
                    std::mem::take(&mut track[p]).finish(&diagnostics, has_reference, averaging)
                })
                .collect();
        }
    }
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
