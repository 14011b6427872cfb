//! Value stability: the first Brownian increments of a path's stream, and the first scrambled
//! Sobol' points and quasi-random increments of a randomization, are pinned to the bit, so that
//! an upgrade of the random-number crates (or of the `sobol` crate's parameters) cannot
//! silently change every study's numbers.

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

#[test]
fn first_scrambled_sobol_points_and_quasi_increments_are_pinned() {
    use sdae_noise::{QuasiBrownian, SobolPoints};
    // Randomization 0 of study 2026 (its scrambles and shifts come from the sobol crate's
    // parameters and the xoshiro256++ stream of the randomization).
    let points = SobolPoints::scrambled(3, 2026, 0).unwrap();
    let bits: Vec<u64> = (0..2)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .map(|(i, j)| points.coordinate_bits(i, j))
        .collect();
    // Point 0 is the shifts e_j, point 1 the shifts ^ the scrambled first direction numbers.
    let expected_points: [u64; 6] = [
        0x54a60770cd94c440,
        0x5555e2454dd28cc3,
        0xcbd36aa6820f1297,
        0x9f7bfc95d2e9621b,
        0xf0151d40f65cc86e,
        0x7a03a0e8c8a60002,
    ];
    assert_eq!(bits, expected_points, "{bits:#018x?}");
    let quasi = QuasiBrownian::with_quasi_limit(2026, 0, 2, 2, 3).unwrap();
    let mut unit = [0.0; 4];
    quasi.unit_increments(1, &mut unit).unwrap();
    let bits: Vec<u64> = unit.iter().map(|x| x.to_bits()).collect();
    // dw_0 = (0.1800..., 1.3163...), dw_1 = (0.2630..., 0.8569...) over unit steps: coordinates
    // 0..3 quasi-random (AS 241 of the scrambled points), coordinate 3 the first normal of the
    // padding streams, ordered by the two-step bridge per component.
    let expected_increments: [u64; 4] = [
        0x3fc70d3c39588c34,
        0x3ff50fe6ee1810fc,
        0x3fd0d56cc6c51ae1,
        0x3feb6bc1eade3000,
    ];
    assert_eq!(bits, expected_increments, "{bits:#018x?}");
}
