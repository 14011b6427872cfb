//! Value stability: the first Brownian increments of a path's stream are pinned to the bit, so
//! that an upgrade of the random-number crates cannot silently change every study's numbers.

use sdae_noise::{GaussianIncrements, IncrementSource};

#[test]
fn first_increments_of_a_path_are_pinned() {
    let mut source = GaussianIncrements::for_path(2026, 0, 2);
    let mut dw = [0.0; 2];
    let mut bits = Vec::new();
    for _ in 0..3 {
        source.next_increment(1.0, &mut dw);
        bits.extend(dw.iter().map(|x| x.to_bits()));
    }
    // dw_0 = (-1.2630..., 0.3996...), dw_1 = (-0.9082..., 1.9554...),
    // dw_2 = (-0.3623..., -0.7433...): standard normals (the path's streams and the 2048-layer
    // ziggurat of `PathStreams`), h = 1.
    let expected: [u64; 6] = [
        0xbff4358860e23aa5,
        0x3fd993fad747f890,
        0xbfed104751c5efde,
        0x3fff4999ee041dab,
        0xbfd730405204074d,
        0xbfe7c9407f945037,
    ];
    assert_eq!(bits, expected, "{bits:#018x?}");
    // At h = 1/4 the same normals are scaled by sqrt(h) = 1/2, exactly.
    let mut source = GaussianIncrements::for_path(2026, 0, 2);
    source.next_increment(0.25, &mut dw);
    assert_eq!(dw[0], 0.5 * f64::from_bits(expected[0]));
}
