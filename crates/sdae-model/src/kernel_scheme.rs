//! A scheme written once over the number type: [`KernelScheme::step`] over any [`Real`] `T`
//! runs for one path (`T = f64`) and for W paths in SIMD lanes (`Lanes<S>`) with the same
//! operations, so that [`Kernelized`] makes of it both a [`Scheme`] (path by path) and a
//! [`LaneScheme`] (an ensemble in lanes, [`LaneEnsemble`](crate::LaneEnsemble)) whose paths are
//! the one-path paths bit for bit, whatever the width.
//!
//! The step reaches the system and the constraint through a [`StepKernel`]: the drift, the
//! noise, M^-1, and the constrained update of seed eq. 3.1 from any point y and free velocity
//! v~ ([`StepKernel::constrain`]): the kappa root r' = y + M^-1 grad g(r) kappa on g = 0 and
//! v' = v~ + M^-1 grad g(r) lambda with Dg(r') v' = 0. One path solves it with the ball solver
//! (any constraint and mass, the homotopy fallback, typed errors); lanes with the closed form
//! of a sphere or Newton over the constraint's lane formulas (a diagonal mass), and a lane
//! they do not decide steps through the one-path step.
//!
//! `crates/sdae-study/examples/custom_scheme.rs` writes a symplectic Euler step this way.

use pulp::Simd;
use sdae_ift::{BallSolver, Certificate, SolverSettings};
use sdae_lanes::{Lanes, Real};
use sdae_manifold::vector::{max_abs, norm2_squared};
use sdae_manifold::{Constraint, Mass, scratch_len};

use crate::constrained::{UpdateBuffers, constrained_update};
use crate::error::{FailureKind, StepFailure};
use crate::lane_diagnostics::LaneRecord;
use crate::lane_ensemble::LaneStore;
use crate::scheme::{Scheme, StepOutcome, StepResult};
use crate::system::{System, check_dimensions, check_step_input};

/// What a [`KernelScheme`]'s step calls on its paths: one path (`T = f64`) or W lanes.
pub trait StepKernel<T: Real> {
    /// `x` in every path, of the kind of the step's numbers.
    fn splat(&self, x: f64) -> T;
    /// out = a(r, v).
    fn drift(&mut self, r: &[T], v: &[T], out: &mut [T]);
    /// out += B(r, v) dw.
    fn add_noise(&mut self, r: &[T], v: &[T], dw: &[T], out: &mut [T]);
    /// x <- M^-1 x.
    fn apply_inverse_mass(&self, x: &mut [T]);
    /// out = v + M^-1 (tau a(r, v) + B(r, v) dw): the free velocity v~ of seed eq. 3.1 (tau =
    /// eta h), from the drift's product with tau, the noise, M^-1 and v in that order.
    #[inline(always)]
    fn free_velocity(&mut self, r: &[T], v: &[T], dw: &[T], tau: T, out: &mut [T]) {
        self.drift(r, v, out);
        for f in out.iter_mut() {
            *f = tau * *f;
        }
        self.add_noise(r, v, dw, out);
        self.apply_inverse_mass(out);
        for (f, vi) in out.iter_mut().zip(v) {
            *f = *f + *vi;
        }
    }
    /// The constrained update of seed eq. 3.1 from r, a point y and the free velocity v~ (in
    /// `velocity`): r' = y + M^-1 grad g(r) kappa with g(r') = 0 (the kappa root connected to
    /// 0, in the ball of the scheme's radius, [`KernelScheme::solver`]) into `next_r`, and
    /// v' = v~ + M^-1 grad g(r) lambda with Dg(r') v' = 0 in place of v~, lambda into
    /// `multiplier`. One path: a failure where the root is not found or v' is not finite.
    fn constrain(
        &mut self, r: &[T], y: &[T], velocity: &mut [T], next_r: &mut [T], multiplier: &mut [T],
    ) -> Result<Constrained<T>, StepFailure>;
    /// The paths whose `x` is finite; one path: a failure naming `what` where it is not.
    fn check_finite(&self, what: &'static str, x: &[T]) -> Result<T::Mask, StepFailure>;
}

/// What [`StepKernel::constrain`] found, per path.
#[derive(Debug, Clone, Copy)]
pub struct Constrained<T: Real> {
    /// The paths it decided (always, for one path).
    pub ok: T::Mask,
    /// Newton iterations of the kappa root (0 in closed form).
    pub newton_iterations: T,
    /// |g(r')|.
    pub position_residual: T,
    /// The certificate's contraction estimate (NaN without probes).
    pub contraction: T,
    /// |kappa|.
    pub kappa_norm: T,
}

/// A group's r_k, v_k and increments dw (one path, or a row of W lanes per coordinate).
#[derive(Clone, Copy)]
pub struct KernelState<'a, T> {
    /// r_k, n entries.
    pub r: &'a [T],
    /// v_k, n entries.
    pub v: &'a [T],
    /// dw, l entries.
    pub dw: &'a [T],
}

