//! Registers for [`Program::eval`] without a heap allocation per call: each thread keeps, per
//! number type, a few buffers of registers, lent out for one evaluation and taken back after.
//!
//! A program's evaluation needs a `Vec<T>` of its registers. The methods that evaluate take
//! `&self` and run on many threads at once, so the buffers cannot live in the system; a
//! thread-local pool of `Vec<T>` per type `T` (found by `TypeId`, downcast with `Any`: no
//! `unsafe`) lends one out. The evaluation itself runs in the caller's frame (the buffer is
//! moved out of the pool and back, three words each way), so that over lanes it is compiled
//! with the caller's instruction set. A buffer whose length is the program's register count
//! is preferred: [`Program::eval`] then only writes the constants before running the tape.
//! Buffers are allocated on a thread's first evaluations only.

use std::any::{Any, TypeId};
use std::cell::RefCell;

use sdae_expr::Program;
use sdae_lanes::Real;

/// The most buffers a thread keeps per number type (a system evaluates a handful of programs
/// of different sizes; more are dropped when given back).
const KEPT_PER_TYPE: usize = 16;

thread_local! {
    /// Per number type: its `Vec<Vec<T>>` of idle buffers.
    static POOLS: RefCell<Vec<(TypeId, Box<dyn Any>)>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `T` from this thread's pool, preferably of length `len` (else any, else a new
/// empty one).
fn take<T: Real>(len: usize) -> Vec<T> {
    POOLS
        .try_with(|pools| {
            let mut pools = pools.try_borrow_mut().ok()?;
            let idle = pools
                .iter_mut()
                .find(|(id, _)| *id == TypeId::of::<T>())?
                .1
                .downcast_mut::<Vec<Vec<T>>>()?;
            let at = idle
                .iter()
                .position(|b| b.len() == len)
                .or_else(|| idle.len().checked_sub(1))?;
            Some(idle.swap_remove(at))
        })
        .ok()
        .flatten()
        .unwrap_or_default()
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

/// `program.eval(inputs, out)` with registers lent by this thread's pool.
#[inline(always)]
pub(crate) fn eval<T: Real>(program: &Program, inputs: &[&[T]], out: &mut [T]) {
    let mut registers = take::<T>(program.registers());
    program.eval(inputs, out, &mut registers);
    give_back(registers);
}

/// `f` with a buffer of `len` values of `T` (their values unspecified: `seed` or left over),
/// lent by this thread's pool.
#[inline(always)]
pub(crate) fn with_buffer<T: Real, R>(len: usize, seed: T, f: impl FnOnce(&mut [T]) -> R) -> R {
    let mut buffer = take::<T>(len);
    buffer.resize(len, seed);
    let result = f(&mut buffer[..len]);
    give_back(buffer);
    result
}
