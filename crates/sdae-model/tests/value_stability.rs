//! Value stability: the first Brownian increments of a path's stream are pinned to the bit, so
//! that an upgrade of the random-number crates cannot silently change every study's numbers.

use sdae_model::{GaussianIncrements, IncrementSource};

#[test]
fn first_increments_of_a_path_are_pinned() {
    let mut source = GaussianIncrements::for_path(2026, 0, 2);
    let mut dw = [0.0; 2];
    let mut bits = Vec::new();
    for _ in 0..3 {
        source.next_increment(1.0, &mut dw);
        bits.extend(dw.iter().map(|x| x.to_bits()));
    }
    // dw_0 = (-0.8687..., 0.7489...), dw_1 = (-1.8031..., 1.4864...),
    // dw_2 = (-0.1226..., -0.5952...): standard normals, h = 1.
    let expected: [u64; 6] = [
        0xbfebcc87cfd25fa5,
        0x3fe7f74a2fdc899a,
        0xbffcd9840e403ec8,
        0x3ff7c854c5921346,
        0xbfbf63a2577abb6c,
        0xbfe30c208731d71b,
    ];
    assert_eq!(bits, expected, "{bits:#018x?}");
    // At h = 1/4 the same normals are scaled by sqrt(h) = 1/2, exactly.
    let mut source = GaussianIncrements::for_path(2026, 0, 2);
    source.next_increment(0.25, &mut dw);
    assert_eq!(dw[0], 0.5 * f64::from_bits(expected[0]));
}
