//! Many paths of one scheme stepped W at a time in SIMD lanes: [`LaneEnsemble`], [`LanePaths`].

use std::mem::take;

use pulp::Simd;
use sdae_lanes::{LANE_BLOCK, LaneMask, LaneWidth, Lanes, LineVec};
use sdae_manifold::Constraint;

use crate::diagnostics::PathDiagnostics;
use crate::ensemble::{PathEnsemble, check_initial_state, check_path, for_each_row};
use crate::error::{ModelError, StepFailure, check_dim, check_step_size, try_filled, try_lines};
use crate::lane_diagnostics::{DiagnosticsColumns, LaneRecord};
use crate::scheme::Scheme;
use crate::system::System;

/// A [`Scheme`] that may step many paths at once: [`LaneEnsemble`] calls
/// [`LaneScheme::step_lanes`] for every step, and steps every path through [`Scheme::step`]
/// where it returns `false`.
pub trait LaneScheme: Scheme {
    /// Steps every path of `paths` that goes on by h with the increments `dw` (layout of
    /// [`PathEnsemble::step`]) with the instruction set of `width`, usually through
    /// [`LanePaths::step_groups`]; returns `false`, having changed nothing, where this scheme
    /// has no lane form for its system.
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool;
}

impl<T: LaneScheme + ?Sized> LaneScheme for Box<T> {
    #[inline]
    fn step_lanes(&mut self, paths: &mut LanePaths, width: LaneWidth, h: f64, dw: &[f64]) -> bool {
        (**self).step_lanes(paths, width, h, dw)
    }
}

/// The state of P paths in structure-of-arrays layout, block by block of [`LANE_BLOCK`] paths
/// (coordinate i of path p at `(p / LANE_BLOCK) * n * LANE_BLOCK + i * LANE_BLOCK + p %
/// LANE_BLOCK`: a block's n rows
/// of LANE_BLOCK lanes are contiguous, so that a group of W = LANE_BLOCK lanes is stepped where
/// it lies), with each path's mu (seed eq. 1.4, constraint j of path p at `j * stride + p`,
/// stride = [`lane_stride`](sdae_lanes::lane_stride)`(P)`), [`PathDiagnostics`] and, once a step has failed, its
/// [`StepFailure`].
#[derive(Debug, Clone)]
pub struct LanePaths {
    paths: usize,
    stride: usize,
    /// Positions, block by block.
    r: LineVec<f64>,
    /// Velocities, block by block.
    v: LineVec<f64>,
    /// mu, constraint j of path p at `j * stride + p`.
    mu: LineVec<f64>,
    /// 1 for a path that goes on, 0 for a stopped path or a padding lane.
    alive: LineVec<f64>,
    failures: Vec<Option<StepFailure>>,
    /// How many of `failures` are `Some`.
    failed: usize,
    diagnostics: DiagnosticsColumns,
    /// Path-steps taken by the scalar step.
    scalar_steps: usize,
    /// One path's r, v and dw for the scalar step.
    lane_r: Vec<f64>,
    lane_v: Vec<f64>,
    lane_dw: Vec<f64>,
}

/// What a lane form computed for the W lanes of one group ([`LanePaths::step_groups`]) of a
/// system with one constraint: the lanes it decided (`ok`), their (r, v) after the step, the
/// increment of mu and what each lane's step outcome adds to its diagnostics.
pub struct LaneStep<Sd: Simd, const N: usize> {
    /// The lanes whose step the lane form decided; the others go through the scalar step.
    pub ok: LaneMask<Sd>,
    /// r_{k+1}.
    pub r: [Lanes<Sd>; N],
    /// v_{k+1}.
    pub v: [Lanes<Sd>; N],
    /// mu_{k+1} - mu_k.
    pub dmu: Lanes<Sd>,
    /// What each decided lane's step adds to its path's diagnostics.
    pub record: LaneRecord<Sd>,
}

