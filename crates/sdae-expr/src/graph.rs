//! Expressions as a graph of nodes, each built simplified: constants folded, x*0, x*1, x+0,
//! x-0, x/1, x^0, x^1, --x removed.

use std::collections::HashMap;

use crate::ExprError;
use crate::func::{CONSTANTS, Func, MAX_INTEGER_POWER, atan2, powf, powi};
use crate::parse::{BinaryOp, Syntax, SyntaxNode};
use crate::symbols::{Symbol, SymbolTable, Var};

/// The most nodes a graph holds (its expressions, their derivatives and what was folded away
/// on the way).
pub const MAX_GRAPH_NODES: usize = 1 << 22;

/// An expression: a node of a [`Graph`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExprId(pub(crate) u32);

impl ExprId {
    /// Its index in the graph.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A node; its operands are earlier nodes of the same graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Node {
    /// A constant.
    Const(f64),
    /// An input.
    Input(Var),
    /// -a.
    Neg(ExprId),
    /// a + b.
    Add(ExprId, ExprId),
    /// a - b.
    Sub(ExprId, ExprId),
    /// a b.
    Mul(ExprId, ExprId),
    /// a / b.
    Div(ExprId, ExprId),
    /// a^n by multiplications ([`crate::powi`]), 2 <= |n| <= [`MAX_INTEGER_POWER`].
    PowI(ExprId, i32),
    /// a^b by `f64::powf`.
    Pow(ExprId, ExprId),
    /// f(a).
    Func(Func, ExprId),
    /// atan2(y, x).
    Atan2(ExprId, ExprId),
}

impl Node {
    /// The operands.
    pub fn operands(&self) -> impl Iterator<Item = ExprId> {
        let (a, b) = match *self {
            Node::Const(_) | Node::Input(_) => (None, None),
            Node::Neg(a) | Node::PowI(a, _) | Node::Func(_, a) => (Some(a), None),
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Pow(a, b)
            | Node::Atan2(a, b) => (Some(a), Some(b)),
        };
        a.into_iter().chain(b)
    }

    /// The same operation on the operands `f` maps them to.
    fn map_operands(self, f: impl Fn(ExprId) -> ExprId) -> Node {
        match self {
            Node::Const(_) | Node::Input(_) => self,
            Node::Neg(a) => Node::Neg(f(a)),
            Node::PowI(a, n) => Node::PowI(f(a), n),
            Node::Func(g, a) => Node::Func(g, f(a)),
            Node::Add(a, b) => Node::Add(f(a), f(b)),
            Node::Sub(a, b) => Node::Sub(f(a), f(b)),
            Node::Mul(a, b) => Node::Mul(f(a), f(b)),
            Node::Div(a, b) => Node::Div(f(a), f(b)),
            Node::Pow(a, b) => Node::Pow(f(a), f(b)),
            Node::Atan2(a, b) => Node::Atan2(f(a), f(b)),
        }
    }
}

