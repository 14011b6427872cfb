//! The root solver on the pendulum's kappa equation, whose roots are known in closed form:
//! r' = (1 - gamma) r + s t on the unit circle (r, t orthonormal, s = eta |v| h) gives
//! R(gamma) = (1 - (1 - gamma)^2 - s^2) / 2, roots 1 -/+ sqrt(1 - s^2) for s <= 1, none for s > 1
//! (seed Section 5.1, Fig. 1).

use sdae_ift::{BallProblem, BallSolver, IftError, Method, SolverSettings, quadratic_root};
use sdae_manifold::{DenseGram, ScalarGram};

struct PendulumKappa {
    s: f64,
}

impl BallProblem for PendulumKappa {
    type Matrix = ScalarGram;
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut ScalarGram>) {
        r[0] = 0.5 * (1.0 - (1.0 - g[0]).powi(2) - self.s * self.s);
        if let Some(j) = j {
            j.0 = 1.0 - g[0];
        }
    }
}

/// The same problem with its Jacobian in a 1 x 1 dense matrix: solved by the general path.
struct DensePendulumKappa(PendulumKappa);

impl BallProblem for DensePendulumKappa {
    type Matrix = DenseGram;
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut DenseGram>) {
        let mut scalar = ScalarGram(0.0);
        self.0.evaluate(g, r, Some(&mut scalar));
        if let Some(j) = j {
            j.set(0, 0, scalar.0);
        }
    }
}

fn solver(homotopy: bool) -> BallSolver<ScalarGram> {
    BallSolver::new(
        ScalarGram(0.0),
        SolverSettings {
            homotopy,
            ..SolverSettings::default()
        },
    )
}

#[test]
fn newton_finds_the_small_root_with_a_contraction_certificate() {
    // Inside the theorem: C_g = 1, C_eta = 1/4, C_kappa = 1/8.
    for s in [1e-3, 0.05, 0.1, 0.2, 0.25] {
        let mut solver = solver(true);
        let cert = solver.solve(&mut PendulumKappa { s }, 0.125).unwrap();
        let exact = 1.0 - (1.0 - s * s).sqrt();
        // |R| <= tol at the root and R'(kappa) = 1 - kappa bound the root's error.
        let bound = SolverSettings::default().tolerance / (1.0 - exact) + 4.0 * f64::EPSILON;
        assert!((solver.root()[0] - exact).abs() <= bound, "s={s}");
        assert_eq!(cert.method, Method::Newton);
        assert!(
            cert.contraction < 0.5,
            "s={s}: contraction {}",
            cert.contraction
        );
        // For a scalar problem the estimate is exact: |J(0)^-1 J(k) - 1| = kappa.
        assert!((cert.contraction - exact).abs() < 1e-12);
        assert!(cert.residual <= 1e-14 && cert.iterations <= 6, "{cert:?}");
    }
}

#[test]
fn the_second_root_is_rejected() {
    let s: f64 = 0.8;
    let second = 1.0 + (1.0 - s * s).sqrt();
    // Newton from a start near the second root converges to it: rejected as spurious.
    let mut plain = solver(false);
    let err = plain
        .solve_from(&mut PendulumKappa { s }, 10.0, &[1.5])
        .unwrap_err();
    match err {
        IftError::Implausible { norm, .. } => assert!((norm - second).abs() < 1e-12),
        other => panic!("expected Implausible, got {other:?}"),
    }
    let err = plain
        .solve_from(&mut PendulumKappa { s }, 0.125, &[1.5])
        .unwrap_err();
    assert!(matches!(err, IftError::OutsideBall { .. }), "{err:?}");
    // With the fallback, the homotopy from gamma = 0 recovers the first root.
    let mut globalized = solver(true);
    let cert = globalized
        .solve_from(&mut PendulumKappa { s }, 10.0, &[1.5])
        .unwrap();
    assert_eq!(cert.method, Method::Homotopy);
    assert!((globalized.root()[0] - (1.0 - (1.0 - s * s).sqrt())).abs() < 1e-14);
}

#[test]
fn homotopy_recovers_when_newton_starts_at_a_singular_point() {
    // J(1) = 0: Newton cannot take a single step from gamma = 1.
    let s = 0.9;
    let mut plain = solver(false);
    assert!(matches!(
        plain.solve_from(&mut PendulumKappa { s }, 10.0, &[1.0]),
        Err(IftError::NoConvergence { .. })
    ));
    // Its root has contraction 0.56 > 1/2: only a ball-free solve (no certificate) takes it.
    let mut globalized = solver(true);
    let cert = globalized
        .solve_from(&mut PendulumKappa { s }, f64::INFINITY, &[1.0])
        .unwrap();
    assert_eq!(cert.method, Method::Homotopy);
    assert!(cert.homotopy_steps > 0);
    assert!((globalized.root()[0] - (1.0 - (1.0 - s * s).sqrt())).abs() < 1e-14);
}