/// The lane form of a scheme's step for systems of N coordinates and one constraint
/// ([`LanePaths::step_groups`]).
pub trait LaneKernel<Sch: ?Sized, const N: usize> {
    /// The step of W lanes from (r, v) with increments dw (l of them); `None` if this group
    /// must go through the scalar step (say, the system has no lane form). Implementations
    /// should be `#[inline(always)]`, so that they compile with the instruction set of `Sd`.
    fn step<Sd: Simd>(
        &self, scheme: &Sch, r: &[Lanes<Sd>; N], v: &[Lanes<Sd>; N], dw: &[Lanes<Sd>],
    ) -> Option<LaneStep<Sd, N>>;
}

impl LanePaths {
    /// `paths` >= 1 paths of a system with n coordinates, m constraints and noise dimension
    /// l, each at (r0, v0) with mu = 0.
    pub fn new<S: System>(
        system: &S, paths: usize, r0: &[f64], v0: &[f64],
    ) -> Result<Self, ModelError> {
        if paths == 0 {
            return Err(ModelError::InvalidSetting {
                name: "paths",
                value: 0.0,
                reason: "an ensemble needs at least one path",
            });
        }
        let c = system.constraint();
        let (n, m, l) = (c.dim(), c.n_constraints(), system.noise_dim());
        let stride = paths
            .checked_next_multiple_of(LANE_BLOCK)
            .ok_or(ModelError::Allocation {
                what: "the lanes of the paths",
                len: usize::MAX,
                entry_bytes: std::mem::size_of::<f64>(),
            })?;
        let mut state = Self {
            paths,
            stride,
            r: try_lines("the lanes' positions", 0.0, n, stride)?,
            v: try_lines("the lanes' velocities", 0.0, n, stride)?,
            mu: try_lines("the lanes' multipliers", 0.0, m, stride)?,
            alive: try_lines("the lanes' flags", 0.0, 1, stride)?,
            failures: try_filled("the paths' failures", None, paths, 1)?,
            failed: 0,
            diagnostics: DiagnosticsColumns::new(stride)?,
            scalar_steps: 0,
            lane_r: vec![0.0; n],
            lane_v: vec![0.0; n],
            lane_dw: vec![0.0; l],
        };
        state.restart(r0, v0)?;
        Ok(state)
    }

    /// The number P of paths.
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// The stride of the layout, [`lane_stride`](sdae_lanes::lane_stride)`(P)`.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Where coordinate 0 of path (or lane) p lies in the positions and the velocities: in
    /// block p / LANE_BLOCK of n rows, at lane p % LANE_BLOCK.
    fn lane_base(&self, p: usize) -> usize {
        (p / LANE_BLOCK) * self.lane_r.len() * LANE_BLOCK + p % LANE_BLOCK
    }

    /// The noise dimension l.
    pub fn noise_dim(&self) -> usize {
        self.lane_dw.len()
    }

    /// How many path-steps went through the scalar step.
    pub fn scalar_steps(&self) -> usize {
        self.scalar_steps
    }

    /// How many paths have stopped on a failed step.
    pub fn failed_paths(&self) -> usize {
        self.failed
    }

    /// Puts every path at (r0, v0) with mu = 0, fresh diagnostics and no failure.
    fn restart(&mut self, r0: &[f64], v0: &[f64]) -> Result<(), ModelError> {
        let n = self.lane_r.len();
        check_dim("initial position", n, r0.len())?;
        check_dim("initial velocity", n, v0.len())?;
        // Padding lanes hold the initial state too, so that they compute finite numbers.
        let block = n * LANE_BLOCK;
        for (r, v) in self
            .r
            .chunks_exact_mut(block)
            .zip(self.v.chunks_exact_mut(block))
        {
            for i in 0..n {
                r[i * LANE_BLOCK..(i + 1) * LANE_BLOCK].fill(r0[i]);
                v[i * LANE_BLOCK..(i + 1) * LANE_BLOCK].fill(v0[i]);
            }
        }
        self.mu.fill(0.0);
        self.alive.fill(0.0);
        self.alive[..self.paths].fill(1.0);
        self.failures.fill(None);
        self.failed = 0;
        self.diagnostics.reset();
        Ok(())
    }

