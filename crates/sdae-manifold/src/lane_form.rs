//! A constraint's forms over SIMD lanes, for engines that step many paths at once.
//!
//! A constraint offers them through [`Constraint::lane_form`]:
//! it hands a [`LaneFormVisitor`] either itself for the fixed-size closed-form kernels (one
//! quadratic equation in 2 or 3 coordinates, as the [`Sphere`](crate::Sphere)) or itself with its mass as a [`LaneForm`]: its [`ConstraintLanes`] formulas over lanes
//! for the Newton iteration of the kappa system (seed eq. 3.1, upper part) and the velocity
//! update (lower part). The default offers none, and an engine then steps the paths one at a
//! time. A constraint written once over [`Real`](sdae_lanes::Real) as
//! [`Equations`] has its lane form by a blanket impl
//! (`crates/sdae-scheme/examples/custom_constraint.rs`: a double pendulum); a crate can also
//! implement [`ConstraintLanes`] for its own constraint; the built-in ones are the bead
//! chain's ([`BeadChain`](crate::BeadChain), with Thomas' algorithm for its tridiagonal
//! Newton matrix) and rigid bonds' ([`RigidBonds`](crate::RigidBonds), with an LU
//! factorization with partial pivoting per lane). The Newton
//! matrix and its factorization are the one-path storage and code run over lanes, named by
//! the structure ([`GramShape`]): a constraint with one equation names
//! [`Scalar`](crate::Scalar) (`crates/sdae-scheme/examples/custom_constraint.rs`: a torus).
//!
//! Each formula of a lane form must take the floating-point operations of the scalar
//! [`Constraint`] method it names, in the same order: then a lane's numbers
//! are the scalar step's, bit for bit, whatever the width.

mod bonds;
mod chain;

use pulp::Simd;
use sdae_lanes::{LaneMask, Lanes};

use crate::constraint::Constraint;
use crate::equations::Equations;
use crate::factor::MatrixFactor;
use crate::mass::Mass;
use crate::roundoff::Roundoff;
use crate::shape::GramShape;
use crate::vector::sum_squares;

/// What a constraint offers an engine over lanes ([`Constraint::lane_form`]):
/// the engine implements the methods for the forms it can step, and a constraint calls the one
/// that fits it. A form the engine does not step falls back to [`LaneFormVisitor::none`].
pub trait LaneFormVisitor: Sized {
    /// What the engine makes of the offer.
    type Output;
    /// No lane form: the paths step one at a time.
    fn none(self) -> Self::Output;
    /// A constraint of one quadratic equation in 2 or 3 coordinates with the scalar Gram
    /// storage (the sphere; [`offer_closed_form`](crate::offer_closed_form)), whose kappa
    /// system the engine solves in closed form on arrays of that size.
    fn closed_form<E: Equations>(self, constraint: &E) -> Self::Output {
        let _ = constraint;
        self.none()
    }
    /// The constraint's formulas over lanes for the Newton iteration with its mass, built by
    /// `build` (called at most once, when the engine has no lane form kept from an earlier
    /// step; `None`: no lane form for this mass after all).
    fn newton<L: ConstraintLanes>(
        self, build: impl FnOnce() -> Option<LaneForm<L>>,
    ) -> Self::Output {
        let _ = build;
        self.none()
    }
}

