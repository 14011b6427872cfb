//! The coefficients of the inherent SDE (seed eq. 2.4) and the multiplier increment (eq. 2.3)
//! against closed forms for the planar unit pendulum (seed Section 5.1), and the hidden
//! constraint d/dt Dg(r) v = 0 for a bead chain with a diagonal mass (m > 1).

use crate::common;

use sdae_ift::SolverSettings;
use sdae_manifold::{BeadChain, Constraint, Curvature, DiagonalMass};
use sdae_model::{AdditiveNoise, MechanicalSystem, System, TangentProjector};
use sdae_reference::InherentSde;

/// States on the circle and off it (the coefficients are the natural extension, Lemma 4.2).
const STATES: [([f64; 2], [f64; 2]); 4] = [
    ([1.0, 0.0], [0.0, 0.5]),
    ([0.6, -0.8], [1.6, 1.2]),
    ([-0.28, 0.96], [-2.88, -0.84]),
    ([1.1, 0.3], [0.7, -1.9]),
];

fn close(what: &str, got: &[f64], want: &[f64], tol: f64) {
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol,
            "{what}[{i}]: {g} vs {w} (diff {:e})",
            g - w
        );
    }
}

#[test]
fn pendulum_drift_diffusion_and_multiplier_match_closed_forms() {
    let dw = [0.3, -0.7];
    let h = 0.01;
    for gravity in [0.0, 1.0] {
        let mut sde = InherentSde::new(common::planar(gravity, 1.0)).unwrap();
        for (r, v) in STATES {
            let r2 = r[0] * r[0] + r[1] * r[1];
            let v2 = v[0] * v[0] + v[1] * v[1];
            let a = [0.0, -gravity];
            let ra = r[0] * a[0] + r[1] * a[1];
            // Drift: P a - |v|^2 r / |r|^2 with P = I - r r^T / |r|^2 (c_g = 0: -|v|^2 r/|r|^2).
            let drift_exact = [
                a[0] - ra * r[0] / r2 - v2 * r[0] / r2,
                a[1] - ra * r[1] / r2 - v2 * r[1] / r2,
            ];
            let (mut drift, mut rate) = ([0.0; 2], [0.0; 1]);
            sde.drift(&r, &v, &mut drift, &mut rate).unwrap();
            close("drift", &drift, &drift_exact, 1e-14);
            // mu rate of eq. 2.3: grad g = -r, G = |r|^2, D^2 g(v, v) = -|v|^2.
            close("mu rate", &rate, &[(ra + v2) / r2], 1e-14);
            // Diffusion: (I - r r^T / |r|^2) dw.
            let rw = r[0] * dw[0] + r[1] * dw[1];
            let diffusion_exact = [dw[0] - rw * r[0] / r2, dw[1] - rw * r[1] / r2];
            let mut diffusion = [0.0; 2];
            sde.diffusion(&r, &v, &dw, &mut diffusion).unwrap();
            close("diffusion", &diffusion, &diffusion_exact, 1e-14);
            // Multiplier increment: dmu = (r . (a h + dw) + |v|^2 h) / |r|^2, and the matching
            // velocity increment M^-1 [a h + dw + grad g dmu] = a h + dw - r dmu.
            let dmu_exact = (ra * h + rw + v2 * h) / r2;
            let (mut dv, mut dmu) = ([0.0; 2], [0.0; 1]);
            sde.multiplier_increment(&r, &v, h, &dw, &mut dv, &mut dmu)
                .unwrap();
            close("dmu", &dmu, &[dmu_exact], 1e-14);
            let dv_exact = [
                a[0] * h + dw[0] - r[0] * dmu_exact,
                a[1] * h + dw[1] - r[1] * dmu_exact,
            ];
            close("dv", &dv, &dv_exact, 1e-14);
            let dv_parts: Vec<f64> = (0..2).map(|i| drift[i] * h + diffusion[i]).collect();
            close("dv = drift h + diffusion", &dv, &dv_parts, 1e-14);
        }
    }
}

#[test]
fn chain_drift_keeps_the_hidden_constraint_and_diffusion_is_tangent() {
    // Along the inherent SDE, d(Dg(r) v) = [D^2 g(v, v) + Dg accel] dt + Dg(M^-1 P_M B) dw = 0.
    let beads = 6;
    let chain = BeadChain::new(beads, 0.2).unwrap();
    let n = chain.dim();
    let m = chain.n_constraints();
    let masses: Vec<f64> = (0..beads).map(|i| 1.0 + 0.3 * i as f64).collect();
    let mass = DiagonalMass::per_particle(&masses, 3).unwrap();
    let gravity = |_r: &[f64], v: &[f64], out: &mut [f64]| {
        for (i, o) in out.iter_mut().enumerate() {
            *o = -0.1 * v[i] - if i % 3 == 2 { 1.0 } else { 0.0 };
        }
    };
    let system =
        MechanicalSystem::new(chain, mass, gravity, AdditiveNoise::new(0.7, n).unwrap()).unwrap();
    let mut sde = InherentSde::new(system).unwrap();
    let r = sde.system().constraint().zigzag(0.4);
    // A tangent velocity: project an arbitrary one.
    let mut v: Vec<f64> = (0..n).map(|i| ((i * 7 % 5) as f64 - 2.0) * 0.3).collect();
    let c = *sde.system().constraint();
    TangentProjector::new(&c, SolverSettings::default())
        .project_velocity(&c, sde.system().mass(), &r, &mut v)
        .unwrap();
    let mut dgv = vec![0.0_f64; m];
    c.jacobian_mul(&r, &v, &mut dgv);
    assert!(dgv.iter().all(|x| x.abs() < 1e-13), "{dgv:?}");

    let (mut accel, mut rate) = (vec![0.0; n], vec![0.0; m]);
    sde.drift(&r, &v, &mut accel, &mut rate).unwrap();
    let mut curvature = vec![0.0_f64; m];
    c.second_derivative(&r, &v, &v, &mut curvature);
    c.jacobian_mul(&r, &accel, &mut dgv);
    for (a, b) in dgv.iter().zip(&curvature) {
        assert!((a + b).abs() < 1e-12, "hidden constraint: {a} + {b}");
    }
    let dw: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut diffusion = vec![0.0; n];
    sde.diffusion(&r, &v, &dw, &mut diffusion).unwrap();
    c.jacobian_mul(&r, &diffusion, &mut dgv);
    assert!(dgv.iter().all(|x| x.abs() < 1e-12), "{dgv:?}");
    // The noise did change v: the projection is not the zero map.
    assert!(diffusion.iter().map(|x| x.abs()).sum::<f64>() > 0.1);
}