/// Where a step leaves r_{k+1}, v_{k+1} and mu_{k+1} - mu_k, with n entries of scratch.
pub struct KernelNext<'a, T> {
    /// r_{k+1}, n entries.
    pub r: &'a mut [T],
    /// v_{k+1}, n entries.
    pub v: &'a mut [T],
    /// mu_{k+1} - mu_k, m entries.
    pub dmu: &'a mut [T],
    /// Scratch, n entries.
    pub work: &'a mut [T],
}

/// What a step decided, per path, and what it adds to the diagnostics.
#[derive(Debug, Clone, Copy)]
pub struct KernelOutcome<T: Real> {
    /// The paths the step decided (a lane outside them steps through the one-path step).
    pub ok: T::Mask,
    /// The drift truncation factor (1 for an untruncated scheme).
    pub eta: T,
    /// The constrained update's numbers, where the step made one.
    pub constrained: Option<Constrained<T>>,
}

impl<T: Real> KernelOutcome<T> {
    /// The outcome of an untruncated step (eta = 1) whose paths are those its constrained
    /// update decided.
    pub fn untruncated(constrained: Constrained<T>) -> Self {
        Self {
            ok: constrained.ok,
            eta: constrained.kappa_norm.splat_like(1.0),
            constrained: Some(constrained),
        }
    }
}

/// A scheme whose step is written once over [`Real`]; [`Kernelized`] runs it.
pub trait KernelScheme: Clone + Send + Sync + 'static {
    /// The system it steps.
    type System: System + Clone + Send + Sync + 'static;
    /// The system.
    fn system(&self) -> &Self::System;
    /// The root solver's settings and the radius C_kappa of the ball the kappa root must lie
    /// in ([`StepKernel::constrain`]); the default: default settings, no ball.
    fn solver(&self) -> (SolverSettings, f64) {
        (SolverSettings::default(), f64::INFINITY)
    }
    /// One step of size h from `state` into `next`. Must be `#[inline(always)]`, so that it
    /// compiles with the lanes' instruction set, and must take each path's floating-point
    /// operations in an order that does not depend on `T`.
    fn step<T: Real, K: StepKernel<T>>(
        &self, kernel: &mut K, h: f64, state: KernelState<'_, T>, next: KernelNext<'_, T>,
    ) -> Result<KernelOutcome<T>, StepFailure>;
}

/// A [`KernelScheme`] as a [`Scheme`] (one path at a time, with typed failures) and a
/// [`LaneScheme`](crate::LaneScheme) (an ensemble's paths in lanes where the constraint offers a lane form for a
/// diagonal mass: a sphere of dimension 2 or 3, or [`Equations`](sdae_manifold::Equations)).
#[derive(Debug, Clone)]
pub struct Kernelized<K: KernelScheme> {
    pub(crate) scheme: K,
    solver: BallSolver<<<K::System as System>::Constraint as Constraint>::Gram>,
    radius: f64,
    /// One path's buffers, one after the other: r_{k+1}, v_{k+1}, v' and the step's scratch
    /// (n each), the increment of mu (m), the constraint's workspace ([`split_buffers`]).
    buffers: Vec<f64>,
    /// (n, m).
    dims: (usize, usize),
    /// The lane kernels' buffers between steps.
    pub(crate) lanes: LaneStore,
}

impl<K: KernelScheme> Kernelized<K> {
    /// The scheme, with its buffers; a failure if the system's parts do not fit.
    pub fn new(scheme: K) -> Result<Self, crate::ModelError> {
        let (n, m) = check_dimensions(scheme.system())?;
        let (settings, radius) = scheme.solver();
        let c = scheme.system().constraint();
        Ok(Self {
            solver: BallSolver::new(c.new_gram(), settings),
            radius,
            buffers: vec![0.0; 4 * n + m + scratch_len(n, m)],
            dims: (n, m),
            lanes: LaneStore::default(),
            scheme,
        })
    }

    /// The scheme.
    pub fn scheme(&self) -> &K {
        &self.scheme
    }
}

