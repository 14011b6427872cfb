//! The constraint g(q) = 0 of a specification: its m expressions, their Jacobian with its
//! sparsity pattern, and the compiled programs of g, Dg u, Dg^T z and D^2 g(u, w), evaluated
//! over any [`Real`] ([`ExpressionConstraint`]).

use std::marker::PhantomData;
use std::sync::Arc;

use sdae_expr::{ExprId, Graph, Program, SymbolTable};
use sdae_lanes::Real;
use sdae_manifold::{
    Dense, Equations, GramShape, GramStructure, InverseMassOf, ManifoldError, Mass, Roundoff,
};

use crate::error::SpecError;
use crate::error::compile;
use crate::fused::{FusedPrograms, GramSink, GramTarget};
use crate::names::{Q, U, V, W, Z, slot};
use crate::scratch;

/// The most nonzero entries per row of the Jacobian for which the rounding floor of a
/// quadratic constraint is measured from its Hessian (beyond it the floor is unknown).
const ROUNDOFF_ROW_LIMIT: usize = 32;

/// The compiled constraint, shared by the system's clones.
#[derive(Debug)]
pub(crate) struct ConstraintPrograms {
    pub(crate) n: usize,
    pub(crate) m: usize,
    /// g(q).
    pub(crate) value: Program,
    /// Dg(q) u.
    pub(crate) jacobian_mul: Program,
    /// Dg(q)^T z.
    pub(crate) transpose_mul: Program,
    /// D^2 g(q)(u, w).
    pub(crate) second: Program,
    /// The structurally nonzero entries of Dg(q), in the order of `pattern`.
    pub(crate) entries: Program,
    /// (row, col) of the structurally nonzero entries of Dg.
    pub(crate) pattern: Vec<(usize, usize)>,
    /// Every g_i is a polynomial of degree <= 2 (D^2 g does not depend on q).
    pub(crate) quadratic: bool,
    /// The rounding floor's kind.
    pub(crate) roundoff: Roundoff,
    /// The structure of Dg M^-1 Dg^T for a diagonal M.
    pub(crate) structure: GramStructure,
    /// The step's composite forms, one program each, for a diagonal mass.
    pub(crate) fused: FusedPrograms,
}

/// Where an expression may read velocities: anywhere, or nowhere (the coordinates' names, to
/// name a velocity read).
#[derive(Clone, Copy)]
pub(crate) enum Reads<'a> {
    /// f(q, v).
    Velocities,
    /// f(q) of these coordinates.
    Coordinates(&'a [String]),
}

/// Parses expression `text` of entry `key`; refuses a velocity where it `reads` coordinates
/// only.
pub(crate) fn parse(
    graph: &mut Graph, table: &SymbolTable, key: &str, text: &str, reads: Reads<'_>,
) -> Result<ExprId, SpecError> {
    let e = graph
        .parse(text, table)
        .map_err(|error| SpecError::expression(key, text, error))?;
    if let Reads::Coordinates(names) = reads
        && let Some(var) = graph.inputs_of(e).into_iter().find(|v| v.slot == V)
    {
        let name = &names[var.index as usize];
        let message = format!(
            "reads the velocity `v_{name}`: it must be a function of the coordinates alone"
        );
        return Err(SpecError::conflict(key, message));
    }
    Ok(e)
}

