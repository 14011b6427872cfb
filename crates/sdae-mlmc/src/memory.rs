//! The memory rule: a run is refused before it starts when the blocks of samples it would
//! keep do not fit in the memory available.

use crate::block::{BLOCK, BlockKey};
use crate::sums::LevelSums;

/// Bytes a run holds for each block of samples it takes: the block's index and sums while its
/// level runs, and its key and sums in the checkpoint's journal (which keeps every block of
/// the run).
pub const BLOCK_BYTES: u64 =
    (size_of::<u64>() + 2 * size_of::<LevelSums>() + size_of::<BlockKey>()) as u64;

/// `None` when a run that takes `samples` samples per level (counts as reals: predicted ones
/// may be huge, infinite or not a number, which counts as infinite) fits in the memory
/// available, else the rule it breaks: the samples and blocks it needs and the bytes they take
/// ([`BLOCK_BYTES`] per block of [`BLOCK`] samples), against what the machine has.
/// Overflow-free: the count is summed in f64 and compared before it is converted.
pub fn samples_exceed_memory(samples: &[f64], what: &str) -> Option<String> {
    let block = BLOCK as f64;
    // A count that is not a number is no count a run can hold.
    let count = |n: f64| {
        if n.is_nan() {
            f64::INFINITY
        } else {
            n.max(0.0)
        }
    };
    let blocks: f64 = samples.iter().map(|&n| (count(n) / block).ceil()).sum();
    let total: f64 = samples.iter().map(|&n| count(n)).sum();
    let (limit, source) = sdae_stats::memory::available();
    let bytes = blocks * BLOCK_BYTES as f64;
    (bytes.is_nan() || bytes > limit as f64).then(|| {
        format!(
            "{what} take {total:.3e} samples in {blocks:.3e} blocks of {}, which need at least \
             {}, more than the {} available ({source})",
            BLOCK,
            if bytes < u64::MAX as f64 {
                sdae_stats::memory::bytes(bytes as u64)
            } else {
                format!("{bytes:.3e} B")
            },
            sdae_stats::memory::bytes(limit)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_counts_beyond_the_memory_are_named_without_overflow() {
        assert_eq!(samples_exceed_memory(&[4096.0; 7], "the test"), None);
        for huge in [1e12, 1e18, 1e300, f64::INFINITY, f64::NAN] {
            let rule = samples_exceed_memory(&[1024.0, huge], "the plan's levels")
                .unwrap_or_else(|| panic!("{huge} samples accepted"));
            assert!(rule.starts_with("the plan's levels take "), "{rule}");
            assert!(rule.contains("available"), "{rule}");
        }
        // The bytes of a block: its index, its sums twice (in flight and in the journal), its
        // key.
        assert!(BLOCK_BYTES >= 8 + 2 * size_of::<LevelSums>() as u64);
    }
}
