//! Expressions compiled to a tape: a flat list of operations over registers, common
//! subexpressions computed once, constants pooled, evaluated over any [`Real`].

use std::collections::HashMap;

use sdae_lanes::Real;

use crate::ExprError;
use crate::func::{Func, atan2, powf, powi_steps};
use crate::graph::{ExprId, Graph, Node};
use crate::symbols::MAX_SLOTS;

/// The most operations of a compiled program.
pub const MAX_PROGRAM_OPS: usize = 1 << 20;

/// An operation of a [`Program`]: it writes the register after the last one written, reading
/// earlier registers (the constants first, then the results of earlier operations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Op {
    /// Value `index` of input slice `slot`.
    Load {
        /// The slice.
        slot: u16,
        /// The value.
        index: u32,
    },
    /// -a.
    Neg(u32),
    /// a + b.
    Add(u32, u32),
    /// a - b.
    Sub(u32, u32),
    /// a b.
    Mul(u32, u32),
    /// a / b.
    Div(u32, u32),
    /// a^b by `f64::powf`, path by path.
    Pow(u32, u32),
    /// atan2(a, b), path by path.
    Atan2(u32, u32),
    /// f(a).
    Func(Func, u32),
}

/// How to compile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CompileOptions {
    /// Compute each distinct operation on the same registers once (common subexpression
    /// elimination); off only to measure what it saves.
    pub cse: bool,
}

impl Default for CompileOptions {
    fn default() -> Self {
        CompileOptions { cse: true }
    }
}

/// Expressions compiled for evaluation: constants, then operations, then the registers of the
/// outputs.
///
/// Evaluated over `f64` (one path) or [`sdae_lanes::Lanes`] (W paths), lane i computes exactly
/// what the `f64` evaluation computes for path i: the arithmetic is IEEE per lane, integer
/// powers are the same multiplications on both, and the other functions run per lane with the
/// standard library's f64 functions.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    constants: Vec<f64>,
    ops: Vec<Op>,
    outputs: Vec<u32>,
    slot_lens: Vec<usize>,
}

/// The compiler's state: the program so far and, with CSE, the register of each operation.
struct Compiler<'g> {
    graph: &'g Graph,
    cse: bool,
    program: Program,
    constants: HashMap<u64, u32>,
    seen: HashMap<Op, u32>,
    registers: HashMap<ExprId, u32>,
}

impl Program {
    /// Compiles `outputs` of `graph` with the default options (CSE on).
    pub fn compile(graph: &Graph, outputs: &[ExprId]) -> Result<Program, ExprError> {
        Self::compile_with(graph, outputs, CompileOptions::default())
    }

