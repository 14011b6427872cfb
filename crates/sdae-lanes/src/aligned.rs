//! A global allocator that starts every buffer of a cache line or more on a cache line.
//!
//! A value of W lanes is W f64 (64 bytes with AVX-512) aligned to 8 bytes, so a `Vec` of them
//! starts wherever the system allocator puts it (16-byte boundaries with glibc). On processors
//! that split a 512-bit access into two 256-bit halves (AMD Zen 4), a buffer at 16 or 48 modulo
//! 64 makes every lane access straddle two halves; the lane ensembles then run about 20% slower,
//! and which buffers land badly changes with the order of allocations (docs/performance.md).
//! A program opts in with
//!
//! ```
//! #[global_allocator]
//! static ALLOCATOR: sdae_lanes::LineAligned = sdae_lanes::LineAligned;
//! # fn main() { let v = vec![0.0f64; 64]; assert_eq!(v.as_ptr() as usize % 64, 0); }
//! ```
//!
//! Smaller allocations keep their own alignment, so small vectors cost no more memory.

use std::alloc::{GlobalAlloc, Layout, System};

/// The cache line: 64 bytes, one AVX-512 vector.
pub const LINE: usize = 64;

/// The system allocator, with every allocation of [`LINE`] bytes or more aligned to [`LINE`].
#[derive(Debug, Clone, Copy, Default)]
pub struct LineAligned;

/// `layout` aligned to a line where it is a line or more long.
fn on_line(layout: Layout) -> Layout {
    if layout.size() >= LINE && layout.align() < LINE {
        layout.align_to(LINE).unwrap_or(layout)
    } else {
        layout
    }
}

// SAFETY: every block is allocated and freed by `System` with the same layout, `on_line` of the
// caller's layout, which is a deterministic function of the caller's size and alignment and
// never weakens the alignment the caller asked for.
unsafe impl GlobalAlloc for LineAligned {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: `on_line` keeps the size (nonzero, as the caller's) and a valid alignment.
        unsafe { System.alloc(on_line(layout)) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as in `alloc`.
        unsafe { System.alloc_zeroed(on_line(layout)) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` with `on_line(layout)`, the caller's layout being
        // the one it allocated with.
        unsafe { System.dealloc(ptr, on_line(layout)) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = on_line(layout);
        // SAFETY: the caller guarantees `new_size` > 0 and that it rounds to a valid layout
        // with `layout.align()`.
        let new = on_line(unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) });
        if new.align() == old.align() {
            // SAFETY: `ptr` was allocated by `System` with `old`; the new block keeps its
            // alignment.
            return unsafe { System.realloc(ptr, old, new_size) };
        }
        // The block crosses the line size: a new block with the other alignment.
        // SAFETY: `new` is a valid nonzero layout; both blocks are live for the copy, which
        // covers the smaller of the two sizes; `ptr` is freed with the layout it was
        // allocated with.
        unsafe {
            let moved = System.alloc(new);
            if !moved.is_null() {
                std::ptr::copy_nonoverlapping(ptr, moved, layout.size().min(new_size));
                System.dealloc(ptr, old);
            }
            moved
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_or_more_is_aligned_to_a_line_and_less_keeps_its_alignment() {
        let long = on_line(Layout::from_size_align(64, 8).unwrap());
        assert_eq!((long.size(), long.align()), (64, 64));
        let short = on_line(Layout::from_size_align(48, 8).unwrap());
        assert_eq!((short.size(), short.align()), (48, 8));
        let strict = on_line(Layout::from_size_align(256, 128).unwrap());
        assert_eq!(strict.align(), 128);
    }

    #[test]
    fn blocks_are_aligned_and_keep_their_bytes_across_reallocation() {
        let a = LineAligned;
        let layout = Layout::from_size_align(40, 8).unwrap();
        // SAFETY: nonzero layouts; each block is freed once, with the layout it has.
        unsafe {
            let p = a.alloc(layout);
            assert!(!p.is_null());
            for i in 0..40 {
                *p.add(i) = i as u8;
            }
            let q = a.realloc(p, layout, 1000);
            assert_eq!(q as usize % LINE, 0);
            assert!((0..40).all(|i| *q.add(i) == i as u8));
            let grown = Layout::from_size_align(1000, 8).unwrap();
            let r = a.realloc(q, grown, 24);
            assert!((0..24).all(|i| *r.add(i) == i as u8));
            a.dealloc(r, Layout::from_size_align(24, 8).unwrap());
            let z = a.alloc_zeroed(grown);
            assert_eq!(z as usize % LINE, 0);
            assert!((0..1000).all(|i| *z.add(i) == 0));
            a.dealloc(z, grown);
        }
    }
}