impl<K: KernelScheme> Scheme for Kernelized<K> {
    type System = K::System;
    fn system(&self) -> &K::System {
        self.scheme.system()
    }
    fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, dw: &[f64]) -> StepResult {
        check_step_input(self.scheme.system(), r, v, h, dw)?;
        let Self {
            scheme,
            solver,
            radius,
            buffers,
            dims: (n, m),
            ..
        } = self;
        let ([next_r, next_v, new_v, work, dmu], scratch) =
            split_buffers(buffers, [*n, *n, *n, *n, *m]);
        let mut kernel = OnePath {
            system: scheme.system(),
            solver,
            radius: *radius,
            scratch,
            new_v,
            certificate: None,
        };
        let state = KernelState { r, v, dw };
        let next = KernelNext {
            r: next_r,
            v: next_v,
            dmu,
            work,
        };
        let outcome = scheme.step(&mut kernel, h, state, next)?;
        if !outcome.ok {
            return Err(StepFailure::Other {
                kind: FailureKind::Other,
                message: "the scheme's step decided no path".into(),
            });
        }
        let certificate = kernel.certificate;
        r.copy_from_slice(next_r);
        v.copy_from_slice(next_v);
        Ok(StepOutcome {
            eta: outcome.eta,
            newton_iterations: certificate.map_or(0, |c| c.iterations),
            certificate,
            position_residual: certificate.map(|c| c.residual),
            velocity_residual: None,
        })
    }
    fn multiplier_increment(&self) -> &[f64] {
        let (n, m) = self.dims;
        &self.buffers[4 * n..4 * n + m]
    }
}

/// One path's buffers of [`Kernelized`], split from one allocation: pieces of the lengths
/// `lens` one after the other (r_{k+1}, v_{k+1}, v', the step's scratch and the increment of
/// mu), and the rest (the constraint's workspace).
fn split_buffers<const K: usize>(
    buffers: &mut [f64], lens: [usize; K],
) -> ([&mut [f64]; K], &mut [f64]) {
    let mut rest = buffers;
    let pieces = lens.map(|len| {
        let (piece, tail) = std::mem::take(&mut rest).split_at_mut(len);
        rest = tail;
        piece
    });
    (pieces, rest)
}

/// The one-path [`StepKernel`]: the system's own functions and the ball solver.
struct OnePath<'a, S: System> {
    system: &'a S,
    solver: &'a mut BallSolver<<S::Constraint as Constraint>::Gram>,
    radius: f64,
    scratch: &'a mut [f64],
    new_v: &'a mut [f64],
    /// The last constrained update's certificate.
    certificate: Option<Certificate>,
}

impl<S: System> StepKernel<f64> for OnePath<'_, S> {
    #[inline(always)]
    fn splat(&self, x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn drift(&mut self, r: &[f64], v: &[f64], out: &mut [f64]) {
        self.system.drift(r, v, out);
    }
    #[inline(always)]
    fn add_noise(&mut self, r: &[f64], v: &[f64], dw: &[f64], out: &mut [f64]) {
        self.system.add_noise(r, v, dw, out);
    }
    #[inline(always)]
    fn apply_inverse_mass(&self, x: &mut [f64]) {
        self.system.mass().apply_inverse(x);
    }
    fn constrain(
        &mut self, r: &[f64], y: &[f64], velocity: &mut [f64], next_r: &mut [f64],
        multiplier: &mut [f64],
    ) -> Result<Constrained<f64>, StepFailure> {
        let (certificate, at_y) = constrained_update(
            self.system.constraint(),
            self.system.mass(),
            self.solver,
            self.radius,
            r,
            y,
            velocity,
            UpdateBuffers {
                x: next_r,
                scratch: self.scratch,
                lambda: multiplier,
                new_v: self.new_v,
            },
        )?;
        if at_y {
            next_r.copy_from_slice(y);
        }
        velocity.copy_from_slice(self.new_v);
        self.certificate = Some(certificate);
        Ok(Constrained {
            ok: true,
            newton_iterations: certificate.iterations as f64,
            position_residual: certificate.residual,
            contraction: certificate.contraction,
            kappa_norm: certificate.norm,
        })
    }
    fn check_finite(&self, what: &'static str, x: &[f64]) -> Result<bool, StepFailure> {
        let norm2 = norm2_squared(x);
        if norm2.is_finite() {
            return Ok(true);
        }
        Err(StepFailure::NonFinite {
            what,
            size: max_abs(x).max(norm2.sqrt()),
        })
    }
}

/// What a lane step adds to its lanes' diagnostics: eta and the constrained update's numbers
/// (|kappa| / C_kappa where the ball is finite).
#[inline(always)]
pub(crate) fn lane_record<Sd: Simd>(
    outcome: &KernelOutcome<Lanes<Sd>>, radius: f64,
) -> LaneRecord<Sd> {
    let eta = outcome.eta;
    match &outcome.constrained {
        None => LaneRecord::plain(eta),
        Some(c) => LaneRecord {
            eta,
            newton_iterations: c.newton_iterations,
            position_residual: Some(c.position_residual),
            velocity_residual: None,
            certificate: Some((
                c.contraction,
                radius.is_finite().then(|| c.kappa_norm / radius),
            )),
        },
    }
}

/// The radius of the scheme's ball ([`KernelScheme::solver`]).
#[inline(always)]
pub(crate) fn radius<K: KernelScheme>(scheme: &Kernelized<K>) -> f64 {
    scheme.radius
}
