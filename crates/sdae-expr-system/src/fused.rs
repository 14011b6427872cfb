//! The step's composite forms of a constraint, each compiled as one program (where the
//! composition of g, Dg u, Dg^T z and D^2 g(u, w) takes several calls), for a diagonal mass
//! whose inverse W = M^-1 is an input (slot [`W`], n values):
//!
//! - g(x) and the cross Gram matrix G = Dg(x) W Dg(r)^T, G_ij = sum_k J_ik(x) (J_jk(r) w_k)
//!   over the coordinates k rows i and j share, in increasing k: the entries the products
//!   p -> Dg(x) W Dg(r)^T p give (the terms of the other coordinates are exact zeros), with
//!   the same operations, so the same numbers (but for the sign of a zero);
//! - the coefficients [c0, c1, c2] of the kappa system of one quadratic equation: c0 = g(y),
//!   c1 = Dg(y) w~, c2 = D^2 g(w~, w~) 0.5 with w~_k = J_k(r) w_k, as the composed formula
//!   computes them.
//!
//! Inputs: x (or y) in slot [`Q`], r in slot [`U`], W in slot [`W`] (none where M = I: the
//! products by 1 are left out, as the composed forms leave them out).

use sdae_expr::{ExprId, Graph, Jacobian, Program, Var};
use sdae_lanes::Real;
use sdae_manifold::{DenseGram, ScalarGram, TridiagonalGram};

use crate::error::SpecError;
use crate::error::compile;
use crate::names::{Q, U, W};
use crate::scratch::Sink;

/// The fused programs of a constraint, for a diagonal M^-1 given as an input and for the unit
/// mass (M^-1 = I folded in: the products by 1 dropped, as the composed forms skip them).
#[derive(Debug)]
pub(crate) struct FusedPrograms {
    /// The (i, j) of the Gram entries that are not structurally zero (rows i and j of Dg
    /// share a coordinate), row by row.
    pub(crate) gram_pattern: Vec<(usize, usize)>,
    /// Whether `gram_pattern` covers every entry of the dense storage (m^2).
    pub(crate) fills_dense: bool,
    /// Whether `gram_pattern` covers every entry of the tridiagonal storage (3m - 2).
    pub(crate) fills_band: bool,
    /// For a diagonal M^-1 (slot [`W`]).
    pub(crate) diagonal: Forms,
    /// For M = I.
    pub(crate) unit: Forms,
}

/// The fused programs for one kind of mass.
#[derive(Debug)]
pub(crate) struct Forms {
    /// g(x), then the Gram entries of the pattern.
    pub(crate) value_gram: Program,
    /// The Gram entries of the pattern.
    pub(crate) gram: Program,
    /// [c0, c1, c2] where m = 1 and g is quadratic.
    pub(crate) kappa: Option<Program>,
}

impl FusedPrograms {
    /// The fused programs of g (`g`, with its Jacobian over slot [`Q`] and its second
    /// derivatives D^2 g(u, w) with u in slot [`U`], w in slot [`W`]).
    pub(crate) fn new(
        graph: &mut Graph, g: &[ExprId], jacobian: &Jacobian, second: &[ExprId], quadratic: bool,
    ) -> Result<Self, SpecError> {
        let n = jacobian.cols();
        let derivatives = |error| SpecError::expression("constraints", "", error);
        let at_x: Vec<ExprId> = jacobian.entries().iter().map(|e| e.expr).collect();
        let r: Vec<ExprId> = (0..n).map(|k| graph.input(input(U, k))).collect();
        let at_r = graph
            .substitute(&at_x, &|var| (var.slot == Q).then(|| r[var.index as usize]))
            .map_err(derivatives)?;
        let parts = Parts {
            g,
            jacobian,
            at_x: &at_x,
            second,
            quadratic,
        };
        let w: Vec<ExprId> = (0..n).map(|k| graph.input(input(W, k))).collect();
        let (gram_pattern, diagonal) = parts.forms(graph, &at_r, &w)?;
        let one = vec![graph.num(1.0); n];
        let (_, unit) = parts.forms(graph, &at_r, &one)?;
        let m = jacobian.rows();
        let band = if m == 1 { 1 } else { 3 * m - 2 };
        Ok(Self {
            fills_dense: gram_pattern.len() == m * m,
            fills_band: gram_pattern.len() == band,
            gram_pattern,
            diagonal,
            unit,
        })
    }
}