    /// Sets path p to (r, v) and lets it go on (mu and diagnostics go on from where they were).
    fn set_state(&mut self, p: usize, r: &[f64], v: &[f64]) -> Result<(), ModelError> {
        check_path(p, self.paths)?;
        check_dim("position", self.lane_r.len(), r.len())?;
        check_dim("velocity", self.lane_v.len(), v.len())?;
        let base = self.lane_base(p);
        scatter(&mut self.r, LANE_BLOCK, base, r);
        scatter(&mut self.v, LANE_BLOCK, base, v);
        self.alive[p] = 1.0;
        if self.failures[p].take().is_some() {
            self.failed -= 1;
        }
        Ok(())
    }

    /// Path p's step through the scalar step of `scheme` (nothing if the path has stopped):
    /// its (r, v), mu and diagnostics as [`PathState::step`](crate::PathState::step) updates
    /// them, or its failure.
    pub fn step_one<Sch: Scheme + ?Sized>(
        &mut self, scheme: &mut Sch, p: usize, h: f64, dw: &[f64],
    ) {
        if self.alive[p] == 0.0 {
            return;
        }
        self.scalar_steps += 1;
        let base = self.lane_base(p);
        gather(&self.r, LANE_BLOCK, base, &mut self.lane_r);
        gather(&self.v, LANE_BLOCK, base, &mut self.lane_v);
        gather(dw, self.stride, p, &mut self.lane_dw);
        match scheme.step(&mut self.lane_r, &mut self.lane_v, h, &self.lane_dw) {
            Ok(outcome) => {
                scatter(&mut self.r, LANE_BLOCK, base, &self.lane_r);
                scatter(&mut self.v, LANE_BLOCK, base, &self.lane_v);
                for (j, d) in scheme.multiplier_increment().iter().enumerate() {
                    self.mu[j * self.stride + p] += d;
                }
                self.diagnostics.record(p, &outcome, h);
            }
            Err(failure) => {
                self.alive[p] = 0.0;
                self.failures[p] = Some(failure.blaming_increment(&self.lane_dw));
                self.failed += 1;
            }
        }
    }

    /// Steps every path that goes on, W = `Sd::F64_LANES` lanes at a time, for a system of N
    /// coordinates with one constraint: `kernel` computes a group's step from its r_k, v_k and
    /// increments (l of them); the lanes it decides take its (r, v), mu + dmu and outcome, the
    /// others (and all of a group for which it returns `None`) go through the scalar step.
    /// Returns `false`, having changed nothing, unless the system has N coordinates, one
    /// constraint and at most N noise components.
    #[inline(always)]
    pub fn step_groups<Sch, Sd, const N: usize, K>(
        &mut self, simd: Sd, scheme: &mut Sch, input: StepInput<'_>, kernel: &K,
    ) -> bool
    where
        Sch: Scheme + ?Sized,
        Sd: Simd,
        K: LaneKernel<Sch, N>,
    {
        let (stride, l) = (self.stride, self.lane_dw.len());
        let StepInput { h, dw } = input;
        if self.lane_r.len() != N || self.mu.len() != stride || l > N {
            return false;
        }
        let width = Sd::F64_LANES;
        for offset in (0..stride).step_by(width) {
            let alive = Lanes::load(simd, &self.alive[offset..]);
            let alive = alive.eq(alive.splat_like(1.0));
            let base = self.lane_base(offset);
            let r: [Lanes<Sd>; N] = load_rows(simd, &self.r, LANE_BLOCK, base, N);
            let v: [Lanes<Sd>; N] = load_rows(simd, &self.v, LANE_BLOCK, base, N);
            let noise: [Lanes<Sd>; N] = load_rows(simd, dw, stride, offset, l);
            let Some(step) = kernel.step(scheme, &r, &v, &noise[..l]) else {
                for p in offset..(offset + width).min(self.paths) {
                    self.step_one(scheme, p, h, dw);
                }
                continue;
            };
            let done = step.ok.and(alive);
            for i in 0..N {
                let row = base + i * LANE_BLOCK;
                Lanes::select(done, step.r[i], r[i]).store(&mut self.r[row..]);
                Lanes::select(done, step.v[i], v[i]).store(&mut self.v[row..]);
            }
            let mu = Lanes::load(simd, &self.mu[offset..]);
            Lanes::select(done, mu + step.dmu, mu).store(&mut self.mu[offset..]);
            self.finish_group(scheme, input, offset, Decided { alive, done }, &step.record);
        }
        true
    }

