//! A bead chain's Gram matrix G_M = Dg M^-1 grad g is tridiagonal only for masses whose inverse
//! couples no two beads: such masses are refused, naming the coupling; masses block-diagonal
//! per bead keep the tridiagonal storage, and it matches the dense product entry by entry.

use sdae_manifold::{
    BeadChain, Constraint, DenseGram, DenseMass, GramMatrix, ManifoldError, Mass, TridiagonalGram,
    assemble_dense_by_columns, scratch_len,
};

const BEADS: usize = 6;

/// I + c (coupling of each coordinate of bead j to the same coordinate of bead j + 1).
fn neighbour_coupled(c: f64) -> DenseMass {
    let n = 3 * BEADS;
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        m[i * n + i] = 1.0;
        if i + 3 < n {
            m[i * n + i + 3] = c;
            m[(i + 3) * n + i] = c;
        }
    }
    DenseMass::new(n, m).unwrap()
}

/// A different SPD 3 x 3 block per bead, nothing between beads.
fn block_diagonal() -> DenseMass {
    let n = 3 * BEADS;
    let mut m = vec![0.0; n * n];
    for b in 0..BEADS {
        let (d, o) = (2.0 + b as f64 * 0.5, 0.3 + 0.1 * b as f64);
        let block = [[d, o, 0.1], [o, d + 1.0, -0.2], [0.1, -0.2, d + 0.5]];
        for (i, row) in block.iter().enumerate() {
            for (j, &x) in row.iter().enumerate() {
                m[(3 * b + i) * n + 3 * b + j] = x;
            }
        }
    }
    DenseMass::new(n, m).unwrap()
}

#[test]
fn a_mass_that_couples_beads_is_refused_with_the_coupling() {
    let chain = BeadChain::new(BEADS, 0.2).unwrap();
    match chain.check_mass(&neighbour_coupled(0.3)) {
        Err(ManifoldError::CoupledMass {
            first,
            second,
            row,
            col,
            entry,
        }) => {
            assert_eq!(second, first + 1, "neighbouring beads");
            assert_eq!((row / 3).abs_diff(col / 3), 1);
            assert!(entry.abs() > 0.1, "{entry}");
        }
        other => panic!("{other:?}"),
    }
    // A weaker coupling is still a coupling.
    assert!(matches!(
        chain.check_mass(&neighbour_coupled(1e-6)),
        Err(ManifoldError::CoupledMass { .. })
    ));
}

#[test]
fn a_mass_block_diagonal_per_bead_keeps_the_tridiagonal_gram() {
    let chain = BeadChain::new(BEADS, 0.2).unwrap();
    let mass = block_diagonal();
    chain.check_mass(&mass).unwrap();
    let (n, m) = (chain.dim(), chain.n_constraints());
    let x1 = chain.zigzag(0.4);
    let x2 = chain.zigzag(0.3);
    let mut scratch = vec![0.0; scratch_len(n, m)];
    let mut gram = TridiagonalGram::zeros(m);
    chain.cross_gram(&x1, &x2, &mass, &mut scratch, &mut gram);
    let mut dense = DenseGram::zeros(m);
    assemble_dense_by_columns(&chain, &x1, &x2, &mass, &mut scratch, &mut dense);
    let scale = (0..m).map(|i| dense.entry(i, i).abs()).fold(0.0, f64::max);
    for i in 0..m {
        for j in 0..m {
            let (a, b) = (gram.entry(i, j), dense.entry(i, j));
            assert!(
                (a - b).abs() <= 1e-12 * scale,
                "G[{i}][{j}]: tridiagonal {a}, dense {b}"
            );
        }
    }
    // The mass is not the identity in disguise: the Gram differs from the identity mass's.
    let mut unit = TridiagonalGram::zeros(m);
    chain.cross_gram(
        &x1,
        &x2,
        &sdae_manifold::IdentityMass,
        &mut scratch,
        &mut unit,
    );
    assert!((unit.entry(0, 0) - gram.entry(0, 0)).abs() > 0.1 * scale);
    const { assert!(!DenseMass::DIAGONAL) };
}