/// A constraint's formulas over W lanes for a diagonal mass M^-1 (`w`), each with the
/// floating-point operations of the one-path [`Constraint`] method it names: the Newton step of
/// an ensemble engine is written once over them. The constraint implements them itself; an
/// engine holds it with its mass as a [`LaneForm`].
pub trait ConstraintLanes: Constraint + Clone + Send + Sync + 'static {
    /// The structure of the Newton matrix: its storage and factorization over lanes.
    type Shape: GramShape;
    /// One evaluation of the kappa system at (x1, r): g(x1) and J = Dg(x1) M^-1 grad g(r) into
    /// `jacobian` (`Constraint::value_and_cross_gram`), [`max_abs_and_finite`] of g(x1), J
    /// factored into `factor` with the first half of J^-1 g(x1) into `step`
    /// ([`MatrixFactor::factor`]). `values` is scratch for g(x1); a constraint whose
    /// factorization runs row by row does it all in one pass over the rows.
    #[allow(clippy::too_many_arguments)]
    fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>],
        jacobian: &mut Jacobian<Sd, Self>, factor: &mut Factor<Sd, Self>, step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd>;
    /// force <- M^-1 force + v (v~ of eq. 3.1 from the force eta a h + B dw), then the first
    /// half ([`MatrixFactor::forward_in_place`]) of lambda = J^-1 (-Dg(x) v~) into `out`. The
    /// default takes three passes; a constraint can fuse them.
    #[inline(always)]
    fn velocity_right_hand_side<Sd: Simd>(
        &self, w: &InverseMass, x: &[Lanes<Sd>], force: &mut [Lanes<Sd>], v: &[Lanes<Sd>],
        factor: &Factor<Sd, Self>, out: &mut [Lanes<Sd>],
    ) {
        for (k, (f, vi)) in force.iter_mut().zip(v).enumerate() {
            *f = w.apply(k, *f) + *vi;
        }
        self.negated_jacobian_mul(x, force, out);
        factor.forward_in_place(out);
    }
    /// out = base + M^-1 grad g(r) z (`Constraint::displace`); without a base, out is its own
    /// (out <- out + M^-1 grad g(r) z, each entry of out read before it is written).
    fn displace_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>,
        out: &mut [Lanes<Sd>],
    );
    /// v_{k+1} = v~ + M^-1 grad g(r) lambda in place of v~ (`v`,
    /// [`ConstraintLanes::displace_lanes`] without a base), then the lanes whose v_{k+1} the
    /// scalar step finds finite (|v_{k+1}|^2 finite; a constraint may report fewer lanes, which
    /// then step through the scalar stepper) and, if `monitor`, max_i |(Dg(x) v_{k+1})_i| (in
    /// `scratch`, m rows). The default takes three passes; a constraint can fuse them.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn finish_velocity<Sd: Simd>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], lambda: &[Lanes<Sd>], x: &[Lanes<Sd>],
        monitor: bool, v: &mut [Lanes<Sd>], scratch: &mut [Lanes<Sd>],
    ) -> (LaneMask<Sd>, Lanes<Sd>) {
        self.displace_lanes(w, r, lambda, None::<&[Lanes<Sd>]>, v);
        let finite = sum_squares(v).is_finite();
        if !monitor {
            return (finite, v[0].splat_like(0.0));
        }
        // max_i |-(Dg(x) v)_i| = max_i |(Dg(x) v)_i|.
        self.negated_jacobian_mul(x, v, scratch);
        (finite, max_abs(scratch))
    }
    /// out = -Dg(x) u, the negation of `Constraint::jacobian_mul` (bit for bit: negation is
    /// exact and commutes with rounding), so that lambda's right-hand side needs no pass of its
    /// own.
    fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    );
    /// The coefficients [c0, c1, c2] of the kappa system R(gamma) = g(y + M^-1 grad g(r)
    /// gamma) = c0 + c1 gamma + c2 gamma^2 where g is quadratic, with the operations of
    /// `Constraint::kappa_quadratic`: an engine then takes the root in closed form, as the
    /// ball solver does for one path. `None` (the default): Newton.
    #[inline(always)]
    fn kappa_quadratic_lanes<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, w: &InverseMass, r: &[Lanes<Sd>], y: &P,
    ) -> Option<[Lanes<Sd>; 3]> {
        let _ = (w, r, y);
        None
    }
    /// The local measure of the motion (`Constraint::local_motion`); `None` (the default)
    /// where that is `None`, and the engine takes the seed's measure.
    fn local_motion_lanes<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        let _ = (v, a);
        None
    }
}

/// A constraint with its lane formulas and the diagonal M^-1 it steps with: what a
/// constraint offers an engine ([`LaneFormVisitor::newton`]) and the engine keeps. Its methods
/// are the constraint's [`ConstraintLanes`] methods with this mass.
pub struct LaneForm<C> {
    constraint: C,
    inverse_mass: InverseMass,
}