    /// Steps every path that goes on, W = `Sd::F64_LANES` lanes at a time, for a system of any
    /// size: `kernel` computes a group's step from its r_k and v_k (read where they lie when
    /// the group is a whole block, W = [`LANE_BLOCK`], else copied) and its increments (read
    /// where they lie when the ensemble is one group, stride = W, else copied), and leaves
    /// r_{k+1}, v_{k+1} and mu_{k+1} - mu_k in `rows`; the lanes it decides take them and
    /// their outcome, the others (and all of a group for which it returns `None`) go through
    /// the scalar step from r_k and v_k. `rows` must have the system's n, m and l
    /// ([`LaneRows::new`]); a group without a path that goes on is skipped.
    #[inline(always)]
    pub fn step_wide_groups<Sch, Sd, K>(
        &mut self, scheme: &mut Sch, input: StepInput<'_>, kernel: &mut K, rows: &mut LaneRows<Sd>,
    ) where
        Sch: Scheme + ?Sized,
        Sd: Simd,
        K: WideKernel<Sch, Sd>,
    {
        let stride = self.stride;
        let StepInput { h, dw } = input;
        let simd = rows.simd;
        // With one group, the increments' rows lie as the kernel reads them.
        let whole_increments = if stride == Sd::F64_LANES {
            Lanes::rows(simd, dw)
        } else {
            None
        };
        for offset in (0..stride).step_by(Sd::F64_LANES) {
            let alive = Lanes::load(simd, &self.alive[offset..]);
            let alive = alive.eq(alive.splat_like(1.0));
            if (!alive).all() {
                continue;
            }
            let mut dw_copy = take(&mut rows.dw);
            let increments = match whole_increments {
                Some(rows) => rows,
                None => {
                    load_into(&mut dw_copy, dw, stride, offset);
                    &dw_copy[..]
                }
            };
            let base = self.lane_base(offset);
            // r_k and v_k where they lie if the group is a whole block, else copied.
            let (mut r_copy, mut v_copy) = (take(&mut rows.r_copy), take(&mut rows.v_copy));
            let whole_block = if Sd::F64_LANES == LANE_BLOCK {
                let block = base..base + r_copy.len() * LANE_BLOCK;
                Lanes::rows(simd, &self.r[block.clone()]).zip(Lanes::rows(simd, &self.v[block]))
            } else {
                None
            };
            let state = match whole_block {
                Some(state) => state,
                None => {
                    load_into(&mut r_copy, &self.r, LANE_BLOCK, base);
                    load_into(&mut v_copy, &self.v, LANE_BLOCK, base);
                    (&r_copy[..], &v_copy[..])
                }
            };
            let state = GroupState {
                r: state.0,
                v: state.1,
                dw: increments,
                group: offset / Sd::F64_LANES,
                alive,
            };
            let stepped = kernel.step(scheme, state, rows);
            (rows.r_copy, rows.v_copy, rows.dw) = (r_copy, v_copy, dw_copy);
            let Some((ok, record)) = stepped else {
                for p in offset..(offset + Sd::F64_LANES).min(self.paths) {
                    self.step_one(scheme, p, h, dw);
                }
                continue;
            };
            let done = ok.and(alive);
            store_selected(done, &rows.r, &mut self.r, LANE_BLOCK, base);
            store_selected(done, &rows.v, &mut self.v, LANE_BLOCK, base);
            for (j, dmu) in rows.dmu.iter_mut().enumerate() {
                *dmu = *dmu + Lanes::load(simd, &self.mu[j * stride + offset..]);
            }
            store_selected(done, &rows.dmu, &mut self.mu, stride, offset);
            self.finish_group(scheme, input, offset, Decided { alive, done }, &record);
        }
    }

