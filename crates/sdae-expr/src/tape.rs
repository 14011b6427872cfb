//! Expressions compiled to a tape: a flat list of operations over registers, common
//! subexpressions computed once, constants pooled, evaluated over any [`Real`].

use sdae_lanes::Real;

use crate::func::{Func, atan2, powf};

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

/// Expressions compiled for evaluation: constants, then operations (the inputs' loads
/// first), then the registers of the outputs.
///
/// Evaluated over `f64` (one path) or [`sdae_lanes::Lanes`] (W paths), lane i computes exactly
/// what the `f64` evaluation computes for path i: the arithmetic is IEEE per lane, integer
/// powers are the same multiplications on both, and the other functions run per lane with the
/// standard library's f64 functions. Each output has the bits of its expression evaluated node
/// by node: the compiler's rewrites (negations folded into sums, products and quotients, a
/// division by a power of two as a product) are exact for every input.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    pub(crate) constants: Vec<f64>,
    pub(crate) ops: Vec<Op>,
    pub(crate) outputs: Vec<u32>,
    pub(crate) slot_lens: Vec<usize>,
    /// The number of loads at the start of `ops`.
    pub(crate) loads: usize,
}

impl Program {
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
        let Some(&seed) = out.first() else {
            return self.eval_in(inputs, out, &mut []);
        };
        if scratch.len() < self.registers() {
            scratch.resize(self.registers(), seed);
        }
        self.eval_in(inputs, out, scratch);
    }

    /// [`Program::eval`] on registers the caller holds: `registers` has at least
    /// [`Program::registers`] entries (their values before the call do not matter), say
    /// an array on the caller's stack, so that an evaluation needs no buffer of its own.
    ///
    /// # Panics
    ///
    /// As [`Program::eval`], and if `registers` is shorter than [`Program::registers`] while
    /// there are outputs.
    #[inline(always)]
    pub fn eval_in<T: Real>(&self, inputs: &[&[T]], out: &mut [T], registers: &mut [T]) {
        assert_eq!(out.len(), self.outputs.len(), "one value per output");
        let Some(&seed) = out.first() else {
            return self.check_inputs(inputs);
        };
        self.run_in(inputs, registers, seed);
        for (o, &register) in out.iter_mut().zip(&self.outputs) {
            *o = registers[register as usize];
        }
    }

    /// The register of each output, in order: after [`Program::run_in`], output i is
    /// `registers[output_registers()[i]]` (for a caller that writes the outputs where they
    /// belong, without a slice of its own).
    pub fn output_registers(&self) -> &[u32] {
        &self.outputs
    }

    /// Computes every register of the program ([`Program::eval_in`] without writing the
    /// outputs), the constants of the kind of `seed`.
    ///
    /// # Panics
    ///
    /// As [`Program::eval_in`].
    #[inline(always)]
    pub fn run_in<T: Real>(&self, inputs: &[&[T]], registers: &mut [T], seed: T) {
        self.check_inputs(inputs);
        let registers = &mut registers[..self.registers()];
        let (constants, rest) = registers.split_at_mut(self.constants.len());
        for (r, &c) in constants.iter_mut().zip(&self.constants) {
            *r = seed.splat_like(c);
        }
        // The loads, then the operations: every register written before it is read.
        for (r, op) in rest.iter_mut().zip(&self.ops[..self.loads]) {
            if let Op::Load { slot, index } = *op {
                *r = inputs[slot as usize][index as usize];
            }
        }
        let base = self.constants.len();
        for (k, op) in self.ops.iter().enumerate().skip(self.loads) {
            // Indexed in place rather than through a closure, which would be compiled out of
            // line without the caller's instruction set.
            let value = match *op {
                Op::Load { slot, index } => inputs[slot as usize][index as usize],
                Op::Neg(a) => -registers[a as usize],
                Op::Add(a, b) => registers[a as usize] + registers[b as usize],
                Op::Sub(a, b) => registers[a as usize] - registers[b as usize],
                Op::Mul(a, b) => registers[a as usize] * registers[b as usize],
                Op::Div(a, b) => registers[a as usize] / registers[b as usize],
                Op::Pow(a, b) => powf(registers[a as usize], registers[b as usize]),
                Op::Atan2(a, b) => atan2(registers[a as usize], registers[b as usize]),
                Op::Func(f, a) => f.apply(registers[a as usize]),
            };
            registers[base + k] = value;
        }
    }

    /// Panics where an input slice is shorter than [`Program::input_lens`] says.
    #[inline(always)]
    fn check_inputs<T>(&self, inputs: &[&[T]]) {
        for (slot, &len) in self.slot_lens.iter().enumerate() {
            assert!(
                inputs.get(slot).map_or(0, |s| s.len()) >= len,
                "input slice {slot} shorter than {len}"
            );
        }
    }

    /// The outputs' values where every output is a constant (a program of no operations
    /// read), else `None`.
    pub fn constant_outputs(&self) -> Option<Vec<f64>> {
        self.outputs
            .iter()
            .map(|&r| self.constants.get(r as usize).copied())
            .collect()
    }
}
