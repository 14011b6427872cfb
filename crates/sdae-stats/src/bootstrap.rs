//! The paired bootstrap over whole paths.
//!
//! A resample draws n paths with replacement and keeps each drawn path's values at every level
//! together, so that a statistic across levels (an order's slope, a local slope, a ratio of
//! means) keeps the correlation the shared Brownian path gives it. Resamples come from a fixed
//! stream, so every interval built on them is a function of the data alone.

use rand::RngExt;
use sdae_noise::path_rng;

/// Bootstrap resamples behind the study's intervals.
pub const BOOTSTRAP_RESAMPLES: usize = 400;

/// Seed of the resampling stream: the resamples of n paths draw from `path_rng(BOOTSTRAP_SEED,
/// n)`, the same for every statistic of n paths.
const BOOTSTRAP_SEED: u64 = 0x5eed_b007;

/// Per-path rows of one width (a path's errors at every level, products of them, ...): what a
/// paired bootstrap resamples, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct PathTable {
    width: usize,
    cells: Vec<f64>,
}

impl PathTable {
    /// The table of `paths` rows of `width` columns; `row(i, cells)` fills the row of path i.
    pub fn from_rows(paths: usize, width: usize, mut row: impl FnMut(usize, &mut [f64])) -> Self {
        let mut cells = vec![0.0; paths * width];
        if width > 0 {
            for (i, cells) in cells.chunks_exact_mut(width).enumerate() {
                row(i, cells);
            }
        }
        Self { width, cells }
    }

    /// The number of paths (rows).
    pub fn paths(&self) -> usize {
        self.cells.len().checked_div(self.width).unwrap_or(0)
    }

    /// The number of columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The row of path `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.cells[i * self.width..(i + 1) * self.width]
    }
}

/// A uniform index in 0..n from 64 random bits (multiply-shift).
pub fn index(bits: u64, n: usize) -> usize {
    ((u128::from(bits) * n as u128) >> 64) as usize
}

/// Independent partial sums per column: the additions of consecutive draws do not wait on each
/// other.
const PARTIALS: usize = 4;

/// The paired bootstrap of `table`: for each of `resamples` resamples, n = `table.paths()` row
/// indices drawn uniformly with replacement (from the fixed stream of n paths), and
/// `statistic(S)` of the column sums S_c = sum over the drawn rows i of `row_i[c]`. Smooth
/// functions of means (per-level means of d^p, and their covariances from columns of centred
/// products) are functions of these sums; the rows stay whole, so the levels of a path are
/// drawn together. Returns the statistics that are `Some` (a resample can be degenerate, say all
/// its values equal) in the order of the resamples.
pub fn paired_bootstrap<T>(
    table: &PathTable, resamples: usize, mut statistic: impl FnMut(&[f64]) -> Option<T>,
) -> Vec<T> {
    let (n, width) = (table.paths(), table.width);
    let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
    let mut partial = vec![0.0; PARTIALS * width];
    let mut sums = vec![0.0; width];
    let mut results = Vec::with_capacity(resamples);
    if n == 0 || width == 0 {
        return results;
    }
    let add = |lane: &mut [f64], bits: u64| {
        for (s, x) in lane.iter_mut().zip(table.row(index(bits, n))) {
            *s += x;
        }
    };
    for _ in 0..resamples {
        partial.fill(0.0);
        for _ in 0..n / PARTIALS {
            for lane in partial.chunks_exact_mut(width) {
                add(lane, rng.random::<u64>());
            }
        }
        for lane in partial.chunks_exact_mut(width).take(n % PARTIALS) {
            add(lane, rng.random::<u64>());
        }
        for (c, s) in sums.iter_mut().enumerate() {
            *s = partial.iter().skip(c).step_by(width).sum();
        }
        results.extend(statistic(&sums));
    }
    results
}

/// The q-quantile of sorted values (linear between order statistics).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let x = q * (sorted.len() - 1) as f64;
    let (i, w) = (x.floor() as usize, x - x.floor());
    let j = (i + 1).min(sorted.len() - 1);
    (1.0 - w) * sorted[i] + w * sorted[j]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_sums_are_sums_over_rows_drawn_from_the_fixed_stream() {
        // Lengths off and on multiples of the partial sums' count.
        for n in [1, 2, 3, 10, 1003] {
            let table = PathTable::from_rows(n, 3, |i, row| {
                let x = (0.37 * i as f64).sin().exp();
                row.copy_from_slice(&[x, x * x, -2.0 * x]);
            });
            let sums = paired_bootstrap(&table, 5, |s| Some(s.to_vec()));
            let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
            for s in sums {
                let mut expected = [0.0; 3];
                for _ in 0..n {
                    let row = table.row(index(rng.random::<u64>(), n));
                    expected.iter_mut().zip(row).for_each(|(e, x)| *e += x);
                }
                for (a, b) in s.iter().zip(expected) {
                    assert!((a - b).abs() <= 1e-13 * b.abs(), "n = {n}: {a} against {b}");
                }
            }
        }
    }

    #[test]
    fn degenerate_resamples_are_dropped() {
        let table = PathTable::from_rows(4, 1, |i, row| row[0] = i as f64);
        let kept = paired_bootstrap(&table, 50, |s| (s[0] > 6.0).then_some(s[0]));
        assert!(!kept.is_empty() && kept.len() < 50 && kept.iter().all(|&s| s > 6.0));
        let empty = PathTable::from_rows(0, 2, |_, _| {});
        assert!(paired_bootstrap(&empty, 5, |s| Some(s.len())).is_empty());
    }
}