    /// Compiles `outputs` of `graph`: their nodes in order, integer powers expanded into
    /// multiplications, each constant once. Refuses an expression not of `graph` and a
    /// program beyond [`MAX_PROGRAM_OPS`] operations.
    pub fn compile_with(
        graph: &Graph, outputs: &[ExprId], options: CompileOptions,
    ) -> Result<Program, ExprError> {
        for &e in outputs {
            graph.check(e)?;
        }
        let order = graph.reachable_from(outputs);
        // Constants first, so that they take the first registers; 1 for the negative powers.
        let mut constants: Vec<f64> = order.iter().filter_map(|&e| graph.constant(e)).collect();
        if order
            .iter()
            .any(|&e| matches!(graph.node(e), Node::PowI(_, n) if n < 0))
        {
            constants.push(1.0);
        }
        constants.sort_by_key(|c| c.to_bits());
        constants.dedup_by_key(|c| c.to_bits());
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
            },
            seen: HashMap::new(),
            registers: HashMap::new(),
        };
        for e in order {
            let register = compiler.node(e)?;
            compiler.registers.insert(e, register);
        }
        let mut program = compiler.program;
        program.outputs = outputs.iter().map(|e| compiler.registers[e]).collect();
        Ok(program)
    }

    /// The number of operations (loads of inputs included).
    pub fn op_count(&self) -> usize {
        self.ops.len()
    }

    /// The operations.
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }

    /// The pooled constants (each distinct value once).
    pub fn constants(&self) -> &[f64] {
        &self.constants
    }

    /// The number of outputs.
    pub fn outputs(&self) -> usize {
        self.outputs.len()
    }

    /// The shortest length of each input slice the program reads (1 + the largest index read
    /// from it; 0 for a slice it does not read).
    pub fn input_lens(&self) -> &[usize] {
        &self.slot_lens
    }

    /// The registers an evaluation uses (constants and operations).
    pub fn registers(&self) -> usize {
        self.constants.len() + self.ops.len()
    }

    /// Evaluates the outputs: `out[i]` is output i at the inputs `inputs[slot][index]`.
    /// `scratch` holds the registers (grown on the first call, then reused without allocating).
    ///
    /// # Panics
    ///
    /// If `out` is not one value per output, or an input slice is shorter than
    /// [`Program::input_lens`] says (a caller's layout error).
    ///
    /// Inlined always, so that over lanes it is compiled with the instruction set of the
    /// caller (a `pulp::WithSimd` kernel): called out of line, the lanes' operations would be
    /// compiled without it.
    #[inline(always)]
    pub fn eval<T: Real>(&self, inputs: &[&[T]], out: &mut [T], scratch: &mut Vec<T>) {
        assert_eq!(out.len(), self.outputs.len(), "one value per output");
        for (slot, &len) in self.slot_lens.iter().enumerate() {
            assert!(
                inputs.get(slot).map_or(0, |s| s.len()) >= len,
                "input slice {slot} shorter than {len}"
            );
        }
        let Some(&seed) = out.first() else {
            return;
        };
        // Every register written in place: sized once, the constants set on every call.
        if scratch.len() != self.registers() {
            scratch.clear();
            scratch.resize(self.registers(), seed);
        }
        for (r, &c) in scratch.iter_mut().zip(&self.constants) {
            *r = seed.splat_like(c);
        }
        let base = self.constants.len();
        for (k, op) in self.ops.iter().enumerate() {
            // Indexed in place rather than through a closure, which would be compiled out of
            // line without the caller's instruction set.
            let value = match *op {
                Op::Load { slot, index } => inputs[slot as usize][index as usize],
                Op::Neg(a) => -scratch[a as usize],
                Op::Add(a, b) => scratch[a as usize] + scratch[b as usize],
                Op::Sub(a, b) => scratch[a as usize] - scratch[b as usize],
                Op::Mul(a, b) => scratch[a as usize] * scratch[b as usize],
                Op::Div(a, b) => scratch[a as usize] / scratch[b as usize],
                Op::Pow(a, b) => powf(scratch[a as usize], scratch[b as usize]),
                Op::Atan2(a, b) => atan2(scratch[a as usize], scratch[b as usize]),
                Op::Func(f, a) => f.apply(scratch[a as usize]),
            };
            scratch[base + k] = value;
        }
        for (o, &register) in out.iter_mut().zip(&self.outputs) {
            *o = scratch[register as usize];
        }
    }
}

impl Compiler<'_> {
    /// The register of node `e`, its operands already compiled.
    fn node(&mut self, e: ExprId) -> Result<u32, ExprError> {
        let reg = |x: ExprId| self.registers[&x];
        let op = match self.graph.node(e) {
            Node::Const(c) => return Ok(self.constants[&c.to_bits()]),
            Node::Input(var) => {
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
                Op::Load {
                    slot: var.slot,
                    index: var.index,
                }
            }
            Node::Neg(a) => Op::Neg(reg(a)),
            Node::Add(a, b) => commutative(Op::Add, reg(a), reg(b)),
            Node::Sub(a, b) => Op::Sub(reg(a), reg(b)),
            Node::Mul(a, b) => commutative(Op::Mul, reg(a), reg(b)),
            Node::Div(a, b) => Op::Div(reg(a), reg(b)),
            Node::Pow(a, b) => Op::Pow(reg(a), reg(b)),
            Node::Atan2(y, x) => Op::Atan2(reg(y), reg(x)),
            Node::Func(f, a) => Op::Func(f, reg(a)),
            Node::PowI(a, n) => return self.powi(reg(a), n),
        };
        self.emit(op)
    }

    /// x^n as [`crate::powi`] computes it, each multiplication an operation.
    fn powi(&mut self, x: u32, n: i32) -> Result<u32, ExprError> {
        let mut result = x;
        for multiply in powi_steps(n.unsigned_abs()) {
            result = self.emit(Op::Mul(result, result))?;
            if multiply {
                result = self.emit(Op::Mul(result, x))?;
            }
        }
        if n < 0 {
            // Pooled by `compile_with` whenever a negative power is there.
            let one = self.constants[&1f64.to_bits()];
            result = self.emit(Op::Div(one, result))?;
        }
        Ok(result)
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
