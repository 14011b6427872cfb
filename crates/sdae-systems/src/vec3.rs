//! Vectors of R^3 of one path or of W paths: coordinate k of atom (or bead) a in `x[3a + k]`,
//! an `f64` for one path, a [`Lanes`](sdae_lanes::Lanes) for W paths (the layout of
//! [`System::drift`](sdae_model::System::drift) over lanes).
//!
//! The systems write their forces once over [`Real`], so that lane i of the lane form performs
//! the scalar form's floating-point operations for path i in the same order, bit for bit. The
//! loops are written out (no closures or array `map`): a closure does not inherit the
//! instruction set of the lane code that calls it.

use sdae_lanes::Real;

/// A vector of R^3.
pub(crate) type Vec3<T> = [T; 3];

/// Atom `a` of `x`.
#[inline(always)]
pub(crate) fn atom<T: Real>(x: &[T], a: usize) -> Vec3<T> {
    [x[3 * a], x[3 * a + 1], x[3 * a + 2]]
}

/// a - b.
#[inline(always)]
pub(crate) fn sub<T: Real>(a: Vec3<T>, b: Vec3<T>) -> Vec3<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a . b = a_0 b_0 + a_1 b_1 + a_2 b_2, summed in that order.
#[inline(always)]
pub(crate) fn dot<T: Real>(a: Vec3<T>, b: Vec3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a x b.
#[inline(always)]
pub(crate) fn cross<T: Real>(a: Vec3<T>, b: Vec3<T>) -> Vec3<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// force_a += f, except in the paths of `skip` (which keep their force unchanged, as for a
/// term that adds nothing there).
#[inline(always)]
pub(crate) fn add_to<T: Real>(force: &mut [T], a: usize, f: Vec3<T>, skip: T::Mask) {
    for (o, fk) in force[3 * a..3 * a + 3].iter_mut().zip(f) {
        *o = T::select(skip, *o, *o + fk);
    }
}

/// A check shared by the systems' tests: their lane forms against their scalar functions.
#[cfg(test)]
pub(crate) mod check {
    use pulp::{Simd, WithSimd};
    use sdae_lanes::{LaneWidth, Lanes};
    use sdae_model::System;

    /// Paths' states (r, v, dw) and the system whose lane forms are checked on them.
    struct Compare<'a, Sys> {
        system: &'a Sys,
        states: &'a [[Vec<f64>; 3]],
    }

    impl<Sys: System> WithSimd for Compare<'_, Sys> {
        type Output = ();
        fn with_simd<S: Simd>(self, simd: S) {
            let width = Lanes::<S>::WIDTH;
            for (g, group) in self.states.chunks(width).enumerate() {
                // Coordinate i of lane k: path k of the group (the last path repeated).
                let rows = |which: usize| -> Vec<Lanes<S>> {
                    let len = group[0][which].len();
                    (0..len)
                        .map(|i| {
                            let row: Vec<f64> = (0..width)
                                .map(|k| group[k.min(group.len() - 1)][which][i])
                                .collect();
                            Lanes::load(simd, &row)
                        })
                        .collect()
                };
                let (r, v, dw) = (rows(0), rows(1), rows(2));
                let mut drift = vec![Lanes::splat(simd, f64::NAN); r.len()];
                assert!(self.system.drift(&r, &v, &mut drift), "a lane form");
                let mut noise = drift.clone();
                assert!(self.system.add_noise(&r, &v, &dw, &mut noise));
                for (k, [r, v, dw]) in group.iter().enumerate() {
                    let mut expected = vec![0.0; r.len()];
                    self.system.drift(r, v, &mut expected);
                    let lane = |x: &[Lanes<S>]| -> Vec<u64> {
                        x.iter().map(|x| x.lane(k).to_bits()).collect()
                    };
                    let bits = |x: &[f64]| -> Vec<u64> { x.iter().map(|x| x.to_bits()).collect() };
                    assert_eq!(
                        lane(&drift),
                        bits(&expected),
                        "drift, W = {width}, path {}",
                        g * width + k
                    );
                    self.system.add_noise(r, v, dw, &mut expected);
                    assert_eq!(
                        lane(&noise),
                        bits(&expected),
                        "noise, W = {width}, path {}",
                        g * width + k
                    );
                }
            }
        }
    }

    /// `paths` states near `r0` (r0 moved by up to 0.1 per coordinate; velocities and
    /// increments of order 1 and 0.03), different for every path.
    pub(crate) fn states_near(r0: &[f64], paths: usize) -> Vec<[Vec<f64>; 3]> {
        (0..paths)
            .map(|p| {
                let wave = |scale: f64, shift: f64| -> Vec<f64> {
                    (0..r0.len())
                        .map(|i| scale * (1.3 * i as f64 + 0.7 * p as f64 + shift).sin())
                        .collect()
                };
                let r = r0.iter().zip(wave(0.1, 0.0)).map(|(x, d)| x + d).collect();
                [r, wave(1.0, 0.4), wave(0.03, 1.1)]
            })
            .collect()
    }

    /// Checks that `system`'s lane forms of the drift and the noise give, in every lane of
    /// every width (1, 4, 8 and this processor's best), the scalar functions' numbers bit for
    /// bit on each of `states` ([r, v, dw] per path).
    pub(crate) fn lane_forms_match_scalar<Sys: System>(system: &Sys, states: &[[Vec<f64>; 3]]) {
        for width in LaneWidth::ALL {
            width.dispatch(Compare { system, states });
        }
    }
}