impl ConstraintPrograms {
    /// The constraints `texts` over n coordinates, differentiated and compiled.
    pub(crate) fn new(
        graph: &mut Graph, table: &SymbolTable, texts: &[String], names: &[String],
    ) -> Result<Self, SpecError> {
        let (n, m) = (names.len(), texts.len());
        let reads = Reads::Coordinates(names);
        let g = texts
            .iter()
            .enumerate()
            .map(|(i, text)| parse(graph, table, &format!("constraints[{i}]"), text, reads))
            .collect::<Result<Vec<_>, _>>()?;
        let derivatives = |error| SpecError::expression("constraints", "", error);
        let q = slot(Q, n);
        let (u, w, z) = (slot(U, n), slot(W, n), slot(Z, m));
        let jacobian = graph.jacobian(&g, &q).map_err(derivatives)?;
        let products = graph.jacobian_vector(&jacobian, &u).map_err(derivatives)?;
        let second = graph
            .second_directional(&jacobian, &q, &u, &w)
            .map_err(derivatives)?;
        // (Dg^T z)_j = sum_i J_ij z_i over the column's entries, rows in order.
        let mut transpose: Vec<ExprId> = (0..n).map(|_| graph.num(0.0)).collect();
        for entry in jacobian.entries() {
            let zi = graph.input(z[entry.row]);
            let term = graph.mul(entry.expr, zi);
            transpose[entry.col] = graph.add(transpose[entry.col], term);
        }
        let pattern = jacobian.pattern();
        let entry_exprs: Vec<ExprId> = jacobian.entries().iter().map(|e| e.expr).collect();
        let quadratic = second
            .iter()
            .all(|&e| graph.inputs_of(e).iter().all(|v| v.slot != Q));
        let roundoff = if quadratic {
            quadratic_roundoff(graph, &g, &pattern)?
        } else {
            Roundoff::Unknown
        };
        let fused = FusedPrograms::new(graph, &g, &jacobian, &second, quadratic)?;
        Ok(Self {
            n,
            m,
            fused,
            value: compile(graph, &g, "constraints")?,
            jacobian_mul: compile(graph, &products, "constraints")?,
            transpose_mul: compile(graph, &transpose, "constraints")?,
            second: compile(graph, &second, "constraints")?,
            entries: compile(graph, &entry_exprs, "constraints")?,
            structure: structure(m, &pattern),
            pattern,
            quadratic,
            roundoff,
        })
    }

    /// Dg(x) as a dense row-major m x n matrix.
    pub(crate) fn dense_jacobian(&self, x: &[f64]) -> Vec<f64> {
        let mut values = vec![0.0; self.pattern.len()];
        scratch::eval(&self.entries, &[x], &mut values);
        let mut dense = vec![0.0; self.m * self.n];
        for (&(i, j), value) in self.pattern.iter().zip(values) {
            dense[i * self.n + j] = value;
        }
        dense
    }
}

/// The structure of Dg M^-1 Dg^T for a diagonal M from the pattern of Dg: rows i and j couple
/// where they share a coordinate. Scalar for m = 1; tridiagonal where only neighbouring rows
/// share coordinates; dense otherwise.
fn structure(m: usize, pattern: &[(usize, usize)]) -> GramStructure {
    if m == 1 {
        return GramStructure::Scalar;
    }
    let mut rows_of_col: std::collections::BTreeMap<usize, (usize, usize)> = Default::default();
    for &(row, col) in pattern {
        let span = rows_of_col.entry(col).or_insert((row, row));
        span.0 = span.0.min(row);
        span.1 = span.1.max(row);
    }
    if rows_of_col.values().all(|(lo, hi)| hi - lo <= 1) {
        GramStructure::Tridiagonal
    } else {
        GramStructure::Dense
    }
}

