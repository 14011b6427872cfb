//! The splitting step over W lanes for a constraint that offers its formulas over lanes
//! ([`Equations`]: the bead chain, rigid bonds, a user's constraint) with a diagonal mass:
//! the SHAKE projection's root by Newton with a convergence mask per lane ([`NewtonRoot`], the
//! kappa system at y = r + tau v without a ball), the RATTLE projection's multiplier from
//! G_M(r) lambda = -Dg(r) v with G_M(r) = Dg(r) M^-1 grad g(r) (the Newton matrix at x = r,
//! factored by the constraint's lane factorization), the O step per coordinate.
//!
//! The step is the body of `kernel.rs` ([`NewtonLanes`] its kernel), the general path's, so
//! that a decided lane is the scalar step of its path. A lane the step does not
//! decide (a SHAKE iteration that does not converge, a pivot the factorization rejects, a
//! non-finite value) goes through the scalar step from (r_k, v_k), which reports the failure
//! as for one path.

use pulp::{Simd, WithSimd};
use sdae_ift::SolverSettings;
use sdae_lanes::{LANE_BLOCK, LaneMask, Lanes, LineVec};
use sdae_manifold::Equations;
use sdae_manifold::lane_form::{Factor, Jacobian, LaneForm, max_abs};
use sdae_manifold::{GramShape, GramStructure, MatrixFactor, SquareMatrix};
use sdae_model::engine::{
    Drifted, GroupState, LaneRecord, LaneRows, LaneStore, NewtonKernels, NewtonRoot, WideKernel,
};
use sdae_model::{Scheme, System, drift_over_lanes};

use crate::config::{SplittingConfig, StepSizes};
use crate::kernel::{
    self, Motion, NoLaneForm, Shaken, SplittingKernel, StepNumbers, drift_and_thermostat,
    shake_impulse,
};
use crate::splitting::Splitting;

impl<S: System> NewtonKernels for Splitting<S> {
    type Kernel<Sd: Simd, C: Equations> = Kernel<Sd, C>;
    fn kernel<Sd: Simd, C: Equations>(&self, simd: Sd, constraint: LaneForm<C>) -> Kernel<Sd, C> {
        Kernel::new(simd, constraint)
    }
    fn prepare<Sd: Simd, C: Equations>(&self, kernel: &mut Kernel<Sd, C>, h: f64) {
        kernel.lanes.constants = Constants::new(self, h);
    }
    fn lane_store(&mut self) -> &mut LaneStore {
        &mut self.lanes
    }
}

/// The scheme's numbers for one step size.
#[derive(Clone)]
struct Constants {
    numbers: StepNumbers,
    settings: SolverSettings,
}

impl Constants {
    /// The constants for h; the scheme's O factors must be those of h
    /// ([`Splitting::refresh_numbers`]).
    fn new<S: System>(scheme: &Splitting<S>, h: f64) -> Self {
        debug_assert_eq!(scheme.numbers.sizes.h.to_bits(), h.to_bits());
        Self {
            numbers: scheme.numbers.clone(),
            settings: scheme.config().solver,
        }
    }
}

/// The step body's kernel over a group's lanes ([`NewtonLanes`]), a projection's multiplier
/// and the groups' end points.
pub struct Kernel<Sd: Simd, C: Equations> {
    lanes: NewtonLanes<Sd, C>,
    /// A projection's multiplier (m rows).
    lambda: LineVec<Lanes<Sd>>,
    /// Each group's last end point, up to [`END_POINTS_BYTES`].
    ends: Vec<EndPoint<Sd, C>>,
    /// How many groups' end points are kept.
    kept_groups: usize,
}

