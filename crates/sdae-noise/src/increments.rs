//! Sources of Brownian increments dw_k = w(t_{k+1}) - w(t_k).
//!
//! Path i of a study draws from its own streams [`PathStreams::for_path`]`(seed, i)`, so
//! results do not depend on the thread count or on which paths run where.

use crate::path_streams::{PathStreams, StandardNormals};

/// Something that fills the next Brownian increment over a step of size h.
pub trait IncrementSource {
    /// The dimension l of the increments.
    fn dim(&self) -> usize;
    /// out = the next increment (length l) for a step of size h.
    fn next_increment(&mut self, h: f64, out: &mut [f64]);
    /// How many increments are left, if the source is finite.
    fn remaining(&self) -> Option<usize> {
        None
    }
}

/// Gaussian increments sqrt(h) N(0, I_l) from a source of standard normals: a path's
/// [`PathStreams`] ([`GaussianIncrements::for_path`]) or any random-number generator
/// (through rand_distr's `StandardNormal`).
#[derive(Debug, Clone)]
pub struct GaussianIncrements<R> {
    normals: R,
    dim: usize,
}

impl<R: StandardNormals> GaussianIncrements<R> {
    /// Increments of dimension `dim` drawn from `normals`.
    pub fn new(normals: R, dim: usize) -> Self {
        Self { normals, dim }
    }
}

impl GaussianIncrements<PathStreams> {
    /// Increments of path `index` of a study with seed `seed` ([`PathStreams::for_path`]).
    pub fn for_path(seed: u64, index: u64, dim: usize) -> Self {
        Self::new(PathStreams::for_path(seed, index), dim)
    }
}

impl<R: StandardNormals> IncrementSource for GaussianIncrements<R> {
    fn dim(&self) -> usize {
        self.dim
    }
    #[inline]
    fn next_increment(&mut self, h: f64, out: &mut [f64]) {
        self.normals.fill_scaled(h.sqrt(), out);
    }
}

/// Increments of a coarser grid: each is the sum of `factor` consecutive increments of a finer
/// source, so several step sizes can run on the same Brownian path.
#[derive(Debug, Clone)]
pub struct Coarsened<I> {
    fine: I,
    factor: usize,
    buffer: Vec<f64>,
}

impl<I: IncrementSource> Coarsened<I> {
    /// Sums `factor` >= 1 fine increments per coarse one.
    pub fn new(fine: I, factor: usize) -> Self {
        let dim = fine.dim();
        Self {
            fine,
            factor: factor.max(1),
            buffer: vec![0.0; dim],
        }
    }
}

impl<I: IncrementSource> IncrementSource for Coarsened<I> {
    fn dim(&self) -> usize {
        self.fine.dim()
    }
    fn remaining(&self) -> Option<usize> {
        self.fine.remaining().map(|r| r / self.factor)
    }
    fn next_increment(&mut self, h: f64, out: &mut [f64]) {
        let fine_h = h / self.factor as f64;
        out.fill(0.0);
        for _ in 0..self.factor {
            self.fine.next_increment(fine_h, &mut self.buffer);
            for (o, b) in out.iter_mut().zip(&self.buffer) {
                *o += b;
            }
        }
    }
}

/// Increments read from a buffer (row k holds dw_k), e.g. a stored Brownian path.
#[derive(Debug, Clone)]
pub struct RecordedIncrements<'a> {
    data: &'a [f64],
    dim: usize,
    position: usize,
}

impl<'a> RecordedIncrements<'a> {
    /// Reads consecutive chunks of length `dim` from `data`.
    pub fn new(data: &'a [f64], dim: usize) -> Self {
        Self {
            data,
            dim,
            position: 0,
        }
    }
}

impl IncrementSource for RecordedIncrements<'_> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn remaining(&self) -> Option<usize> {
        (self.data.len() - self.position).checked_div(self.dim)
    }
    /// Copies the next stored increment; past the end of the buffer it yields NaN, which the
    /// path driver (`sdae_model::run_path`) prevents by checking
    /// [`IncrementSource::remaining`] up front.
    fn next_increment(&mut self, _h: f64, out: &mut [f64]) {
        let end = self.position + self.dim;
        if end <= self.data.len() {
            out.copy_from_slice(&self.data[self.position..end]);
            self.position = end;
        } else {
            out.fill(f64::NAN);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let mut a = GaussianIncrements::for_path(7, 3, 2);
        let mut b = GaussianIncrements::for_path(7, 3, 2);
        let mut c = GaussianIncrements::for_path(7, 4, 2);
        let (mut x, mut y, mut z) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        a.next_increment(1.0, &mut x);
        b.next_increment(1.0, &mut y);
        c.next_increment(1.0, &mut z);
        assert_eq!(x, y);
        assert_ne!(x, z);
    }

    #[test]
    fn coarsened_sums_the_fine_increments() {
        let data: Vec<f64> = (0..8).map(|k| k as f64).collect();
        let mut coarse = Coarsened::new(RecordedIncrements::new(&data, 2), 2);
        let mut out = [0.0; 2];
        coarse.next_increment(1.0, &mut out);
        assert_eq!(out, [0.0 + 2.0, 1.0 + 3.0]);
        coarse.next_increment(1.0, &mut out);
        assert_eq!(out, [4.0 + 6.0, 5.0 + 7.0]);
    }
}
