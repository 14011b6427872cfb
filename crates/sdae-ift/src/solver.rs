//! Newton's method in a ball with a certificate of uniqueness, and the homotopy continuation of
//! seed eq. 3.10 (the constructive form of the globalized implicit function theorem, Appendix B)
//! as fallback.

use crate::criteria::{ProbeMap, power_iteration, quadratic_root};
use crate::error::IftError;
use crate::iteration::{
    FactorPass, NewtonStart, NewtonSystem, certify, newton_from_zero, newton_iterate, start_at,
    start_from_zero,
};
use crate::problem::BallProblem;
use crate::settings::SolverSettings;
use sdae_manifold::GramStructure;
use sdae_manifold::vector::{max_abs as norm_max, norm2};
use sdae_manifold::{Factorize, Solve};

/// How the root was found.
///
/// Held in a word, so that a [`Certificate`] has no padding and a copy of it (or of a step's
/// outcome that holds it) moves aligned words: as a byte, its copy read a word across the byte,
/// its padding and the next field, written apart just before, which stalls the processor's
/// store forwarding (13% of a pendulum step, `benches/mass.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum Method {
    /// Plain Newton from the start value.
    Newton,
    /// Homotopy continuation in tau from (0, 0) to (1, gamma*), after Newton failed.
    Homotopy,
    /// The root of a quadratic R connected to 0, in closed form (no iterations).
    ClosedForm,
}

/// The evidence that the root found is the one the theorem speaks of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Certificate {
    /// Newton steps (the homotopy's corrector steps included; 0 in closed form).
    pub iterations: usize,
    /// Accepted continuation steps (0 when Newton succeeded).
    pub homotopy_steps: usize,
    /// How the root was found.
    pub method: Method,
    /// max_i |R_i(gamma*)|.
    pub residual: f64,
    /// |gamma*| (Euclidean).
    pub norm: f64,
    /// The ball's radius.
    pub radius: f64,
    /// |first Newton step from 0| (Euclidean).
    pub first_step: f64,
    /// Estimate of |J(0)^-1 J(gamma*) - I|, the contraction factor of the simplified Newton map
    /// between 0 and gamma* (Thm 3.4, Step 3: < 1/2 inside the theorem's ball; exact in closed
    /// form); NaN if not computed.
    pub contraction: f64,
    /// The part of |gamma*| set aside as a rounding correction when |gamma*| reached the
    /// radius (0 when the root lies in the ball on its own).
    ///
    /// The theorem's root solves R = 0 with g(r_k) = 0 exactly; in floating point g(r_k) and
    /// every evaluation of R carry residuals up to the solver's tolerance t = max(tolerance,
    /// residual floor), and correcting them moves gamma by at most |J(0)^-1 (t, ..., t)| when
    /// J(0)^-1 has no negative entries (a scalar, or an M-matrix such as a chain's Gram matrix
    /// whose neighbouring segments meet at less than 90 degrees; an estimate otherwise). For a
    /// long chain with the theory's C_kappa = 1/(8 C_g^4) this exceeds the radius, so the ball
    /// check certifies |gamma*| - rounding < radius: the part of gamma* the theorem bounds.
    pub rounding: f64,
}

/// Buffers of the solver, created once and reused (no allocation per solve on the Newton path).
#[derive(Debug, Clone)]
pub struct BallSolver<A: Factorize> {
    settings: SolverSettings,
    gamma: Vec<f64>,
    residual: Vec<f64>,
    residual_at_zero: Vec<f64>,
    step: Vec<f64>,
    probe: Vec<f64>,
    /// The problem's companion right-hand side at the root ([`BallProblem::companion_rhs`]).
    companion_rhs: Vec<f64>,
    /// The companion system's solution, where `companion_ready`.
    companion: Vec<f64>,
    matrix: A,
    factor: A::Factor,
    factor_at_zero: A::Factor,
    /// Whether `factor` (rather than `factor_at_zero`) holds the Jacobian at the root.
    root_in_factor: bool,
    /// Whether `step` holds J(0)^-1 J(gamma) p for p = gamma / |gamma| at the current gamma:
    /// the first image of the contraction estimate, formed while J(gamma) was factored.
    probe_image_ready: bool,
    /// Whether `companion` solves the companion system at the current root.
    companion_ready: bool,
    /// The tolerance of the current solve: the settings' or the problem's residual floor.
    tolerance: f64,
    history: Vec<f64>,
}

