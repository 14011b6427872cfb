//! The fused forms of an expression constraint (g with the cross Gram matrix, the cross Gram
//! matrix, the kappa coefficients of one quadratic equation: one compiled program each)
//! against the composed defaults of sdae-manifold (`cross_gram_by_products`,
//! `kappa_coefficients`) with a diagonal, non-unit M^-1: within 1e-13 relative on a double
//! pendulum (dense storage), a chain of bonds (tridiagonal, and dense with the entries off
//! the band), a circle (scalar, quadratic) and a torus (scalar, not quadratic); over lanes
//! (W = 1, 4, 8) bit for bit what one path computes; and, where the mass is offered as not
//! diagonal, the composed numbers themselves.

use pulp::{Simd, WithSimd};
use sdae_expr_system::{ExpressionConstraint, ExpressionSpec, ExpressionSystem};
use sdae_lanes::{LaneWidth, Lanes, Real};
use sdae_manifold::{
    DenseGram, Equations, GramShape, InverseMassOf, Scalar, SquareMatrix, Tridiagonal,
};

use crate::{base_spec, double_pendulum, near, torus};

/// Paths per check: two blocks of the widest lanes.
const PATHS: usize = 16;

/// Relative agreement of a fused form with its composition.
const TOLERANCE: f64 = 1e-13;

/// A diagonal M^-1 = diag(w), offered as diagonal (the fused programs run) or not (the
/// constraint composes its forms).
struct Inverse {
    w: Vec<f64>,
    diagonal: bool,
}

impl Inverse {
    /// A non-unit diagonal of n entries.
    fn new(n: usize, diagonal: bool) -> Self {
        let w = (0..n).map(|k| 0.45 + 0.3 * ((k * 7 % 5) as f64)).collect();
        Self { w, diagonal }
    }
}

impl<T: Real> InverseMassOf<T> for Inverse {
    fn apply_inverse(&self, x: &mut [T]) {
        for (xk, &wk) in x.iter_mut().zip(&self.w) {
            *xk = *xk * wk;
        }
    }
    fn diagonal_entry(&self, k: usize) -> Option<f64> {
        self.diagonal.then(|| self.w[k])
    }
    fn inverse_inner(&self, a: &[T], b: &[T], _: &mut [T]) -> T {
        let mut sum = a[0].splat_like(-0.0);
        for ((x, y), &wk) in a.iter().zip(b).zip(&self.w) {
            sum = sum + *x * *y * wk;
        }
        sum
    }
}

/// The m^2 entries of `matrix`, column j as A e_j.
fn entries<T: Real, Mx: SquareMatrix<T>>(matrix: &Mx, m: usize, like: T) -> Vec<T> {
    let (zero, one) = (like.splat_like(0.0), like.splat_like(1.0));
    let mut out = Vec::new();
    for j in 0..m {
        let mut unit = vec![zero; m];
        unit[j] = one;
        let mut column = vec![zero; m];
        matrix.product(&unit, &mut column);
        out.extend(column);
    }
    out
}

/// A point (x, r, y) of the hooks' arguments.
type Point<T> = [Vec<T>; 3];

/// g(x) and Dg(x) W Dg(r)^T (`value_and_cross_gram`), Dg(r) W Dg(x)^T (`cross_gram`) and
/// the kappa coefficients at (r, y) where there are, through the constraint's forms.
fn hooks<T: Real, Sh: GramShape>(
    g: &ExpressionConstraint<Sh>, inverse: &Inverse, [x, r, y]: &Point<T>,
) -> Vec<T> {
    let (n, m, like) = (g.dim(), g.n_constraints(), x[0]);
    let mut scratch = vec![like; n + 2 * m];
    let mut out = vec![like; m];
    let mut gram = Sh::Matrix::<T>::zeros_like(like, m);
    Equations::value_and_cross_gram(g, inverse, x, r, &mut scratch, &mut out, &mut gram);
    out.extend(entries(&gram, m, like));
    Equations::cross_gram(g, inverse, r, x, &mut scratch, &mut gram);
    out.extend(entries(&gram, m, like));
    out.extend(
        Equations::kappa_quadratic(g, inverse, r, y, &mut scratch)
            .into_iter()
            .flatten(),
    );
    out
}