/// The step body's kernel over W lanes for a constraint's lane form: its constants, the SHAKE
/// root and the buffers of one group's step.
struct NewtonLanes<Sd: Simd, C: Equations> {
    simd: Sd,
    constants: Constants,
    constraint: LaneForm<C>,
    /// The SHAKE root.
    root: NewtonRoot<Sd, C>,
    /// G_M(r) and its factors, with g(r) and the first half of G_M(r)^-1 g(r) that their
    /// evaluation leaves (m rows each, not read).
    gram: Jacobian<Sd, C>,
    gram_factor: Factor<Sd, C>,
    values: LineVec<Lanes<Sd>>,
    solved: LineVec<Lanes<Sd>>,
    /// F(r), the zero velocity of F(r) = a(r, 0) and the next velocity (n rows each).
    force: LineVec<Lanes<Sd>>,
    zero: LineVec<Lanes<Sd>>,
    u: LineVec<Lanes<Sd>>,
    /// Path-by-path buffers of a system without lane forms of this size.
    scratch: Vec<f64>,
}

/// Whether C's G_M is 1 x 1: the RATTLE multiplier is then the quotient by G_M itself, which
/// an end point keeps with its factors.
const fn scalar<C: Equations>() -> bool {
    matches!(<C::Shape as GramShape>::STRUCTURE, GramStructure::Scalar)
}

/// The memory the end points of an ensemble's groups may take (beyond it, the groups past the
/// first ones evaluate F and factor G_M at the start of each step anew).
const END_POINTS_BYTES: usize = 64 << 20;

/// What a group's last step left at its end point r_{k+1}: F(r_{k+1}) and the factors of
/// G_M(r_{k+1}) (with G_M(r_{k+1}) itself where it is 1 x 1), the first things its next step
/// needs (the kick and RATTLE at r_k). The scalar step keeps the same for one path.
struct EndPoint<Sd: Simd, C: Equations> {
    /// r_{k+1}, row by row (W values per coordinate); empty until the group's first step.
    r: Vec<f64>,
    force: LineVec<Lanes<Sd>>,
    gram_factor: Factor<Sd, C>,
    gram: Option<Jacobian<Sd, C>>,
}