#[derive(Clone, Copy)]
enum Corrector {
    Converged(usize),
    Failed(usize),
}

impl<A: Factorize> BallSolver<A> {
    /// Buffers for problems whose Jacobian has the order and structure of `template`.
    pub fn new(template: A, settings: SolverSettings) -> Self {
        let m = template.order();
        Self {
            settings,
            gamma: vec![0.0; m],
            residual: vec![0.0; m],
            residual_at_zero: vec![0.0; m],
            step: vec![0.0; m],
            probe: vec![0.0; m],
            companion_rhs: vec![0.0; m],
            companion: vec![0.0; m],
            factor: template.new_factor(),
            factor_at_zero: template.new_factor(),
            matrix: template,
            root_in_factor: false,
            probe_image_ready: false,
            companion_ready: false,
            tolerance: settings.tolerance,
            history: Vec::with_capacity(settings.max_iterations + 1),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &SolverSettings {
        &self.settings
    }

    /// The root of the last successful solve.
    pub fn root(&self) -> &[f64] {
        &self.gamma
    }

    /// The factored Jacobian at the root of the last successful solve (seed design: the lambda
    /// system of eq. 3.1 has this matrix, so it is factored once and used twice).
    pub fn root_factor(&self) -> &A::Factor {
        if self.root_in_factor {
            &self.factor
        } else {
            &self.factor_at_zero
        }
    }

    /// The solution z of the problem's companion system D R(gamma*) z = b
    /// ([`BallProblem::companion_rhs`]) at the root of the last successful solve, where the
    /// solver solved it while factoring D R(gamma*) (with the operations of
    /// `root_factor().solve_in_place(b)`); `None` where it did not (a root at 0, in closed
    /// form, on the scalar path, or a problem without one): the caller then solves it with
    /// [`BallSolver::root_factor`].
    ///
    /// ```
    /// use sdae_ift::{BallProblem, BallSolver, SolverSettings};
    /// use sdae_manifold::{GramMatrix, Solve, TridiagonalGram};
    ///
    /// /// R(gamma) = T gamma + gamma.gamma / 20 - 1 with T = tridiag(-0.3, 2, -0.3), and the
    /// /// companion system J(gamma*) z = (1, 2, 3).
    /// struct Problem;
    /// impl BallProblem for Problem {
    ///     type Matrix = TridiagonalGram;
    ///     fn dim(&self) -> usize { 3 }
    ///     fn evaluate(&mut self, g: &[f64], r: &mut [f64], j: Option<&mut TridiagonalGram>) {
    ///         for i in 0..3 {
    ///             let left = if i > 0 { g[i - 1] } else { 0.0 };
    ///             let right = if i < 2 { g[i + 1] } else { 0.0 };
    ///             r[i] = 2.0 * g[i] - 0.3 * (left + right) + g[i] * g[i] / 20.0 - 1.0;
    ///         }
    ///         if let Some(j) = j {
    ///             for i in 0..3 { j.diag[i] = 2.0 + g[i] / 10.0; }
    ///             j.lower.fill(-0.3);
    ///             j.upper.fill(-0.3);
    ///         }
    ///     }
    ///     fn companion_rhs(&mut self, out: &mut [f64]) -> bool {
    ///         out.copy_from_slice(&[1.0, 2.0, 3.0]);
    ///         true
    ///     }
    /// }
    /// let mut solver = BallSolver::new(TridiagonalGram::zeros(3), SolverSettings::default());
    /// solver.solve(&mut Problem, f64::INFINITY)?;
    /// let z = solver.companion().expect("solved with the root's factorization").to_vec();
    /// // The same bits as a solve with the root's factors afterwards.
    /// let mut apart = [1.0, 2.0, 3.0];
    /// solver.root_factor().solve_in_place(&mut apart);
    /// assert_eq!(z, apart);
    /// // And J(gamma*) z = b.
    /// let mut j = TridiagonalGram::zeros(3);
    /// Problem.evaluate(solver.root(), &mut [0.0; 3], Some(&mut j));
    /// let mut jz = [0.0; 3];
    /// j.mul_vec(&z, &mut jz);
    /// assert!(jz.iter().zip([1.0, 2.0, 3.0]).all(|(a, b)| (a - b).abs() < 1e-14));
    /// # Ok::<(), sdae_ift::IftError>(())
    /// ```
    pub fn companion(&self) -> Option<&[f64]> {
        self.companion_ready.then_some(&self.companion[..])
    }

    /// Finds the root of `problem` in the ball |gamma| < `radius`, starting Newton from 0
    /// (or in closed form, [`BallProblem::quadratic`]). On success the problem's last evaluation
    /// was at the root.
    ///
    /// The closed form is inlined into the caller; Newton and the homotopy are not.
    #[inline(always)]
    pub fn solve<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, radius: f64,
    ) -> Result<Certificate, IftError> {
        self.companion_ready = false;
        if self.gamma.len() == 1
            && let Some(coefficients) = problem.quadratic()
            && let Some(outcome) = self.solve_quadratic(problem, radius, coefficients)
        {
            return outcome;
        }
        // Not decided in closed form: Newton and the homotopy decide.
        self.solve_newton(problem, radius, None)
    }

    /// Like [`BallSolver::solve`] but starts Newton from `start` (the homotopy fallback still
    /// starts from 0); no closed form.
    pub fn solve_from<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, radius: f64, start: &[f64],
    ) -> Result<Certificate, IftError> {
        self.solve_newton(problem, radius, Some(start))
    }