/// The same by the composed defaults.
fn composed<Sh: GramShape>(
    g: &ExpressionConstraint<Sh>, inverse: &Inverse, [x, r, y]: &Point<f64>,
) -> Vec<f64> {
    let (n, m) = (g.dim(), g.n_constraints());
    let mut scratch = vec![0.0; n + 2 * m];
    let mut out = vec![0.0; m];
    Equations::value(g, x, &mut out);
    let mut gram = Sh::Matrix::<f64>::zeros_like(0.0, m);
    sdae_manifold::cross_gram_by_products(g, x, r, inverse, &mut scratch, &mut gram);
    out.extend(entries(&gram, m, 0.0));
    sdae_manifold::cross_gram_by_products(g, r, x, inverse, &mut scratch, &mut gram);
    out.extend(entries(&gram, m, 0.0));
    if g.is_quadratic() && m == 1 {
        let c = sdae_manifold::kappa_coefficients(g, r, y, inverse, &mut scratch);
        out.extend(c);
    }
    out
}

/// The hooks over lanes, W paths at a time.
struct OverLanes<'a, Sh: GramShape> {
    g: &'a ExpressionConstraint<Sh>,
    inverse: &'a Inverse,
    points: &'a [Point<f64>],
}

impl<Sh: GramShape> WithSimd for OverLanes<'_, Sh> {
    type Output = Vec<Vec<f64>>;
    fn with_simd<S: Simd>(self, simd: S) -> Vec<Vec<f64>> {
        let width = Lanes::<S>::WIDTH;
        let mut results = vec![Vec::new(); self.points.len()];
        for start in (0..self.points.len()).step_by(width) {
            let block = &self.points[start..start + width];
            let lanes = |which: usize| -> Vec<Lanes<S>> {
                (0..self.g.dim())
                    .map(|k| {
                        Lanes::load(simd, &block.iter().map(|p| p[which][k]).collect::<Vec<_>>())
                    })
                    .collect()
            };
            let rows = hooks(self.g, self.inverse, &[lanes(0), lanes(1), lanes(2)]);
            for (lane, result) in results[start..start + width].iter_mut().enumerate() {
                *result = rows.iter().map(|x| x.lane(lane)).collect();
            }
        }
        results
    }
}

/// Every check on constraint `g` of the system `name`, at points near `r0`, with a non-unit
/// diagonal M^-1 and with M = I (the unit's programs).
fn check<Sh: GramShape>(name: &str, g: &ExpressionConstraint<Sh>, r0: &[f64]) {
    let points: Vec<Point<f64>> = (0..PATHS)
        .map(|p| {
            [
                near(r0, p, 0.1),
                near(r0, p + 30, 0.1),
                near(r0, p + 60, 0.1),
            ]
        })
        .collect();
    let unit = Inverse {
        w: vec![1.0; g.dim()],
        diagonal: true,
    };
    for inverse in [Inverse::new(g.dim(), true), unit] {
        let one_path: Vec<Vec<f64>> = points.iter().map(|p| hooks(g, &inverse, p)).collect();
        for (p, (point, fused)) in points.iter().zip(&one_path).enumerate() {
            let expected = composed(g, &inverse, point);
            agree(
                &format!("{name}, w {:?}, path {p}", inverse.w),
                fused,
                &expected,
            );
            // Offered as not diagonal, the constraint composes: the composed numbers exactly.
            let composing = Inverse {
                diagonal: false,
                w: inverse.w.clone(),
            };
            let undivided = hooks(g, &composing, point);
            let same = undivided
                .iter()
                .zip(&expected)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{name}, path {p}: composed\n{undivided:?}\n{expected:?}"
            );
        }
        for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
            let found = width.dispatch(OverLanes {
                g,
                inverse: &inverse,
                points: &points,
            });
            for (p, (a, b)) in found.iter().zip(&one_path).enumerate() {
                let same =
                    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "{name}, {width:?}, path {p}:\n{a:?}\n{b:?}");
            }
        }
    }
}