    /// The diagnostics of a group's decided lanes (`done`) and the scalar step of its other
    /// lanes that go on (`alive`).
    #[inline(always)]
    fn finish_group<Sch, Sd>(
        &mut self, scheme: &mut Sch, input: StepInput<'_>, offset: usize, lanes: Decided<Sd>,
        record: &LaneRecord<Sd>,
    ) where
        Sch: Scheme + ?Sized,
        Sd: Simd,
    {
        let (StepInput { h, dw }, Decided { alive, done }) = (input, lanes);
        self.diagnostics.record_lanes(offset, done, record, h);
        let undecided = alive.and(!done);
        if (!undecided).all() {
            return;
        }
        for lane in 0..Sd::F64_LANES {
            if undecided.lane(lane) {
                self.step_one(scheme, offset + lane, h, dw);
            }
        }
    }
}

/// One group's W lanes of a system of any size ([`LanePaths::step_wide_groups`]): the
/// increments of the step, and r, v and the increment of mu after it (r_k and v_k are the
/// kernel's input, where they lie in the ensemble's state when they can be).
#[derive(Debug, Clone)]
pub struct LaneRows<Sd: Simd> {
    simd: Sd,
    /// r_{k+1} (n rows).
    pub r: LineVec<Lanes<Sd>>,
    /// v_{k+1} (n rows).
    pub v: LineVec<Lanes<Sd>>,
    /// The increments dw (l rows), copied for a group of an ensemble of several groups.
    dw: LineVec<Lanes<Sd>>,
    /// mu_{k+1} - mu_k (m rows).
    pub dmu: LineVec<Lanes<Sd>>,
    /// r_k and v_k copied, for a group narrower than a block.
    r_copy: LineVec<Lanes<Sd>>,
    v_copy: LineVec<Lanes<Sd>>,
}

impl<Sd: Simd> LaneRows<Sd> {
    /// Rows for a system with n coordinates, m constraints and l noise components.
    pub fn new(simd: Sd, n: usize, m: usize, l: usize) -> Self {
        let zero = Lanes::splat(simd, 0.0);
        Self {
            simd,
            r: LineVec::from_elem(zero, n),
            v: LineVec::from_elem(zero, n),
            dw: LineVec::from_elem(zero, l),
            dmu: LineVec::from_elem(zero, m),
            r_copy: LineVec::from_elem(zero, n),
            v_copy: LineVec::from_elem(zero, n),
        }
    }

    /// The instruction set.
    pub fn simd(&self) -> Sd {
        self.simd
    }
}

/// The lane form of a scheme's step for systems of any size ([`LanePaths::step_wide_groups`]),
/// with buffers of its own for the instruction set `Sd`.
pub trait WideKernel<Sch: ?Sized, Sd: Simd> {
    /// The step of W lanes from `state` = (r_k, v_k, dw) into `rows` (r_{k+1}, v_{k+1} and
    /// the increment of mu) for the lanes it decides, which it returns
    /// with what their steps add to their diagnostics; `None` if this group must go through
    /// the scalar step. `state` is left as it is: a lane the kernel does not decide steps
    /// again from it through the scalar step.
    fn step(
        &mut self, scheme: &Sch, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)>;
}

/// A group's r_k, v_k and increments dw, a row of W lanes per coordinate ([`WideKernel::step`]).
#[derive(Clone, Copy)]
pub struct GroupState<'a, Sd: Simd> {
    /// r_k, n rows.
    pub r: &'a [Lanes<Sd>],
    /// v_k, n rows.
    pub v: &'a [Lanes<Sd>],
    /// The increments, l rows.
    pub dw: &'a [Lanes<Sd>],
    /// The group's index in the ensemble (its paths are W * group .. W * (group + 1)): a
    /// kernel may keep what it computed for the group's next step.
    pub group: usize,
    /// The lanes whose paths go on: only their r_{k+1} and v_{k+1} are stored.
    pub alive: LaneMask<Sd>,
}

