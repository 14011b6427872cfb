//! The root solver on the pendulum's kappa equation, whose roots are known in closed form:
//! r' = (1 - gamma) r + s t on the unit circle (r, t orthonormal, s = eta |v| h) gives
//! R(gamma) = (1 - (1 - gamma)^2 - s^2) / 2, roots 1 -/+ sqrt(1 - s^2) for s <= 1, none for s > 1
//! (seed Section 5.1, Fig. 1).

use sdae_ift::{BallProblem, BallSolver, IftError, Method, SolverSettings};
use sdae_manifold::{DenseGram, ScalarGram};

struct PendulumKappa {
    s: f64,
}

impl BallProblem for PendulumKappa {
    type Matrix = ScalarGram;
    fn dim(&self) -> usize {
        1
    }
    fn new_matrix(&self) -> ScalarGram {
        ScalarGram(0.0)
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
    fn new_matrix(&self) -> DenseGram {
        DenseGram::zeros(1)
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
    let mut globalized = solver(true);
    let cert = globalized
        .solve_from(&mut PendulumKappa { s }, 10.0, &[1.0])
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
    fn new_matrix(&self) -> ScalarGram {
        ScalarGram(0.0)
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
