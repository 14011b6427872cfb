//! Many independent paths of one scheme stepped together: [`PathEnsemble`], [`PathLoop`].

use sdae_lanes::lane_stride;
use sdae_manifold::{Constraint, check_state};
use sdae_noise::EnsembleIncrements;

use crate::diagnostics::PathDiagnostics;
use crate::driver::{INITIAL_STATE_TOLERANCE, PathState};
use crate::error::{ModelError, StepFailure, check_dim, check_step_size, try_filled};
use crate::scheme::Scheme;
use crate::system::System;

/// P independent paths of one scheme, each with its state (r, v), its mu (seed eq. 1.4), its
/// [`PathDiagnostics`] and, once a step has failed, its [`StepFailure`]: a failed path keeps
/// its last good state and stops; the others go on.
///
/// Implemented by [`PathLoop`], which steps the paths of any [`Scheme`] one at a time, and
/// [`LaneEnsemble`](crate::LaneEnsemble), which steps W at a time in SIMD lanes; the
/// increments of a step are laid out by [`lane_stride`].
///
/// A path's numbers never depend on the other paths of its ensemble: path p of an ensemble
/// computes exactly what [`run_path`](crate::run_path) computes for that path alone, so a
/// Monte Carlo run gives the same numbers however its paths are grouped into ensembles and
/// threads. An implementation that steps W paths in SIMD lanes is `sdae_scheme::Ensemble`.
///
/// ```
/// use sdae_lanes::lane_stride;
/// use sdae_model::{
///     MechanicalSystem, NoNoise, PathEnsemble, PathLoop, Scheme, StepFailure, StepOutcome,
///     StepResult, ZeroDrift,
/// };
/// use sdae_noise::{GaussianIncrements, IncrementSource};
/// use sdae_manifold::{IdentityMass, Sphere};
///
/// // A scheme that only moves along a circle's tangent (enough to show the bookkeeping).
/// type Circle = MechanicalSystem<Sphere, IdentityMass, ZeroDrift, NoNoise>;
/// struct Rotate(Circle);
/// impl Scheme for Rotate {
///     type System = Circle;
///     fn system(&self) -> &Circle {
///         &self.0
///     }
///     fn step(&mut self, r: &mut [f64], v: &mut [f64], h: f64, _dw: &[f64])
///         -> StepResult {
///         let (c, s) = (h.cos(), h.sin());
///         let (x, y) = (r[0], r[1]);
///         r.copy_from_slice(&[c * x - s * y, s * x + c * y]);
///         v.copy_from_slice(&[-r[1], r[0]]);
///         Ok(StepOutcome::PLAIN)
///     }
///     fn multiplier_increment(&self) -> &[f64] {
///         &[0.0]
///     }
/// }
///
/// let system = MechanicalSystem::new(Sphere::new(2, 1.0)?, IdentityMass, ZeroDrift, NoNoise)?;
/// let mut paths = PathLoop::new(Rotate(system), 3, &[1.0, 0.0], &[0.0, 1.0])?;
/// assert_eq!(paths.stride(), lane_stride(3));
/// for _ in 0..100 {
///     paths.step(0.01, &[])?;
/// }
/// let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
/// paths.state(2, &mut r, &mut v, &mut mu)?;
/// assert!((r[0] - 1f64.cos()).abs() < 1e-12 && paths.diagnostics(2)?.steps == 100);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub trait PathEnsemble {
    /// The system stepped.
    type System: System;
    /// The system.
    fn system(&self) -> &Self::System;
    /// The number P of paths.
    fn paths(&self) -> usize;
    /// The stride of the increments' layout, [`lane_stride`]`(P)`.
    fn stride(&self) -> usize {
        lane_stride(self.paths())
    }
    /// Puts every path back at (r0, v0) with mu = 0, fresh diagnostics and no failure. Fails,
    /// leaving the paths alone, unless (r0, v0) has n coordinates each, is finite and lies on
    /// the tangent bundle within [`INITIAL_STATE_TOLERANCE`] ([`check_initial_state`]).
    fn restart(&mut self, r0: &[f64], v0: &[f64]) -> Result<(), ModelError>;
    /// Sets path p to (r, v) and lets it go on if it had stopped (its mu and diagnostics go on
    /// from where they were; a failure it had is dropped). Only the lengths are checked: a
    /// path may be placed anywhere, off the manifold too (to see how a scheme fails there).
    fn set_state(&mut self, p: usize, r: &[f64], v: &[f64]) -> Result<(), ModelError>;
    /// Advances every path that goes on by one step of size h with Brownian increments `dw`
    /// (component j of path p at `j * stride + p`, length l * stride); returns how many paths
    /// stopped in this step.
    fn step(&mut self, h: f64, dw: &[f64]) -> Result<usize, ModelError>;
    /// Draws every path's next increment from `noise` into `dw` ([`EnsembleIncrements::fill`])
    /// and takes that step ([`PathEnsemble::step`]); returns how many paths stopped in it.
    /// Fails, drawing nothing, unless `noise` draws the system's l components for exactly
    /// this ensemble's P paths (increments drawn for fewer paths would silently give the
    /// others path 0's numbers) and `dw` holds one step (l * stride).
    fn step_drawing(
        &mut self, h: f64, noise: &mut EnsembleIncrements, dw: &mut [f64],
    ) -> Result<usize, ModelError> {
        check_dim("paths of the increments", self.paths(), noise.paths())?;
        let l = self.system().noise_dim();
        check_dim("noise dimension of the increments", l, noise.dim())?;
        check_dim("increments (l * stride)", l * self.stride(), dw.len())?;
        noise.fill(h, dw)?;
        self.step(h, dw)
    }
    /// Copies path p's (r, v, mu) into the slices (mu of length m, or empty to skip it).
    fn state(
        &self, p: usize, r: &mut [f64], v: &mut [f64], mu: &mut [f64],
    ) -> Result<(), ModelError>;
    /// Copies the (r, v, mu) of each path in `paths` into one row of `rows` (row i for
    /// `paths[i]`, each 2n + `mu_len` long, `mu_len` either m or 0 to leave mu out): a whole
    /// block's states in one call instead of one [`PathEnsemble::state`] call per path.
    fn read_rows(
        &self, paths: &[usize], mu_len: usize, rows: &mut [f64],
    ) -> Result<(), ModelError> {
        let n = self.system().constraint().dim();
        for_each_row(paths, n, mu_len, rows, |p, r, v, mu| {
            self.state(p, r, v, mu)
        })
    }
    /// What path p's steps did so far.
    fn diagnostics(&self, p: usize) -> Result<PathDiagnostics, ModelError>;
    /// Why path p stopped on a failed step, or `None`. The step that failed is the path's
    /// step k = [`PathDiagnostics::steps`] (the steps it completed), from t_k = k h.
    fn failure(&self, p: usize) -> Result<Option<&StepFailure>, ModelError>;
    /// Stops path p (its caller found it failed, say beyond a blow-up bound): it takes no
    /// further steps until [`PathEnsemble::restart`].
    fn stop(&mut self, p: usize) -> Result<(), ModelError>;
    /// How many paths have stopped on a failed step (those with a [`PathEnsemble::failure`];
    /// paths stopped by [`PathEnsemble::stop`] are not counted).
    fn failed_paths(&self) -> usize {
        (0..self.paths())
            .filter(|&p| matches!(self.failure(p), Ok(Some(_))))
            .count()
    }
}