#[test]
fn no_root_is_reported_at_the_fold() {
    // Seed Fig. 1(b): s = 1.2 > 1. The homotopy path (1 - gamma)^2 = 1 - tau s^2 folds at
    // tau = 1 / s^2.
    let s: f64 = 1.2;
    let mut solver = solver(true);
    match solver.solve(&mut PendulumKappa { s }, 10.0).unwrap_err() {
        IftError::NoRoot { tau, norm } => {
            assert!((tau - 1.0 / (s * s)).abs() < 1e-3, "tau = {tau}");
            assert!(norm < 1.0);
        }
        other => panic!("expected NoRoot, got {other:?}"),
    }
}

#[test]
fn newton_from_zero_converges_inside_the_theorem() {
    // Why the homotopy is never needed from gamma = 0 inside the theorem's hypotheses: the
    // simplified Newton map contracts with factor <= 1/2 on the ball (Thm 3.4, Step 3), so Newton
    // from 0 converges. Check it over the whole admissible range s = eta |v| h <= C_eta = 1/4.
    let mut solver = solver(false);
    for k in 0..=1000 {
        let s = 0.25 * k as f64 / 1000.0;
        let cert = solver.solve(&mut PendulumKappa { s }, 0.125).unwrap();
        assert_eq!(cert.method, Method::Newton);
        assert!(cert.iterations <= 5, "s = {s}: {cert:?}");
    }
}

#[test]
fn scalar_fast_path_matches_the_general_path() {
    // m = 1 takes a scalar Newton path; a 1 x 1 dense Jacobian takes the general one (which
    // divides by the pivot where the scalar factor multiplies by its inverse, so values agree to
    // rounding). Iteration counts and methods agree exactly, failures are the same errors.
    let settings = |homotopy| SolverSettings {
        homotopy,
        ..SolverSettings::default()
    };
    for homotopy in [false, true] {
        for s in [0.0, 1e-9, 0.1, 0.25, 0.8, 0.99, 1.2] {
            for radius in [0.125, 10.0] {
                let mut scalar = BallSolver::new(ScalarGram(0.0), settings(homotopy));
                let mut dense = BallSolver::new(DenseGram::zeros(1), settings(homotopy));
                let fast = scalar.solve(&mut PendulumKappa { s }, radius);
                let general = dense.solve(&mut DensePendulumKappa(PendulumKappa { s }), radius);
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * (1.0 + a.abs());
                match (fast, general) {
                    (Ok(f), Ok(g)) => {
                        assert_eq!(
                            (f.iterations, f.homotopy_steps, f.method),
                            (g.iterations, g.homotopy_steps, g.method),
                            "s = {s}, radius = {radius}"
                        );
                        for (a, b) in [
                            (f.residual, g.residual),
                            (f.norm, g.norm),
                            (f.first_step, g.first_step),
                            (f.contraction, g.contraction),
                            (scalar.root()[0], dense.root()[0]),
                        ] {
                            assert!(close(a, b), "s = {s}, radius = {radius}: {f:?} {g:?}");
                        }
                    }
                    (Err(f), Err(g)) => assert_eq!(
                        std::mem::discriminant(&f),
                        std::mem::discriminant(&g),
                        "s = {s}, radius = {radius}: {f:?} {g:?}"
                    ),
                    (f, g) => panic!("s = {s}, radius = {radius}: {f:?} against {g:?}"),
                }
            }
        }
    }
}

/// The same problem declaring its coefficients: R(gamma) = -s^2/2 + gamma - gamma^2/2.
struct QuadraticPendulumKappa(PendulumKappa);

impl BallProblem for QuadraticPendulumKappa {
    type Matrix = ScalarGram;
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut ScalarGram>) {
        self.0.evaluate(g, r, j);
    }
    fn quadratic(&mut self) -> Option<[f64; 3]> {
        Some([-0.5 * self.0.s * self.0.s, 1.0, -0.5])
    }
}