impl<C: ConstraintLanes> LaneForm<C> {
    /// `constraint` with a diagonal `mass`; `None` for another mass.
    pub fn new<M: Mass>(constraint: &C, mass: &M) -> Option<Self> {
        M::DIAGONAL.then(|| Self {
            constraint: constraint.clone(),
            inverse_mass: InverseMass::of(mass, constraint.dim()),
        })
    }
    /// The constraint.
    pub fn constraint(&self) -> &C {
        &self.constraint
    }
    /// M^-1.
    pub fn inverse_mass(&self) -> &InverseMass {
        &self.inverse_mass
    }
    /// The kind of the residual floor (`Constraint::roundoff`).
    pub fn roundoff(&self) -> Roundoff {
        self.constraint.roundoff()
    }
    /// (n, m).
    pub fn dims(&self) -> (usize, usize) {
        (self.constraint.dim(), self.constraint.n_constraints())
    }
    /// [`ConstraintLanes::evaluate_and_factor`].
    #[inline(always)]
    pub fn evaluate_and_factor<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, x1: &P, r: &[Lanes<Sd>], values: &mut [Lanes<Sd>], jacobian: &mut Jacobian<Sd, C>,
        factor: &mut Factor<Sd, C>, step: &mut [Lanes<Sd>],
    ) -> Evaluation<Sd> {
        let w = &self.inverse_mass;
        self.constraint
            .evaluate_and_factor(w, x1, r, values, jacobian, factor, step)
    }
    /// [`ConstraintLanes::velocity_right_hand_side`].
    #[inline(always)]
    pub fn velocity_right_hand_side<Sd: Simd>(
        &self, x: &[Lanes<Sd>], force: &mut [Lanes<Sd>], v: &[Lanes<Sd>], factor: &Factor<Sd, C>,
        out: &mut [Lanes<Sd>],
    ) {
        let w = &self.inverse_mass;
        self.constraint
            .velocity_right_hand_side(w, x, force, v, factor, out);
    }
    /// [`ConstraintLanes::displace_lanes`].
    #[inline(always)]
    pub fn displace<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, r: &[Lanes<Sd>], z: &[Lanes<Sd>], base: Option<&P>, out: &mut [Lanes<Sd>],
    ) {
        self.constraint
            .displace_lanes(&self.inverse_mass, r, z, base, out);
    }
    /// [`ConstraintLanes::finish_velocity`].
    #[inline(always)]
    pub fn finish_velocity<Sd: Simd>(
        &self, r: &[Lanes<Sd>], lambda: &[Lanes<Sd>], x: &[Lanes<Sd>], monitor: bool,
        v: &mut [Lanes<Sd>], scratch: &mut [Lanes<Sd>],
    ) -> (LaneMask<Sd>, Lanes<Sd>) {
        let w = &self.inverse_mass;
        self.constraint
            .finish_velocity(w, r, lambda, x, monitor, v, scratch)
    }
    /// [`ConstraintLanes::negated_jacobian_mul`].
    #[inline(always)]
    pub fn negated_jacobian_mul<Sd: Simd>(
        &self, x: &[Lanes<Sd>], u: &[Lanes<Sd>], out: &mut [Lanes<Sd>],
    ) {
        self.constraint.negated_jacobian_mul(x, u, out);
    }
    /// [`ConstraintLanes::kappa_quadratic_lanes`].
    #[inline(always)]
    pub fn kappa_quadratic<Sd: Simd, P: PointLanes<Sd> + ?Sized>(
        &self, r: &[Lanes<Sd>], y: &P,
    ) -> Option<[Lanes<Sd>; 3]> {
        self.constraint
            .kappa_quadratic_lanes(&self.inverse_mass, r, y)
    }
    /// [`ConstraintLanes::local_motion_lanes`].
    #[inline(always)]
    pub fn local_motion<Sd: Simd>(&self, v: &[Lanes<Sd>], a: &[Lanes<Sd>]) -> Option<Lanes<Sd>> {
        self.constraint.local_motion_lanes(v, a)
    }
}

/// A diagonal M^-1 applied to lanes: x (M^-1)_kk, or x itself where M^-1 = I (every entry 1:
/// x * 1 = x exactly, so leaving out the products changes no bit of the scalar step's).
pub struct InverseMass {
    entries: Vec<f64>,
    unit: bool,
}

impl InverseMass {
    /// The diagonal (M^-1)_kk of `mass`, k < n.
    pub fn of<M: Mass>(mass: &M, n: usize) -> Self {
        let entries: Vec<f64> = (0..n)
            .map(|k| mass.inverse_diagonal_entry(k).unwrap_or(0.0))
            .collect();
        let unit = entries.iter().all(|&w| w == 1.0);
        Self { entries, unit }
    }

    /// Whether M^-1 = I.
    #[inline(always)]
    pub fn is_unit(&self) -> bool {
        self.unit
    }

    /// (M^-1)_kk.
    #[inline(always)]
    pub fn entry(&self, k: usize) -> f64 {
        self.entries[k]
    }

    /// x (M^-1)_kk.
    #[inline(always)]
    pub fn apply<Sd: Simd>(&self, k: usize, x: Lanes<Sd>) -> Lanes<Sd> {
        if self.unit { x } else { x * self.entries[k] }
    }
}