/// What the fused forms are built from: g, its Jacobian (entries `at_x`, over slot [`Q`]) and
/// its second derivatives D^2 g(u, w).
struct Parts<'a> {
    g: &'a [ExprId],
    jacobian: &'a Jacobian,
    at_x: &'a [ExprId],
    second: &'a [ExprId],
    quadratic: bool,
}

impl Parts<'_> {
    /// The Gram pattern and the forms with M^-1 = diag(`w`), J(r) given (`at_r`).
    fn forms(
        &self, graph: &mut Graph, at_r: &[ExprId], w: &[ExprId],
    ) -> Result<(Vec<(usize, usize)>, Forms), SpecError> {
        // J_jk(r) w_k: column k of M^-1 grad g(r) e_j.
        let scaled: Vec<ExprId> = at_r
            .iter()
            .zip(self.jacobian.entries())
            .map(|(&e, entry)| graph.mul(e, w[entry.col]))
            .collect();
        let (pattern, gram) = gram_entries(graph, self.jacobian, self.at_x, &scaled);
        let value_gram: Vec<ExprId> = self.g.iter().chain(&gram).copied().collect();
        let kappa = match self.quadratic && self.g.len() == 1 {
            true => Some(kappa(graph, self, &scaled)?),
            false => None,
        };
        let forms = Forms {
            value_gram: compile(graph, &value_gram, "constraints")?,
            gram: compile(graph, &gram, "constraints")?,
            kappa: kappa
                .map(|c| compile(graph, &c, "constraints"))
                .transpose()?,
        };
        Ok((pattern, forms))
    }
}

/// Input `index` of slot `slot`.
fn input(slot: u16, index: usize) -> Var {
    Var::new(slot, index as u32)
}

/// The Gram entries G_ij = sum_k J_ik(x) (J_jk(r) w_k) over the coordinates rows i and j
/// share, in increasing k, for every (i, j) that shares one; `at_x` and `scaled` are J(x)
/// and J(r) w in the order of the Jacobian's entries.
fn gram_entries(
    graph: &mut Graph, jacobian: &Jacobian, at_x: &[ExprId], scaled: &[ExprId],
) -> (Vec<(usize, usize)>, Vec<ExprId>) {
    let m = jacobian.rows();
    // (col, position in the entries) of each row, columns increasing.
    let mut rows: Vec<Vec<(usize, usize)>> = vec![Vec::new(); m];
    for (position, entry) in jacobian.entries().iter().enumerate() {
        rows[entry.row].push((entry.col, position));
    }
    let (mut pattern, mut entries) = (Vec::new(), Vec::new());
    for (i, row_i) in rows.iter().enumerate() {
        for (j, row_j) in rows.iter().enumerate() {
            let mut sum = None;
            for &(k, pi) in row_i {
                let Some(&(_, pj)) = row_j.iter().find(|(col, _)| *col == k) else {
                    continue;
                };
                let term = graph.mul(at_x[pi], scaled[pj]);
                sum = Some(match sum {
                    Some(s) => graph.add(s, term),
                    None => term,
                });
            }
            if let Some(sum) = sum {
                pattern.push((i, j));
                entries.push(sum);
            }
        }
    }
    (pattern, entries)
}

