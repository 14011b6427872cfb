//! Many independent paths of one system, stepped together in SIMD lanes (seed eq. 3.1, 3.2).
//!
//! An [`Ensemble`] is a [`PathEnsemble`]: it holds P paths in structure-of-arrays layout
//! (coordinate i of path p at `i * stride + p`, stride = [`lane_stride`]`(P)`) and advances W
//! of them at once, W the width of the instruction set chosen at run time ([`LaneWidth`]): 1
//! (scalar), 4 (AVX2) or 8 (AVX-512). For a sphere constraint (the pendulums) with a diagonal
//! mass the step is the closed form of [`Stepper`] written once over [`Lanes`], with the
//! system's drift and noise in lanes ([`System::drift_lanes`], [`System::add_noise_lanes`]: the
//! built-in systems' lane forms, or a user's drift and noise evaluated path by path within the
//! lanes, which gives the same numbers); a lane the closed form does not decide (no root, a
//! root outside the ball or not contracting, a non-finite value) finishes its step through the
//! scalar [`Stepper`], which reports the failure exactly as for one path. Any other constraint
//! steps its paths one at a time through the scalar [`Stepper`].
//!
//! Lane p computes exactly what a lane of any other width computes: a path's numbers do not
//! depend on W, on the other paths or on how paths are split across ensembles or threads.
//!
//! ```
//! use sdae_model::{EnsembleIncrements, PathEnsemble};
//! use sdae_scheme::{Ensemble, Stepper, StepperConfig};
//! use sdae_systems::{PendulumParams, pendulum};
//! let system = pendulum(PendulumParams::default())?;
//! let config = StepperConfig::for_system(&system)?.with_c_eta(1.0)?;
//! let mut ensemble = Ensemble::new(Stepper::new(system, config)?, 100, &[1.0, 0.0], &[0.0, 0.5])?;
//! // Path p's increments from its own stream (seed 7, index p), drawn W paths at once.
//! let indices: Vec<u64> = (0..100).collect();
//! let mut noise = EnsembleIncrements::for_paths(7, &indices, 2);
//! let h = 1e-3;
//! let mut dw = vec![0.0; 2 * ensemble.stride()];
//! for _ in 0..1000 {
//!     noise.fill(h, &mut dw)?;
//!     ensemble.step(h, &dw)?;
//! }
//! assert_eq!(ensemble.failed_paths(), 0);
//! let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
//! ensemble.state(17, &mut r, &mut v, &mut mu)?;
//! assert!((r[0] * r[0] + r[1] * r[1] - 1.0).abs() < 1e-12);
//! assert_eq!(ensemble.diagnostics(17)?.steps, 1000);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod sphere;

use pulp::Simd;
use sdae_manifold::Constraint;
use sdae_model::lanes::{LaneWidth, Lanes};
use sdae_model::{
    ModelError, PathDiagnostics, PathEnsemble, Scheme, StepFailure, System, check_dim, check_path,
    check_step_size, lane_stride,
};

use crate::error::SchemeError;
use crate::stepper::Stepper;

/// P paths of one system and the scalar stepper that decides what the lanes do not.
pub struct Ensemble<S: System> {
    stepper: Stepper<S>,
    paths: usize,
    stride: usize,
    /// Positions, coordinate i of path p at `i * stride + p`.
    r: Vec<f64>,
    /// Velocities, same layout.
    v: Vec<f64>,
    /// mu (seed eq. 1.4), constraint j of path p at `j * stride + p`.
    mu: Vec<f64>,
    /// The instruction set the steps run with.
    width: LaneWidth,
    /// 1 for a path that goes on, 0 for a stopped path or a padding lane.
    alive: Vec<f64>,
    /// Why each path stopped.
    failures: Vec<Option<StepFailure>>,
    diagnostics: Vec<PathDiagnostics>,
    /// Path-steps taken by the scalar stepper.
    scalar_steps: usize,
    /// One path's r, v and dw for the scalar stepper.
    lane_r: Vec<f64>,
    lane_v: Vec<f64>,
    lane_dw: Vec<f64>,
}