    /// Newton from 0 (`start` `None`, or all zeros) or from `start`, then the homotopy where
    /// Newton fails and the settings allow it.
    #[inline(never)]
    fn solve_newton<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, radius: f64, start: Option<&[f64]>,
    ) -> Result<Certificate, IftError> {
        let start = start.filter(|start| start.iter().any(|&g| g != 0.0));
        self.probe_image_ready = false;
        self.companion_ready = false;
        // Not certified on the scalar fast path: the general path below repeats the solve and
        // reports the failure or falls back to the homotopy.
        if A::STRUCTURE == GramStructure::Scalar
            && start.is_none()
            && let Some(certificate) = self.solve_scalar(problem, radius)
        {
            return Ok(certificate);
        }
        self.tolerance = self.settings.tolerance.max(problem.residual_floor());
        self.history.clear();
        // R(0), J(0) and the first Newton step from 0: the scale of the right root.
        let (mut corrector, gamma, step) = self.corrector(problem, 1.0);
        let tolerance = corrector.tolerance;
        let at_zero = start_from_zero(&mut corrector, tolerance, gamma, step);
        if at_zero.failed() {
            return Err(corrector.failure_at_zero(at_zero.residual()));
        }
        let first_step = at_zero.first_step();
        let paths = match start {
            None => {
                // Iteration 0 is gamma = 0 with R(0), J(0) and its Newton step already at hand.
                corrector.history.push(at_zero.residual());
                *corrector.root_in_factor = false;
                at_zero
            }
            Some(start) => {
                gamma.copy_from_slice(start);
                start_at(0.0)
            }
        };
        let settings = self.settings;
        let newton = self.run_corrector(problem, 1.0, &settings, 0.0, paths);
        let newton_outcome = match newton {
            Corrector::Converged(k) => self.accept(radius, first_step, k, 0, Method::Newton),
            Corrector::Failed(k) => Err(self.no_convergence(k)),
        };
        let newton_error = match newton_outcome {
            Ok(certificate) => return Ok(certificate),
            Err(e) if !self.settings.homotopy => return Err(e),
            Err(e) => e,
        };
        let newton_iterations = self.history.len();
        match self.homotopy(problem) {
            Ok((steps, iterations)) => self.accept(
                radius,
                first_step,
                newton_iterations + iterations,
                steps,
                Method::Homotopy,
            ),
            // Newton found a root that was rejected: that root is the finding to report.
            Err(_) if matches!(newton, Corrector::Converged(_)) => Err(newton_error),
            Err(homotopy_error) => Err(homotopy_error),
        }
    }

    /// The root of R(gamma) = c0 + c1 gamma + c2 gamma^2 (m = 1) connected to 0, with the checks
    /// and the certificate of the iterative path.
    ///
    /// The homotopy of seed eq. 3.10, F(tau, gamma) = c2 gamma^2 + c1 gamma + tau c0, has the
    /// discriminant d(tau) = c1^2 - 4 tau c0 c2, with d(0) = c1^2 > 0. While d > 0 the path from
    /// (0, 0) is the branch gamma(tau) = -2 tau c0 / (c1 + sign(c1) sqrt(d(tau))), the root of
    /// smaller modulus (the other root, (c1 + sign(c1) sqrt(d)) / (-2 c2), starts at -c1/c2
    /// != 0: the spurious "solution 2" of seed Fig. 1a). So the root the theorem certifies
    /// (Thm 3.4; Appendix B, Thm B.2) is, at tau = 1,
    ///
    /// gamma* = -2 c0 / (c1 + sign(c1) sqrt(c1^2 - 4 c0 c2)),
    ///
    /// free of cancellation. If d(1) < 0 the path folds at tau* = c1^2 / (4 c0 c2) < 1, where
    /// gamma = -c1 / (2 c2): `NoRoot` with these exact values (seed Fig. 1b). The first Newton
    /// step is |c0 / c1| and the contraction |J(0)^-1 J(gamma*) - 1| = |2 c2 gamma* / c1|, exactly
    /// (J(gamma) = c1 + 2 c2 gamma). R and J are evaluated once at gamma*: the problem's last
    /// evaluation is at the root, and J(gamma*) is factored for [`BallSolver::root_factor`].
    ///
    /// `None` when the iterative path must decide (J(0) = 0 or non-finite coefficients, whose
    /// errors it reports; a residual at gamma* above the tolerance, or a singular J(gamma*)).
    #[inline(always)]
    fn solve_quadratic<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, radius: f64, coefficients: [f64; 3],
    ) -> Option<Result<Certificate, IftError>> {
        let tolerance = self.settings.tolerance.max(problem.residual_floor());
        let root = quadratic_root(coefficients, tolerance);
        if !root.usable {
            return None;
        }
        self.tolerance = tolerance;
        let [c0, c1, c2] = coefficients;
        if !root.real {
            return Some(Err(IftError::NoRoot {
                tau: c1 * c1 / (4.0 * c0 * c2),
                norm: (c1 / (2.0 * c2)).abs(),
            }));
        }
        let (first_step, gamma, norm) = (root.first_step, root.gamma, root.norm);
        // The rounding allowance of `rounding` with J(0) = c1.
        let rounding = if norm < radius {
            0.0
        } else {
            self.tolerance / c1.abs()
        };
        if let Err(e) = self.in_ball_and_plausible(norm, rounding, radius, first_step) {
            return Some(Err(e));
        }
        self.gamma[0] = gamma;
        problem.evaluate(&self.gamma, &mut self.residual, Some(&mut self.matrix));
        let residual = self.residual[0].abs();
        if residual > self.tolerance
            || residual.is_nan()
            || self.matrix.factor_into(&mut self.factor).is_err()
        {
            return None;
        }
        self.root_in_factor = true;
        if let Err(e) = self.contracting(root.contraction, radius) {
            return Some(Err(e));
        }
        Some(Ok(Certificate {
            iterations: 0,
            homotopy_steps: 0,
            method: Method::ClosedForm,
            residual,
            norm,
            radius,
            first_step,
            contraction: root.contraction,
            rounding,
        }))
    }

    /// Newton from gamma = 0 for m = 1 on scalars: the iteration and certificate written once
    /// for one path and for lanes ([`newton_from_zero`], [`certify`]), with the tolerances and
    /// checks of the general path (`GeneralCorrector` at tau = 1, `accept`,
    /// `contraction_estimate`) and
    /// its floating-point operations, without the per-call overhead of slices of length 1.
    /// `None` when the general path must decide (no convergence, a singular or non-finite
    /// Jacobian, a root outside the ball, implausible or not contracting): it repeats the
    /// solve, so errors and the homotopy fallback are those of the general path.
    #[inline]
    fn solve_scalar<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, radius: f64,
    ) -> Option<Certificate> {
        self.tolerance = self.settings.tolerance.max(problem.residual_floor());
        let (mut gamma, mut step) = ([0.0], [0.0]);
        let mut system = OnePath {
            problem,
            matrix: &mut self.matrix,
            factor: &mut self.factor,
            factor_at_zero: &mut self.factor_at_zero,
            residual_at_zero: &mut self.residual_at_zero[0],
            at_zero: true,
        };
        let settings = self.settings;
        let root = newton_from_zero(
            &mut system,
            &settings,
            self.tolerance,
            &mut gamma,
            &mut step,
        );
        self.root_in_factor = root.iterated;
        self.gamma[0] = gamma[0];
        // Power iteration on J(0)^-1 J(gamma*) - 1 (exact after one step for m = 1).
        let probes = settings.probes(radius).min(1);
        let (ok, norm, contraction) = certify(
            &mut system,
            &settings,
            radius,
            probes,
            root.first_step,
            root.ok,
            &mut gamma,
            &mut step,
        );
        // Not certified: the general path repeats the solve and reports it.
        ok.then_some(Certificate {
            iterations: root.iterations as usize,
            homotopy_steps: 0,
            method: Method::Newton,
            rounding: 0.0,
            residual: root.residual,
            norm,
            radius,
            first_step: root.first_step,
            contraction,
        })
    }

    /// The size of the correction of residuals below the tolerance for a root of Euclidean norm
    /// `norm` ([`Certificate::rounding`]): 0 when |gamma| < radius, otherwise |J(0)^-1 t| with
    /// t the tolerance in every component, from J(0) factored in `factor_at_zero`.
    fn rounding(&mut self, norm: f64, radius: f64) -> f64 {
        if norm < radius || !norm.is_finite() {
            return 0.0;
        }
        // The residual at the root is in `history`: its buffer serves as scratch here (`probe`
        // may hold the contraction estimate's start).
        self.residual.fill(self.tolerance);
        self.factor_at_zero.solve_in_place(&mut self.residual);
        norm2(&self.residual)
    }

    /// The first two tests of the one acceptance rule ([`SolverSettings::accepts`]) as typed
    /// errors, in its order: the ball ([`SolverSettings::in_ball`], `OutsideBall`), then the
    /// plausibility against the first Newton step (`Implausible`).
    fn in_ball_and_plausible(
        &self, norm: f64, rounding: f64, radius: f64, first_step: f64,
    ) -> Result<(), IftError> {
        if !self.settings.in_ball(norm, rounding, radius) {
            return Err(IftError::OutsideBall {
                norm,
                radius,
                rounding,
            });
        }
        let bound = self.settings.plausibility_bound(first_step);
        if self.settings.implausible(norm, bound) {
            return Err(IftError::Implausible {
                norm,
                bound,
                factor: self.settings.plausibility_factor,
            });
        }
        Ok(())
    }

    /// Checks the root in `self.gamma` by the one acceptance rule ([`SolverSettings::accepts`],
    /// its tests as typed errors in its order), and builds its certificate.
    fn accept(
        &mut self, radius: f64, first_step: f64, iterations: usize, homotopy_steps: usize,
        method: Method,
    ) -> Result<Certificate, IftError> {
        let norm = norm2(&self.gamma);
        let rounding = self.rounding(norm, radius);
        self.in_ball_and_plausible(norm, rounding, radius, first_step)?;
        let residual = self.history.last().copied().unwrap_or(0.0);
        let contraction = self.contraction_estimate(radius, norm);
        self.contracting(contraction, radius)?;
        Ok(Certificate {
            iterations,
            homotopy_steps,
            method,
            residual,
            norm,
            radius,
            first_step,
            contraction,
            rounding,
        })
    }

    fn no_convergence(&self, iterations: usize) -> IftError {
        if let Some(&last) = self.history.last()
            && !last.is_finite()
        {
            return IftError::NonFinite {
                what: "residual",
                iteration: iterations,
            };
        }
        IftError::NoConvergence {
            iterations,
            history: self.history.clone(),
            tolerance: self.settings.tolerance,
        }
    }

    /// The general path's [`NewtonSystem`] at homotopy parameter `tau`, with the buffers it
    /// works on, and gamma and the step buffer apart.
    fn corrector<'s, P: BallProblem<Matrix = A>>(
        &'s mut self, problem: &'s mut P, tau: f64,
    ) -> (GeneralCorrector<'s, P, A>, &'s mut [f64], &'s mut [f64]) {
        let corrector = GeneralCorrector {
            problem,
            tau,
            tolerance: self.tolerance,
            contraction_probes: self.settings.contraction_probes,
            previous_step: f64::INFINITY,
            singular_at_zero: None,
            residual: &mut self.residual,
            residual_at_zero: &mut self.residual_at_zero,
            probe: &mut self.probe,
            companion_rhs: &mut self.companion_rhs,
            companion: &mut self.companion,
            matrix: &mut self.matrix,
            factor: &mut self.factor,
            factor_at_zero: &mut self.factor_at_zero,
            root_in_factor: &mut self.root_in_factor,
            probe_image_ready: &mut self.probe_image_ready,
            companion_ready: &mut self.companion_ready,
            history: &mut self.history,
        };
        (corrector, &mut self.gamma, &mut self.step)
    }

    /// Newton on F(tau, gamma) = R(gamma) + (tau - 1) R(0) from `paths` ([`newton_iterate`],
    /// with `settings`' iteration limit) to `tolerance` (0 means the solver's effective
    /// tolerance). At tau = 1 this is plain Newton on R. On success the factored Jacobian at the
    /// root is in `root_factor` and the problem's last evaluation was at the root.
    fn run_corrector<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P, tau: f64, settings: &SolverSettings, tolerance: f64,
        paths: NewtonStart<f64>,
    ) -> Corrector {
        let (mut corrector, gamma, step) = self.corrector(problem, tau);
        let tolerance = if tolerance > 0.0 {
            tolerance
        } else {
            corrector.tolerance
        };
        let root = newton_iterate(&mut corrector, settings, tolerance, gamma, step, paths);
        if root.ok {
            Corrector::Converged(root.last_iteration)
        } else {
            Corrector::Failed(root.last_iteration)
        }
    }

    /// Follows F(tau, gamma(tau)) = 0 from (0, 0) to tau = 1 (Euler predictor along
    /// d gamma/d tau = -J^-1 R(0), Newton corrector, step halving on failure).
    /// Returns (accepted steps, corrector iterations).
    fn homotopy<P: BallProblem<Matrix = A>>(
        &mut self, problem: &mut P,
    ) -> Result<(usize, usize), IftError> {
        let mut tau = 0.0;
        let mut dtau: f64 = 0.125;
        let mut accepted = 0;
        let mut iterations = 0;
        let mut saved = self.gamma.clone();
        saved.fill(0.0);
        self.gamma.fill(0.0);
        // The tangent at (0, 0) uses J(0), already factored.
        let mut tangent = self.residual_at_zero.clone();
        self.factor_at_zero.solve_in_place(&mut tangent);
        for _ in 0..self.settings.max_homotopy_steps {
            let next = (tau + dtau).min(1.0);
            for ((g, s), t) in self.gamma.iter_mut().zip(&saved).zip(&tangent) {
                *g = s - (next - tau) * t;
            }
            let final_step = next == 1.0;
            let (max_it, tol) = if final_step {
                (self.settings.max_iterations, 0.0)
            } else {
                // Loose along the path, but never below the floor of g's evaluation.
                (8, self.tolerance.max(1e-9))
            };
            let settings = SolverSettings {
                max_iterations: max_it,
                ..self.settings
            };
            match self.run_corrector(problem, next, &settings, tol, start_at(0.0)) {
                Corrector::Converged(k) => {
                    iterations += k;
                    accepted += 1;
                    if final_step {
                        return Ok((accepted, iterations));
                    }
                    tau = next;
                    saved.copy_from_slice(&self.gamma);
                    // New tangent from the Jacobian at the corrected point (factored by newton).
                    tangent.copy_from_slice(&self.residual_at_zero);
                    self.factor.solve_in_place(&mut tangent);
                    dtau = (2.0 * dtau).min(0.5);
                }
                Corrector::Failed(k) => {
                    iterations += k;
                    self.gamma.copy_from_slice(&saved);
                    dtau *= 0.5;
                    if dtau < self.settings.min_tau_step {
                        return Err(IftError::NoRoot {
                            tau,
                            norm: norm2(&saved),
                        });
                    }
                }
            }
        }
        Err(self.no_convergence(iterations))
    }

    /// Rejects a root of a finite ball whose contraction estimate reaches the limit.
    fn contracting(&self, contraction: f64, radius: f64) -> Result<(), IftError> {
        if self.settings.not_contracting(contraction, radius) {
            return Err(IftError::NotContracting {
                contraction,
                limit: self.settings.max_contraction,
            });
        }
        Ok(())
    }

    /// The contraction estimate of the root in `self.gamma` ([`power_iteration`]); `norm` is
    /// |gamma*|. p = gamma* / |gamma*| and its first image J(0)^-1 J(gamma*) p are at hand where
    /// they were formed with the factorization at the root.
    fn contraction_estimate(&mut self, radius: f64, norm: f64) -> f64 {
        let image_ready = std::mem::take(&mut self.probe_image_ready);
        if !image_ready {
            unit_probe(&mut self.probe, &self.gamma, norm);
        }
        let Self {
            matrix,
            factor_at_zero,
            probe,
            step,
            settings,
            ..
        } = self;
        let mut map = AtZero {
            matrix,
            factor_at_zero,
        };
        power_iteration(
            norm,
            settings.probes(radius),
            probe,
            step,
            image_ready,
            &mut map,
        )
    }
}

