//! The compiler of [`Program`]s: a graph's nodes in order, with the rewrites that leave every
//! value's bits as the node-by-node evaluation computes them (IEEE 754, round to nearest):
//!
//! - each distinct operation on the same registers once (CSE; a + b and b + a alike);
//! - negations kept aside and folded into the operation that reads them: a + (-b) = a - b,
//!   (-a) + b = b - a, a - (-b) = a + b, (-a) b = -(a b), (-a) / b = -(a / b), |-a| = |a|,
//!   exact for every operand (signed zeros, infinities and NaN included: IEEE defines a - b as
//!   a + (-b), and a product's or quotient's sign as the operands' signs combined); a
//!   negation is computed only where nothing absorbs it ((-a) + (-b) = (-a) - b keeps one:
//!   -(a + b) would turn a + (-a) = +0 into -0);
//! - a division by a constant power of two as the product with its reciprocal, where the
//!   reciprocal is a normal number: both are the correctly rounded value of the same real
//!   number;
//! - the inputs loaded first, the constants each once, those no operation reads dropped.

use std::collections::HashMap;

use crate::ExprError;
use crate::func::{Func, powi_steps};
use crate::graph::{ExprId, Graph, Node};
use crate::symbols::MAX_SLOTS;
use crate::tape::{CompileOptions, MAX_PROGRAM_OPS, Op, Program};

/// A compiled node: the register of its value, or of its negation.
#[derive(Debug, Clone, Copy)]
struct Value {
    register: u32,
    negated: bool,
}

impl Value {
    /// The register's value itself.
    fn plain(register: u32) -> Self {
        Value {
            register,
            negated: false,
        }
    }

    /// The negation of this value.
    fn flip(self) -> Self {
        Value {
            negated: !self.negated,
            ..self
        }
    }
}

/// The compiler's state: the program so far and, with CSE, the register of each operation.
struct Compiler<'g> {
    graph: &'g Graph,
    cse: bool,
    program: Program,
    constants: HashMap<u64, u32>,
    seen: HashMap<Op, u32>,
    values: HashMap<ExprId, Value>,
}

/// 1 / c where c is a power of two whose reciprocal is a normal number (then x / c and
/// x (1 / c) are the same correctly rounded number for every x).
fn exact_reciprocal(c: f64) -> Option<f64> {
    const MANTISSA: u64 = (1 << 52) - 1;
    let r = 1.0 / c;
    (c.is_normal() && c.to_bits() & MANTISSA == 0 && r.is_normal()).then_some(r)
}

/// The constants of the nodes in `order`, each value once, sorted by bits: the graph's
/// constants, 1 for negative integer powers, the reciprocals of constant divisors.
fn pooled_constants(graph: &Graph, order: &[ExprId]) -> Vec<f64> {
    let mut constants: Vec<f64> = Vec::new();
    for &e in order {
        match graph.node(e) {
            Node::Const(c) => constants.push(c),
            Node::PowI(_, n) if n < 0 => constants.push(1.0),
            Node::Div(_, b) => constants.extend(graph.constant(b).and_then(exact_reciprocal)),
            _ => {}
        }
    }
    constants.sort_by_key(|c| c.to_bits());
    constants.dedup_by_key(|c| c.to_bits());
    constants
}

impl Program {
    /// Compiles `outputs` of `graph` with the default options (CSE on).
    pub fn compile(graph: &Graph, outputs: &[ExprId]) -> Result<Program, ExprError> {
        Self::compile_with(graph, outputs, CompileOptions::default())
    }

    /// Compiles `outputs` of `graph`: their nodes in order, integer powers expanded into
    /// multiplications, each constant once, with the exact rewrites of the type's docs.
    /// Refuses an expression not of `graph` and a program beyond [`MAX_PROGRAM_OPS`]
    /// operations.
    pub fn compile_with(
        graph: &Graph, outputs: &[ExprId], options: CompileOptions,
    ) -> Result<Program, ExprError> {
        compile(graph, outputs, options)
    }
}

