//! The quasi-Monte Carlo increments of one path ([`QuasiIncrements`]).

use crate::error::NoiseError;
use crate::increments::IncrementSource;
use crate::qmc::quasi_brownian::QuasiBrownian;

/// The N increments of one quasi-Monte Carlo Brownian path ([`QuasiBrownian`]), computed up
/// front and handed out in order: step k of size h gives sqrt(h) xi_k, xi_k the path's
/// increment over unit step k ([`QuasiBrownian::unit_increments`]).
///
/// By Brownian scaling this is the bridge-ordered path of the grid t_k = k h, so the source
/// needs no step size until it is used; the path is Brownian only if every step has the same
/// h, which debug builds check (to a relative 1e-12, so that [`Coarsened`](crate::Coarsened)'s
/// h / factor passes). Past the N-th step it yields NaN, as
/// [`RecordedIncrements`](crate::RecordedIncrements) does; [`IncrementSource::remaining`]
/// tells how many steps are left.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiIncrements {
    unit: Vec<f64>,
    dim: usize,
    position: usize,
    first_step: Option<f64>,
}

impl QuasiIncrements {
    /// Path `index` of randomization `randomization` of a study with seed `seed`: increments
    /// of dimension `dim` over `steps` steps ([`QuasiBrownian::new`], then
    /// [`QuasiBrownian::path`]). It scrambles the Sobol' points for this path alone; paths
    /// that share a randomization share a [`QuasiBrownian`] instead.
    pub fn new(
        seed: u64, randomization: u64, index: u64, dim: usize, steps: usize,
    ) -> Result<Self, NoiseError> {
        QuasiBrownian::new(seed, randomization, dim, steps)?.path(index)
    }
}

impl QuasiBrownian {
    /// The increments of path `index` (point `index` of the Sobol' points); fails if `index`
    /// >= 2^32.
    pub fn path(&self, index: u64) -> Result<QuasiIncrements, NoiseError> {
        let mut unit = vec![0.0; self.steps() * self.dim()];
        self.unit_increments(index, &mut unit)?;
        Ok(QuasiIncrements {
            unit,
            dim: self.dim(),
            position: 0,
            first_step: None,
        })
    }
}

impl IncrementSource for QuasiIncrements {
    fn dim(&self) -> usize {
        self.dim
    }
    fn remaining(&self) -> Option<usize> {
        Some((self.unit.len() - self.position) / self.dim)
    }
    /// out = sqrt(h) xi_k for the next step k, NaN past the last.
    fn next_increment(&mut self, h: f64, out: &mut [f64]) {
        let first = *self.first_step.get_or_insert(h);
        debug_assert!(
            (h - first).abs() <= 1e-12 * first.abs(),
            "a quasi-random path is drawn on a uniform grid: step {h} after {first}"
        );
        let end = self.position + self.dim;
        if end <= self.unit.len() {
            let scale = h.sqrt();
            for (o, xi) in out.iter_mut().zip(&self.unit[self.position..end]) {
                *o = scale * xi;
            }
            self.position = end;
        } else {
            out.fill(f64::NAN);
        }
    }
}
