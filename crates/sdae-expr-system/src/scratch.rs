//! Registers for [`Program::eval_in`] without a heap allocation per call: on the caller's stack
//! for the small programs, else lent by a per-thread pool.
//!
//! A program's evaluation needs its registers. The methods that evaluate take `&self` and run
//! on many threads at once, so the registers cannot live in the system. A program of at most
//! [`STACK_REGISTERS`] registers (a pendulum's g, Dg u, Dg^T z and D^2 g(u, w) have 8 to 14)
//! runs on an array in the caller's frame, of [`SMALL_REGISTERS`] or [`STACK_REGISTERS`]
//! entries, written once per call (a store per register, cheaper than finding a buffer); a
//! larger one on a buffer of the thread's pool, a stack of
//! idle `Vec<T>` per number type (found by `TypeId`, downcast with `Any`: no `unsafe`), taken
//! and given back (a nested use takes a second buffer). Either way the evaluation runs in the
//! caller's frame, so that over lanes it is compiled with the caller's instruction set.
//! Buffers are allocated on a thread's first evaluations only.

use std::any::{Any, TypeId};
use std::cell::RefCell;

use sdae_expr::Program;
use sdae_lanes::Real;

/// The most registers of a program evaluated on the smaller array of the caller's stack.
const SMALL_REGISTERS: usize = 16;

/// The most registers of a program evaluated on the caller's stack.
const STACK_REGISTERS: usize = 32;

/// The most idle buffers a thread keeps per number type (more are dropped when given back).
const KEPT_PER_TYPE: usize = 8;

thread_local! {
    /// Per number type: its `Vec<Vec<T>>` of idle buffers.
    static POOLS: RefCell<Vec<(TypeId, Box<dyn Any>)>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of at least `len` values of `T` from this thread's pool (a new one if none is
/// idle).
fn take<T: Real>(len: usize, seed: T) -> Vec<T> {
    let mut buffer = POOLS
        .try_with(|pools| {
            let mut pools = pools.try_borrow_mut().ok()?;
            let (_, idle) = pools.iter_mut().find(|(id, _)| *id == TypeId::of::<T>())?;
            idle.downcast_mut::<Vec<Vec<T>>>()?.pop()
        })
        .ok()
        .flatten()
        .unwrap_or_default();
    if buffer.len() < len {
        buffer.resize(len, seed);
    }
    buffer
}

/// Gives `buffer` back to this thread's pool (dropped if the pool is full).
fn give_back<T: Real>(buffer: Vec<T>) {
    let _ = POOLS.try_with(|pools| {
        let Ok(mut pools) = pools.try_borrow_mut() else {
            return;
        };
        let position = pools.iter().position(|(id, _)| *id == TypeId::of::<T>());
        let entry = match position {
            Some(i) => &mut pools[i].1,
            None => {
                pools.push((TypeId::of::<T>(), Box::new(Vec::<Vec<T>>::new())));
                &mut pools.last_mut().expect("just pushed").1
            }
        };
        if let Some(idle) = entry.downcast_mut::<Vec<Vec<T>>>()
            && idle.len() < KEPT_PER_TYPE
        {
            idle.push(buffer);
        }
    });
}

/// Where a program's outputs go, one by one ([`eval_to`]): a slice (output k into entry k),
/// or a constraint's storages (the values of g and the Gram entries).
pub(crate) trait Sink<T> {
    /// Output `k` is `value`.
    fn put(&mut self, k: usize, value: T);
}

impl<T> Sink<T> for [T] {
    #[inline(always)]
    fn put(&mut self, k: usize, value: T) {
        self[k] = value;
    }
}

/// `program.eval_in(inputs, out, registers)` with registers on the stack where they are few,
/// else lent by this thread's pool.
#[inline(always)]
pub(crate) fn eval<T: Real>(program: &Program, inputs: &[&[T]], out: &mut [T]) {
    assert_eq!(out.len(), program.outputs(), "one value per output");
    match out.first() {
        Some(&seed) => eval_to(program, inputs, seed, out),
        None => program.eval_in(inputs, out, &mut []),
    }
}

/// Runs `program` on `inputs` ([`Program::run_in`]) with registers on the stack where they
/// are few, else lent by this thread's pool, and hands output k to `sink` (constants of the
/// kind of `seed`).
#[inline(always)]
pub(crate) fn eval_to<T: Real, S: Sink<T> + ?Sized>(
    program: &Program, inputs: &[&[T]], seed: T, sink: &mut S,
) {
    // One evaluation on whichever array fits (the tape's code once per caller); each array
    // is written only where it is chosen.
    let (mut small, mut large);
    let mut pooled = None;
    let registers: &mut [T] = match program.registers() {
        len if len <= SMALL_REGISTERS => {
            small = [seed; SMALL_REGISTERS];
            &mut small
        }
        len if len <= STACK_REGISTERS => {
            large = [seed; STACK_REGISTERS];
            &mut large
        }
        len => pooled.insert(take(len, seed)),
    };
    program.run_in(inputs, registers, seed);
    for (k, &register) in program.output_registers().iter().enumerate() {
        sink.put(k, registers[register as usize]);
    }
    if let Some(buffer) = pooled {
        give_back(buffer);
    }
}

/// `f` with a buffer of `len` values of `T` (their values unspecified: `seed` or left over),
/// lent by this thread's pool.
#[inline(always)]
pub(crate) fn with_buffer<T: Real, R>(len: usize, seed: T, f: impl FnOnce(&mut [T]) -> R) -> R {
    let mut buffer = take(len, seed);
    let result = f(&mut buffer[..len]);
    give_back(buffer);
    result
}
