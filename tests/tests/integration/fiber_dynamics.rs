//! Mechanics of the fiber without noise: free fall of the center of mass under gravity with
//! fixed segment lengths, and dissipation by air drag.

use sdae_manifold::state_residuals;
use sdae_model::{Scheme, System};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{AirFlow, Fiber, FiberParams, Masses};

/// A noise-free fiber in still air with the given drag coefficients and unequal bead masses.
fn fiber(linear_drag: f64, quadratic_drag: f64) -> Fiber {
    Fiber::new(&FiberParams {
        beads: 12,
        segment: 0.1,
        masses: Masses::PerParticle((0..12).map(|j| 0.05 + 0.005 * j as f64).collect()),
        air: AirFlow::default(),
        linear_drag,
        quadratic_drag,
        turbulence: 0.0,
        ..FiberParams::default()
    })
    .unwrap()
}

/// A stepper whose truncation never acts at these speeds (so eta = 1 exactly).
fn stepper(fiber: &Fiber) -> Stepper<Fiber> {
    Stepper::new(
        fiber.clone(),
        StepperConfig::new(100.0, f64::INFINITY).unwrap(),
    )
    .unwrap()
}

#[test]
fn free_fiber_falls_with_gravity_and_keeps_its_segments() {
    let fiber = fiber(0.0, 0.0);
    assert_eq!(fiber.noise_dim(), 0);
    let g = fiber.params().gravity;
    let (h, steps) = (1e-4, 10_000);
    for (name, (mut r, mut v)) in [("hanging", fiber.hanging()), ("zigzag", fiber.zigzag(0.3))] {
        let start = r.clone();
        let com0 = fiber.center_of_mass(&r);
        let mut stepper = stepper(&fiber);
        let mut worst = (0.0_f64, 0.0_f64);
        for k in 1..=steps {
            let report = stepper.step(&mut r, &mut v, h, &[]).unwrap();
            assert_eq!(report.eta, 1.0);
            let (residuals, _, _) = state_residuals(fiber.constraint(), &r, &v).unwrap();
            worst = (
                worst.0.max(residuals.position),
                worst.1.max(residuals.velocity),
            );
            if k % 1000 == 0 {
                // Explicit Euler from rest: P_k = M g t_k and x_k = x_0 + g h^2 k (k - 1) / 2.
                let t = k as f64 * h;
                let (com, vcom) = (fiber.center_of_mass(&r), fiber.center_of_mass(&v));
                for c in 0..3 {
                    let fall = 0.5 * g[c] * h * h * (k * (k - 1)) as f64;
                    assert!(
                        (vcom[c] - g[c] * t).abs() < 1e-11,
                        "{name} t = {t}: COM velocity {vcom:?}"
                    );
                    assert!(
                        (com[c] - com0[c] - fall).abs() < 1e-11,
                        "{name} t = {t}: COM {com:?}"
                    );
                }
            }
        }
        assert!(
            worst.0 < 1e-12 && worst.1 < 1e-12,
            "{name}: residuals {worst:?}"
        );
        // After 1 s the fiber has fallen by g / 2: far more than any tolerance above.
        let com = fiber.center_of_mass(&r);
        assert!((com[2] - com0[2] + 0.5).abs() < 1e-3, "{name}: {com:?}");
        if name == "hanging" {
            // A straight fiber along gravity feels no bending force: it falls rigidly.
            let shift = r[2] - start[2];
            for (j, (a, b)) in r.chunks_exact(3).zip(start.chunks_exact(3)).enumerate() {
                let moved = [a[0] - b[0], a[1] - b[1], a[2] - b[2] - shift];
                assert!(moved.iter().all(|d| d.abs() < 1e-12), "bead {j}: {moved:?}");
            }
        }
    }
}

/// The mechanical energy every `every` steps along `steps` steps from the zigzag state.
fn energies(fiber: &Fiber, h: f64, steps: usize, every: usize) -> Vec<f64> {
    let (mut r, mut v) = fiber.zigzag(0.3);
    let mut stepper = stepper(fiber);
    let mut out = vec![fiber.energy(&r, &v)];
    for k in 1..=steps {
        stepper.step(&mut r, &mut v, h, &[]).unwrap();
        if k % every == 0 {
            out.push(fiber.energy(&r, &v));
        }
    }
    out
}

#[test]
fn drag_dissipates_energy() {
    let (h, steps, every) = (1e-4, 10_000, 500);
    let dissipative = energies(&fiber(0.05, 0.05), h, steps, every);
    let decreasing = |e: &[f64]| e.windows(2).all(|w| w[1] < w[0]);
    assert!(decreasing(&dissipative), "{dissipative:?}");
    let (first, last) = (dissipative[0], dissipative[dissipative.len() - 1]);
    eprintln!("with drag: energy {first} -> {last}");
    assert!(last < first - 0.1, "{first} -> {last}");
    // Without drag nothing dissipates: the check above fails and the energy is nearly kept.
    let conservative = energies(&fiber(0.0, 0.0), h, steps, every);
    let (first, last) = (conservative[0], conservative[conservative.len() - 1]);
    eprintln!("without drag: energy {first} -> {last}");
    assert!(!decreasing(&conservative), "{conservative:?}");
    assert!((last - first).abs() < 0.01, "{first} -> {last}");
}