/// Checks the length of the rows of [`PathEnsemble::read_rows`] (2n + `mu_len` per path) and
/// hands `read` each listed path with the (r, v, mu) parts of its row.
pub(crate) fn for_each_row(
    paths: &[usize], n: usize, mu_len: usize, rows: &mut [f64],
    mut read: impl FnMut(usize, &mut [f64], &mut [f64], &mut [f64]) -> Result<(), ModelError>,
) -> Result<(), ModelError> {
    let row = 2 * n + mu_len;
    check_dim("rows ((2n + mu) per path)", paths.len() * row, rows.len())?;
    for (&p, out) in paths.iter().zip(rows.chunks_exact_mut(row.max(1))) {
        let (r, rest) = out.split_at_mut(n);
        let (v, mu) = rest.split_at_mut(n);
        read(p, r, v, mu)?;
    }
    Ok(())
}

/// Checks a path index against the number of paths ([`ModelError::PathIndex`] unless
/// p < `paths`).
pub fn check_path(p: usize, paths: usize) -> Result<(), ModelError> {
    if p < paths {
        Ok(())
    } else {
        Err(ModelError::PathIndex { index: p, paths })
    }
}

/// Checks an ensemble's start as [`run_path`](crate::run_path) checks a path's: r0 and v0 of
/// length n (the system's coordinates), finite, |g(r0)| and |Dg(r0) v0| within
/// [`INITIAL_STATE_TOLERANCE`] ([`ModelError::Manifold`] with the residual and where it is
/// largest otherwise).
pub fn check_initial_state<S: System + ?Sized>(
    system: &S, r0: &[f64], v0: &[f64],
) -> Result<(), ModelError> {
    let constraint = system.constraint();
    check_dim("initial position", constraint.dim(), r0.len())?;
    check_dim("initial velocity", constraint.dim(), v0.len())?;
    check_state(constraint, r0, v0, INITIAL_STATE_TOLERANCE)?;
    Ok(())
}

/// The paths of any [`Scheme`] (a user's, one without a lane form), stepped one at a time by
/// the same [`PathState::step`] as [`run_path`](crate::run_path).
pub struct PathLoop<Sch: Scheme> {
    scheme: Sch,
    /// The coordinates n.
    n: usize,
    /// Path p's r_k and v_k: entries p n to (p + 1) n, in one buffer for all paths (one
    /// allocation each, none on restart, paths next to each other).
    r: Vec<f64>,
    v: Vec<f64>,
    /// Path p's k, mu and diagnostics.
    states: Vec<PathState>,
    /// Whether path p goes on.
    alive: Vec<bool>,
    failures: Vec<Option<StepFailure>>,
    /// One path's increment.
    dw: Vec<f64>,
}