/// `fused` agrees with `expected` entry by entry within [`TOLERANCE`] relative (to the entry
/// or the largest entry).
fn agree(what: &str, fused: &[f64], expected: &[f64]) {
    assert_eq!(fused.len(), expected.len(), "{what}: the same forms");
    let scale = expected.iter().fold(0.0f64, |s, e| s.max(e.abs()));
    for (k, (a, b)) in fused.iter().zip(expected).enumerate() {
        let close = (a - b).abs() <= TOLERANCE * b.abs().max(scale);
        assert!(close, "{what}, output {k}: fused {a:e}, composed {b:e}");
    }
}

/// A chain of `beads` beads in space with unit bonds written in order, on a zigzag.
fn chain(beads: usize) -> ExpressionSpec {
    let mut spec = base_spec(&[], &[], &[]);
    (spec.coordinates, spec.particles, spec.dimension) = (None, Some(beads), Some(3));
    spec.constraints = (1..beads)
        .map(|i| {
            let j = i + 1;
            format!("((x{j} - x{i})^2 + (y{j} - y{i})^2 + (z{j} - z{i})^2 - 1) / 2")
        })
        .collect();
    let (dx, dy) = ((2.0f64 / 3.0).sqrt(), (1.0f64 / 3.0).sqrt());
    spec.position = (0..beads)
        .flat_map(|i| [i as f64 * dx, if i % 2 == 1 { dy } else { 0.0 }, 0.0])
        .collect();
    spec
}

#[test]
fn fused_forms_equal_the_composed_forms_and_lanes_equal_one_path() {
    let pendulum = ExpressionSystem::compile(&double_pendulum()).unwrap();
    check(
        "double pendulum",
        pendulum.expression_constraint(),
        pendulum.initial_state().0,
    );
    let chain = ExpressionSystem::compile(&chain(5)).unwrap();
    let r0 = chain.initial_state().0;
    let banded = chain.with_shape::<Tridiagonal>().unwrap();
    check("chain (tridiagonal)", banded.expression_constraint(), r0);
    check("chain (dense)", chain.expression_constraint(), r0);
    let circle = ExpressionSystem::compile(&base_spec(
        &["x", "y"],
        &["(1 - (x^2 + y^2)) / 2"],
        &[0.6, 0.8],
    ))
    .unwrap()
    .with_shape::<Scalar>()
    .unwrap();
    assert!(circle.expression_constraint().is_quadratic());
    check(
        "circle",
        circle.expression_constraint(),
        circle.initial_state().0,
    );
    let torus = ExpressionSystem::compile(&torus())
        .unwrap()
        .with_shape::<Scalar>()
        .unwrap();
    assert!(!torus.expression_constraint().is_quadratic());
    check(
        "torus",
        torus.expression_constraint(),
        torus.initial_state().0,
    );
}

#[test]
fn a_dense_storage_of_a_banded_gram_is_zero_off_the_band() {
    let chain = ExpressionSystem::compile(&chain(5)).unwrap();
    let g = chain.expression_constraint();
    let (n, m) = (g.dim(), g.n_constraints());
    let x = near(chain.initial_state().0, 3, 0.1);
    let mut gram = DenseGram::zeros(m);
    for i in 0..m {
        for j in 0..m {
            gram.set(i, j, f64::NAN);
        }
    }
    let mut scratch = vec![0.0; n + 2 * m];
    Equations::cross_gram(g, &Inverse::new(n, true), &x, &x, &mut scratch, &mut gram);
    for i in 0..m {
        for j in 0..m {
            let entry = gram.get(i, j);
            match i.abs_diff(j) {
                0 | 1 => assert!(entry.is_finite() && entry != 0.0, "({i}, {j}): {entry}"),
                _ => assert_eq!(entry, 0.0, "({i}, {j})"),
            }
        }
    }
}