/// Expressions, their derivatives and the nodes they share. Nodes are only added, each after
/// its operands; an [`ExprId`] stays valid for the graph's life.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    nodes: Vec<Node>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// The number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node of `e` (panics if `e` is not of this graph: [`Graph::check`] tells).
    pub fn node(&self, e: ExprId) -> Node {
        self.nodes[e.index()]
    }

    /// `e` if it is a node of this graph.
    pub fn check(&self, e: ExprId) -> Result<ExprId, ExprError> {
        if e.index() < self.nodes.len() {
            Ok(e)
        } else {
            Err(ExprError::ForeignExpression {
                id: e.index(),
                nodes: self.nodes.len(),
            })
        }
    }

    /// The value of `e` if it is a constant.
    pub fn constant(&self, e: ExprId) -> Option<f64> {
        match self.node(e) {
            Node::Const(c) => Some(c),
            _ => None,
        }
    }

    /// Refuses a graph grown beyond [`MAX_GRAPH_NODES`].
    pub(crate) fn within_limit(&self) -> Result<(), ExprError> {
        if self.nodes.len() > MAX_GRAPH_NODES {
            return Err(ExprError::Limit {
                what: "expression graph nodes",
                found: self.nodes.len(),
                limit: MAX_GRAPH_NODES,
                position: None,
            });
        }
        Ok(())
    }

    fn push(&mut self, node: Node) -> ExprId {
        self.nodes.push(node);
        ExprId((self.nodes.len() - 1) as u32)
    }

    /// The constant `c`.
    pub fn num(&mut self, c: f64) -> ExprId {
        self.push(Node::Const(c))
    }

    /// The input `var`.
    pub fn input(&mut self, var: Var) -> ExprId {
        self.push(Node::Input(var))
    }

    /// -a.
    pub fn neg(&mut self, a: ExprId) -> ExprId {
        match self.node(a) {
            Node::Const(c) => self.num(-c),
            Node::Neg(inner) => inner,
            _ => self.push(Node::Neg(a)),
        }
    }

    /// a + b.
    pub fn add(&mut self, a: ExprId, b: ExprId) -> ExprId {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x + y),
            (Some(0.0), _) => b,
            (_, Some(0.0)) => a,
            _ => self.push(Node::Add(a, b)),
        }
    }

    /// a - b.
    pub fn sub(&mut self, a: ExprId, b: ExprId) -> ExprId {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x - y),
            (Some(0.0), _) => self.neg(b),
            (_, Some(0.0)) => a,
            _ => self.push(Node::Sub(a, b)),
        }
    }

    /// a b.
    pub fn mul(&mut self, a: ExprId, b: ExprId) -> ExprId {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x * y),
            (Some(0.0), _) | (_, Some(0.0)) => self.num(0.0),
            (Some(1.0), _) => b,
            (_, Some(1.0)) => a,
            (Some(-1.0), _) => self.neg(b),
            (_, Some(-1.0)) => self.neg(a),
            _ => self.push(Node::Mul(a, b)),
        }
    }

    /// a / b.
    pub fn div(&mut self, a: ExprId, b: ExprId) -> ExprId {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x / y),
            (Some(0.0), _) => self.num(0.0),
            (_, Some(1.0)) => a,
            _ => self.push(Node::Div(a, b)),
        }
    }

    /// a^b: a^0 = 1, a^1 = a, an integer exponent up to [`MAX_INTEGER_POWER`] by
    /// multiplications, any other by `f64::powf`.
    pub fn pow(&mut self, a: ExprId, b: ExprId) -> ExprId {
        let Some(n) = self.constant(b) else {
            return self.push(Node::Pow(a, b));
        };
        if n.fract() == 0.0 && n.abs() <= f64::from(MAX_INTEGER_POWER) {
            return self.powi(a, n as i32);
        }
        match self.constant(a) {
            Some(x) => self.num(powf(x, n)),
            None => self.push(Node::Pow(a, b)),
        }
    }

    /// a^n by multiplications ([`crate::powi`]; |n| at most [`MAX_INTEGER_POWER`], beyond it
    /// `f64::powf`).
    pub fn powi(&mut self, a: ExprId, n: i32) -> ExprId {
        if n.unsigned_abs() > MAX_INTEGER_POWER as u32 {
            let b = self.num(f64::from(n));
            return self.push(Node::Pow(a, b));
        }
        match (self.constant(a), n) {
            (_, 0) => self.num(1.0),
            (_, 1) => a,
            (Some(x), _) => self.num(powi(x, n)),
            _ => self.push(Node::PowI(a, n)),
        }
    }

    /// f(a).
    pub fn func(&mut self, f: Func, a: ExprId) -> ExprId {
        match self.constant(a) {
            Some(x) => self.num(f.apply(x)),
            None => self.push(Node::Func(f, a)),
        }
    }

    /// atan2(y, x).
    pub fn atan2(&mut self, y: ExprId, x: ExprId) -> ExprId {
        match (self.constant(y), self.constant(x)) {
            (Some(a), Some(b)) => self.num(atan2(a, b)),
            _ => self.push(Node::Atan2(y, x)),
        }
    }

    /// Parses `text` and binds its names to `table` ([`Graph::bind`]).
    pub fn parse(&mut self, text: &str, table: &SymbolTable) -> Result<ExprId, ExprError> {
        let syntax = Syntax::parse(text)?;
        self.bind(&syntax, table)
    }

    /// The expression of `syntax` with its names bound: inputs read at evaluation, parameters
    /// and constants folded in. Refuses a name the table does not know, naming it (with the
    /// nearest known name, if one is close).
    pub fn bind(&mut self, syntax: &Syntax, table: &SymbolTable) -> Result<ExprId, ExprError> {
        let mut ids = Vec::with_capacity(syntax.nodes().len());
        for node in syntax.nodes() {
            let id = match *node {
                SyntaxNode::Number(c) => self.num(c),
                SyntaxNode::Name { ref name, position } => self.name(name, position, table)?,
                SyntaxNode::Neg(a) => self.neg(ids[a]),
                SyntaxNode::Binary(op, a, b) => self.binary(op, ids[a], ids[b]),
                SyntaxNode::Call(f, a) => self.func(f, ids[a]),
                SyntaxNode::Atan2(y, x) => self.atan2(ids[y], ids[x]),
            };
            ids.push(id);
        }
        self.within_limit()?;
        ids.last().copied().ok_or_else(|| ExprError::Syntax {
            position: 0,
            message: "empty expression".into(),
        })
    }

    fn name(
        &mut self, name: &str, position: usize, table: &SymbolTable,
    ) -> Result<ExprId, ExprError> {
        match table.get(name) {
            Some(Symbol::Input(var)) => Ok(self.input(var)),
            Some(Symbol::Parameter(c)) => Ok(self.num(c)),
            None => match CONSTANTS.iter().find(|(n, _)| *n == name) {
                Some(&(_, c)) => Ok(self.num(c)),
                None => Err(ExprError::UnknownSymbol {
                    name: name.to_string(),
                    position,
                    hint: table
                        .nearest(name)
                        .map(|near| format!("; did you mean `{near}`?"))
                        .unwrap_or_default(),
                }),
            },
        }
    }

    /// a op b.
    pub fn binary(&mut self, op: BinaryOp, a: ExprId, b: ExprId) -> ExprId {
        match op {
            BinaryOp::Add => self.add(a, b),
            BinaryOp::Sub => self.sub(a, b),
            BinaryOp::Mul => self.mul(a, b),
            BinaryOp::Div => self.div(a, b),
            BinaryOp::Pow => self.pow(a, b),
        }
    }

    /// The nodes `e` depends on, `e` included, in increasing order (operands first).
    pub fn reachable(&self, e: ExprId) -> Vec<ExprId> {
        self.reachable_from(&[e])
    }

    /// The nodes any of `roots` depends on, roots included, in increasing order.
    pub fn reachable_from(&self, roots: &[ExprId]) -> Vec<ExprId> {
        let mut seen = vec![false; roots.iter().map(|e| e.index() + 1).max().unwrap_or(0)];
        let mut stack: Vec<ExprId> = roots.to_vec();
        let mut found = Vec::new();
        while let Some(e) = stack.pop() {
            if std::mem::replace(&mut seen[e.index()], true) {
                continue;
            }
            found.push(e);
            stack.extend(self.node(e).operands());
        }
        found.sort_unstable();
        found
    }

    /// `roots` with each input `var` for which `replace(var)` is `Some(e)` replaced by the
    /// expression `e` (of this graph): the nodes that depend on a replaced input built again
    /// with the same operations (not simplified anew, so that each evaluates exactly as the
    /// original evaluates with the replacements' values as inputs), the others shared.
    pub fn substitute(
        &mut self, roots: &[ExprId], replace: &dyn Fn(Var) -> Option<ExprId>,
    ) -> Result<Vec<ExprId>, ExprError> {
        for &e in roots {
            self.check(e)?;
        }
        let mut image: HashMap<ExprId, ExprId> = HashMap::new();
        for e in self.reachable_from(roots) {
            let node = self.node(e);
            let new = match node {
                Node::Input(var) => replace(var).map(|r| self.check(r)).transpose()?,
                _ if node.operands().all(|a| image[&a] == a) => None,
                _ => Some(self.push(node.map_operands(|a| image[&a]))),
            };
            image.insert(e, new.unwrap_or(e));
        }
        self.within_limit()?;
        Ok(roots.iter().map(|e| image[e]).collect())
    }

    /// The inputs `e` depends on, sorted.
    pub fn inputs_of(&self, e: ExprId) -> Vec<Var> {
        let mut vars: Vec<Var> = self
            .reachable(e)
            .into_iter()
            .filter_map(|n| match self.node(n) {
                Node::Input(var) => Some(var),
                _ => None,
            })
            .collect();
        vars.sort_unstable();
        vars.dedup();
        vars
    }

    /// `e` as text of the grammar, each input as `names` calls it (e.g. by the table the
    /// expression was bound to). Written as a tree: a subexpression shared by several nodes
    /// (as derivatives share them) is written out at each use.
    pub fn display(&self, e: ExprId, names: &dyn Fn(Var) -> String) -> String {
        let mut texts: HashMap<ExprId, (String, u8)> = HashMap::new();
        for n in self.reachable(e) {
            let text = self.render(n, names, &|a| texts[&a].clone());
            texts.insert(n, text);
        }
        texts.remove(&e).map(|(text, _)| text).unwrap_or_default()
    }

    /// The text of node `e` and its precedence (0 sums, 1 products, 2 signs, 3 powers, 4
    /// atoms), its operands' from `sub`.
    fn render(
        &self, e: ExprId, names: &dyn Fn(Var) -> String, sub: &dyn Fn(ExprId) -> (String, u8),
    ) -> (String, u8) {
        let wrap = |(text, p): (String, u8), min: u8| {
            if p < min { format!("({text})") } else { text }
        };
        match self.node(e) {
            Node::Const(c) if c.is_sign_negative() => (format!("{c:?}"), 2),
            Node::Const(c) => (format!("{c:?}"), 4),
            Node::Input(var) => (names(var), 4),
            Node::Neg(a) => (format!("-{}", wrap(sub(a), 3)), 2),
            Node::Add(a, b) => (format!("{} + {}", wrap(sub(a), 0), wrap(sub(b), 1)), 0),
            Node::Sub(a, b) => (format!("{} - {}", wrap(sub(a), 0), wrap(sub(b), 1)), 0),
            Node::Mul(a, b) => (format!("{}*{}", wrap(sub(a), 1), wrap(sub(b), 3)), 1),
            Node::Div(a, b) => (format!("{}/{}", wrap(sub(a), 1), wrap(sub(b), 3)), 1),
            Node::PowI(a, n) if n < 0 => (format!("{}^({n})", wrap(sub(a), 4)), 3),
            Node::PowI(a, n) => (format!("{}^{n}", wrap(sub(a), 4)), 3),
            Node::Pow(a, b) => (format!("{}^{}", wrap(sub(a), 4), wrap(sub(b), 4)), 3),
            Node::Func(f, a) => (format!("{}({})", f.name(), sub(a).0), 4),
            Node::Atan2(y, x) => (format!("atan2({}, {})", sub(y).0, sub(x).0), 4),
        }
    }
}