/// Compiles `outputs` of `graph` ([`Program::compile_with`]).
fn compile(
    graph: &Graph, outputs: &[ExprId], options: CompileOptions,
) -> Result<Program, ExprError> {
    for &e in outputs {
        graph.check(e)?;
    }
    let order = graph.reachable_from(outputs);
    let constants = pooled_constants(graph, &order);
    let mut compiler = Compiler {
        graph,
        cse: options.cse,
        constants: constants
            .iter()
            .enumerate()
            .map(|(i, c)| (c.to_bits(), i as u32))
            .collect(),
        program: Program {
            constants,
            ops: Vec::new(),
            outputs: Vec::new(),
            slot_lens: Vec::new(),
            loads: 0,
        },
        seen: HashMap::new(),
        values: HashMap::new(),
    };
    // The inputs first (they read no register), then the rest in order.
    let is_input = |e: &&ExprId| matches!(graph.node(**e), Node::Input(_));
    let inputs = order.iter().filter(is_input);
    for &e in inputs.chain(order.iter().filter(|e| !is_input(e))) {
        let value = compiler.node(e)?;
        compiler.values.insert(e, value);
    }
    let mut registers = Vec::with_capacity(outputs.len());
    for e in outputs {
        registers.push(compiler.operand(compiler.values[e])?);
    }
    let mut program = compiler.program;
    program.outputs = registers;
    program.loads = program
        .ops
        .iter()
        .take_while(|op| matches!(op, Op::Load { .. }))
        .count();
    drop_unread_constants(&mut program);
    Ok(program)
}

impl Compiler<'_> {
    /// The compiled value of node `e`.
    fn value(&self, e: ExprId) -> Value {
        self.values[&e]
    }

    /// The value of node `e`, its operands already compiled.
    fn node(&mut self, e: ExprId) -> Result<Value, ExprError> {
        let op = match self.graph.node(e) {
            Node::Const(c) => return Ok(Value::plain(self.constants[&c.to_bits()])),
            Node::Input(var) => self.load(var)?,
            Node::Neg(a) => return Ok(self.value(a).flip()),
            Node::Add(a, b) => return self.sum(self.value(a), self.value(b)),
            Node::Sub(a, b) => return self.sum(self.value(a), self.value(b).flip()),
            Node::Mul(a, b) => return self.product(self.value(a), self.value(b)),
            Node::Div(a, b) => return self.quotient(self.value(a), b),
            Node::Pow(a, b) => {
                let (a, b) = (self.value(a), self.value(b));
                Op::Pow(self.operand(a)?, self.operand(b)?)
            }
            Node::Atan2(y, x) => {
                let (y, x) = (self.value(y), self.value(x));
                Op::Atan2(self.operand(y)?, self.operand(x)?)
            }
            Node::Func(Func::Abs, a) => Op::Func(Func::Abs, self.value(a).register),
            Node::Func(f, a) => Op::Func(f, self.operand(self.value(a))?),
            Node::PowI(a, n) => return self.powi(self.value(a), n),
        };
        Ok(Value::plain(self.emit(op)?))
    }

    /// The load of input `var`, its slot's length noted; refuses a slot beyond the limit.
    fn load(&mut self, var: crate::Var) -> Result<Op, ExprError> {
        let slot = var.slot as usize;
        if slot >= MAX_SLOTS {
            return Err(ExprError::Limit {
                what: "input slot",
                found: slot,
                limit: MAX_SLOTS - 1,
                position: None,
            });
        }
        let lens = &mut self.program.slot_lens;
        if lens.len() <= slot {
            lens.resize(slot + 1, 0);
        }
        lens[slot] = lens[slot].max(var.index as usize + 1);
        Ok(Op::Load {
            slot: var.slot,
            index: var.index,
        })
    }

    /// a + b with the negations folded: a - b, b - a, or (-a) - b.
    fn sum(&mut self, a: Value, b: Value) -> Result<Value, ExprError> {
        let op = match (a.negated, b.negated) {
            (false, false) => commutative(Op::Add, a.register, b.register),
            (false, true) => Op::Sub(a.register, b.register),
            (true, false) => Op::Sub(b.register, a.register),
            (true, true) => Op::Sub(self.operand(a)?, b.register),
        };
        Ok(Value::plain(self.emit(op)?))
    }

    /// a b, negated where one operand is.
    fn product(&mut self, a: Value, b: Value) -> Result<Value, ExprError> {
        let op = commutative(Op::Mul, a.register, b.register);
        Ok(Value {
            register: self.emit(op)?,
            negated: a.negated != b.negated,
        })
    }

    /// a / b: the product with 1 / b where b is a constant power of two with a normal
    /// reciprocal, else the quotient; negated where one operand is.
    fn quotient(&mut self, a: Value, b: ExprId) -> Result<Value, ExprError> {
        if let Some(r) = self.graph.constant(b).and_then(exact_reciprocal) {
            let reciprocal = Value::plain(self.constants[&r.to_bits()]);
            return self.product(a, reciprocal);
        }
        let b = self.values[&b];
        Ok(Value {
            register: self.emit(Op::Div(a.register, b.register))?,
            negated: a.negated != b.negated,
        })
    }

    /// x^n as [`crate::powi`] computes it, each multiplication an operation.
    fn powi(&mut self, x: Value, n: i32) -> Result<Value, ExprError> {
        let mut result = x;
        for multiply in powi_steps(n.unsigned_abs()) {
            result = self.product(result, result)?;
            if multiply {
                result = self.product(result, x)?;
            }
        }
        if n < 0 {
            // Pooled by `pooled_constants` whenever a negative power is there.
            let one = self.constants[&1f64.to_bits()];
            let register = self.emit(Op::Div(one, result.register))?;
            result = Value { register, ..result };
        }
        Ok(result)
    }

    /// The register holding `value` itself: its negation computed where it is negated.
    fn operand(&mut self, value: Value) -> Result<u32, ExprError> {
        match value.negated {
            true => self.emit(Op::Neg(value.register)),
            false => Ok(value.register),
        }
    }

    /// The register of `op`: an earlier one computing the same with CSE, else a new one.
    fn emit(&mut self, op: Op) -> Result<u32, ExprError> {
        if self.cse
            && let Some(&r) = self.seen.get(&op)
        {
            return Ok(r);
        }
        if self.program.ops.len() >= MAX_PROGRAM_OPS {
            return Err(ExprError::Limit {
                what: "program operations",
                found: self.program.ops.len() + 1,
                limit: MAX_PROGRAM_OPS,
                position: None,
            });
        }
        let r = (self.program.constants.len() + self.program.ops.len()) as u32;
        self.program.ops.push(op);
        if self.cse {
            self.seen.insert(op, r);
        }
        Ok(r)
    }
}