/// The rounding floor of quadratic constraints: a few ulps of max |H_jk| |x|^2 per coordinate
/// of a row, stated as [`Roundoff::SquaredRadius`] with d the most coordinates of a row and
/// 1 / rho^2 the largest |H_jk| over the rows (for the sphere's (1 - |x|^2 / rho^2) / 2, whose
/// Hessian is -I / rho^2, the sphere's own floor). Unknown where a row has more than
/// [`ROUNDOFF_ROW_LIMIT`] coordinates.
fn quadratic_roundoff(
    graph: &mut Graph, g: &[ExprId], pattern: &[(usize, usize)],
) -> Result<Roundoff, SpecError> {
    let mut widest = 0;
    let mut largest: f64 = 0.0;
    for (i, &gi) in g.iter().enumerate() {
        let vars: Vec<_> = pattern
            .iter()
            .filter(|(row, _)| *row == i)
            .map(|&(_, col)| sdae_expr::Var::new(Q, col as u32))
            .collect();
        if vars.len() > ROUNDOFF_ROW_LIMIT {
            return Ok(Roundoff::Unknown);
        }
        widest = widest.max(vars.len());
        let hessian = graph
            .constant_hessian(gi, &vars)
            .map_err(|error| SpecError::expression("constraints", "", error))?;
        for h in hessian.into_iter().flatten() {
            largest = largest.max(h.abs());
        }
    }
    Ok(if largest > 0.0 {
        Roundoff::SquaredRadius {
            dim: widest,
            inverse_radius_squared: largest,
        }
    } else {
        Roundoff::Unknown
    })
}

/// The constraint g(q) = 0 of an [`ExpressionSystem`](crate::ExpressionSystem): g, Dg u,
/// Dg^T z and D^2 g(u, w) are compiled programs evaluated over any [`Real`] (`f64` for one
/// path, lanes for W paths, bit for bit). `Sh` is the structure of its Gram matrix
/// Dg M^-1 Dg^T the engines factor: [`Dense`] (always valid, the default),
/// [`Tridiagonal`](sdae_manifold::Tridiagonal) where only neighbouring equations share a
/// coordinate, [`Scalar`](sdae_manifold::Scalar) for one equation
/// ([`ExpressionSystem::visit_shape`](crate::ExpressionSystem::visit_shape) picks it).
pub struct ExpressionConstraint<Sh: GramShape = Dense> {
    pub(crate) programs: Arc<ConstraintPrograms>,
    shape: PhantomData<fn() -> Sh>,
}

impl<Sh: GramShape> Clone for ExpressionConstraint<Sh> {
    fn clone(&self) -> Self {
        Self::of(self.programs.clone())
    }
}

impl<Sh: GramShape> std::fmt::Debug for ExpressionConstraint<Sh> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExpressionConstraint")
            .field("n", &self.programs.n)
            .field("m", &self.programs.m)
            .field("shape", &Sh::STRUCTURE)
            .field("quadratic", &self.programs.quadratic)
            .finish()
    }
}

impl<Sh: GramShape> ExpressionConstraint<Sh> {
    /// The constraint of `programs` with shape `Sh`.
    pub(crate) fn of(programs: Arc<ConstraintPrograms>) -> Self {
        Self {
            programs,
            shape: PhantomData,
        }
    }

    /// The sparsity pattern of Dg: the (row, col) of its structurally nonzero entries.
    pub fn pattern(&self) -> &[(usize, usize)] {
        &self.programs.pattern
    }

    /// The structure the pattern allows: `Scalar` for m = 1, `Tridiagonal` where only
    /// neighbouring equations share a coordinate, `Dense` otherwise.
    pub fn structure(&self) -> GramStructure {
        self.programs.structure
    }

    /// n.
    pub fn dim(&self) -> usize {
        self.programs.n
    }

    /// m.
    pub fn n_constraints(&self) -> usize {
        self.programs.m
    }

