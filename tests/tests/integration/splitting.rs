//! The splitting schemes BAOAB and g-BAOAB with SHAKE/RATTLE projections (`sdae-splitting`):
//! the exact law of the free rotor's angular velocity, energy conservation of order 2 without
//! friction and noise (RATTLE), the constraint to the projection's tolerance, lanes that
//! compute each path's own numbers, the projection's typed failure where the half-explicit
//! step goes on, and the systems the schemes refuse.

use crate::common::{Ellipse, noisy_pendulum};
use sdae_lanes::LaneWidth;
use sdae_manifold::Constraint;
use sdae_manifold::{DenseMass, DiagonalMass, Hypersurface, Sphere};
use sdae_model::{
    AdditiveNoise, ClosureNoise, FailureKind, LaneEnsemble, MechanicalSystem, NoObserver, Observer,
    PathEnsemble, Scheme, StepFailure, StepOutcome, System, TimeGrid, ZeroDrift, project_state,
    run_path,
};
use sdae_noise::{EnsembleIncrements, GaussianIncrements, IncrementSource};
use sdae_scheme::{Stepper, StepperConfig};
use sdae_splitting::{Splitting, SplittingConfig, SplittingError};
use sdae_systems::{
    ChainMolecule, ChainMoleculeParams, Fiber, FiberParams, Pendulum, PendulumDrift,
    PendulumParams, RigidTriatomicParams, chain_molecule, pendulum, rigid_triatomic,
};

