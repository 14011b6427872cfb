//! Equipartition of the constrained Langevin systems (seed Section 5.2): at equilibrium
//! E[v^T M v / 2] = (n - m) kT / 2.
//!
//! Independent paths (stream i of a fixed seed) start from the initial state at rest and run
//! to several relaxation times m_a / gamma; each path's time average of the kinetic energy
//! after a burn-in is one sample, and the standard error comes from the spread of these path
//! means (batch means over independent paths). The check is |mean - target| < 4 SE. The same
//! check must fail for a system whose noise is that of 2 kT, which shows that the test can see
//! a wrong temperature.

use sdae_manifold::Constraint;
use sdae_model::{Scheme, System};
use sdae_noise::{GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_systems::{
    AngleParams, ChainMoleculeParams, Langevin, Masses, Potential, RigidTriatomicParams,
    TorsionParams, TrapParams, chain_molecule, rigid_triatomic,
};

const SEED: u64 = 20_240_905;

/// Mean and standard error of the kinetic energy, one batch per path.
struct Estimate {
    mean: f64,
    standard_error: f64,
}

impl Estimate {
    fn z(&self, target: f64) -> f64 {
        (self.mean - target) / self.standard_error
    }
}

/// Runs `paths` paths of `system` from `state` with step h to t_end, averaging the kinetic
/// energy (from `kinetic`) every `every` steps after `burn_in`.
#[allow(clippy::too_many_arguments)]
fn kinetic_energy_estimate<S>(
    system: &S, state: &(Vec<f64>, Vec<f64>), kinetic: impl Fn(&[f64]) -> f64, h: f64,
    burn_in: f64, t_end: f64, every: usize, paths: u64,
) -> Estimate
where
    S: System + Clone,
{
    let config = StepperConfig::new(1.0, f64::INFINITY).unwrap();
    let mut stepper = Stepper::new(system.clone(), config).unwrap();
    let steps = (t_end / h).round() as usize;
    let first = (burn_in / h).round() as usize;
    let mut dw = vec![0.0; system.noise_dim()];
    let mut truncated = 0usize;
    let means: Vec<f64> = (0..paths)
        .map(|i| {
            let (mut r, mut v) = state.clone();
            let mut noise = GaussianIncrements::for_path(SEED, i, dw.len());
            let (mut sum, mut count) = (0.0, 0usize);
            for k in 1..=steps {
                noise.next_increment(h, &mut dw);
                let report = stepper.step(&mut r, &mut v, h, &dw).unwrap();
                truncated += usize::from(report.eta < 1.0);
                if k >= first && k % every == 0 {
                    sum += kinetic(&v);
                    count += 1;
                }
            }
            sum / count as f64
        })
        .collect();
    // The drift-truncation must stay an exception, or it would damp the friction (design
    // notes, Section 6) and bias the temperature.
    let fraction = truncated as f64 / (steps as f64 * paths as f64);
    assert!(fraction < 1e-4, "{truncated} truncated steps");
    let p = means.len() as f64;
    let mean = means.iter().sum::<f64>() / p;
    let variance = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (p - 1.0);
    Estimate {
        mean,
        standard_error: (variance / p).sqrt(),
    }
}

/// The Langevin parameters shared by both systems: gamma = 2, kT = 1, so that with masses
/// <= 1.5 the velocities relax within 0.75 time units.
const FRICTION: f64 = 2.0;
const TEMPERATURE: f64 = 1.0;

fn report(name: &str, estimate: &Estimate, target: f64) {
    eprintln!(
        "{name}: mean {:.4} target {target:.4} SE {:.4} z {:.2}",
        estimate.mean,
        estimate.standard_error,
        estimate.z(target)
    );
}

/// Paths of the estimate at the right temperature (`EQUIPARTITION_PATHS` overrides, to
/// measure the bias with many paths) and at the wrong one (fewer suffice).
fn paths() -> (u64, u64) {
    let right = std::env::var("EQUIPARTITION_PATHS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(48);
    (right, right.div_ceil(3))
}

/// Equipartition of the Langevin system `build(kT)` with `dof` = n - m degrees of freedom: the
/// estimate at kT is within 4 standard errors of (n - m) kT / 2, and the same check fails for
/// the system at 2 kT (the check has power).
fn check_equipartition<C, P>(
    name: &str, build: impl Fn(f64) -> Langevin<C, P>,
    initial: impl Fn(&Langevin<C, P>) -> (Vec<f64>, Vec<f64>), dof: usize,
) where
    C: Constraint + Clone,
    P: Potential + Clone,
    Langevin<C, P>: System + Clone,
{
    let system = build(TEMPERATURE);
    let target = system.equipartition_energy();
    assert_eq!(system.degrees_of_freedom(), dof);
    let state = initial(&system);
    let run = |s: &Langevin<C, P>, paths| {
        kinetic_energy_estimate(
            s,
            &state,
            |v| s.kinetic_energy(v),
            H,
            BURN_IN,
            T_END,
            5,
            paths,
        )
    };
    let right = run(&system, paths().0);
    report(name, &right, target);
    assert!(right.z(target).abs() < 4.0, "equipartition fails");
    let wrong = run(&build(2.0 * TEMPERATURE), paths().1);
    report(&format!("{name} at 2 kT"), &wrong, target);
    assert!(
        wrong.z(target).abs() > 4.0,
        "the check cannot see a wrong temperature"
    );
}

#[test]
fn chain_molecule_equipartition() {
    let params = |temperature| ChainMoleculeParams {
        atoms: 4,
        masses: Masses::PerParticle(vec![1.0, 1.5, 1.5, 1.0]),
        friction: FRICTION,
        temperature,
        angle: AngleParams {
            stiffness: 10.0,
            ..AngleParams::default()
        },
        torsion: TorsionParams {
            stiffness: 1.0,
            ..TorsionParams::default()
        },
        ..ChainMoleculeParams::default()
    };
    let build = |temperature| chain_molecule(&params(temperature)).unwrap();
    check_equipartition("chain molecule", build, |s| s.initial_state(), 12 - 3);
}

#[test]
fn rigid_triatomic_equipartition() {
    let params = |temperature| RigidTriatomicParams {
        bond_lengths: [1.0, 1.2, 1.5],
        masses: Masses::PerParticle(vec![1.5, 1.0, 0.8]),
        trap: TrapParams {
            stiffness: 2.0,
            center: [0.5, -0.5, 1.0],
        },
        friction: FRICTION,
        temperature,
    };
    let build = |temperature| rigid_triatomic(&params(temperature)).unwrap();
    check_equipartition("rigid triatomic", build, |s| s.initial_state(), 9 - 3);
}

/// The step. The explicit Euler step heats: a free velocity by the factor
/// 1 / (1 - gamma h / (2 m)), an oscillation of frequency omega by about omega^2 h m / (2 gamma)
/// more (the stiffest here, the bond angles, have omega^2 ~ 30). With h = 0.001 this biases the
/// kinetic energy by well under one standard error of the estimate (measured with 480 paths).
const H: f64 = 0.001;

/// Burn-in: more than 3 relaxation times m / gamma (kinetic energy relaxes twice as fast).
const BURN_IN: f64 = 2.5;

/// End of each path: the time average runs over 5 relaxation times.
const T_END: f64 = 6.5;