    /// out = g(x), m values.
    #[inline(always)]
    pub fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        scratch::eval(&self.programs.value, &[x], &mut out[..self.programs.m]);
    }

    /// out = Dg(x) u, m values.
    #[inline(always)]
    pub fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        let program = &self.programs.jacobian_mul;
        scratch::eval(program, &[x, &[], u], &mut out[..self.programs.m]);
    }

    /// out = Dg(x)^T z, n values (overwritten).
    #[inline(always)]
    pub fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        let program = &self.programs.transpose_mul;
        scratch::eval(program, &[x, &[], &[], &[], z], &mut out[..self.programs.n]);
    }

    /// out = D^2 g(x)(u, w), m values.
    #[inline(always)]
    pub fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        let program = &self.programs.second;
        scratch::eval(program, &[x, &[], u, w], &mut out[..self.programs.m]);
    }

    /// Whether every g_i is a polynomial of degree at most 2 (D^2 g constant): with m = 1 the
    /// kappa root is taken in closed form.
    pub fn is_quadratic(&self) -> bool {
        self.programs.quadratic
    }

    /// The rounding floor: for quadratic constraints, a few ulps of |H| |x|^2 (H the
    /// constant Hessian, d the most coordinates in a row); unknown otherwise.
    pub fn roundoff(&self) -> Roundoff {
        self.programs.roundoff
    }

    /// Every mass fits a scalar or dense Gram storage; a tridiagonal one needs a diagonal mass
    /// (another couples equations that share no coordinate).
    pub fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        let _ = mass;
        if M::DIAGONAL || Sh::STRUCTURE != GramStructure::Tridiagonal {
            return Ok(());
        }
        Err(ManifoldError::InvalidParameter {
            name: "mass",
            value: f64::NAN,
            reason: "a tridiagonal Gram storage of an expression constraint needs a diagonal mass",
        })
    }
}

/// The formulas written once over [`Real`]: through sdae-manifold's blanket impls the
/// constraint is a `Constraint`, a `Curvature` and, with a diagonal mass, steps in lanes with
/// the one-path numbers.
impl<Sh: GramShape> Equations for ExpressionConstraint<Sh> {
    type Shape = Sh;
    fn dim(&self) -> usize {
        self.programs.n
    }
    fn n_constraints(&self) -> usize {
        self.programs.m
    }
    #[inline(always)]
    fn value<T: Real>(&self, x: &[T], out: &mut [T]) {
        ExpressionConstraint::value(self, x, out);
    }
    #[inline(always)]
    fn jacobian_mul<T: Real>(&self, x: &[T], u: &[T], out: &mut [T]) {
        ExpressionConstraint::jacobian_mul(self, x, u, out);
    }
    #[inline(always)]
    fn jacobian_transpose_mul<T: Real>(&self, x: &[T], z: &[T], out: &mut [T]) {
        ExpressionConstraint::jacobian_transpose_mul(self, x, z, out);
    }
    #[inline(always)]
    fn second_derivative<T: Real>(&self, x: &[T], u: &[T], w: &[T], out: &mut [T]) {
        ExpressionConstraint::second_derivative(self, x, u, w, out);
    }
    fn is_quadratic(&self) -> bool {
        self.programs.quadratic
    }
    fn roundoff(&self) -> Roundoff {
        self.programs.roundoff
    }
    fn check_mass<M: Mass>(&self, mass: &M) -> Result<(), ManifoldError> {
        ExpressionConstraint::check_mass(self, mass)
    }
    /// For a diagonal mass one program of x1, x2 and M^-1 (fused: the numbers of
    /// the composed products); by the products otherwise.
    #[inline(always)]
    fn cross_gram<T: Real, Inv: InverseMassOf<T>>(
        &self, inverse_mass: &Inv, x1: &[T], x2: &[T], scratch: &mut [T],
        out: &mut <Sh as GramShape>::Matrix<T>,
    ) {
        if !self.fused_gram(inverse_mass, x1, x2, scratch, &mut [], out) {
            sdae_manifold::cross_gram_by_products(self, x1, x2, inverse_mass, scratch, out);
        }
    }
    /// For a diagonal mass one program of x, r and M^-1 (fused); g, then the cross
    /// Gram matrix otherwise.
    #[inline(always)]
    fn value_and_cross_gram<T: Real, Inv: InverseMassOf<T>>(
        &self, inverse_mass: &Inv, x: &[T], r: &[T], scratch: &mut [T], value: &mut [T],
        gram: &mut <Sh as GramShape>::Matrix<T>,
    ) {
        let value = &mut value[..self.programs.m];
        if !self.fused_gram(inverse_mass, x, r, scratch, value, gram) {
            Equations::value(self, x, value);
            Equations::cross_gram(self, inverse_mass, x, r, scratch, gram);
        }
    }
    /// For one quadratic equation and a diagonal mass one program of r, y and M^-1
    /// (fused: the composed formula's numbers); the composed formula for another
    /// mass; `None` for other constraints (Newton).
    #[inline(always)]
    fn kappa_quadratic<T: Real, Inv: InverseMassOf<T>>(
        &self, inverse_mass: &Inv, r: &[T], y: &[T], scratch: &mut [T],
    ) -> Option<[T; 3]> {
        let fused = &self.programs.fused;
        fused.unit.kappa.as_ref()?;
        let mut c = [r[0]; 3];
        let (program, w) = match inverse_diagonal(inverse_mass, r[0], scratch, self.programs.n) {
            Diagonal::Unit => (&fused.unit.kappa, &[][..]),
            Diagonal::Entries(w) => (&fused.diagonal.kappa, w),
            Diagonal::Not => {
                let c = sdae_manifold::kappa_coefficients(self, r, y, inverse_mass, scratch);
                return Some(c);
            }
        };
        scratch::eval(program.as_ref()?, &[y, &[], r, w], &mut c);
        Some(c)
    }
}

