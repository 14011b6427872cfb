//! Closed forms of configurational averages under the invariant measure of constrained
//! Langevin dynamics, exp(-V / kT) times the volume the mass metric induces on the constraint
//! manifold: what the equipartition study measures the schemes' invariant-measure bias
//! against.
//!
//! - The Gibbs pendulum (unit mass, length rho, gravity c_g, kT = sigma^2 / (2 gamma)), with
//!   k = c_g rho / kT: the planar E[cos phi] = I1(k) / I0(k); the spherical
//!   E[cos phi] = coth(k) - 1 / k.
//! - The rigid triatomic in the trap V = sum_a k_t / 2 |x_a - c|^2: a rigid body's volume is
//!   constant in (centre of mass, orientation), and V = 3 k_t / 2 |X - c|^2 + const with X the
//!   mean of the atoms' positions, Gaussian with covariance kT / (3 k_t) for every orientation:
//!   E[|X - c|^2] = kT / k_t.
//! - The rigid trimer (three equal masses, two rigid bonds, a bond-angle potential V(theta)):
//!   in the directions of the two bonds, the induced volume carries the factor
//!   sqrt(4 - cos^2 theta) (a Gram determinant), and cos theta is uniform under the bond
//!   directions' area measure, so cos theta has the density proportional to
//!   sqrt(4 - x^2) exp(-V(arccos x) / kT) on [-1, 1]; its mean by quadrature.

use sdae_systems::{ChainMoleculeParams, Masses, PendulumParams, RigidTriatomicParams};

/// The Gibbs pendulum's E[cos phi] with k = c_g rho / kT, kT = sigma^2 / (2 gamma): planar
/// I1(k) / I0(k), spherical coth(k) - 1 / k; None without friction or noise.
pub(crate) fn pendulum_cos_angle(p: &PendulumParams) -> Option<f64> {
    if !(p.friction > 0.0 && p.noise > 0.0) {
        return None;
    }
    let kt = p.noise * p.noise / (2.0 * p.friction);
    let k = p.gravity * p.length / kt;
    Some(match p.dim {
        2 => bessel_i(1, k) / bessel_i(0, k),
        _ if k == 0.0 => 0.0,
        _ => 1.0 / k.tanh() - 1.0 / k,
    })
}

/// The trapped rigid triatomic's E[|X - c|^2] = kT / k_t; None without a trap or temperature.
pub(crate) fn triatomic_centroid_distance(p: &RigidTriatomicParams) -> Option<f64> {
    (p.trap.stiffness > 0.0 && p.temperature > 0.0).then(|| p.temperature / p.trap.stiffness)
}

/// The rigid trimer's E[cos theta] under the bond-angle potential k / 2 (theta - theta0)^2,
/// for three equal masses at a positive temperature; None for other chain molecules.
pub(crate) fn trimer_cos_bond_angle(p: &ChainMoleculeParams) -> Option<f64> {
    let equal_masses = match &p.masses {
        Masses::Uniform(_) => true,
        Masses::PerParticle(m) => m.iter().all(|x| *x == m[0]),
    };
    (p.atoms == 3 && equal_masses && p.temperature > 0.0).then(|| {
        let (k, theta0, kt) = (p.angle.stiffness, p.angle.equilibrium, p.temperature);
        trimer_cos_angle(|x| {
            let theta = x.clamp(-1.0, 1.0).acos();
            0.5 * k * (theta - theta0) * (theta - theta0) / kt
        })
    })
}

/// The modified Bessel function I_n(x) of the first kind for integer n >= 0 and x >= 0, by its
/// power series sum_j (x/2)^(2j + n) / (j! (j + n)!), summed until the terms no longer change
/// the sum (x up to a few hundred).
pub fn bessel_i(n: u32, x: f64) -> f64 {
    let half = 0.5 * x;
    let mut term = (1..=n).fold(1.0, |t, i| t * half / f64::from(i));
    let mut sum = term;
    for j in 1..10_000 {
        term *= half * half / (f64::from(j) * f64::from(j + n));
        sum += term;
        if term < sum * f64::EPSILON {
            break;
        }
    }
    sum
}

/// <x> under the density proportional to sqrt(4 - x^2) exp(-u(x)) on [-1, 1], by composite
/// Simpson's rule on 20 000 intervals.
fn trimer_cos_angle(u: impl Fn(f64) -> f64) -> f64 {
    const INTERVALS: usize = 20_000;
    let step = 2.0 / INTERVALS as f64;
    let (mut norm, mut first) = (0.0, 0.0);
    for i in 0..=INTERVALS {
        let x = -1.0 + step * i as f64;
        let weight = match i {
            0 | INTERVALS => 1.0,
            _ if i % 2 == 1 => 4.0,
            _ => 2.0,
        };
        let density = (4.0 - x * x).sqrt() * (-u(x)).exp();
        norm += weight * density;
        first += weight * x * density;
    }
    first / norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SystemSpec;

    #[test]
    fn bessel_values_match_tables() {
        // Abramowitz and Stegun, Table 9.8.
        assert!((bessel_i(0, 1.0) - 1.266_065_877_752_008).abs() < 1e-14);
        assert!((bessel_i(1, 1.0) - 0.565_159_103_992_485).abs() < 1e-14);
        assert!((bessel_i(1, 4.0) - 9.759_465_153_704_45).abs() < 1e-12);
        assert_eq!(bessel_i(1, 0.0), 0.0);
    }

    #[test]
    fn gibbs_pendulum_mean_cosine() {
        let planar = SystemSpec::Pendulum(PendulumParams {
            dim: 2,
            length: 1.0,
            gravity: 4.0,
            noise: 2.0,
            friction: 2.0,
        });
        let exact = planar.exact_average("cos_angle").unwrap();
        assert!((exact - bessel_i(1, 4.0) / bessel_i(0, 4.0)).abs() < 1e-15);
        // Without friction there is no temperature.
        let cold = SystemSpec::Pendulum(PendulumParams {
            friction: 0.0,
            ..PendulumParams::default()
        });
        assert_eq!(cold.exact_average("cos_angle"), None);
    }

    /// Without a potential the trimer's cos theta has the density sqrt(4 - x^2) / norm, which
    /// is even: mean 0; with a stiff angle potential the mean is near cos theta0.
    #[test]
    fn trimer_law_limits() {
        assert!(trimer_cos_angle(|_| 0.0).abs() < 1e-12);
        let theta0: f64 = 1.9;
        let stiff = trimer_cos_angle(|x| 0.5 * 1e4 * (x.acos() - theta0).powi(2));
        assert!((stiff - theta0.cos()).abs() < 1e-3, "{stiff}");
    }
}
