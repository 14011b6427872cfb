//! Observers of a path: what the path driver reports at each step, and a recorder with
//! interpolation between grid points (seed Remark 4.2).

use crate::scheme::StepOutcome;

/// Receives the state at steps of the path.
pub trait Observer {
    /// Whether mu must be accumulated (it is not otherwise).
    fn wants_mu(&self) -> bool {
        false
    }
    /// Whether to be called at step k (k = 0 and k = N are always offered).
    fn wants_step(&self, k: usize) -> bool {
        let _ = k;
        true
    }
    /// The state at t_k; `mu` is empty unless [`Observer::wants_mu`].
    fn observe(&mut self, k: usize, t: f64, r: &[f64], v: &[f64], mu: &[f64]);
    /// After a successful step, with its outcome.
    fn step_done(&mut self, k: usize, outcome: &StepOutcome) {
        let _ = (k, outcome);
    }
}

/// Observes nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl Observer for NoObserver {
    fn wants_step(&self, _k: usize) -> bool {
        false
    }
    fn observe(&mut self, _k: usize, _t: f64, _r: &[f64], _v: &[f64], _mu: &[f64]) {}
}

/// How to read a recorded trajectory between grid points (seed Remark 4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// The value at the last grid point t_k <= t.
    PiecewiseConstant,
    /// Linear between t_k <= t <= t_{k+1}.
    PiecewiseLinear,
}

/// Records r, v (and mu if asked) at every `every`-th step and at the end.
#[derive(Debug, Clone, Default)]
pub struct Recorder {
    every: usize,
    record_mu: bool,
    dim: usize,
    mu_dim: usize,
    /// Recorded step indices.
    pub steps: Vec<usize>,
    /// Recorded times.
    pub times: Vec<f64>,
    /// Recorded positions, one row of n per time.
    pub r: Vec<f64>,
    /// Recorded velocities.
    pub v: Vec<f64>,
    /// Recorded multipliers mu, one row of m per time (empty unless asked).
    pub mu: Vec<f64>,
}

impl Recorder {
    /// Records every `every`-th step (>= 1).
    pub fn every(every: usize) -> Self {
        Self {
            every: every.max(1),
            ..Self::default()
        }
    }
    /// Also records mu.
    pub fn with_mu(mut self) -> Self {
        self.record_mu = true;
        self
    }
    /// Number of recorded times.
    pub fn len(&self) -> usize {
        self.times.len()
    }
    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }
    /// Recorded position number i.
    pub fn position(&self, i: usize) -> &[f64] {
        &self.r[i * self.dim..(i + 1) * self.dim]
    }
    /// Recorded velocity number i.
    pub fn velocity(&self, i: usize) -> &[f64] {
        &self.v[i * self.dim..(i + 1) * self.dim]
    }
    /// Recorded multiplier number i (empty unless recorded).
    pub fn multiplier(&self, i: usize) -> &[f64] {
        if self.mu_dim == 0 {
            &[]
        } else {
            &self.mu[i * self.mu_dim..(i + 1) * self.mu_dim]
        }
    }

    /// The interpolated (r, v, mu) at time t into the three buffers (seed Remark 4.2); t is
    /// clamped to the recorded range. Returns `None` if nothing was recorded.
    pub fn interpolate(
        &self, t: f64, how: Interpolation, r: &mut [f64], v: &mut [f64], mu: &mut [f64],
    ) -> Option<()> {
        if self.times.is_empty() {
            return None;
        }
        let k = self.times.partition_point(|&s| s <= t).saturating_sub(1);
        let k1 = (k + 1).min(self.times.len() - 1);
        let w = match how {
            Interpolation::PiecewiseConstant => 0.0,
            Interpolation::PiecewiseLinear if k1 == k => 0.0,
            Interpolation::PiecewiseLinear => {
                ((t - self.times[k]) / (self.times[k1] - self.times[k])).clamp(0.0, 1.0)
            }
        };
        let blend = |a: &[f64], b: &[f64], out: &mut [f64]| {
            for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
                *o = (1.0 - w) * x + w * y;
            }
        };
        blend(self.position(k), self.position(k1), r);
        blend(self.velocity(k), self.velocity(k1), v);
        blend(self.multiplier(k), self.multiplier(k1), mu);
        Some(())
    }
}

impl Observer for Recorder {
    fn wants_mu(&self) -> bool {
        self.record_mu
    }
    fn wants_step(&self, k: usize) -> bool {
        k.is_multiple_of(self.every)
    }
    fn observe(&mut self, k: usize, t: f64, r: &[f64], v: &[f64], mu: &[f64]) {
        if self.steps.last() == Some(&k) {
            return;
        }
        self.dim = r.len();
        self.mu_dim = mu.len();
        self.steps.push(k);
        self.times.push(t);
        self.r.extend_from_slice(r);
        self.v.extend_from_slice(v);
        self.mu.extend_from_slice(mu);
    }
}