/// One ensemble step's size h and the Brownian increments dw of every path (coordinate j of
/// path p at `j * stride + p`, [`lane_stride`](sdae_lanes::lane_stride)).
#[derive(Debug, Clone, Copy)]
pub struct StepInput<'a> {
    /// The step size h.
    pub h: f64,
    /// The increments, l rows of the ensemble's stride.
    pub dw: &'a [f64],
}

/// The lanes of a group whose paths go on (`alive`) and those the kernel decided (`done`).
#[derive(Clone, Copy)]
struct Decided<Sd: Simd> {
    alive: LaneMask<Sd>,
    done: LaneMask<Sd>,
}

/// Buffers of a lane form kept between steps whatever their instruction set (the set is chosen
/// at run time; one scheme keeps one set of buffers). A clone starts empty.
#[derive(Default)]
pub struct LaneStore(Option<Box<dyn std::any::Any + Send + Sync>>);

impl LaneStore {
    /// The buffers kept, if they have type T; the store is left empty until
    /// [`LaneStore::put`].
    pub fn take<T: std::any::Any + Send + Sync>(&mut self) -> Option<Box<T>> {
        self.0.take()?.downcast::<T>().ok()
    }

    /// Keeps `buffers` for the next step (the box taken back, so that a step allocates
    /// nothing).
    pub fn put<T: std::any::Any + Send + Sync>(&mut self, buffers: Box<T>) {
        self.0 = Some(buffers);
    }
}

impl Clone for LaneStore {
    fn clone(&self) -> Self {
        Self(None)
    }
}

impl std::fmt::Debug for LaneStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "LaneStore(buffers)"
        } else {
            "LaneStore(empty)"
        })
    }
}

/// P paths of a [`LaneScheme`], stepped in SIMD lanes where it has a lane form.
///
/// Many paths of one scheme in structure-of-arrays layout ([`LanePaths`]), stepped W at a time
/// in SIMD lanes where the scheme has a lane form ([`LaneScheme`]) and one at a time through
/// its scalar [`Scheme::step`] where it has none ([`LaneEnsemble`]).
///
/// A lane form computes, lane by lane, exactly what the scalar step computes for that path
/// alone; a lane it does not decide (a failure, a case outside its closed form) finishes its
/// step through the scalar step, which reports the failure as for one path. So a path's
/// numbers do not depend on W, on the other paths or on how paths are grouped.
///
/// ```
/// use sdae_lanes::LaneWidth;
/// use sdae_manifold::{IdentityMass, Sphere};
/// use sdae_model::engine::LanePaths;
/// use sdae_model::{
///     LaneEnsemble, LaneScheme, MechanicalSystem, NoNoise, PathEnsemble, Scheme, StepFailure,
///     StepOutcome, StepResult, ZeroDrift,
/// };
///
/// // A scheme without a lane form: every path steps through `step`.
/// type Circle = MechanicalSystem<Sphere, IdentityMass, ZeroDrift, NoNoise>;
/// struct Drift(Circle);
/// impl Scheme for Drift {
///     type System = Circle;
///     fn system(&self) -> &Circle {
///         &self.0
///     }
///     fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, _dw: &[f64])
///         -> StepResult {
///         r[0] += h * v[0];
///         r[1] += h * v[1];
///         Ok(StepOutcome::PLAIN)
///     }
///     fn multiplier_increment(&self) -> &[f64] {
///         &[0.5]
///     }
/// }
/// impl LaneScheme for Drift {
///     fn step_lanes(&mut self, _: &mut LanePaths, _: LaneWidth, _: f64, _: &[f64]) -> bool {
///         false
///     }
/// }
///
/// let system = MechanicalSystem::new(Sphere::new(2, 1.0)?, IdentityMass, ZeroDrift, NoNoise)?;
/// let mut paths = LaneEnsemble::new(Drift(system), 5, &[1.0, 0.0], &[0.0, 1.0])?;
/// for _ in 0..10 {
///     paths.step(0.1, &[])?;
/// }
/// let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
/// paths.state(4, &mut r, &mut v, &mut mu)?;
/// assert!((r[1] - 1.0).abs() < 1e-12 && mu[0] == 5.0 && paths.scalar_steps() == 50);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct LaneEnsemble<Sch: LaneScheme> {
    scheme: Sch,
    paths: LanePaths,
    /// The instruction set the steps run with.
    width: LaneWidth,
}

