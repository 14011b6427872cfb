//! The paired bootstrap over whole paths.
//!
//! A resample draws n paths with replacement and keeps each drawn path's values at every level
//! together, so that a statistic across levels (an order's slope, a local slope, a ratio of
//! means) keeps the correlation the shared Brownian path gives it. Resamples come from a fixed
//! stream, so every interval built on them is a function of the data alone.

use pulp::{Simd, WithSimd};
use rand::RngExt;
use sdae_noise::path_rng;

/// Bootstrap resamples behind the study's intervals.
pub const BOOTSTRAP_RESAMPLES: usize = 400;

/// Seed of the resampling stream: the resamples of n paths draw from `path_rng(BOOTSTRAP_SEED,
/// n)`, the same for every statistic of n paths.
const BOOTSTRAP_SEED: u64 = 0x5eed_b007;

/// Columns per block of a [`PathTable`]'s storage: a resample draws its rows once and sums
/// them block of columns by block of columns, each pass reading one block (every path's values
/// at these columns). Blocks of 16 keep a wide table's passes few (each draw costs a pass an
/// index and an address whatever the block's width: 3 passes over 44 columns took 0.6x the
/// time of 6 passes of 8, and 16 was the fastest of 2 to 48); a table of at most 8 columns
/// takes blocks of 8 (half the memory, as fast).
fn block_width(width: usize) -> usize {
    if width > 8 { 16 } else { 8 }
}

/// Per-path rows of one width (a path's errors at every level, products of them, ...): what a
/// paired bootstrap resamples, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct PathTable {
    width: usize,
    paths: usize,
    /// Columns per block ([`block_width`]).
    block: usize,
    /// Block b of path i (columns `b * block..(b + 1) * block`, the last block padded with
    /// zeros) at `cells[(b * paths + i) * block..]`.
    cells: Vec<f64>,
}

impl PathTable {
    /// The table of `paths` rows of `width` columns; `row(i, cells)` fills the row of path i.
    pub fn from_rows(paths: usize, width: usize, mut row: impl FnMut(usize, &mut [f64])) -> Self {
        let paths = if width > 0 { paths } else { 0 };
        let block = block_width(width);
        let mut cells = vec![0.0; width.div_ceil(block) * block * paths];
        let mut values = vec![0.0; width];
        for i in 0..paths {
            row(i, &mut values);
            for (b, part) in values.chunks(block).enumerate() {
                let at = (b * paths + i) * block;
                cells[at..at + part.len()].copy_from_slice(part);
            }
        }
        Self {
            width,
            paths,
            block,
            cells,
        }
    }

    /// The number of paths (rows).
    pub fn paths(&self) -> usize {
        self.paths
    }

    /// The number of columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The row of path `i` (a copy: the table keeps its columns in blocks).
    pub fn row(&self, i: usize) -> Vec<f64> {
        let blocks = self.cells.chunks_exact(self.block * self.paths.max(1));
        let mut row: Vec<f64> = blocks
            .flat_map(|b| &b[i * self.block..(i + 1) * self.block])
            .copied()
            .collect();
        row.truncate(self.width);
        row
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
///
/// Each column's sum is taken in one fixed order, whatever the width: draw k goes to partial
/// sum k mod 4 (draws in the order of the stream), and S_c is the sum of the four partials in
/// order. A resample's indices are drawn once and summed block of columns by block of columns.
pub fn paired_bootstrap<T>(
    table: &PathTable, resamples: usize, mut statistic: impl FnMut(&[f64]) -> Option<T>,
) -> Vec<T> {
    let (n, width) = (table.paths(), table.width);
    let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
    let mut sums = vec![0.0; width];
    let mut draws = vec![0; n];
    let mut results = Vec::with_capacity(resamples);
    if n == 0 || width == 0 {
        return results;
    }
    let arch = pulp::Arch::new();
    for _ in 0..resamples {
        draws.fill_with(|| index(rng.random::<u64>(), n));
        column_sums(arch, table, &draws, &mut sums);
        results.extend(statistic(&sums));
    }
    results
}

/// The column sums of the rows `draws` of `table` into `sums` ([`ResampleSums`]). Not
/// generic: compiled once, in this crate.
#[inline(never)]
fn column_sums(arch: pulp::Arch, table: &PathTable, draws: &[usize], sums: &mut [f64]) {
    arch.dispatch(ResampleSums { table, draws, sums });
}

/// The column sums of one resample, compiled for the widest instruction set the processor
/// has (AVX-512, AVX2 or plain f64; the additions are the same, so are the sums).
struct ResampleSums<'a> {
    table: &'a PathTable,
    draws: &'a [usize],
    sums: &'a mut [f64],
}

impl WithSimd for ResampleSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        match self.table.block {
            8 => resample_sums::<S, 8>(simd, self.table, self.draws, self.sums),
            _ => resample_sums::<S, 16>(simd, self.table, self.draws, self.sums),
        }
    }
}