/// J(0)^-1 J(gamma*) from J(gamma*) and J(0)'s factors ([`ProbeMap`]).
struct AtZero<'a, A: Factorize> {
    matrix: &'a A,
    factor_at_zero: &'a A::Factor,
}

impl<A: Factorize> ProbeMap<f64> for AtZero<'_, A> {
    #[inline(always)]
    fn apply(&mut self, probe: &[f64], image: &mut [f64]) {
        self.matrix.mul_vec(probe, image);
        self.factor_at_zero.solve_in_place(image);
    }
}

/// A problem of one unknown with the solver's matrix and factors, as the [`NewtonSystem`] of
/// [`BallSolver::solve_scalar`]: an evaluation of R and J, J factored (J(0) into
/// `factor_at_zero`, R(0) kept in `residual_at_zero`), and the step solved in one half.
struct OnePath<'a, P, A: Factorize> {
    problem: &'a mut P,
    matrix: &'a mut A,
    factor: &'a mut A::Factor,
    factor_at_zero: &'a mut A::Factor,
    residual_at_zero: &'a mut f64,
    /// Whether the last evaluation was at gamma = 0.
    at_zero: bool,
}

impl<P: BallProblem<Matrix = A>, A: Factorize> NewtonSystem<f64> for OnePath<'_, P, A> {
    #[inline(always)]
    fn evaluate_and_factor(&mut self, gamma: Option<&[f64]>, step: &mut [f64]) -> (f64, bool) {
        self.at_zero = gamma.is_none();
        self.problem
            .evaluate(gamma.unwrap_or(&[0.0]), step, Some(&mut *self.matrix));
        let largest = step[0].abs();
        let factor = if self.at_zero {
            *self.residual_at_zero = step[0];
            &mut *self.factor_at_zero
        } else {
            &mut *self.factor
        };
        let factored = self.matrix.factor_into(factor).is_ok();
        (largest, largest.is_finite() && factored)
    }
    #[inline(always)]
    fn back_substitute(&mut self, step: &mut [f64]) {
        if self.at_zero {
            self.factor_at_zero.solve_in_place(step);
        } else {
            self.factor.solve_in_place(step);
        }
    }
}