impl<Sch: LaneScheme> LaneEnsemble<Sch> {
    /// `paths` >= 1 paths of `scheme`, each starting at (r0, v0) ([`check_initial_state`]).
    pub fn new(scheme: Sch, paths: usize, r0: &[f64], v0: &[f64]) -> Result<Self, ModelError> {
        check_initial_state(scheme.system(), r0, v0)?;
        let paths = LanePaths::new(scheme.system(), paths, r0, v0)?;
        Ok(Self {
            scheme,
            paths,
            width: LaneWidth::Best,
        })
    }

    /// The same ensemble stepping with the instruction set of `width` (default
    /// [`LaneWidth::Best`]); the numbers do not depend on it.
    pub fn with_width(mut self, width: LaneWidth) -> Self {
        self.width = width;
        self
    }

    /// Steps from now on with the instruction set of `width`.
    pub fn set_width(&mut self, width: LaneWidth) {
        self.width = width;
    }

    /// The scheme (system and constants).
    pub fn scheme(&self) -> &Sch {
        &self.scheme
    }

    /// How many path-steps went through the scalar step (all of them for a scheme or system
    /// without a lane form, else the steps the lane form did not decide).
    pub fn scalar_steps(&self) -> usize {
        self.paths.scalar_steps
    }
}

impl<Sch: LaneScheme> PathEnsemble for LaneEnsemble<Sch> {
    type System = Sch::System;

    fn system(&self) -> &Self::System {
        self.scheme.system()
    }

    fn paths(&self) -> usize {
        self.paths.paths
    }

    fn stride(&self) -> usize {
        self.paths.stride
    }

    fn restart(&mut self, r0: &[f64], v0: &[f64]) -> Result<(), ModelError> {
        check_initial_state(self.scheme.system(), r0, v0)?;
        self.paths.restart(r0, v0)
    }

    fn set_state(&mut self, p: usize, r: &[f64], v: &[f64]) -> Result<(), ModelError> {
        self.paths.set_state(p, r, v)
    }

    /// A path whose step fails keeps its state and stops; the failure is kept
    /// ([`PathEnsemble::failure`]) and the other paths go on.
    fn step(&mut self, h: f64, dw: &[f64]) -> Result<usize, ModelError> {
        check_step_size(h)?;
        let paths = &mut self.paths;
        check_dim(
            "increments (l * stride)",
            paths.noise_dim() * paths.stride,
            dw.len(),
        )?;
        let before = paths.failed_paths();
        if !self.scheme.step_lanes(paths, self.width, h, dw) {
            for p in 0..paths.paths {
                paths.step_one(&mut self.scheme, p, h, dw);
            }
        }
        Ok(paths.failed_paths() - before)
    }

    fn state(
        &self, p: usize, r: &mut [f64], v: &mut [f64], mu: &mut [f64],
    ) -> Result<(), ModelError> {
        let paths = &self.paths;
        check_path(p, paths.paths)?;
        check_dim("position", paths.lane_r.len(), r.len())?;
        check_dim("velocity", paths.lane_v.len(), v.len())?;
        let base = paths.lane_base(p);
        gather(&paths.r, LANE_BLOCK, base, r);
        gather(&paths.v, LANE_BLOCK, base, v);
        if !mu.is_empty() {
            check_dim("multiplier", paths.mu.len() / paths.stride, mu.len())?;
            gather(&paths.mu, paths.stride, p, mu);
        }
        Ok(())
    }

