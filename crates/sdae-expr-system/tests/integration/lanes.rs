//! The compiled programs over lanes (W = 1, 4, 8) against one path in f64, bit for bit: g,
//! Dg u, Dg^T z, D^2 g(u, w), the drift, the noise and the observables of the three test
//! systems, on paths of different states.

use pulp::{Simd, WithSimd};
use sdae_expr_system::ExpressionSystem;
use sdae_lanes::{LaneWidth, Lanes};
use sdae_manifold::Equations;

use crate::{near, systems};

/// Paths per check: two blocks of the widest lanes.
const PATHS: usize = 16;

/// What one path of each quantity computes, all outputs in a row.
fn one_path(system: &ExpressionSystem, inputs: &[Vec<f64>; 5]) -> Vec<f64> {
    let [r, v, u, w, z] = inputs;
    let g = system.expression_constraint();
    let (n, m) = (g.dim(), g.n_constraints());
    let mut out = vec![0.0; 3 * m + 3 * n + system.observable_names().len()];
    let (values, rest) = out.split_at_mut(m);
    Equations::value(g, r, values);
    let (product, rest) = rest.split_at_mut(m);
    Equations::jacobian_mul(g, r, u, product);
    let (transpose, rest) = rest.split_at_mut(n);
    Equations::jacobian_transpose_mul(g, r, &z[..m], transpose);
    let (second, rest) = rest.split_at_mut(m);
    Equations::second_derivative(g, r, u, w, second);
    let (drift, rest) = rest.split_at_mut(n);
    system.evaluate_drift(r, v, drift);
    let (noise, rest) = rest.split_at_mut(n);
    noise.copy_from_slice(&w[..n]);
    system.evaluate_noise(r, v, u, noise);
    for (o, name) in rest.iter_mut().zip(system.observable_names()) {
        *o = system.observable(name).unwrap().value(r, v);
    }
    out
}

/// The same quantities over lanes, W paths at a time.
struct OverLanes<'a> {
    system: &'a ExpressionSystem,
    paths: &'a [[Vec<f64>; 5]],
}

impl WithSimd for OverLanes<'_> {
    type Output = Vec<Vec<f64>>;
    fn with_simd<S: Simd>(self, simd: S) -> Vec<Vec<f64>> {
        let width = Lanes::<S>::WIDTH;
        let g = self.system.expression_constraint();
        let (n, m) = (g.dim(), g.n_constraints());
        let names = self.system.observable_names();
        let mut results = vec![Vec::new(); self.paths.len()];
        for start in (0..self.paths.len()).step_by(width) {
            let block = &self.paths[start..start + width];
            let lanes = |slot: usize, len: usize| -> Vec<Lanes<S>> {
                (0..len)
                    .map(|i| {
                        let column: Vec<f64> = block.iter().map(|p| p[slot][i]).collect();
                        Lanes::load(simd, &column)
                    })
                    .collect()
            };
            let (r, v, u, w, z) = (
                lanes(0, n),
                lanes(1, n),
                lanes(2, n),
                lanes(3, n),
                lanes(4, m),
            );
            let zero = Lanes::splat(simd, 0.0);
            let mut rows = vec![zero; 3 * m + 3 * n + names.len()];
            let (values, rest) = rows.split_at_mut(m);
            Equations::value(g, &r, values);
            let (product, rest) = rest.split_at_mut(m);
            Equations::jacobian_mul(g, &r, &u, product);
            let (transpose, rest) = rest.split_at_mut(n);
            Equations::jacobian_transpose_mul(g, &r, &z, transpose);
            let (second, rest) = rest.split_at_mut(m);
            Equations::second_derivative(g, &r, &u, &w, second);
            let (drift, rest) = rest.split_at_mut(n);
            self.system.evaluate_drift(&r, &v, drift);
            let (noise, rest) = rest.split_at_mut(n);
            noise.copy_from_slice(&w);
            self.system.evaluate_noise(&r, &v, &u, noise);
            for (o, name) in rest.iter_mut().zip(&names) {
                *o = self.system.observable(name).unwrap().evaluate(&r, &v);
            }
            for (lane, result) in results[start..start + width].iter_mut().enumerate() {
                *result = rows.iter().map(|x| x.lane(lane)).collect();
            }
        }
        results
    }
}

#[test]
fn lanes_compute_what_one_path_computes_bit_for_bit() {
    for (name, system) in systems() {
        let n = system.coordinates().len();
        let r0 = system.initial_state().0;
        let paths: Vec<[Vec<f64>; 5]> = (0..PATHS)
            .map(|p| {
                let zero = vec![0.0; n];
                [
                    near(r0, p, 0.1),
                    near(&zero, p + 40, 1.0),
                    near(&zero, p + 80, 1.0),
                    near(&zero, p + 120, 1.0),
                    near(&zero, p + 160, 1.0),
                ]
            })
            .collect();
        let expected: Vec<Vec<f64>> = paths.iter().map(|p| one_path(&system, p)).collect();
        for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
            let found = width.dispatch(OverLanes {
                system: &system,
                paths: &paths,
            });
            for (p, (a, b)) in found.iter().zip(&expected).enumerate() {
                let same =
                    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "{name}, {width:?}, path {p}:\n{a:?}\n{b:?}");
            }
        }
    }
}