impl<P, A: Factorize> ProbeMap<f64> for OnePath<'_, P, A> {
    #[inline(always)]
    fn apply(&mut self, probe: &[f64], image: &mut [f64]) {
        let mut map = AtZero {
            matrix: &*self.matrix,
            factor_at_zero: &*self.factor_at_zero,
        };
        map.apply(probe, image);
    }
}

/// probe = gamma / `norm`, the contraction estimate's start.
fn unit_probe(probe: &mut [f64], gamma: &[f64], norm: f64) {
    for (p, g) in probe.iter_mut().zip(gamma) {
        *p = g / norm;
    }
}

/// The general path's [`NewtonSystem`]: F(tau, gamma) = R(gamma) + (tau - 1) R(0) of a
/// problem of any m with the solver's buffers (seed eq. 3.10; R itself at tau = 1). R(0) is
/// evaluated at iteration 0 into `residual_at_zero` and J(0) factored into `factor_at_zero`;
/// J(gamma) is factored once the iteration knows what for: with the next Newton step in one
/// pass where it goes on, alone at the last iteration, and at a root of R with the companion
/// system and the contraction estimate's first image in the same pass
/// ([`Factorize::factor_with`]). Each residual goes to `history` for the typed errors.
struct GeneralCorrector<'a, P, A: Factorize> {
    problem: &'a mut P,
    tau: f64,
    /// The solver's effective tolerance.
    tolerance: f64,
    contraction_probes: usize,
    /// |J^-1 F| of the last step off tau = 1 (the homotopy corrector's fail-fast test).
    previous_step: f64,
    /// Why J(0) could not be factored.
    singular_at_zero: Option<sdae_manifold::LinearError>,
    residual: &'a mut [f64],
    residual_at_zero: &'a mut [f64],
    /// gamma = 0 for the evaluation at 0, then the contraction estimate's start.
    probe: &'a mut [f64],
    companion_rhs: &'a mut [f64],
    companion: &'a mut [f64],
    matrix: &'a mut A,
    factor: &'a mut A::Factor,
    factor_at_zero: &'a mut A::Factor,
    root_in_factor: &'a mut bool,
    probe_image_ready: &'a mut bool,
    companion_ready: &'a mut bool,
    history: &'a mut Vec<f64>,
}

