//! Symbolic derivatives: partial derivatives, gradients, Jacobians with their sparsity,
//! directional second derivatives, and the test for constant second derivatives.

use std::collections::HashMap;

use crate::ExprError;
use crate::func::Func;
use crate::graph::{ExprId, Graph, Node};
use crate::symbols::Var;

/// A structurally nonzero entry of a [`Jacobian`]: d row / d col is `expr`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// The expression's index in the list.
    pub row: usize,
    /// The variable's index.
    pub col: usize,
    /// The partial derivative.
    pub expr: ExprId,
}

/// The Jacobian of a list of expressions with respect to a list of variables, its entries that
/// are not the constant 0 after simplification (the sparsity pattern), row by row, columns
/// increasing within a row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Jacobian {
    rows: usize,
    cols: usize,
    entries: Vec<Entry>,
    row_starts: Vec<usize>,
}

impl Jacobian {
    /// The number of expressions.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The number of variables.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The structurally nonzero entries, row by row.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The structurally nonzero entries of row `row`.
    pub fn row(&self, row: usize) -> &[Entry] {
        &self.entries[self.row_starts[row]..self.row_starts[row + 1]]
    }

    /// The sparsity pattern: the (row, col) of the structurally nonzero entries.
    pub fn pattern(&self) -> Vec<(usize, usize)> {
        self.entries.iter().map(|e| (e.row, e.col)).collect()
    }

    /// The entry (row, col), `None` where it is structurally zero.
    pub fn get(&self, row: usize, col: usize) -> Option<ExprId> {
        self.row(row).iter().find(|e| e.col == col).map(|e| e.expr)
    }
}

impl Graph {
    /// d e / d var, simplified as it is built.
    pub fn diff(&mut self, e: ExprId, var: Var) -> Result<ExprId, ExprError> {
        self.check(e)?;
        let zero = self.num(0.0);
        let one = self.num(1.0);
        let mut derivatives: HashMap<ExprId, ExprId> = HashMap::new();
        for n in self.reachable(e) {
            let d = |x: ExprId| derivatives[&x];
            let node = self.node(n);
            let dn = match node {
                Node::Input(v) if v == var => one,
                _ if node.operands().all(|x| d(x) == zero) => zero,
                _ => self.diff_node(n, node, &d),
            };
            derivatives.insert(n, dn);
        }
        self.within_limit()?;
        Ok(derivatives[&e])
    }

    /// The derivative of node `n` (= `node`) whose operands' derivatives are `d`, not all zero.
    fn diff_node(&mut self, n: ExprId, node: Node, d: &dyn Fn(ExprId) -> ExprId) -> ExprId {
        match node {
            Node::Const(_) | Node::Input(_) => self.num(0.0),
            Node::Neg(a) => self.neg(d(a)),
            Node::Add(a, b) => self.add(d(a), d(b)),
            Node::Sub(a, b) => self.sub(d(a), d(b)),
            Node::Mul(a, b) => {
                let (left, right) = (self.mul(d(a), b), self.mul(a, d(b)));
                self.add(left, right)
            }
            Node::Div(a, b) => {
                // da / b - a db / b^2
                let first = self.div(d(a), b);
                let (a_db, b2) = (self.mul(a, d(b)), self.powi(b, 2));
                let second = self.div(a_db, b2);
                self.sub(first, second)
            }
            Node::PowI(a, k) => {
                let (c, power) = (self.num(f64::from(k)), self.powi(a, k - 1));
                let factor = self.mul(c, power);
                self.mul(factor, d(a))
            }
            Node::Pow(a, b) => self.diff_pow(n, a, b, d),
            Node::Func(f, a) => self.diff_func(n, f, a, d(a)),
            Node::Atan2(y, x) => {
                // (x dy - y dx) / (x^2 + y^2)
                let (x_dy, y_dx) = (self.mul(x, d(y)), self.mul(y, d(x)));
                let numerator = self.sub(x_dy, y_dx);
                let (x2, y2) = (self.powi(x, 2), self.powi(y, 2));
                let denominator = self.add(x2, y2);
                self.div(numerator, denominator)
            }
        }
    }

    /// d (a^b) for n = a^b by `powf`.
    fn diff_pow(
        &mut self, n: ExprId, a: ExprId, b: ExprId, d: &dyn Fn(ExprId) -> ExprId,
    ) -> ExprId {
        if let Some(c) = self.constant(b) {
            // c a^(c - 1) da
            let exponent = self.num(c - 1.0);
            let power = self.pow(a, exponent);
            let factor = self.mul(b, power);
            return self.mul(factor, d(a));
        }
        // a^b (db log a + b da / a)
        let log_a = self.func(Func::Log, a);
        let first = self.mul(d(b), log_a);
        let b_da = self.mul(b, d(a));
        let second = self.div(b_da, a);
        let sum = self.add(first, second);
        self.mul(n, sum)
    }