/// [c0, c1, c2] of the kappa system of the one quadratic equation g (y in slot [`Q`]):
/// w~_k = J_k(r) w_k (`scaled`, 0 off the pattern), c0 = g(y), c1 = sum_k J_k(y) w~_k over
/// the pattern in increasing k, c2 = D^2 g(w~, w~) 0.5 (D^2 g(u, w) with both directions w~).
fn kappa(
    graph: &mut Graph, parts: &Parts<'_>, scaled: &[ExprId],
) -> Result<Vec<ExprId>, SpecError> {
    let derivatives = |error| SpecError::expression("constraints", "", error);
    let zero = graph.num(0.0);
    let mut direction = vec![zero; parts.jacobian.cols()];
    let mut c1 = zero;
    for ((entry, &jy), &w) in parts.jacobian.entries().iter().zip(parts.at_x).zip(scaled) {
        direction[entry.col] = w;
        let term = graph.mul(jy, w);
        c1 = graph.add(c1, term);
    }
    let along = |var: Var| match var.slot {
        U | W => Some(direction[var.index as usize]),
        _ => None,
    };
    let curvature = graph
        .substitute(&parts.second[..1], &along)
        .map_err(derivatives)?[0];
    let half = graph.num(0.5);
    let c2 = graph.mul(curvature, half);
    Ok(vec![parts.g[0], c1, c2])
}

/// The storage a Gram matrix is written into (the three of sdae-manifold's shapes).
pub(crate) enum GramTarget<'a, T> {
    /// m = 1.
    Scalar(&'a mut T),
    /// Tridiagonal bands.
    Tridiagonal(&'a mut TridiagonalGram<T>),
    /// Dense, row-major.
    Dense(&'a mut DenseGram<T>),
}

impl<'a, T: Real> GramTarget<'a, T> {
    /// `matrix` as one of the three storages (`None` for another shape's storage).
    #[inline(always)]
    pub(crate) fn of<Mx: 'static>(matrix: &'a mut Mx) -> Option<Self> {
        let any: &mut dyn std::any::Any = matrix;
        if any.is::<ScalarGram<T>>() {
            return any
                .downcast_mut::<ScalarGram<T>>()
                .map(|s| Self::Scalar(&mut s.0));
        }
        if any.is::<TridiagonalGram<T>>() {
            return any.downcast_mut().map(Self::Tridiagonal);
        }
        any.downcast_mut().map(Self::Dense)
    }

    /// Zeros where `fused` writes no entry of an m x m matrix.
    #[inline(always)]
    pub(crate) fn clear_unwritten(&mut self, fused: &FusedPrograms, m: usize, like: T) {
        let zero = like.splat_like(0.0);
        match self {
            Self::Scalar(value) if fused.gram_pattern.is_empty() => **value = zero,
            Self::Tridiagonal(bands) if !fused.fills_band => {
                for band in [&mut bands.lower, &mut bands.diag, &mut bands.upper] {
                    band.fill(zero);
                }
            }
            Self::Dense(matrix) if !fused.fills_dense => {
                for i in 0..m {
                    for j in 0..m {
                        matrix.set(i, j, zero);
                    }
                }
            }
            _ => {}
        }
    }

    /// Entry (i, j) is `value`.
    #[inline(always)]
    fn set(&mut self, i: usize, j: usize, value: T) {
        match self {
            Self::Scalar(entry) => **entry = value,
            Self::Tridiagonal(bands) if i == j => bands.diag[i] = value,
            Self::Tridiagonal(bands) if i > j => bands.lower[j] = value,
            Self::Tridiagonal(bands) => bands.upper[i] = value,
            Self::Dense(matrix) => matrix.set(i, j, value),
        }
    }
}

/// The outputs of a fused program: first `values.len()` values of g, then the Gram entries
/// of `pattern` into `target`.
pub(crate) struct GramSink<'a, 'b, T> {
    /// g's values (empty where the program has none).
    pub(crate) values: &'b mut [T],
    /// The (i, j) of the Gram outputs.
    pub(crate) pattern: &'b [(usize, usize)],
    /// The Gram storage.
    pub(crate) target: GramTarget<'a, T>,
}

impl<T: Real> Sink<T> for GramSink<'_, '_, T> {
    #[inline(always)]
    fn put(&mut self, k: usize, value: T) {
        match self.values.get_mut(k) {
            Some(v) => *v = value,
            None => {
                let (i, j) = self.pattern[k - self.values.len()];
                self.target.set(i, j, value);
            }
        }
    }
}