impl<Sch: Scheme> PathLoop<Sch> {
    /// `paths` >= 1 paths of `scheme`, each starting at (r0, v0) ([`check_initial_state`]).
    pub fn new(scheme: Sch, paths: usize, r0: &[f64], v0: &[f64]) -> Result<Self, ModelError> {
        if paths == 0 {
            return Err(ModelError::InvalidSetting {
                name: "paths",
                value: 0.0,
                reason: "an ensemble needs at least one path",
            });
        }
        check_initial_state(scheme.system(), r0, v0)?;
        let system = scheme.system();
        let (n, m) = (r0.len(), system.constraint().n_constraints());
        let l = system.noise_dim();
        let fresh = PathState::new(m, true, false);
        let mut ensemble = Self {
            n,
            r: try_filled("the paths' positions", 0.0, paths, n)?,
            v: try_filled("the paths' velocities", 0.0, paths, n)?,
            states: try_filled("the paths' states", fresh, paths, 1)?,
            alive: try_filled("the paths' flags", true, paths, 1)?,
            failures: try_filled("the paths' failures", None, paths, 1)?,
            dw: vec![0.0; l],
            scheme,
        };
        ensemble.restart(r0, v0)?;
        Ok(ensemble)
    }

    /// The scheme.
    pub fn scheme(&self) -> &Sch {
        &self.scheme
    }

    /// Where path p's r_k and v_k are in their buffers.
    fn rows(&self, p: usize) -> std::ops::Range<usize> {
        p * self.n..(p + 1) * self.n
    }
}

impl<Sch: Scheme> PathEnsemble for PathLoop<Sch> {
    type System = Sch::System;

    fn system(&self) -> &Self::System {
        self.scheme.system()
    }

    fn paths(&self) -> usize {
        self.states.len()
    }

    fn restart(&mut self, r0: &[f64], v0: &[f64]) -> Result<(), ModelError> {
        check_initial_state(self.scheme.system(), r0, v0)?;
        for p in 0..self.states.len() {
            let rows = self.rows(p);
            self.r[rows.clone()].copy_from_slice(r0);
            self.v[rows].copy_from_slice(v0);
            self.states[p].restart();
            self.alive[p] = true;
            self.failures[p] = None;
        }
        Ok(())
    }

    fn set_state(&mut self, p: usize, r: &[f64], v: &[f64]) -> Result<(), ModelError> {
        check_path(p, self.paths())?;
        check_dim("position", self.n, r.len())?;
        check_dim("velocity", self.n, v.len())?;
        let rows = self.rows(p);
        self.r[rows.clone()].copy_from_slice(r);
        self.v[rows].copy_from_slice(v);
        self.alive[p] = true;
        self.failures[p] = None;
        Ok(())
    }

    fn step(&mut self, h: f64, dw: &[f64]) -> Result<usize, ModelError> {
        check_step_size(h)?;
        let stride = self.stride();
        check_dim("increments (l * stride)", self.dw.len() * stride, dw.len())?;
        let mut stopped = 0;
        for p in 0..self.states.len() {
            if !self.alive[p] {
                continue;
            }
            for (j, x) in self.dw.iter_mut().enumerate() {
                *x = dw[j * stride + p];
            }
            let rows = self.rows(p);
            let state = &mut self.states[p];
            if let Err(failure) = state.step(
                &mut self.scheme,
                &mut self.r[rows.clone()],
                &mut self.v[rows],
                h,
                &self.dw,
            ) {
                self.alive[p] = false;
                self.failures[p] = Some(failure);
                stopped += 1;
            }
        }
        Ok(stopped)
    }

    fn state(
        &self, p: usize, r: &mut [f64], v: &mut [f64], mu: &mut [f64],
    ) -> Result<(), ModelError> {
        check_path(p, self.paths())?;
        check_dim("position", self.n, r.len())?;
        check_dim("velocity", self.n, v.len())?;
        if !mu.is_empty() {
            check_dim("multiplier", self.states[p].mu.len(), mu.len())?;
            mu.copy_from_slice(&self.states[p].mu);
        }
        r.copy_from_slice(&self.r[self.rows(p)]);
        v.copy_from_slice(&self.v[self.rows(p)]);
        Ok(())
    }

    fn diagnostics(&self, p: usize) -> Result<PathDiagnostics, ModelError> {
        check_path(p, self.paths())?;
        Ok(self.states[p].diagnostics.clone())
    }

    fn failure(&self, p: usize) -> Result<Option<&StepFailure>, ModelError> {
        check_path(p, self.paths())?;
        Ok(self.failures[p].as_ref())
    }

    fn stop(&mut self, p: usize) -> Result<(), ModelError> {
        check_path(p, self.paths())?;
        self.alive[p] = false;
        Ok(())
    }
}
