//! Which bits of a saved file the tests flip: a checksummed file must refuse each of them.

/// Bits to flip in a file of `len` bytes: in each of its first and last 64 bytes (the format
/// line, the header's frame, the checksums at the end) and 60 spread over the rest.
pub fn sampled_bits(len: usize) -> Vec<usize> {
    let ends = (0..64.min(len)).chain(len.saturating_sub(64)..len);
    let spread = (0..60).map(|k| k * len / 60);
    let mut bytes: Vec<usize> = ends.chain(spread).collect();
    bytes.sort_unstable();
    bytes.dedup();
    bytes.into_iter().map(|b| b * 8 + b % 8).collect()
}