impl<S: System> Ensemble<S> {
    /// `paths` >= 1 paths of `stepper`'s system, each starting at (r0, v0) (not checked to be
    /// on the manifold, as for one path).
    pub fn new(
        stepper: Stepper<S>,
        paths: usize,
        r0: &[f64],
        v0: &[f64],
    ) -> Result<Self, SchemeError> {
        if paths == 0 {
            return Err(SchemeError::invalid(
                "paths",
                0.0,
                "an ensemble needs at least one path",
            ));
        }
        let c = stepper.system().constraint();
        let (n, m) = (c.dim(), c.n_constraints());
        let l = stepper.system().noise_dim();
        let stride = lane_stride(paths);
        let mut ensemble = Self {
            stepper,
            paths,
            stride,
            r: vec![0.0; n * stride],
            v: vec![0.0; n * stride],
            mu: vec![0.0; m * stride],
            width: LaneWidth::Best,
            alive: vec![0.0; stride],
            failures: vec![None; paths],
            diagnostics: vec![PathDiagnostics::default(); paths],
            scalar_steps: 0,
            lane_r: vec![0.0; n],
            lane_v: vec![0.0; n],
            lane_dw: vec![0.0; l],
        };
        ensemble.restart(r0, v0)?;
        Ok(ensemble)
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

    /// The scalar stepper (system and constants).
    pub fn stepper(&self) -> &Stepper<S> {
        &self.stepper
    }

    /// Sets path `p` to (r, v) and lets it go on if it had stopped (its mu and diagnostics go
    /// on from where they were).
    pub fn set_state(&mut self, p: usize, r: &[f64], v: &[f64]) -> Result<(), SchemeError> {
        check_path(p, self.paths)?;
        check_dim("position", self.lane_r.len(), r.len())?;
        check_dim("velocity", self.lane_v.len(), v.len())?;
        scatter(&mut self.r, self.stride, p, r);
        scatter(&mut self.v, self.stride, p, v);
        self.alive[p] = 1.0;
        self.failures[p] = None;
        Ok(())
    }

    /// How many path-steps went through the scalar stepper (all of them for a system without
    /// a lane form; for a sphere, the steps the closed form did not decide).
    pub fn scalar_steps(&self) -> usize {
        self.scalar_steps
    }

    /// How many paths have stopped on a failed step.
    pub fn failed_paths(&self) -> usize {
        self.failures.iter().filter(|f| f.is_some()).count()
    }

    /// Path p's step through the scalar stepper (skipped if the path has stopped).
    fn step_one(&mut self, p: usize, h: f64, dw: &[f64]) {
        if self.alive[p] == 0.0 {
            return;
        }
        self.scalar_steps += 1;
        gather(&self.r, self.stride, p, &mut self.lane_r);
        gather(&self.v, self.stride, p, &mut self.lane_v);
        gather(dw, self.stride, p, &mut self.lane_dw);
        match self
            .stepper
            .step(&mut self.lane_r, &mut self.lane_v, h, &self.lane_dw)
        {
            Ok(outcome) => {
                scatter(&mut self.r, self.stride, p, &self.lane_r);
                scatter(&mut self.v, self.stride, p, &self.lane_v);
                for (j, d) in self.stepper.multiplier_increment().iter().enumerate() {
                    self.mu[j * self.stride + p] += d;
                }
                self.diagnostics[p].record(&outcome, h);
            }
            Err(failure) => {
                self.alive[p] = 0.0;
                self.failures[p] = Some(failure);
            }
        }
    }
}

impl<S: System> PathEnsemble for Ensemble<S> {
    type System = S;

    fn system(&self) -> &S {
        self.stepper.system()
    }

    fn paths(&self) -> usize {
        self.paths
    }

    fn stride(&self) -> usize {
        self.stride
    }

    fn restart(&mut self, r0: &[f64], v0: &[f64]) -> Result<(), ModelError> {
        let n = self.lane_r.len();
        check_dim("initial position", n, r0.len())?;
        check_dim("initial velocity", n, v0.len())?;
        let stride = self.stride;
        for i in 0..n {
            // Padding lanes hold the initial state too, so that they compute finite numbers.
            self.r[i * stride..(i + 1) * stride].fill(r0[i]);
            self.v[i * stride..(i + 1) * stride].fill(v0[i]);
        }
        self.mu.fill(0.0);
        self.alive.fill(0.0);
        self.alive[..self.paths].fill(1.0);
        self.failures.fill(None);
        self.diagnostics.fill(PathDiagnostics::default());
        Ok(())
    }

    /// A path whose step fails keeps its state and stops; the failure is kept
    /// ([`PathEnsemble::failure`]) and the other paths go on.
    fn step(&mut self, h: f64, dw: &[f64]) -> Result<usize, ModelError> {
        check_step_size(h)?;
        check_dim(
            "increments (l * stride)",
            self.lane_dw.len() * self.stride,
            dw.len(),
        )?;
        let before = self.failed_paths();
        // The lanes hold at most MAX_DIM coordinates and as many noise components.
        let lane_form = self
            .stepper
            .system()
            .constraint()
            .as_sphere()
            .is_some_and(|s| s.dim() <= sphere::MAX_DIM && self.lane_dw.len() <= s.dim());
        if lane_form {
            self.width.dispatch(sphere::StepAll {
                ensemble: self,
                h,
                dw,
            });
        } else {
            for p in 0..self.paths {
                self.step_one(p, h, dw);
            }
        }
        Ok(self.failed_paths() - before)
    }

    fn state(
        &self,
        p: usize,
        r: &mut [f64],
        v: &mut [f64],
        mu: &mut [f64],
    ) -> Result<(), ModelError> {
        check_path(p, self.paths)?;
        check_dim("position", self.lane_r.len(), r.len())?;
        check_dim("velocity", self.lane_v.len(), v.len())?;
        gather(&self.r, self.stride, p, r);
        gather(&self.v, self.stride, p, v);
        if !mu.is_empty() {
            check_dim("multiplier", self.mu.len() / self.stride, mu.len())?;
            gather(&self.mu, self.stride, p, mu);
        }
        Ok(())
    }

    fn diagnostics(&self, p: usize) -> Result<&PathDiagnostics, ModelError> {
        check_path(p, self.paths)?;
        Ok(&self.diagnostics[p])
    }

    fn failure(&self, p: usize) -> Result<Option<&StepFailure>, ModelError> {
        check_path(p, self.paths)?;
        Ok(self.failures[p].as_ref())
    }

    fn stop(&mut self, p: usize) -> Result<(), ModelError> {
        check_path(p, self.paths)?;
        self.alive[p] = 0.0;
        Ok(())
    }
}

/// out[i] = from[i * stride + p].
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

/// Loads coordinate i of the W paths from `offset` of each coordinate's row.
#[inline(always)]
fn load_rows<Sd: Simd, const N: usize>(
    simd: Sd,
    from: &[f64],
    stride: usize,
    offset: usize,
    rows: usize,
) -> [Lanes<Sd>; N] {
    let mut out = [Lanes::splat(simd, 0.0); N];
    for (i, o) in out.iter_mut().enumerate().take(rows) {
        *o = Lanes::load(simd, &from[i * stride + offset..]);
    }
    out
}
