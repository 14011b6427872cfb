//! The splitting step over W lanes for a constraint that offers its formulas over lanes
//! ([`ConstraintLanes`]: the bead chain, rigid bonds, a user's constraint) with a diagonal mass:
//! the SHAKE projection's root by Newton with a convergence mask per lane ([`NewtonRoot`], the
//! kappa system at y = r + tau v without a ball), the RATTLE projection's multiplier from
//! G_M(r) lambda = -Dg(r) v with G_M(r) = Dg(r) M^-1 grad g(r) (the Newton matrix at x = r,
//! factored by the constraint's lane factorization), the O step per coordinate.
//!
//! Each formula takes the floating-point operations of [`Splitting`]'s general path in the
//! same order, so that a decided lane is the scalar step of its path. A lane the step does not
//! decide (a SHAKE iteration that does not converge, a pivot the factorization rejects, a
//! non-finite value) goes through the scalar step from (r_k, v_k), which reports the failure
//! as for one path.

use pulp::{Simd, WithSimd};
use sdae_ift::SolverSettings;
use sdae_lanes::{LANE_BLOCK, LaneMask, Lanes, per_path};
use sdae_manifold::lane_form::{ConstraintLanes, Factor, Jacobian, LaneForm, max_abs};
use sdae_manifold::vector::sum_squares;
use sdae_manifold::{MatrixFactor, SquareMatrix};
use sdae_model::engine::{
    Drifted, GroupState, LaneRecord, LaneRows, LaneStore, NewtonKernels, NewtonRoot, WideKernel,
};
use sdae_model::{Scheme, System};

use crate::config::{SplittingConfig, StepSizes};
use crate::ou::OuFactors;
use crate::splitting::Splitting;

impl<S: System> NewtonKernels for Splitting<S> {
    type Kernel<Sd: Simd, C: ConstraintLanes> = Kernel<Sd, C>;
    fn kernel<Sd: Simd, C: ConstraintLanes>(
        &self, simd: Sd, constraint: LaneForm<C>,
    ) -> Kernel<Sd, C> {
        Kernel::new(simd, constraint)
    }
    fn prepare<Sd: Simd, C: ConstraintLanes>(&self, kernel: &mut Kernel<Sd, C>, h: f64) {
        kernel.constants = Constants::new(self, h);
    }
    fn lane_store(&mut self) -> &mut LaneStore {
        &mut self.lanes
    }
}

/// The scheme's numbers for one step size.
#[derive(Clone)]
struct Constants {
    sizes: StepSizes,
    settings: SolverSettings,
    /// The O step's factors for h.
    ou: Vec<OuFactors>,
    monitor_velocity: bool,
}

impl Constants {
    /// The constants for h; the scheme's O factors must be those of h
    /// ([`Splitting::refresh_ou`]).
    fn new<S: System>(scheme: &Splitting<S>, h: f64) -> Self {
        let config = scheme.config();
        Self {
            sizes: StepSizes::new(config, h),
            settings: config.solver,
            ou: scheme.ou.clone(),
            monitor_velocity: config.monitor_velocity_constraint,
        }
    }
}

/// The constraint's lane form, the step's constants and the buffers of one group's step.
pub struct Kernel<Sd: Simd, C: ConstraintLanes> {
    simd: Sd,
    constants: Constants,
    constraint: LaneForm<C>,
    /// The SHAKE root.
    root: NewtonRoot<Sd, C>,
    /// G_M(r) and its factors, with g(r) and the first half of G_M(r)^-1 g(r) that their
    /// evaluation leaves (m rows each, not read).
    gram: Jacobian<Sd, C>,
    gram_factor: Factor<Sd, C>,
    values: Vec<Lanes<Sd>>,
    solved: Vec<Lanes<Sd>>,
    /// A projection's multiplier (m rows).
    lambda: Vec<Lanes<Sd>>,
    /// F(r), the zero velocity of F(r) = a(r, 0) and the next velocity (n rows each).
    force: Vec<Lanes<Sd>>,
    zero: Vec<Lanes<Sd>>,
    u: Vec<Lanes<Sd>>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
    /// Each group's last end point, up to [`END_POINTS_BYTES`].
    ends: Vec<EndPoint<Sd, C>>,
    /// How many groups' end points are kept.
    kept_groups: usize,
}