    /// Reads the rows straight from the lanes: one check for the block, then a strided copy
    /// per path.
    fn read_rows(
        &self, paths: &[usize], mu_len: usize, rows: &mut [f64],
    ) -> Result<(), ModelError> {
        let lanes = &self.paths;
        if mu_len != 0 {
            check_dim("multiplier", lanes.mu.len() / lanes.stride, mu_len)?;
        }
        if let Some(&p) = paths.iter().find(|&&p| p >= lanes.paths) {
            check_path(p, lanes.paths)?;
        }
        let n = lanes.lane_r.len();
        for_each_row(paths, n, mu_len, rows, |p, r, v, mu| {
            let base = lanes.lane_base(p);
            gather(&lanes.r, LANE_BLOCK, base, r);
            gather(&lanes.v, LANE_BLOCK, base, v);
            gather(&lanes.mu, lanes.stride, p, mu);
            Ok(())
        })
    }

    fn diagnostics(&self, p: usize) -> Result<PathDiagnostics, ModelError> {
        check_path(p, self.paths.paths)?;
        Ok(self.paths.diagnostics.get(p))
    }

    fn failure(&self, p: usize) -> Result<Option<&StepFailure>, ModelError> {
        check_path(p, self.paths.paths)?;
        Ok(self.paths.failures[p].as_ref())
    }

    fn stop(&mut self, p: usize) -> Result<(), ModelError> {
        check_path(p, self.paths.paths)?;
        self.paths.alive[p] = 0.0;
        Ok(())
    }

    fn failed_paths(&self) -> usize {
        self.paths.failed_paths()
    }
}

/// out[i] = from[i * stride + p].
#[inline(always)]
fn gather(from: &[f64], stride: usize, p: usize, out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = from[i * stride + p];
    }
}

/// to[i * stride + p] = values[i].
fn scatter(to: &mut [f64], stride: usize, p: usize, values: &[f64]) {
    for (i, x) in values.iter().enumerate() {
        to[i * stride + p] = *x;
    }
}

/// rows[i] = the W paths from `offset` of row i of `from`.
#[inline(always)]
fn load_into<Sd: Simd>(rows: &mut [Lanes<Sd>], from: &[f64], stride: usize, offset: usize) {
    for (i, row) in rows.iter_mut().enumerate() {
        *row = Lanes::load(row.simd(), &from[i * stride + offset..]);
    }
}

/// A lane's values as plain f64 (the first W entries).
#[inline(always)]
fn lane_values<Sd: Simd>(x: Lanes<Sd>) -> [f64; LANE_BLOCK] {
    let mut values = [0.0; LANE_BLOCK];
    x.store(&mut values);
    values
}

/// The lanes of a mask as booleans (the first W entries).
#[inline(always)]
fn mask_values<Sd: Simd>(mask: LaneMask<Sd>) -> [bool; LANE_BLOCK] {
    let one = Lanes::splat(mask.simd(), 1.0);
    lane_values(Lanes::select(mask, one, one.splat_like(0.0))).map(|x| x == 1.0)
}

/// Row i of `to` from `offset` = rows[i] where `done`, unchanged elsewhere: whole rows where
/// every lane is done (the common case; a select and store would compile to a masked store,
/// slow on some processors), else the done lanes one by one.
#[inline(always)]
fn store_selected<Sd: Simd>(
    done: LaneMask<Sd>, rows: &[Lanes<Sd>], to: &mut [f64], stride: usize, offset: usize,
) {
    if done.all() {
        for (i, row) in rows.iter().enumerate() {
            row.store(&mut to[i * stride + offset..]);
        }
        return;
    }
    let done = mask_values(done);
    for (i, row) in rows.iter().enumerate() {
        let values = lane_values(*row);
        for (lane, value) in values.iter().enumerate().take(Sd::F64_LANES) {
            if done[lane] {
                to[i * stride + offset + lane] = *value;
            }
        }
    }
}

/// Loads coordinate i < `rows` of the W paths from `offset` of each coordinate's row (zero
/// beyond `rows`).
#[inline(always)]
fn load_rows<Sd: Simd, const N: usize>(
    simd: Sd, from: &[f64], stride: usize, offset: usize, rows: usize,
) -> [Lanes<Sd>; N] {
    let mut out = [Lanes::splat(simd, 0.0); N];
    for (i, o) in out.iter_mut().enumerate().take(rows) {
        *o = Lanes::load(simd, &from[i * stride + offset..]);
    }
    out
}