impl<P: BallProblem<Matrix = A>, A: Factorize> GeneralCorrector<'_, P, A> {
    /// The typed error of an iteration 0 that failed with max |R(0)| = `r0`.
    fn failure_at_zero(&mut self, r0: f64) -> IftError {
        match self.singular_at_zero.take() {
            Some(source) if r0.is_finite() => IftError::Singular {
                iteration: 0,
                source,
            },
            _ => IftError::NonFinite {
                what: "residual",
                iteration: 0,
            },
        }
    }

    /// Factors J(gamma) at a root into `factor` and in the same pass solves the problem's
    /// companion system into `companion` (where it has one) and, where the contraction
    /// estimate will take a probe from a nonzero gamma, forms its first image J(0)^-1 J(gamma)
    /// p (p = gamma / |gamma|) in `step` ([`Factorize::factor_with`]).
    fn factor_root(
        &mut self, gamma: &[f64], step: &mut [f64],
    ) -> Result<(), sdae_manifold::LinearError> {
        let companion = self.problem.companion_rhs(self.companion_rhs);
        let norm = norm2(gamma);
        let probe = self.contraction_probes > 0 && norm != 0.0 && norm.is_finite();
        if probe {
            unit_probe(self.probe, gamma, norm);
        }
        self.matrix.factor_with(
            self.factor,
            companion.then_some((&self.companion_rhs[..], &mut self.companion[..])),
            probe.then_some((&*self.factor_at_zero, &self.probe[..], step)),
        )?;
        *self.probe_image_ready = probe;
        *self.companion_ready = companion;
        Ok(())
    }
}