#[test]
fn closed_form_matches_newton_and_the_homotopy() {
    // The closed form gives the root Newton (or the homotopy) finds, to rounding, with the same
    // checks; where there is no root it reports the fold of the homotopy path exactly:
    // (1 - gamma)^2 = 1 - tau s^2 folds at tau = 1/s^2, gamma = 1.
    for s in [0.0, 1e-9, 0.1, 0.25, 0.8, 0.99, 1.2] {
        for radius in [0.125, 10.0] {
            let mut closed = solver(true);
            let mut newton = solver(true);
            let exact = closed.solve(&mut QuadraticPendulumKappa(PendulumKappa { s }), radius);
            let iterative = newton.solve(&mut PendulumKappa { s }, radius);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * (1.0 + a.abs());
            match (exact, iterative) {
                (Ok(c), Ok(n)) => {
                    assert_eq!(
                        (c.method, c.iterations, c.homotopy_steps),
                        (Method::ClosedForm, 0, 0)
                    );
                    assert!(c.residual <= 1e-14, "s = {s}: {c:?}");
                    for (a, b) in [
                        (c.norm, n.norm),
                        (c.first_step, n.first_step),
                        (c.contraction, n.contraction),
                        (closed.root()[0], newton.root()[0]),
                    ] {
                        assert!(close(a, b), "s = {s}, radius = {radius}: {c:?} {n:?}");
                    }
                }
                (Err(IftError::NoRoot { tau, norm }), Err(IftError::NoRoot { tau: t, .. })) => {
                    assert!(
                        (tau - 1.0 / (s * s)).abs() < 1e-15 && norm == 1.0,
                        "{tau} {norm}"
                    );
                    assert!((tau - t).abs() < 1e-3, "s = {s}: fold at {tau} against {t}");
                }
                (Err(c), Err(n)) => assert_eq!(
                    std::mem::discriminant(&c),
                    std::mem::discriminant(&n),
                    "s = {s}, radius = {radius}: {c:?} {n:?}"
                ),
                (c, n) => panic!("s = {s}, radius = {radius}: {c:?} against {n:?}"),
            }
        }
    }
    // Without the homotopy the closed form still knows that there is no root.
    let e = solver(false)
        .solve(&mut QuadraticPendulumKappa(PendulumKappa { s: 1.2 }), 10.0)
        .unwrap_err();
    assert!(matches!(e, IftError::NoRoot { .. }), "{e}");
}

/// R(gamma) = J gamma + e in two unknowns: the root -J^-1 e only corrects a residual e at the
/// rounding floor when |e| <= floor.
struct Shifted {
    e: [f64; 2],
    floor: f64,
}

impl BallProblem for Shifted {
    type Matrix = DenseGram;
    fn dim(&self) -> usize {
        2
    }
    fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut DenseGram>) {
        // J = [[2, -1], [-1, 2]], as a chain's Gram matrix.
        r[0] = 2.0 * g[0] - g[1] + self.e[0];
        r[1] = -g[0] + 2.0 * g[1] + self.e[1];
        if let Some(j) = j {
            j.set(0, 0, 2.0);
            j.set(0, 1, -1.0);
            j.set(1, 0, -1.0);
            j.set(1, 1, 2.0);
        }
    }
    fn residual_floor(&self) -> f64 {
        self.floor
    }
}

#[test]
fn a_root_that_only_corrects_rounding_is_certified_in_a_tiny_ball() {
    let floor = 1e-13;
    let radius = 1e-19;
    let settings = SolverSettings {
        tolerance: 0.0,
        ..SolverSettings::default()
    };
    // R(0) = e at the floor: Newton stops at once (gamma = 0), nothing to set aside.
    let mut solver = BallSolver::new(DenseGram::zeros(2), settings);
    let at_floor = solver
        .solve(
            &mut Shifted {
                e: [floor, -floor],
                floor,
            },
            radius,
        )
        .unwrap();
    assert_eq!((at_floor.norm, at_floor.rounding), (0.0, 0.0));
    // A floor that the problem states but the residual exceeds by a little: Newton solves
    // for gamma = -J^-1 e, of size ~ floor, far outside a ball of 1e-19, but no more than
    // correcting residuals below the tolerance t = floor moves it: |J^-1 (t, t)| = sqrt(2) t.
    let mut solver = BallSolver::new(DenseGram::zeros(2), settings);
    let e = [1.2 * floor, -0.3 * floor];
    let cert = solver.solve(&mut Shifted { e, floor }, radius).unwrap();
    let exact = [-(2.0 * e[0] + e[1]) / 3.0, -(e[0] + 2.0 * e[1]) / 3.0];
    assert!(
        (solver.root()[0] - exact[0]).abs() < 1e-28 && (solver.root()[1] - exact[1]).abs() < 1e-28
    );
    assert!(
        (cert.rounding - 2f64.sqrt() * floor).abs() < 1e-27,
        "{cert:?}"
    );
    assert!(
        cert.norm > radius && cert.norm - cert.rounding < radius,
        "{cert:?}"
    );
    // Ten times the floor is not rounding: outside the ball, with the allowance named.
    let mut solver = BallSolver::new(DenseGram::zeros(2), settings);
    let e = [10.0 * floor, 0.0];
    match solver.solve(&mut Shifted { e, floor }, radius) {
        Err(IftError::OutsideBall { rounding, .. }) => {
            assert!((rounding - 2f64.sqrt() * floor).abs() < 1e-27)
        }
        other => panic!("expected OutsideBall, got {other:?}"),
    }
}