/// The memory the end points of an ensemble's groups may take (beyond it, the groups past the
/// first ones evaluate F and factor G_M at the start of each step anew).
const END_POINTS_BYTES: usize = 64 << 20;

/// What a group's last step left at its end point r_{k+1}: F(r_{k+1}) and the factors of
/// G_M(r_{k+1}), the first things its next step needs (the kick and RATTLE at r_k). The
/// scalar step keeps the same for one path.
struct EndPoint<Sd: Simd, C: ConstraintLanes> {
    /// r_{k+1}, row by row (W values per coordinate); empty until the group's first step.
    r: Vec<f64>,
    force: Vec<Lanes<Sd>>,
    gram_factor: Factor<Sd, C>,
}

/// The lanes of a group inside a step: (r, v), mu's increment (the sum of the step's
/// constraint impulses), and what the step reports.
struct Motion<'a, Sd: Simd> {
    r: &'a mut Vec<Lanes<Sd>>,
    v: &'a mut Vec<Lanes<Sd>>,
    impulse: &'a mut [Lanes<Sd>],
    /// The lanes decided so far.
    ok: LaneMask<Sd>,
    /// Newton iterations of the SHAKE projections so far, and max |g| after the last one.
    iterations: Lanes<Sd>,
    residual: Lanes<Sd>,
}

impl<Sd: Simd, C: ConstraintLanes> Kernel<Sd, C> {
    fn new(simd: Sd, constraint: LaneForm<C>) -> Self {
        let (n, m) = constraint.dims();
        let zero = Lanes::splat(simd, 0.0);
        Self {
            simd,
            constants: Constants {
                sizes: StepSizes::new(&SplittingConfig::baoab(), f64::NAN),
                settings: SolverSettings::default(),
                ou: Vec::new(),
                monitor_velocity: false,
            },
            root: NewtonRoot::new(simd, &constraint),
            constraint,
            gram: SquareMatrix::zeros_like(zero, m),
            gram_factor: MatrixFactor::zeros_like(zero, m),
            values: vec![zero; m],
            solved: vec![zero; m],
            lambda: vec![zero; m],
            force: vec![zero; n],
            zero: vec![zero; n],
            u: vec![zero; n],
            scratch: Vec::new(),
            ends: Vec::new(),
            kept_groups: END_POINTS_BYTES / end_point_bytes::<Sd>(n, m),
        }
    }

    /// Whether the group's last end point is r in every lane whose path goes on (the same
    /// bits): then its F(r) and G_M(r)'s factors take the place of this step's.
    #[inline(always)]
    fn resume(&mut self, group: usize, r: &[Lanes<Sd>], alive: LaneMask<Sd>) -> bool {
        let Some(end) = self.ends.get_mut(group) else {
            return false;
        };
        let width = Lanes::<Sd>::WIDTH;
        if end.r.len() != r.len() * width {
            return false;
        }
        let mut row = [0.0; LANE_BLOCK];
        for (k, rk) in r.iter().enumerate() {
            rk.store(&mut row[..width]);
            let kept = &end.r[k * width..(k + 1) * width];
            for (lane, (a, b)) in row.iter().zip(kept).enumerate() {
                if alive.lane(lane) && a.to_bits() != b.to_bits() {
                    return false;
                }
            }
        }
        std::mem::swap(&mut self.force, &mut end.force);
        std::mem::swap(&mut self.gram_factor, &mut end.gram_factor);
        true
    }

    /// Keeps the group's end point r with F(r) and G_M(r)'s factors of the step just taken.
    #[inline(always)]
    fn keep(&mut self, group: usize, r: &[Lanes<Sd>]) {
        if group >= self.kept_groups {
            return;
        }
        while self.ends.len() <= group {
            self.ends.push(EndPoint {
                r: Vec::new(),
                force: self.force.clone(),
                gram_factor: MatrixFactor::zeros_like(
                    Lanes::splat(self.simd, 0.0),
                    self.lambda.len(),
                ),
            });
        }
        let end = &mut self.ends[group];
        let width = Lanes::<Sd>::WIDTH;
        end.r.resize(r.len() * width, 0.0);
        for (k, rk) in r.iter().enumerate() {
            rk.store(&mut end.r[k * width..(k + 1) * width]);
        }
        std::mem::swap(&mut self.force, &mut end.force);
        std::mem::swap(&mut self.gram_factor, &mut end.gram_factor);
    }