/// BAOAB and g-BAOAB.
fn configs() -> [(&'static str, SplittingConfig); 2] {
    [
        ("baoab", SplittingConfig::baoab()),
        ("g-baoab", SplittingConfig::g_baoab()),
    ]
}

fn rotor(friction: f64, noise: f64) -> Pendulum {
    pendulum(PendulumParams {
        dim: 2,
        length: 1.0,
        gravity: 0.0,
        noise,
        friction,
    })
    .unwrap()
}

/// On the free rotor (no gravity) the A steps keep the speed exactly (SHAKE and RATTLE on a
/// circle turn the velocity without changing its length) and the O step updates the angular
/// velocity omega = r x v by the exact Ornstein-Uhlenbeck law with the tangential component
/// of dw. So at any step size, omega(T) ~ N(exp(-gamma T) omega0, kT (1 - exp(-2 gamma T)))
/// with kT = sigma^2 / (2 gamma). Checked at h = T / 4 for 16000 paths in lanes, mean and
/// variance within 4.5 standard errors of their estimators.
#[test]
fn rotor_angular_velocity_has_the_exact_ornstein_uhlenbeck_law() {
    let (gamma, sigma, t, steps, paths): (f64, f64, f64, usize, usize) = (1.0, 1.0, 1.0, 4, 16000);
    let omega0 = 1.0;
    let mean = (-gamma * t).exp() * omega0;
    let variance = sigma * sigma / (2.0 * gamma) * (1.0 - (-2.0 * gamma * t).exp());
    for (name, config) in configs() {
        let scheme = Splitting::new(rotor(gamma, sigma), config).unwrap();
        let mut ensemble = LaneEnsemble::new(scheme, paths, &[0.0, -1.0], &[omega0, 0.0]).unwrap();
        let indices: Vec<u64> = (0..paths as u64).collect();
        let mut noise = EnsembleIncrements::for_paths(11, &indices, 2);
        let h = t / steps as f64;
        let mut dw = vec![0.0; 2 * ensemble.stride()];
        for _ in 0..steps {
            noise.fill(h, &mut dw).unwrap();
            ensemble.step(h, &dw).unwrap();
        }
        assert_eq!(ensemble.failed_paths(), 0, "{name}");
        let (mut r, mut v, mut mu) = ([0.0; 2], [0.0; 2], [0.0; 1]);
        let omega: Vec<f64> = (0..paths)
            .map(|p| {
                ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
                let g = (1.0 - (r[0] * r[0] + r[1] * r[1])) / 2.0;
                assert!(g.abs() <= 1e-12, "{name}: g = {g:e}");
                r[0] * v[1] - r[1] * v[0]
            })
            .collect();
        let n = paths as f64;
        let sample_mean = omega.iter().sum::<f64>() / n;
        let sample_var = omega.iter().map(|w| (w - sample_mean).powi(2)).sum::<f64>() / (n - 1.0);
        let mean_se = (variance / n).sqrt();
        let var_se = variance * (2.0 / (n - 1.0)).sqrt();
        assert!(
            (sample_mean - mean).abs() < 4.5 * mean_se,
            "{name}: mean {sample_mean} against {mean} (se {mean_se})"
        );
        assert!(
            (sample_var - variance).abs() < 4.5 * var_se,
            "{name}: variance {sample_var} against {variance} (se {var_se})"
        );
    }
}

/// The largest |E(t) - E(0)| over a run without friction and noise (both schemes are then
/// RATTLE with the drift split into geodesic substeps).
fn energy_drift<S: Scheme>(
    scheme: &mut S, energy: impl Fn(&[f64], &[f64]) -> f64, r0: &[f64], v0: &[f64], t: f64,
    steps: usize,
) -> f64 {
    struct Energy<F> {
        energy: F,
        start: f64,
        worst: f64,
    }
    impl<F: Fn(&[f64], &[f64]) -> f64> Observer for Energy<F> {
        fn observe(&mut self, k: usize, _t: f64, r: &[f64], v: &[f64], _mu: &[f64]) {
            let e = (self.energy)(r, v);
            if k == 0 {
                self.start = e;
            }
            self.worst = self.worst.max((e - self.start).abs());
        }
    }
    let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
    let mut observer = Energy {
        energy,
        start: 0.0,
        worst: 0.0,
    };
    let mut no_noise = GaussianIncrements::for_path(0, 0, 0);
    let grid = TimeGrid::new(t, steps).unwrap();
    run_path(scheme, &mut r, &mut v, grid, &mut no_noise, &mut observer).unwrap();
    observer.worst
}

/// Without friction and noise the energy error of a symplectic second-order scheme stays
/// bounded over long runs and scales like h^2: halving h divides the largest energy error over
/// T = 200 by 4 (2^1.7 to 2^2.3 accepted: a deterministic ratio, away from h^1 and h^3).
#[test]
fn without_friction_and_noise_energy_is_conserved_to_second_order() {
    let swinging = pendulum(PendulumParams {
        dim: 3,
        length: 1.0,
        gravity: 1.0,
        noise: 0.0,
        friction: 0.0,
    })
    .unwrap();
    let molecule = chain_molecule(&ChainMoleculeParams {
        friction: 0.0,
        temperature: 0.0,
        ..ChainMoleculeParams::default()
    })
    .unwrap();
    let (mut r_mol, mut v_mol) = molecule.initial_state();
    // A velocity on the tangent space: a fixed spread of values, projected.
    for (i, vi) in v_mol.iter_mut().enumerate() {
        *vi = ((i * 7919) % 13) as f64 / 13.0 - 0.5;
    }
    let (c, mass) = (molecule.constraint(), molecule.mass());
    project_state(c, mass, &mut r_mol, &mut v_mol).unwrap();
    for (name, config) in configs() {
        let pendulum_drift = |steps| {
            let mut scheme = Splitting::new(swinging.clone(), config).unwrap();
            let energy =
                |r: &[f64], v: &[f64]| 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + r[2];
            energy_drift(
                &mut scheme,
                energy,
                &[0.6, 0.0, -0.8],
                &[0.0, 1.2, 0.0],
                200.0,
                steps,
            )
        };
        let molecule_drift = |steps| {
            let mut scheme = Splitting::new(molecule.clone(), config).unwrap();
            let energy = |r: &[f64], v: &[f64]| molecule.energy(r, v);
            energy_drift(&mut scheme, energy, &r_mol, &v_mol, 20.0, steps)
        };
        for (what, coarse, fine) in [
            ("pendulum", pendulum_drift(2000), pendulum_drift(4000)),
            ("chain molecule", molecule_drift(2000), molecule_drift(4000)),
        ] {
            let order = (coarse / fine).log2();
            assert!(
                (1.7..=2.3).contains(&order),
                "{name}, {what}: energy errors {coarse:e} and {fine:e}, order {order}"
            );
            assert!(coarse < 0.05, "{name}, {what}: energy error {coarse:e}");
        }
    }
}

/// After every step the constraint holds to the SHAKE tolerance (1e-12 on max |g|, or a
/// tighter one when set) and the velocity is tangent to rounding, on the chain molecule
/// (tridiagonal Gram matrix), the rigid triatomic (dense) and the thermal pendulum.
#[test]
fn the_constraint_holds_to_the_projection_tolerance_after_every_step() {
    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let triatomic = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let thermal = pendulum(PendulumParams {
        friction: 0.5,
        ..PendulumParams::default()
    })
    .unwrap();
    for (name, config) in configs() {
        for tolerance in [1e-12, 1e-9] {
            let config = config.with_tolerance(tolerance).unwrap().monitored();
            let (r, v) = molecule.initial_state();
            let worst = residuals(
                Splitting::new(molecule.clone(), config).unwrap(),
                r,
                v,
                1e-2,
            );
            check_residuals(name, "chain molecule", worst, tolerance);
            let (r, v) = triatomic.initial_state();
            let worst = residuals(
                Splitting::new(triatomic.clone(), config).unwrap(),
                r,
                v,
                1e-2,
            );
            check_residuals(name, "triatomic", worst, tolerance);
            let (r, v) = (vec![0.0, -1.0], vec![0.3, 0.0]);
            let worst = residuals(Splitting::new(thermal.clone(), config).unwrap(), r, v, 0.05);
            check_residuals(name, "pendulum", worst, tolerance);
        }
    }
}

/// (max position residual, max velocity residual) over 400 steps of h.
fn residuals<S: System>(
    mut scheme: Splitting<S>, mut r: Vec<f64>, mut v: Vec<f64>, h: f64,
) -> (f64, f64) {
    let l = scheme.system().noise_dim();
    let mut noise = GaussianIncrements::for_path(5, 0, l);
    let grid = TimeGrid::new(400.0 * h, 400).unwrap();
    let d = run_path(
        &mut scheme,
        &mut r,
        &mut v,
        grid,
        &mut noise,
        &mut NoObserver,
    )
    .unwrap();
    assert_eq!(d.steps, 400);
    (d.max_position_residual, d.max_velocity_residual)
}

fn check_residuals(scheme: &str, system: &str, (position, velocity): (f64, f64), tolerance: f64) {
    assert!(
        position <= tolerance,
        "{scheme}, {system}: max |g| = {position:e} above {tolerance:e}"
    );
    assert!(
        velocity < 1e-12,
        "{scheme}, {system}: max |Dg v| = {velocity:e}"
    );
}

/// Each path of an ensemble, at every lane width, has the numbers of its own run through
/// `run_path` with the same increments, bit for bit: the pendulum (the sphere's closed form
/// in lanes), the chain molecule (Newton's SHAKE over lanes with Thomas' algorithm) and the
/// rigid triatomic (the same with an LU factorization per lane, unequal masses).
#[test]
fn lanes_and_widths_give_each_path_its_own_numbers() {
    let thermal = pendulum(PendulumParams {
        dim: 3,
        friction: 0.5,
        noise: 1.5,
        ..PendulumParams::default()
    })
    .unwrap();
    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let (r_mol, v_mol) = molecule.initial_state();
    let triatomic = rigid_triatomic(&RigidTriatomicParams::default()).unwrap();
    let (r_tri, v_tri) = triatomic.initial_state();
    // Monitored: an ensemble's diagnostics hold the residuals the scheme reports, and
    // `run_path` measures those it does not.
    for (name, config) in configs().map(|(name, config)| (name, config.monitored())) {
        let pendulum_scheme = || Splitting::new(thermal.clone(), config).unwrap();
        let r0 = [0.6, 0.0, -0.8];
        let v0 = [0.0, 0.9, 0.0];
        compare_with_one_path(name, pendulum_scheme, &r0, &v0, 0.05, 13, true);
        let molecule_scheme = || Splitting::new(molecule.clone(), config).unwrap();
        compare_with_one_path(name, molecule_scheme, &r_mol, &v_mol, 0.01, 11, true);
        let triatomic_scheme = || Splitting::new(triatomic.clone(), config).unwrap();
        compare_with_one_path(name, triatomic_scheme, &r_tri, &v_tri, 2e-3, 9, true);
    }
}

/// The thermal ellipse: gravity, friction 0.5, noise 1.5, masses diag(2, 0.5).
fn thermal_ellipse<const QUADRATIC: bool>() -> impl System + Clone {
    MechanicalSystem::new(
        Hypersurface::new(Ellipse::<QUADRATIC>),
        DiagonalMass::new(vec![2.0, 0.5]).unwrap(),
        PendulumDrift {
            gravity: 1.0,
            friction: 0.5,
        },
        AdditiveNoise::new(1.5, 2).unwrap(),
    )
    .unwrap()
}

/// A constraint of one equation (`Hypersurface`: G_M is 1 x 1) steps in lanes by Newton's
/// SHAKE over its lane form (or the closed form where g is quadratic) with each path's own
/// numbers at every width: the RATTLE multiplier is the quotient -Dg(r) v / G_M(r) in lanes
/// as on one path, also from a group's end point.
#[test]
fn a_hypersurface_steps_in_lanes_with_each_paths_numbers() {
    let (r0, v0) = ([0.0, -1.0], [0.8, 0.0]);
    for (name, config) in configs().map(|(name, config)| (name, config.monitored())) {
        let newton = || Splitting::new(thermal_ellipse::<false>(), config).unwrap();
        compare_with_one_path(name, newton, &r0, &v0, 0.02, 9, true);
        let closed_form = || Splitting::new(thermal_ellipse::<true>(), config).unwrap();
        compare_with_one_path(name, closed_form, &r0, &v0, 0.02, 9, true);
    }
}

/// An ensemble's groups keep F and G_M's factors at their end points for the next step; after
/// a restart (every path back at its start) they are not reused: the ensemble continues with
/// the numbers of a fresh one.
#[test]
fn a_restart_does_not_reuse_the_groups_end_points() {
    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let (r0, v0) = molecule.initial_state();
    let l = molecule.noise_dim();
    let (paths, h) = (11, 0.01);
    let indices: Vec<u64> = (0..paths as u64).collect();
    let run = |ensemble: &mut LaneEnsemble<Splitting<ChainMolecule>>, seed: u64, steps: usize| {
        let mut noise = EnsembleIncrements::for_paths(seed, &indices, l);
        let mut dw = vec![0.0; l * ensemble.stride()];
        for _ in 0..steps {
            noise.fill(h, &mut dw).unwrap();
            ensemble.step(h, &dw).unwrap();
        }
    };
    let config = SplittingConfig::g_baoab();
    let build = || {
        LaneEnsemble::new(
            Splitting::new(molecule.clone(), config).unwrap(),
            paths,
            &r0,
            &v0,
        )
    };
    let mut fresh = build().unwrap();
    run(&mut fresh, 3, 30);
    let mut restarted = build().unwrap();
    run(&mut restarted, 9, 20);
    restarted.restart(&r0, &v0).unwrap();
    run(&mut restarted, 3, 30);
    let m = molecule.constraint().n_constraints();
    let state = |ensemble: &LaneEnsemble<_>, p| {
        let (mut r, mut v, mut mu) = (vec![0.0; r0.len()], vec![0.0; r0.len()], vec![0.0; m]);
        ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
        (r, v, mu)
    };
    for p in 0..paths {
        assert_eq!(state(&restarted, p), state(&fresh, p), "path {p}");
    }
    assert_eq!(restarted.scalar_steps(), 0);
}

/// At steps where SHAKE fails on some chain molecules (no root near the drifted point, or no
/// convergence), the ensemble's lanes decide the other paths with their own numbers, and the
/// failing paths stop with the failure `run_path` reports, after the same good steps.
#[test]
fn lanes_hand_failing_projections_to_the_scalar_step() {
    let molecule = chain_molecule(&ChainMoleculeParams::default()).unwrap();
    let (r0, v0) = molecule.initial_state();
    let (name, config) = ("baoab", SplittingConfig::baoab().monitored());
    let scheme = || Splitting::new(molecule.clone(), config).unwrap();
    let failed = compare_with_one_path(name, scheme, &r0, &v0, 0.17, 16, true);
    assert!(failed > 0 && failed < 16, "{failed} of 16 paths failed");
}

/// Compares each path of an ensemble at widths 1, 4 and 8 with its run through `run_path`
/// (`steps` steps of h): (r, v), mu, the diagnostics and, for a path that fails, the failure's
/// kind. `in_lanes`: every step is decided in lanes but the failing ones (which the scalar
/// step reports). Returns the number of failed paths.
fn compare_with_one_path<S: System + Clone>(
    name: &str, build: impl Fn() -> Splitting<S>, r0: &[f64], v0: &[f64], h: f64, paths: usize,
    in_lanes: bool,
) -> usize {
    let (n, steps) = (r0.len(), 50);
    let l = build().system().noise_dim();
    let indices: Vec<u64> = (0..paths as u64).collect();
    let mut expected = Vec::new();
    for p in 0..paths {
        let (mut r, mut v) = (r0.to_vec(), v0.to_vec());
        let mut noise = GaussianIncrements::for_path(3, p as u64, l);
        let mut scheme = build();
        let grid = TimeGrid::new(steps as f64 * h, steps).unwrap();
        let mut last = LastMu(Vec::new());
        let outcome = run_path(&mut scheme, &mut r, &mut v, grid, &mut noise, &mut last);
        let (diagnostics, failure) = match outcome {
            Ok(diagnostics) => (diagnostics, None),
            Err(failure) => (*failure.diagnostics, Some(failure.error.failure.kind())),
        };
        expected.push((r, v, last.0, diagnostics, failure));
    }
    let failed = expected.iter().filter(|e| e.4.is_some()).count();
    for width in [LaneWidth::One, LaneWidth::Four, LaneWidth::Eight] {
        let mut ensemble = LaneEnsemble::new(build(), paths, r0, v0)
            .unwrap()
            .with_width(width);
        let mut noise = EnsembleIncrements::for_paths(3, &indices, l);
        let mut dw = vec![0.0; l * ensemble.stride()];
        for _ in 0..steps {
            noise.fill(h, &mut dw).unwrap();
            ensemble.step(h, &dw).unwrap();
        }
        let m = ensemble.system().constraint().n_constraints();
        let (mut r, mut v, mut mu) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
        for (p, (er, ev, emu, diagnostics, failure)) in expected.iter().enumerate() {
            let at = format!("{name}, {width:?}, path {p}");
            ensemble.state(p, &mut r, &mut v, &mut mu).unwrap();
            assert_eq!((&r, &v), (er, ev), "{at}");
            let ours = ensemble.failure(p).unwrap().map(StepFailure::kind);
            assert_eq!(ours, *failure, "{at}");
            if failure.is_none() {
                assert_eq!(&mu, emu, "{at}");
            }
            assert_eq!(&ensemble.diagnostics(p).unwrap(), diagnostics, "{at}");
        }
        assert_eq!(ensemble.failed_paths(), failed, "{name}, {width:?}");
        if in_lanes {
            let scalar = ensemble.scalar_steps();
            assert_eq!(
                scalar, failed,
                "{name}, {width:?}: the failing steps alone scalar"
            );
        }
    }
    failed
}

/// The path's last mu.
struct LastMu(Vec<f64>);

impl Observer for LastMu {
    fn wants_mu(&self) -> bool {
        true
    }
    fn observe(&mut self, _k: usize, _t: f64, _r: &[f64], _v: &[f64], mu: &[f64]) {
        self.0 = mu.to_vec();
    }
}

/// Where the drifted point tau v lies beyond the radius of the pendulum no point of the
/// circle lies on the normal line (SHAKE's quadratic has no real root): the step is a typed
/// root failure with (r, v) unchanged, counted by an ensemble, while the half-explicit step
/// truncates and goes on from the same state. g-BAOAB's shorter substeps still project.
#[test]
fn shake_fails_where_the_half_explicit_step_goes_on() {
    let system = pendulum(PendulumParams {
        friction: 0.5,
        ..PendulumParams::default()
    })
    .unwrap();
    let (r0, v0) = ([0.0, -1.0], [3.0, 0.0]);
    let (h, dw) = (1.0, [0.1, -0.2]);
    let mut baoab = Splitting::new(system.clone(), SplittingConfig::baoab()).unwrap();
    let (mut r, mut v) = (r0, v0);
    // tau |v| = 1.5 > rho = 1.
    let failure = baoab.step(&mut r, &mut v, h, &dw).unwrap_err();
    assert!(
        matches!(failure, StepFailure::Root { what, .. } if what.contains("SHAKE")),
        "{failure}"
    );
    assert_eq!(failure.kind(), FailureKind::NoRoot, "{failure}");
    assert_eq!((r, v), (r0, v0));
    let config = StepperConfig::for_system(&system)
        .unwrap()
        .with_c_eta(1.0)
        .unwrap();
    let mut half_explicit = Stepper::new(system.clone(), config).unwrap();
    let outcome = half_explicit.step(&mut r, &mut v, h, &dw).unwrap();
    assert!(outcome.truncated());
    let mut g_baoab = Splitting::new(system.clone(), SplittingConfig::g_baoab()).unwrap();
    let (mut r, mut v) = (r0, v0);
    g_baoab.step(&mut r, &mut v, h, &dw).unwrap();

    let mut ensemble = LaneEnsemble::new(baoab, 10, &r0, &v0).unwrap();
    let dw = vec![0.0; 2 * ensemble.stride()];
    ensemble.step(h, &dw).unwrap();
    assert_eq!(ensemble.failed_paths(), 10);
    assert_eq!(
        ensemble.failure(3).unwrap().map(StepFailure::kind),
        Some(FailureKind::NoRoot)
    );
}

/// Systems without a Langevin form (noise that is not sigma I, a drift without a constant
/// friction, velocity-dependent drag) and non-diagonal masses are refused with the reason.
#[test]
fn systems_without_a_langevin_form_are_refused() {
    let fiber = Fiber::new(&FiberParams::default()).unwrap();
    let e = Splitting::new(fiber, SplittingConfig::g_baoab()).unwrap_err();
    assert!(matches!(e, SplittingError::NotLangevin(_)), "{e}");
    let circle = Sphere::unit_circle();
    let closure_noise =
        ClosureNoise::new(2, |_: &[f64], _: &[f64], dw: &[f64], out: &mut [f64]| {
            out[0] += dw[0]
        });
    let system = MechanicalSystem::new(
        circle,
        sdae_manifold::IdentityMass,
        ZeroDrift,
        closure_noise,
    )
    .unwrap();
    let Err(e) = Splitting::new(system, SplittingConfig::baoab()) else {
        panic!("a closure's noise has no Langevin form")
    };
    assert!(e.to_string().contains("Langevin form"), "{e}");
    let dense = DenseMass::new(2, vec![2.0, 0.5, 0.5, 1.0]).unwrap();
    let noise = AdditiveNoise::new(1.0, 2).unwrap();
    let system = MechanicalSystem::new(circle, dense, ZeroDrift, noise).unwrap();
    let e = Splitting::new(system, SplittingConfig::baoab()).unwrap_err();
    assert!(e.to_string().contains("diagonal mass"), "{e}");
}

/// Steps one path through `Scheme::step` (the sphere's lane form at W = 1) and through
/// `step_general` with the same increments, 3000 steps of h = 0.02, each from the state the
/// one-lane step reached; returns the number of steps where a bit of r, v, mu's increment or
/// the outcome (success, eta, the Newton iterations, the certificate, the residuals) differs.
fn one_lane_against_general<S: System + Clone>(
    system: S, config: SplittingConfig, what: &str,
) -> usize {
    let mut one = Splitting::new(system.clone(), config).unwrap();
    let mut general = Splitting::new(system, config).unwrap();
    let (n, l) = (one.system().constraint().dim(), one.system().noise_dim());
    let (mut r, mut v) = (vec![0.0; n], vec![0.0; n]);
    r[0] = 1.5;
    v[1] = 0.7;
    let mut noise = GaussianIncrements::for_path(5, 0, l);
    let mut dw = vec![0.0; l];
    let h = 0.02;
    let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let key = |o: StepOutcome| {
        let residual = |x: Option<f64>| x.map(f64::to_bits);
        let residuals = (residual(o.position_residual), residual(o.velocity_residual));
        (
            o.eta.to_bits(),
            o.newton_iterations,
            o.certificate,
            residuals,
        )
    };
    let mut apart = 0;
    for k in 0..3000 {
        noise.next_increment(h, &mut dw);
        let (mut r1, mut v1) = (r.clone(), v.clone());
        let (mut r2, mut v2) = (r.clone(), v.clone());
        let at = format!("{what}, step {k}");
        let a = one.step(&mut r1, &mut v1, h, &dw).expect(&at);
        let b = general.step_general(&mut r2, &mut v2, h, &dw).expect(&at);
        let (dmu1, dmu2) = (one.multiplier_increment(), general.multiplier_increment());
        let ours = (bits(&r1), bits(&v1), bits(dmu1), key(a));
        let theirs = (bits(&r2), bits(&v2), bits(dmu2), key(b));
        apart += usize::from(ours != theirs);
        (r, v) = (r1, v1);
    }
    apart
}

/// `Splitting`'s own step of one path on a sphere (`Scheme::step`: the lane form at W = 1) and
/// its general path (`step_general`: the constraint, the mass and the Gram factor as traits)
/// agree bit for bit, the one step body over f64 with two kernels: on the planar and
/// spherical thermal pendulums (rho = 1.5, gravity, friction 0.5, noise 3) and a sphere with
/// the diagonal mass diag(2, 0.5, 1), for BAOAB and g-BAOAB, monitored or not, 3000 steps each.
/// (The RATTLE multiplier of a 1 x 1 G_M is the quotient -Dg(r) v / G_M(r) in both; with the
/// product by the factor's reciprocal 1 / G_M on one side, 715 to 880 of the 3000 steps
/// differed by ulps.)
#[test]
fn the_one_lane_step_is_the_general_step_bit_for_bit() {
    let heavy = MechanicalSystem::new(
        Sphere::new(3, 1.5).unwrap(),
        DiagonalMass::new(vec![2.0, 0.5, 1.0]).unwrap(),
        PendulumDrift {
            gravity: 1.0,
            friction: 0.5,
        },
        AdditiveNoise::new(3.0, 3).unwrap(),
    )
    .unwrap();
    for (name, config) in configs() {
        for config in [config, config.monitored()] {
            for (what, apart) in [
                (
                    "d = 2",
                    one_lane_against_general(noisy_pendulum(2), config, name),
                ),
                (
                    "d = 3",
                    one_lane_against_general(noisy_pendulum(3), config, name),
                ),
                (
                    "diagonal mass",
                    one_lane_against_general(heavy.clone(), config, name),
                ),
            ] {
                assert_eq!(apart, 0, "{name}, {what}: steps that differ");
            }
        }
    }
}