/// The pendulum's kappa equation evaluated with a rounding error of size `noise` that changes
/// from one evaluation to the next (as g's rounding does for coordinates far from the origin),
/// with that floor stated.
struct NoisyKappa {
    exact: PendulumKappa,
    noise: f64,
    calls: u32,
}

impl BallProblem for NoisyKappa {
    type Matrix = ScalarGram;
    fn dim(&self) -> usize {
        1
    }
    fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut ScalarGram>) {
        self.exact.evaluate(g, r, j);
        self.calls += 1;
        r[0] += if self.calls.is_multiple_of(2) {
            self.noise
        } else {
            -self.noise
        };
    }
    fn residual_floor(&self) -> f64 {
        2.0 * self.noise
    }
}

#[test]
fn the_homotopy_corrector_stops_at_the_residual_floor() {
    // A floor above the corrector's usual 1e-9: no continuation step could get below it.
    let s = 0.9;
    let mut problem = NoisyKappa {
        exact: PendulumKappa { s },
        noise: 1e-8,
        calls: 0,
    };
    let mut globalized = solver(true);
    let cert = globalized
        .solve_from(&mut problem, f64::INFINITY, &[1.0])
        .unwrap();
    assert_eq!(cert.method, Method::Homotopy);
    let exact = 1.0 - (1.0 - s * s).sqrt();
    // Within what the floor allows: |R'| >= 0.4 near the root.
    assert!(
        (globalized.root()[0] - exact).abs() < 3.0 * 2e-8 / 0.4,
        "{cert:?}"
    );
}

#[test]
fn a_root_whose_contraction_reaches_one_half_is_not_certified() {
    // The exact contraction |J(0)^-1 J(kappa) - 1| of the pendulum's equation is kappa itself.
    let (s, kappa) = (0.9_f64, 1.0 - (1.0 - 0.81_f64).sqrt());
    let closed_form = solver(true).solve(&mut PendulumKappa { s }, 10.0);
    let mut dense = BallSolver::new(DenseGram::zeros(1), SolverSettings::default());
    let general = dense.solve(&mut DensePendulumKappa(PendulumKappa { s }), 10.0);
    for (name, result) in [("closed form", closed_form), ("general path", general)] {
        match result {
            Err(IftError::NotContracting { contraction, limit }) => {
                assert_eq!(limit, 0.5);
                assert!((contraction - kappa).abs() < 1e-9, "{name}: {contraction}");
            }
            other => panic!("{name}: expected NotContracting, got {other:?}"),
        }
    }
    // Without a ball no certificate is claimed: the same root is returned.
    let mut free = solver(true);
    let cert = free.solve(&mut PendulumKappa { s }, f64::INFINITY).unwrap();
    assert!((free.root()[0] - kappa).abs() < 1e-14 && cert.contraction > 0.5);
    // Inside the theorem (contraction 0.2) it is certified.
    let mut inside = solver(true);
    let cert = inside.solve(&mut PendulumKappa { s: 0.6 }, 10.0).unwrap();
    assert!((cert.contraction - 0.2).abs() < 1e-12, "{cert:?}");
}

#[test]
fn the_lanes_accept_a_closed_form_root_exactly_where_the_solver_does_without_rounding() {
    // One acceptance rule (`SolverSettings::accepts`): the lanes' test of a closed-form root
    // (`QuadraticRoot::accepted`, no rounding allowance) accepts a root if and only if the
    // one-path solver accepts it with rounding 0; a root just outside the ball is the
    // solver's alone, which accepts it with its rounding allowance.
    let settings = SolverSettings::default();
    let mut with_rounding = 0;
    for s in [0.0, 1e-9, 0.1, 0.25, 0.5, 0.8, 0.99, 1.2] {
        let coefficients = [-0.5 * s * s, 1.0, -0.5];
        let root = quadratic_root(coefficients, settings.tolerance);
        let edge = root.norm * (1.0 - 4.0 * f64::EPSILON);
        for radius in [0.01, 0.125, 0.3, 10.0, f64::INFINITY, edge] {
            let lanes = root.accepted(&settings, radius);
            let one_path =
                solver(true).solve(&mut QuadraticPendulumKappa(PendulumKappa { s }), radius);
            match &one_path {
                Ok(c) if c.rounding == 0.0 => {
                    assert!(lanes, "s = {s}, radius = {radius}: {c:?}")
                }
                Ok(c) => {
                    assert!(
                        !lanes && radius == edge,
                        "s = {s}, radius = {radius}: {c:?}"
                    );
                    assert!(c.norm - c.rounding < radius, "{c:?}");
                    with_rounding += 1;
                }
                Err(e) => assert!(!lanes, "s = {s}, radius = {radius}: {e}"),
            }
        }
    }
    assert!(
        with_rounding >= 4,
        "{with_rounding} roots on the ball's edge"
    );
}