    /// F(r) = a(r, 0) into `force`; the lanes where it is finite.
    #[inline(always)]
    fn evaluate_force<S: System>(&mut self, system: &S, r: &[Lanes<Sd>]) -> LaneMask<Sd> {
        if !system.drift_lanes(r, &self.zero, &mut self.force) {
            per_path(
                [r, &self.zero],
                &mut self.force,
                &mut self.scratch,
                |[r, v], out| system.drift(r, v, out),
            );
        }
        sum_squares(&self.force).is_finite()
    }

    /// B: v <- v + (h/2) M^-1 F(r).
    #[inline(always)]
    fn kick(&self, v: &mut [Lanes<Sd>]) {
        let half_h = 0.5 * self.constants.sizes.h;
        let inverse_mass = self.constraint.inverse_mass();
        for (k, (vi, &fi)) in v.iter_mut().zip(&self.force).enumerate() {
            *vi = *vi + inverse_mass.apply(k, fi) * half_h;
        }
    }

    /// RATTLE at r: v <- v + M^-1 grad g(r) lambda with G_M(r) lambda = -Dg(r) v, factoring
    /// G_M(r) if `refactor` (else it is factored at this r).
    #[inline(always)]
    fn project_velocity(&mut self, m: &mut Motion<'_, Sd>, refactor: bool) {
        let c = &self.constraint;
        if refactor {
            let at_r = c.evaluate_and_factor(
                &m.r[..],
                m.r,
                &mut self.values,
                &mut self.gram,
                &mut self.gram_factor,
                &mut self.solved,
            );
            m.ok = m.ok.and(at_r.ok);
        }
        c.negated_jacobian_mul(m.r, m.v, &mut self.lambda);
        self.gram_factor.solve_in_place(&mut self.lambda);
        for (i, l) in m.impulse.iter_mut().zip(&self.lambda) {
            *i = *i + *l;
        }
        c.displace(m.r, &self.lambda, Some(&m.v[..]), &mut self.u);
        std::mem::swap(m.v, &mut self.u);
    }

    /// A geodesic substep of length tau: SHAKE onto g = 0 (Newton from kappa = 0, no ball),
    /// the velocity v + M^-1 grad g(r) kappa / tau, RATTLE at the new point.
    #[inline(always)]
    fn geodesic_drift(&mut self, m: &mut Motion<'_, Sd>) {
        let tau = Lanes::splat(self.simd, self.constants.sizes.tau);
        let y = Drifted {
            r: m.r,
            v: m.v,
            tau,
        };
        let root = self.root.solve(
            &self.constraint,
            &self.constants.settings,
            f64::INFINITY,
            y.r,
            &y,
            y.max_abs(),
        );
        self.root.point(&root, &y);
        m.ok = m.ok.and(root.ok);
        m.iterations = m.iterations + root.iterations;
        m.residual = root.residual;
        // gamma* is kept: no contraction probes without a ball.
        let inverse_tau = self.constants.sizes.inverse_tau;
        for (l, k) in self.lambda.iter_mut().zip(&self.root.gamma) {
            *l = *k * inverse_tau;
        }
        for (i, l) in m.impulse.iter_mut().zip(&self.lambda) {
            *i = *i + *l;
        }
        self.constraint
            .displace(m.r, &self.lambda, Some(&m.v[..]), &mut self.u);
        std::mem::swap(m.v, &mut self.u);
        std::mem::swap(m.r, &mut self.root.x);
        self.project_velocity(m, true);
    }

    /// RATTLE after the first kick (factoring G_M(r) unless it is `factored`), A, O with its
    /// RATTLE, A: the part of the step between the force's evaluations, which does not depend
    /// on the system.
    #[inline(always)]
    fn drift_and_thermostat(&mut self, m: &mut Motion<'_, Sd>, dw: &[Lanes<Sd>], factored: bool) {
        self.project_velocity(m, !factored);
        for _ in 0..self.constants.sizes.substeps {
            self.geodesic_drift(m);
        }
        for (vi, ou) in m.v.iter_mut().zip(&self.constants.ou) {
            *vi = *vi * ou.decay;
        }
        for ((vi, ou), &w) in m.v.iter_mut().zip(&self.constants.ou).zip(dw) {
            *vi = *vi + w * ou.noise;
        }
        self.project_velocity(m, false);
        for _ in 0..self.constants.sizes.substeps {
            self.geodesic_drift(m);
        }
    }