/// A point of W lanes read by coordinate: stored (a slice of lanes) or formed where it is read
/// (the drifted point y = r + eta h v of an engine).
pub trait PointLanes<Sd: Simd> {
    /// Coordinates k..k + N.
    fn coords<const N: usize>(&self, k: usize) -> [Lanes<Sd>; N];
    /// The coordinates as stored rows, where the point is stored; `None` (the default) where
    /// it is formed where it is read.
    #[inline(always)]
    fn stored(&self) -> Option<&[Lanes<Sd>]> {
        None
    }
    /// Coordinates 0..out.len() into `out` (the point formed once, for formulas that read it
    /// as a slice).
    #[inline(always)]
    fn write_to(&self, out: &mut [Lanes<Sd>]) {
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.coords::<1>(k)[0];
        }
    }
}

impl<Sd: Simd> PointLanes<Sd> for [Lanes<Sd>] {
    #[inline(always)]
    fn coords<const N: usize>(&self, k: usize) -> [Lanes<Sd>; N] {
        *self[k..]
            .first_chunk::<N>()
            .expect("the point has coordinates k..k + N")
    }
    #[inline(always)]
    fn stored(&self) -> Option<&[Lanes<Sd>]> {
        Some(self)
    }
}

/// Coordinates k..k + N of a displacement's base ([`ConstraintLanes::displace_lanes`]), or of `out`
/// where it is its own base.
#[inline(always)]
pub fn base_coords<Sd: Simd, P: PointLanes<Sd> + ?Sized, const N: usize>(
    base: Option<&P>, out: &[Lanes<Sd>], k: usize,
) -> [Lanes<Sd>; N] {
    match base {
        Some(base) => base.coords::<N>(k),
        None => out.coords::<N>(k),
    }
}

/// What [`ConstraintLanes::evaluate_and_factor`] found, per lane.
pub struct Evaluation<Sd: Simd> {
    /// max_i |g_i(x1)|.
    pub largest: Lanes<Sd>,
    /// The lanes where g(x1) is finite and the factorization passed.
    pub ok: LaneMask<Sd>,
}

impl<Sd: Simd> Evaluation<Sd> {
    /// The end of an evaluation that stores g(x1) in `values` and J in `jacobian`, each in a
    /// pass of its own: [`max_abs_and_finite`] of g(x1), then J factored into `factor` with
    /// the first half of J^-1 g(x1) into `step` ([`MatrixFactor::factor`]).
    #[inline(always)]
    pub fn reduce_and_factor<F: MatrixFactor<Lanes<Sd>>>(
        values: &[Lanes<Sd>], jacobian: &F::Matrix, factor: &mut F, step: &mut [Lanes<Sd>],
    ) -> Self {
        let (largest, finite) = max_abs_and_finite(values);
        let factored = factor.factor(jacobian, Some((values, step)));
        Self {
            largest,
            ok: finite.and(factored),
        }
    }
}

/// The Newton matrix of constraint C over lanes of Sd.
pub type Jacobian<Sd, C> = <<C as ConstraintLanes>::Shape as GramShape>::Matrix<Lanes<Sd>>;

/// The factorization of the Newton matrix of constraint C over lanes of Sd.
pub type Factor<Sd, C> = <<C as ConstraintLanes>::Shape as GramShape>::Factor<Lanes<Sd>>;

/// Whether any lane of `mask` holds.
#[inline(always)]
pub fn active_any<Sd: Simd>(mask: LaneMask<Sd>) -> bool {
    mask.any()
}

/// max_i |x_i| of finite entries (`sdae_manifold::vector::max_abs`).
#[inline(always)]
pub fn max_abs<Sd: Simd>(x: &[Lanes<Sd>]) -> Lanes<Sd> {
    let mut largest = x[0].splat_like(0.0);
    for xi in x {
        largest = largest.max(xi.abs());
    }
    largest
}

/// [`max_abs`] of x, and in the same pass the lanes where every entry of x is finite (their
/// sum is finite; an overflowing sum of finite entries counts as not finite, which sends the
/// lane to the scalar step).
#[inline(always)]
pub fn max_abs_and_finite<Sd: Simd>(x: &[Lanes<Sd>]) -> (Lanes<Sd>, LaneMask<Sd>) {
    let mut largest = x[0].splat_like(0.0);
    let mut sum = largest;
    for xi in x {
        largest = largest.max(xi.abs());
        sum = sum + *xi;
    }
    (largest, sum.is_finite())
}