impl<Sd: Simd, C: Equations> Kernel<Sd, C> {
    fn new(simd: Sd, constraint: LaneForm<C>) -> Self {
        let (n, m) = constraint.dims();
        let zero = Lanes::splat(simd, 0.0);
        Self {
            lanes: NewtonLanes {
                simd,
                constants: Constants {
                    numbers: StepNumbers {
                        sizes: StepSizes::new(&SplittingConfig::baoab(), f64::NAN),
                        ou: Vec::new(),
                        monitor_velocity: false,
                    },
                    settings: SolverSettings::default(),
                },
                root: NewtonRoot::new(simd, &constraint),
                constraint,
                gram: SquareMatrix::zeros_like(zero, m),
                gram_factor: MatrixFactor::zeros_like(zero, m),
                values: LineVec::from_elem(zero, m),
                solved: LineVec::from_elem(zero, m),
                force: LineVec::from_elem(zero, n),
                zero: LineVec::from_elem(zero, n),
                u: LineVec::from_elem(zero, n),
                scratch: Vec::new(),
            },
            lambda: LineVec::from_elem(zero, m),
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
        swap_end_point(&mut self.lanes, end);
        true
    }

    /// Keeps the group's end point r with F(r) and G_M(r)'s factors of the step just taken.
    #[inline(always)]
    fn keep(&mut self, group: usize, r: &[Lanes<Sd>]) {
        if group >= self.kept_groups {
            return;
        }
        while self.ends.len() <= group {
            let (zero, m) = (Lanes::splat(self.lanes.simd, 0.0), self.lambda.len());
            self.ends.push(EndPoint {
                r: Vec::new(),
                force: self.lanes.force.clone(),
                gram_factor: MatrixFactor::zeros_like(zero, m),
                gram: scalar::<C>().then(|| SquareMatrix::zeros_like(zero, m)),
            });
        }
        let end = &mut self.ends[group];
        let width = Lanes::<Sd>::WIDTH;
        end.r.resize(r.len() * width, 0.0);
        for (k, rk) in r.iter().enumerate() {
            rk.store(&mut end.r[k * width..(k + 1) * width]);
        }
        swap_end_point(&mut self.lanes, end);
    }
}

/// Swaps F(r), G_M(r)'s factors (and G_M(r) where kept) between the kernel and an end point.
#[inline(always)]
fn swap_end_point<Sd: Simd, C: Equations>(
    lanes: &mut NewtonLanes<Sd, C>, end: &mut EndPoint<Sd, C>,
) {
    std::mem::swap(&mut lanes.force, &mut end.force);
    std::mem::swap(&mut lanes.gram_factor, &mut end.gram_factor);
    if let Some(gram) = &mut end.gram {
        std::mem::swap(&mut lanes.gram, gram);
    }
}

impl<Sd: Simd, C: Equations> SplittingKernel<Lanes<Sd>> for NewtonLanes<Sd, C> {
    type Rows = LineVec<Lanes<Sd>>;
    type Failure = NoLaneForm;
    #[inline(always)]
    fn numbers(&self) -> &StepNumbers {
        &self.constants.numbers
    }
    #[inline(always)]
    fn inverse_mass(&self, k: usize, x: Lanes<Sd>) -> Lanes<Sd> {
        self.constraint.inverse_mass().apply(k, x)
    }
    /// The system's lane form of F(r), else path by path.
    #[inline(always)]
    fn evaluate_force<S: System>(&mut self, system: &S, r: &[Lanes<Sd>]) -> Result<(), NoLaneForm> {
        drift_over_lanes(system, r, &self.zero, &mut self.force, &mut self.scratch);
        Ok(())
    }
    #[inline(always)]
    fn force(&self) -> &[Lanes<Sd>] {
        &self.force
    }
    /// G_M(r) and its factors by the constraint's lane form; lambda by the factors, or as the
    /// quotient where G_M(r) is a scalar.
    #[inline(always)]
    fn rattle_multiplier(
        &mut self, r: &LineVec<Lanes<Sd>>, v: &LineVec<Lanes<Sd>>, refactor: bool,
        lambda: &mut [Lanes<Sd>],
    ) -> Result<LaneMask<Sd>, NoLaneForm> {
        let c = &self.constraint;
        let mut regular = self.zero[0].eq(self.zero[0]);
        if refactor {
            let at_r = c.evaluate_and_factor(
                &r[..],
                r,
                &mut self.values,
                &mut self.gram,
                &mut self.gram_factor,
                &mut self.solved,
            );
            regular = at_r.ok;
        }
        c.negated_jacobian_mul(r, v, lambda);
        if scalar::<C>() {
            // G_M itself: the 1 x 1 product G_M 1 is exact.
            let mut gram = [lambda[0]];
            self.gram.product(&[lambda[0].splat_like(1.0)], &mut gram);
            lambda[0] = lambda[0] / gram[0];
        } else {
            self.gram_factor.solve_in_place(lambda);
        }
        Ok(regular)
    }
    #[inline(always)]
    fn displace(&mut self, r: &LineVec<Lanes<Sd>>, z: &[Lanes<Sd>], v: &mut LineVec<Lanes<Sd>>) {
        self.constraint.displace(r, z, Some(&v[..]), &mut self.u);
        std::mem::swap(v, &mut self.u);
    }
    /// Newton from kappa = 0 at y = r + tau v, no ball ([`NewtonRoot`]).
    #[inline(always)]
    fn shake(
        &mut self, r: &LineVec<Lanes<Sd>>, v: &LineVec<Lanes<Sd>>, impulse: &mut [Lanes<Sd>],
    ) -> Result<Shaken<Lanes<Sd>>, NoLaneForm> {
        let tau = Lanes::splat(self.simd, self.constants.numbers.sizes.tau);
        let y = Drifted { r, v, tau };
        let root = self.root.solve(
            &self.constraint,
            &self.constants.settings,
            f64::INFINITY,
            y.r,
            &y,
            y.max_abs(),
        );
        self.root.point(&root, &y);
        // gamma* is kept: no contraction probes without a ball.
        let inverse_tau = self.constants.numbers.sizes.inverse_tau;
        shake_impulse(&self.root.gamma, inverse_tau, impulse);
        Ok(Shaken {
            ok: root.ok,
            iterations: root.iterations,
            residual: root.residual,
        })
    }
    #[inline(always)]
    fn move_to_root(&mut self, r: &mut LineVec<Lanes<Sd>>) {
        std::mem::swap(r, &mut self.root.x);
    }
    /// max_i |-(Dg(r) v)_i| = max_i |(Dg(r) v)_i|.
    #[inline(always)]
    fn velocity_residual(
        &mut self, r: &LineVec<Lanes<Sd>>, v: &LineVec<Lanes<Sd>>, scratch: &mut [Lanes<Sd>],
    ) -> Lanes<Sd> {
        self.constraint.negated_jacobian_mul(r, v, scratch);
        max_abs(scratch)
    }
    /// [`drift_and_thermostat`] compiled once per instruction set and constraint, not once
    /// per system.
    #[inline(never)]
    fn middle(
        &mut self, m: &mut Motion<'_, Lanes<Sd>, LineVec<Lanes<Sd>>>, dw: &[Lanes<Sd>],
        factored: bool,
    ) -> Result<(), NoLaneForm> {
        let simd = self.simd;
        simd.vectorize(Middle {
            lanes: self,
            motion: m,
            dw,
            factored,
        })
    }
}

/// [`drift_and_thermostat`] as an operation `Simd::vectorize` compiles as a function of its
/// own with the caller's instruction set (a closure would not inherit it).
struct Middle<'a, 'm, Sd: Simd, C: Equations> {
    lanes: &'a mut NewtonLanes<Sd, C>,
    motion: &'a mut Motion<'m, Lanes<Sd>, LineVec<Lanes<Sd>>>,
    dw: &'a [Lanes<Sd>],
    factored: bool,
}

impl<Sd: Simd, C: Equations> WithSimd for Middle<'_, '_, Sd, C> {
    type Output = Result<(), NoLaneForm>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> Result<(), NoLaneForm> {
        drift_and_thermostat(self.lanes, self.motion, self.dw, self.factored)
    }
}

impl<S: System, Sd: Simd, C: Equations> WideKernel<Splitting<S>, Sd> for Kernel<Sd, C> {
    /// [`Splitting`]'s B A O A B ([`kernel::step`]) for W lanes from `state` = (r_k, v_k) into
    /// `rows`.
    #[inline(always)]
    fn step(
        &mut self, scheme: &Splitting<S>, state: GroupState<'_, Sd>, rows: &mut LaneRows<Sd>,
    ) -> Option<(LaneMask<Sd>, LaneRecord<Sd>)> {
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
        // F(r_k) and G_M(r_k) as the group's last step left them, else anew (a path of the
        // group that the scalar step took, a restart, the first step).
        let resumed = self.resume(group, r_next, alive);
        let zero = Lanes::splat(self.lanes.simd, 0.0);
        let mut m = Motion::new(r_next, v_next, dmu, &mut self.lambda, zero);
        let velocity_residual =
            kernel::step(scheme.system(), &mut self.lanes, &mut m, dw, resumed).ok()?;
        let (ok, record) = (m.ok, m.record(velocity_residual));
        self.keep(group, r_next);
        Some((ok, record))
    }
}

/// What one group's [`EndPoint`] takes, about: r and F(r) (n rows each) and the factors of
/// an m x m matrix (at most m^2 + 3 m rows; with the matrix where m = 1).
fn end_point_bytes<Sd: Simd>(n: usize, m: usize) -> usize {
    (2 * n + m * m + 3 * m) * Lanes::<Sd>::WIDTH * std::mem::size_of::<f64>()
}