    /// d f(a) for n = f(a), da its operand's derivative.
    fn diff_func(&mut self, n: ExprId, f: Func, a: ExprId, da: ExprId) -> ExprId {
        match f {
            Func::Sin => {
                let cos = self.func(Func::Cos, a);
                self.mul(cos, da)
            }
            Func::Cos => {
                let sin = self.func(Func::Sin, a);
                let product = self.mul(sin, da);
                self.neg(product)
            }
            Func::Tan => {
                let cos = self.func(Func::Cos, a);
                let cos2 = self.powi(cos, 2);
                self.div(da, cos2)
            }
            Func::Exp => self.mul(n, da),
            Func::Log => self.div(da, a),
            Func::Sqrt => {
                let two = self.num(2.0);
                let twice = self.mul(two, n);
                self.div(da, twice)
            }
            Func::Abs => {
                let sign = self.func(Func::Sign, a);
                self.mul(sign, da)
            }
            Func::Tanh => {
                let (one, square) = (self.num(1.0), self.powi(n, 2));
                let factor = self.sub(one, square);
                self.mul(factor, da)
            }
            Func::Sign => self.num(0.0),
        }
    }

    /// grad e: d e / d `vars[j]` for each j.
    pub fn gradient(&mut self, e: ExprId, vars: &[Var]) -> Result<Vec<ExprId>, ExprError> {
        let inputs = self.inputs_of(self.check(e)?);
        vars.iter()
            .map(|&var| {
                if inputs.binary_search(&var).is_ok() {
                    self.diff(e, var)
                } else {
                    Ok(self.num(0.0))
                }
            })
            .collect()
    }

    /// The Jacobian of `list` with respect to `vars`, with its sparsity pattern.
    pub fn jacobian(&mut self, list: &[ExprId], vars: &[Var]) -> Result<Jacobian, ExprError> {
        let mut entries = Vec::new();
        let mut row_starts = vec![0];
        for (row, &e) in list.iter().enumerate() {
            let inputs = self.inputs_of(self.check(e)?);
            for (col, &var) in vars.iter().enumerate() {
                if inputs.binary_search(&var).is_err() {
                    continue;
                }
                let expr = self.diff(e, var)?;
                if self.constant(expr) != Some(0.0) {
                    entries.push(Entry { row, col, expr });
                }
            }
            row_starts.push(entries.len());
        }
        Ok(Jacobian {
            rows: list.len(),
            cols: vars.len(),
            entries,
            row_starts,
        })
    }

    /// The Jacobian-vector products (Dg w)_i = sum_j J_ij w_j over the structurally nonzero
    /// entries, columns in order; `w` names the inputs holding the vector (one per column).
    pub fn jacobian_vector(
        &mut self, jacobian: &Jacobian, w: &[Var],
    ) -> Result<Vec<ExprId>, ExprError> {
        if w.len() != jacobian.cols {
            return Err(ExprError::Shape {
                what: "vector of a Jacobian-vector product",
                expected: jacobian.cols,
                found: w.len(),
            });
        }
        let products = (0..jacobian.rows)
            .map(|row| {
                let mut sum = self.num(0.0);
                for entry in jacobian.row(row) {
                    let wj = self.input(w[entry.col]);
                    let term = self.mul(entry.expr, wj);
                    sum = self.add(sum, term);
                }
                sum
            })
            .collect();
        self.within_limit()?;
        Ok(products)
    }

    /// The directional second derivatives D^2 g_i(q)(u, w) = sum_jk d^2 g_i / dq_j dq_k u_j w_k
    /// of the rows g_i of `jacobian` (taken with respect to `vars`), as expressions of q, u and
    /// w: d/dq of (Dg w) in the direction u. `u` and `w` name inputs of slots other than those
    /// of `vars`, one per variable.
    pub fn second_directional(
        &mut self, jacobian: &Jacobian, vars: &[Var], u: &[Var], w: &[Var],
    ) -> Result<Vec<ExprId>, ExprError> {
        if vars.len() != jacobian.cols || u.len() != jacobian.cols {
            return Err(ExprError::Shape {
                what: "variables and direction u of a second derivative",
                expected: jacobian.cols,
                found: if vars.len() == jacobian.cols {
                    u.len()
                } else {
                    vars.len()
                },
            });
        }
        let products = self.jacobian_vector(jacobian, w)?;
        let inner = self.jacobian(&products, vars)?;
        self.jacobian_vector(&inner, u)
    }

    /// The Hessian of `e` with respect to `vars` (row-major, vars.len()^2 values) if every
    /// second partial derivative simplifies to a constant, else `None`: `e` is then a
    /// polynomial of degree at most two in `vars` (a sphere's or a rigid bond's constraint),
    /// whose Taylor series ends at the second term.
    pub fn constant_hessian(
        &mut self, e: ExprId, vars: &[Var],
    ) -> Result<Option<Vec<f64>>, ExprError> {
        let n = vars.len();
        let gradient = self.gradient(e, vars)?;
        let mut hessian = vec![0.0; n * n];
        for (j, &dj) in gradient.iter().enumerate() {
            for (k, second) in self.gradient(dj, vars)?.into_iter().enumerate() {
                match self.constant(second) {
                    Some(c) => hessian[j * n + k] = c,
                    None => return Ok(None),
                }
            }
        }
        Ok(Some(hessian))
    }

    /// Whether every second partial derivative of `e` with respect to `vars` simplifies to a
    /// constant ([`Graph::constant_hessian`]).
    pub fn is_quadratic(&mut self, e: ExprId, vars: &[Var]) -> Result<bool, ExprError> {
        Ok(self.constant_hessian(e, vars)?.is_some())
    }
}
