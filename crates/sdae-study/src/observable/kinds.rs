//! The built-in observables of each system kind a scene can name: their names and their
//! functions f(r, v) of the state (the kinetic energy v^T M v / 2, which every kind has, is
//! built from the system's mass matrix by the module above this one).

use sdae_systems::{PendulumParams, RigidTriatomicParams};

/// The function of an observable: f(r, v).
pub(crate) use sdae_lockstep::ObservableFunction as Function;

/// The built-in observables of the pendulums: the cosine of the angle from the downward vertical
/// -r_d / rho, the height r_d, the energy |v|^2 / 2 + c_g r_d (unit mass), the cosine of the
/// angle turned since the start r . r_0 / rho^2, and the kinetic energy |v|^2 / 2.
pub const PENDULUM: [&str; 5] = [
    "cos_angle",
    "height",
    "energy",
    "cos_turn",
    "kinetic_energy",
];

/// The built-in observables of molecules (chain molecule, triatomic): the end-to-end distance
/// |r_last - r_first|, the cosine of the bond angle at atom 1 and the kinetic energy
/// v^T M v / 2.
pub const MOLECULE: [&str; 3] = ["end_to_end", "cos_bond_angle", "kinetic_energy"];

/// The built-in observables of the rigid triatomic: those of [`MOLECULE`] and the squared
/// distance |X - c|^2 of the mean X of the atoms' positions from the trap's centre c.
pub const TRIATOMIC: [&str; 4] = [
    "end_to_end",
    "cos_bond_angle",
    "kinetic_energy",
    "centroid_distance_squared",
];

/// The built-in observables of the fiber: the coordinates of its last bead (the tip), the
/// end-to-end distance, the mean squared curvature over the inner beads
/// (1 / (K - 2)) sum_i |u_i - u_(i-1)|^2 / ds_i^2 (u_i the unit tangent of segment i, ds_i the
/// mean length of the two segments at bead i) and the kinetic energy v^T M v / 2.
pub const FIBER: [&str; 6] = [
    "tip_x",
    "tip_y",
    "tip_z",
    "end_to_end",
    "mean_squared_curvature",
    "kinetic_energy",
];

/// The pendulum's observables ([`PENDULUM`]) but the kinetic energy, given the initial
/// position r0.
pub(crate) fn pendulum(p: &PendulumParams, name: &str, r0: &[f64]) -> Option<Box<Function>> {
    let (d, rho, g) = (p.dim, p.length, p.gravity);
    Some(match name {
        "cos_angle" => Box::new(move |r, _| -r[d - 1] / rho),
        "height" => Box::new(move |r, _| r[d - 1]),
        "energy" => Box::new(move |r, v| 0.5 * dot(v, v) + g * r[d - 1]),
        "cos_turn" => {
            let (r0, rho2) = (r0.to_vec(), rho * rho);
            Box::new(move |r, _| dot(r, &r0) / rho2)
        }
        _ => return None,
    })
}

/// The observables of a chain of beads ([`MOLECULE`]) but the kinetic energy: the end-to-end
/// distance and the cosine of the angle at bead 1.
pub(crate) fn chain(name: &str) -> Option<Box<Function>> {
    Some(match name {
        "end_to_end" => Box::new(|r, _| {
            let beads = r.len() / 3;
            distance(bead(r, 0), bead(r, beads - 1))
        }),
        "cos_bond_angle" => Box::new(|r, _| {
            let (a, b) = (
                difference(bead(r, 0), bead(r, 1)),
                difference(bead(r, 2), bead(r, 1)),
            );
            dot(&a, &b) / (dot(&a, &a) * dot(&b, &b)).sqrt()
        }),
        _ => return None,
    })
}

/// The rigid triatomic's observables ([`TRIATOMIC`]) but the kinetic energy: those of a chain
/// and |X - c|^2.
pub(crate) fn triatomic(p: &RigidTriatomicParams, name: &str) -> Option<Box<Function>> {
    if name != "centroid_distance_squared" {
        return chain(name);
    }
    let centre = p.trap.center;
    Some(Box::new(move |r, _| {
        let atoms = r.len() / 3;
        (0..3)
            .map(|i| {
                let mean = (0..atoms).map(|a| r[3 * a + i]).sum::<f64>() / atoms as f64;
                (mean - centre[i]) * (mean - centre[i])
            })
            .sum()
    }))
}

/// The fiber's observables ([`FIBER`]) but the kinetic energy: the tip's coordinates, the
/// end-to-end distance and the mean squared curvature.
pub(crate) fn fiber(name: &str) -> Option<Box<Function>> {
    Some(match name {
        "tip_x" | "tip_y" | "tip_z" => {
            let axis = usize::from(name == "tip_y") + 2 * usize::from(name == "tip_z");
            Box::new(move |r, _| r[r.len() - 3 + axis])
        }
        "mean_squared_curvature" => Box::new(|r, _| curvature(r)),
        "end_to_end" => return chain(name),
        _ => return None,
    })
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Bead i of a chain (coordinates 3i..3i+3).
fn bead(r: &[f64], i: usize) -> &[f64] {
    &r[3 * i..3 * i + 3]
}

/// a - b.
fn difference(a: &[f64], b: &[f64]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// |a - b|.
fn distance(a: &[f64], b: &[f64]) -> f64 {
    let d = difference(a, b);
    dot(&d, &d).sqrt()
}

/// (1 / (K - 2)) sum over the inner beads i of |u_i - u_(i-1)|^2 / ds_i^2, with u_i the unit
/// tangent of segment i (bead i to i + 1) and ds_i the mean length of segments i - 1 and i
/// (0 for fewer than 3 beads).
fn curvature(r: &[f64]) -> f64 {
    let beads = r.len() / 3;
    if beads < 3 {
        return 0.0;
    }
    let segment = |i: usize| {
        let d = difference(bead(r, i + 1), bead(r, i));
        let length = dot(&d, &d).sqrt();
        (d.map(|x| x / length), length)
    };
    let mut sum = 0.0;
    let mut before = segment(0);
    for i in 1..beads - 1 {
        let after = segment(i);
        let turn = difference(&after.0, &before.0);
        let ds = 0.5 * (before.1 + after.1);
        sum += dot(&turn, &turn) / (ds * ds);
        before = after;
    }
    sum / (beads - 2) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curvature_of_a_circle_is_one_over_radius_squared() {
        // Beads on a circle of radius 2, 1 degree apart: |u_i - u_(i-1)| / ds -> 1 / R.
        let (radius, step) = (2.0, 1f64.to_radians());
        let r: Vec<f64> = (0..30)
            .flat_map(|i| {
                let a = i as f64 * step;
                [radius * a.cos(), radius * a.sin(), 0.0]
            })
            .collect();
        let k2 = curvature(&r);
        assert!((k2 - 0.25).abs() < 1e-4, "{k2}");
        // A straight chain has none.
        let straight: Vec<f64> = (0..5).flat_map(|i| [0.0, 0.0, -(i as f64)]).collect();
        assert_eq!(curvature(&straight), 0.0);
    }
}