/// The column sums of the rows `draws` of `table`, whose blocks are `W` columns wide (a
/// multiple of the SIMD width).
#[inline(always)]
fn resample_sums<S: Simd, const W: usize>(
    simd: S, table: &PathTable, draws: &[usize], sums: &mut [f64],
) {
    let (blocks, _) = table.cells.as_chunks::<W>();
    for (block, sums) in blocks.chunks_exact(table.paths).zip(sums.chunks_mut(W)) {
        let partial = block_sums(simd, block, draws);
        for (c, s) in sums.iter_mut().enumerate() {
            *s = partial.iter().map(|lane| lane[c]).sum();
        }
    }
}

/// The partial sums of the rows `draws` of one block of columns: draw k added to partial
/// k mod [`PARTIALS`], in the order of the draws; each partial held in SIMD registers (W / the
/// SIMD width of them), one addition per register and draw.
#[inline(always)]
fn block_sums<S: Simd, const W: usize>(
    simd: S, block: &[[f64; W]], draws: &[usize],
) -> [[f64; W]; PARTIALS] {
    let zero = simd.splat_f64s(0.0);
    let mut partial = [[zero; W]; PARTIALS];
    let mut groups = draws.chunks_exact(PARTIALS);
    for group in &mut groups {
        for (lane, &i) in partial.iter_mut().zip(group) {
            add_row(simd, lane, &block[i]);
        }
    }
    for (lane, &i) in partial.iter_mut().zip(groups.remainder()) {
        add_row(simd, lane, &block[i]);
    }
    partial.map(|lane| {
        let mut out = [0.0; W];
        let (vectors, _) = S::as_mut_simd_f64s(&mut out);
        vectors.copy_from_slice(&lane[..vectors.len()]);
        out
    })
}

/// `lane += row`, register by register (the first W / SIMD width registers of `lane`). A
/// function, not a closure: it inherits the caller's instruction set.
#[inline(always)]
fn add_row<S: Simd, const W: usize>(simd: S, lane: &mut [S::f64s; W], row: &[f64; W]) {
    let (row, _) = S::as_simd_f64s(row);
    for (s, x) in lane.iter_mut().zip(row) {
        *s = simd.add_f64s(*s, *x);
    }
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

    /// The bootstrap as it was computed over whole rows: each draw's row added to partial sum
    /// k mod 4, the four partials summed in order.
    fn row_major(table: &PathTable, resamples: usize) -> Vec<Vec<f64>> {
        let (n, width) = (table.paths(), table.width());
        let mut rng = path_rng(BOOTSTRAP_SEED, n as u64);
        let mut out = Vec::new();
        // The draws of whole groups of four go round the partials; the rest fill the first.
        let full = n / PARTIALS * PARTIALS;
        for _ in 0..resamples {
            let mut partial = vec![vec![0.0; width]; PARTIALS];
            for k in 0..n {
                let row = table.row(index(rng.random::<u64>(), n));
                let lane = if k < full { k % PARTIALS } else { k - full };
                partial[lane]
                    .iter_mut()
                    .zip(&row)
                    .for_each(|(s, x)| *s += x);
            }
            out.push(
                (0..width)
                    .map(|c| partial.iter().map(|l| l[c]).sum())
                    .collect(),
            );
        }
        out
    }

    #[test]
    fn block_sums_are_the_row_sums_bit_for_bit() {
        // Widths within, at and across blocks; lengths off and on multiples of the partials.
        for (n, width) in [
            (1, 1),
            (5, 2),
            (7, 8),
            (10, 9),
            (1003, 44),
            (64, 17),
            (9, 16),
            (33, 33),
        ] {
            let table = PathTable::from_rows(n, width, |i, row| {
                for (c, x) in row.iter_mut().enumerate() {
                    *x = ((0.37 * i as f64 + 0.11 * c as f64).sin() * 1e3)
                        .exp2()
                        .ln_1p();
                }
            });
            assert_eq!(table.row(n - 1).len(), width);
            let ours = paired_bootstrap(&table, 7, |s| Some(s.to_vec()));
            for (a, b) in ours.iter().zip(row_major(&table, 7)) {
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(a), bits(&b), "n = {n}, width = {width}");
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