/// `make(a, b)` with the operands in increasing order (a + b and b + a are the same IEEE
/// operation), so that CSE finds both.
fn commutative(make: fn(u32, u32) -> Op, a: u32, b: u32) -> Op {
    make(a.min(b), a.max(b))
}

/// The registers an operation reads.
fn operands(op: &Op) -> [Option<u32>; 2] {
    match *op {
        Op::Load { .. } => [None, None],
        Op::Neg(a) | Op::Func(_, a) => [Some(a), None],
        Op::Add(a, b)
        | Op::Sub(a, b)
        | Op::Mul(a, b)
        | Op::Div(a, b)
        | Op::Pow(a, b)
        | Op::Atan2(a, b) => [Some(a), Some(b)],
    }
}

/// Removes the constants no operation or output reads (a divisor replaced by its
/// reciprocal), every register renumbered.
fn drop_unread_constants(program: &mut Program) {
    let k = program.constants.len();
    let mut read = vec![false; k];
    let registers = program.ops.iter().flat_map(operands).flatten();
    for r in registers.chain(program.outputs.iter().copied()) {
        if let Some(flag) = read.get_mut(r as usize) {
            *flag = true;
        }
    }
    if read.iter().all(|&r| r) {
        return;
    }
    let mut renumber: Vec<u32> = Vec::with_capacity(k);
    let mut kept = 0u32;
    for &r in &read {
        renumber.push(kept);
        kept += r as u32;
    }
    let shift = k as u32 - kept;
    let map = |r: u32| match renumber.get(r as usize) {
        Some(&new) => new,
        None => r - shift,
    };
    let mut index = 0;
    program.constants.retain(|_| {
        index += 1;
        read[index - 1]
    });
    for op in &mut program.ops {
        *op = match *op {
            Op::Load { slot, index } => Op::Load { slot, index },
            Op::Neg(a) => Op::Neg(map(a)),
            Op::Func(f, a) => Op::Func(f, map(a)),
            Op::Add(a, b) => Op::Add(map(a), map(b)),
            Op::Sub(a, b) => Op::Sub(map(a), map(b)),
            Op::Mul(a, b) => Op::Mul(map(a), map(b)),
            Op::Div(a, b) => Op::Div(map(a), map(b)),
            Op::Pow(a, b) => Op::Pow(map(a), map(b)),
            Op::Atan2(a, b) => Op::Atan2(map(a), map(b)),
        };
    }
    for r in &mut program.outputs {
        *r = map(*r);
    }
}

#[cfg(test)]
mod tests;