impl<P: BallProblem<Matrix = A>, A: Factorize> NewtonSystem<f64> for GeneralCorrector<'_, P, A> {
    fn evaluate_and_factor(&mut self, gamma: Option<&[f64]>, _step: &mut [f64]) -> (f64, bool) {
        let Some(gamma) = gamma else {
            self.probe.fill(0.0);
            let matrix = Some(&mut *self.matrix);
            self.problem
                .evaluate(self.probe, self.residual_at_zero, matrix);
            let r0 = norm_max(self.residual_at_zero);
            return (r0, r0.is_finite());
        };
        self.problem
            .evaluate(gamma, self.residual, Some(&mut *self.matrix));
        if self.tau != 1.0 {
            for (r, r0) in self.residual.iter_mut().zip(self.residual_at_zero.iter()) {
                *r += (self.tau - 1.0) * r0;
            }
        }
        let r = norm_max(self.residual);
        self.history.push(r);
        (r, r.is_finite())
    }

    fn factor(&mut self, gamma: &[f64], pass: FactorPass<f64>, step: &mut [f64]) -> bool {
        if !pass.evaluated {
            return false;
        }
        if pass.at_zero {
            let factored =
                self.matrix
                    .factor_and_solve(self.factor_at_zero, self.residual_at_zero, step);
            self.singular_at_zero = factored.err();
            return self.singular_at_zero.is_none();
        }
        *self.probe_image_ready = false;
        *self.companion_ready = false;
        let factored = if pass.converged && self.tau == 1.0 {
            self.factor_root(gamma, step)
        } else if pass.converged || pass.last {
            self.matrix.factor_into(self.factor)
        } else {
            self.matrix
                .factor_and_solve(self.factor, self.residual, step)
        };
        *self.root_in_factor |= factored.is_ok();
        factored.is_ok()
    }

    /// Nothing left: [`NewtonSystem::factor`] solved the step in its pass.
    fn back_substitute(&mut self, _step: &mut [f64]) {}

    /// Off tau = 1, a step longer than half the last one: a corrector that stops contracting
    /// will not converge, so it fails fast.
    fn diverging(&mut self, step: &[f64]) -> bool {
        if self.tau == 1.0 {
            return false;
        }
        let length = norm2(step);
        let diverging = length > 0.5 * self.previous_step;
        self.previous_step = length;
        diverging
    }
}

impl<P, A: Factorize> ProbeMap<f64> for GeneralCorrector<'_, P, A> {
    fn apply(&mut self, probe: &[f64], image: &mut [f64]) {
        let mut map = AtZero {
            matrix: &*self.matrix,
            factor_at_zero: &*self.factor_at_zero,
        };
        map.apply(probe, image);
    }
}
