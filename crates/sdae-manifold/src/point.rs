//! What the forms an engine steps are read from and write: a point read by coordinate, stored
//! or formed where it is read ([`Point`]); a diagonal M^-1 applied entry by entry
//! ([`InverseMass`]); the outcome of one evaluation of the kappa system ([`Evaluation`]).

use sdae_lanes::{PathMask, Real};

use crate::factor::MatrixFactor;
use crate::mass::Mass;

/// A diagonal M^-1 applied entry by entry: x (M^-1)_kk, or x itself where M^-1 = I (every
/// entry 1: x * 1 = x exactly, so leaving out the products changes no bit of the scalar
/// step's).
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
    pub fn apply<T: Real>(&self, k: usize, x: T) -> T {
        if self.unit { x } else { x * self.entries[k] }
    }
}

/// A point read by coordinate, of one path or of W lanes: stored (a slice) or formed where it
/// is read (the drifted point y = r + eta h v of an engine).
pub trait Point<T: Real> {
    /// Coordinates k..k + N.
    fn coords<const N: usize>(&self, k: usize) -> [T; N];
    /// The coordinates as stored, where the point is stored; `None` (the default) where it is
    /// formed where it is read.
    #[inline(always)]
    fn stored(&self) -> Option<&[T]> {
        None
    }
    /// Coordinates 0..out.len() into `out` (the point formed once, for formulas that read it
    /// as a slice).
    #[inline(always)]
    fn write_to(&self, out: &mut [T]) {
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.coords::<1>(k)[0];
        }
    }
}

impl<T: Real> Point<T> for [T] {
    #[inline(always)]
    fn coords<const N: usize>(&self, k: usize) -> [T; N] {
        *self[k..]
            .first_chunk::<N>()
            .expect("the point has coordinates k..k + N")
    }
    #[inline(always)]
    fn stored(&self) -> Option<&[T]> {
        Some(self)
    }
}

/// Coordinates k..k + N of a displacement's base ([`Equations::displace_at`](crate::Equations::displace_at)), or of `out`
/// where it is its own base.
#[inline(always)]
pub fn base_coords<T: Real, P: Point<T> + ?Sized, const N: usize>(
    base: Option<&P>, out: &[T], k: usize,
) -> [T; N] {
    match base {
        Some(base) => base.coords::<N>(k),
        None => out.coords::<N>(k),
    }
}

/// What [`Equations::evaluate_and_factor`](crate::Equations::evaluate_and_factor) found, per path.
pub struct Evaluation<T: Real> {
    /// max_i |g_i(x1)|.
    pub largest: T,
    /// The paths where g(x1) is finite and the factorization passed.
    pub ok: T::Mask,
}

impl<T: Real> Evaluation<T> {
    /// The end of an evaluation that stores g(x1) in `values` and J in `jacobian`, each in a
    /// pass of its own: [`max_abs_and_finite`] of g(x1), then J factored into `factor` with
    /// the first half of J^-1 g(x1) into `step` ([`MatrixFactor::factor`]).
    #[inline(always)]
    pub fn reduce_and_factor<F: MatrixFactor<T>>(
        values: &[T], jacobian: &F::Matrix, factor: &mut F, step: &mut [T],
    ) -> Self {
        let (largest, finite) = max_abs_and_finite(values);
        let factored = factor.factor(jacobian, Some((values, step)));
        Self {
            largest,
            ok: finite.and(factored),
        }
    }
}

/// max_i |x_i| of finite entries (`sdae_manifold::vector::max_abs`).
#[inline(always)]
pub fn max_abs<T: Real>(x: &[T]) -> T {
    let mut largest = x[0].splat_like(0.0);
    for xi in x {
        largest = largest.max(xi.abs());
    }
    largest
}

/// [`max_abs`] of x, and in the same pass the paths where every entry of x is finite (their
/// sum is finite; an overflowing sum of finite entries counts as not finite, which sends the
/// lane to the scalar step).
#[inline(always)]
pub fn max_abs_and_finite<T: Real>(x: &[T]) -> (T, T::Mask) {
    let mut largest = x[0].splat_like(0.0);
    let mut sum = largest;
    for xi in x {
        largest = largest.max(xi.abs());
        sum = sum + *xi;
    }
    (largest, sum.finite())
}