impl<Sh: GramShape> ExpressionConstraint<Sh> {
    /// Runs the fused program of the cross Gram matrix (with g where `values` has m entries)
    /// for the mass (inputs x, r and the diagonal of M^-1, into `scratch`, where it is not
    /// the unit's): g(x) into `values` (none or m), the Gram entries into `gram`. False where
    /// the mass is not diagonal or the storage not one of sdae-manifold's (nothing written).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn fused_gram<T: Real, Inv: InverseMassOf<T>, Mx: 'static>(
        &self, inverse_mass: &Inv, x: &[T], r: &[T], scratch: &mut [T], values: &mut [T],
        gram: &mut Mx,
    ) -> bool {
        let fused = &self.programs.fused;
        let (forms, w) = match inverse_diagonal(inverse_mass, x[0], scratch, self.programs.n) {
            Diagonal::Unit => (&fused.unit, &[][..]),
            Diagonal::Entries(w) => (&fused.diagonal, w),
            Diagonal::Not => return false,
        };
        let program = match values.is_empty() {
            true => &forms.gram,
            false => &forms.value_gram,
        };
        let Some(mut target) = GramTarget::of(gram) else {
            return false;
        };
        target.clear_unwritten(fused, self.programs.m, x[0]);
        let mut sink = GramSink {
            values,
            pattern: &fused.gram_pattern,
            target,
        };
        scratch::eval_to(program, &[x, &[], r, w], x[0], &mut sink);
        true
    }
}

/// M^-1 as the fused programs take it.
enum Diagonal<'s, T> {
    /// M = I.
    Unit,
    /// Its diagonal.
    Entries(&'s [T]),
    /// Not diagonal.
    Not,
}

/// M^-1 where it is the unit matrix, else its diagonal as n numbers of the kind of `like`
/// in the first n entries of `scratch`; `Not` where M is not diagonal (or `scratch` short).
#[inline(always)]
fn inverse_diagonal<'s, T: Real, Inv: InverseMassOf<T>>(
    inverse_mass: &Inv, like: T, scratch: &'s mut [T], n: usize,
) -> Diagonal<'s, T> {
    let mut unit = true;
    for k in 0..n {
        match inverse_mass.diagonal_entry(k) {
            Some(entry) => unit &= entry == 1.0,
            None => return Diagonal::Not,
        }
    }
    if unit {
        return Diagonal::Unit;
    }
    let Some(w) = scratch.get_mut(..n) else {
        return Diagonal::Not;
    };
    for (k, wk) in w.iter_mut().enumerate() {
        *wk = like.splat_like(inverse_mass.diagonal_entry(k).unwrap_or(f64::NAN));
    }
    Diagonal::Entries(w)
}