    /// [`Kernel::drift_and_thermostat`] compiled once per instruction set and constraint, not
    /// once per system.
    #[inline(never)]
    fn middle(&mut self, m: &mut Motion<'_, Sd>, dw: &[Lanes<Sd>], factored: bool) {
        let simd = self.simd;
        simd.vectorize(Middle {
            kernel: self,
            motion: m,
            dw,
            factored,
        });
    }

    /// The last RATTLE, the lanes whose v is finite, and what the step reports.
    #[inline(always)]
    fn finish(&mut self, m: &mut Motion<'_, Sd>) -> LaneRecord<Sd> {
        self.project_velocity(m, false);
        m.ok = m.ok.and(sum_squares(m.v).is_finite());
        // Written out, not `then`: a closure would not inherit the instruction set.
        let velocity_residual = if self.constants.monitor_velocity {
            // max_i |-(Dg(r) v)_i| = max_i |(Dg(r) v)_i|.
            self.constraint
                .negated_jacobian_mul(m.r, m.v, &mut self.lambda);
            Some(max_abs(&self.lambda))
        } else {
            None
        };
        LaneRecord {
            eta: Lanes::splat(self.simd, 1.0),
            newton_iterations: m.iterations,
            position_residual: Some(m.residual),
            velocity_residual,
            certificate: None,
        }
    }
}

/// [`Kernel::drift_and_thermostat`] as an operation `Simd::vectorize` compiles as a function
/// of its own with the caller's instruction set (a closure would not inherit it).
struct Middle<'a, 'm, Sd: Simd, C: ConstraintLanes> {
    kernel: &'a mut Kernel<Sd, C>,
    motion: &'a mut Motion<'m, Sd>,
    dw: &'a [Lanes<Sd>],
    factored: bool,
}

impl<Sd: Simd, C: ConstraintLanes> WithSimd for Middle<'_, '_, Sd, C> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        self.kernel
            .drift_and_thermostat(self.motion, self.dw, self.factored);
    }
}

impl<S: System, Sd: Simd, C: ConstraintLanes> WideKernel<Splitting<S>, Sd> for Kernel<Sd, C> {
    /// [`Splitting`]'s B A O A B for W lanes from `state` = (r_k, v_k) into `rows`.
    #[inline(always)]
    fn step(
        &mut self, scheme: &Splitting<S>, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
        let system = scheme.system();
        let GroupState {
            r,
            v,
            dw,
            group,
            alive,
        } = state;
        let LaneRows {
            r: r_next,
            v: v_next,
            dmu,
            ..
        } = rows;
        r_next.copy_from_slice(r);
        v_next.copy_from_slice(v);
        let zero = Lanes::splat(self.simd, 0.0);
        dmu.fill(zero);
        let mut m = Motion {
            r: r_next,
            v: v_next,
            impulse: dmu,
            ok: zero.eq(zero),
            iterations: zero,
            residual: zero,
        };
        // F(r_k) and G_M(r_k) as the group's last step left them, else anew (a path of the
        // group that the scalar step took, a restart, the first step).
        let resumed = self.resume(group, m.r, alive);
        if !resumed {
            m.ok = m.ok.and(self.evaluate_force(system, m.r));
        }
        self.kick(m.v);
        self.middle(&mut m, dw, resumed);
        m.ok = m.ok.and(self.evaluate_force(system, m.r));
        self.kick(m.v);
        let record = self.finish(&mut m);
        self.keep(group, m.r);
        Some((m.ok, record))
    }
}

/// What one group's [`EndPoint`] takes, about: r and F(r) (n rows each) and the factors of
/// an m x m matrix (at most m^2 + 3 m rows).
fn end_point_bytes<Sd: Simd>(n: usize, m: usize) -> usize {
    (2 * n + m * m + 3 * m) * Lanes::<Sd>::WIDTH * std::mem::size_of::<f64>()
}
