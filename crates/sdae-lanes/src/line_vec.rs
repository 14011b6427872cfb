//! [`LineVec`]: a growable buffer of plain values (f64, [`Lanes`](crate::Lanes)) whose first
//! value starts on a cache line, whatever the global allocator does.
//!
//! A `Vec` of lane values starts where the allocator puts it: glibc's malloc gives 16-byte
//! boundaries, and a 512-bit access at 16 or 48 modulo 64 straddles two halves of a line
//! (5-19% of a lane ensemble's step on an AMD EPYC, docs/performance.md). The ensemble's
//! states, rows and scratch are `LineVec`s, so that a program gets aligned lanes without
//! installing [`LineAligned`](crate::LineAligned).

use std::fmt;
use std::marker::PhantomData;
use std::mem::{align_of, size_of};
use std::ops::{Deref, DerefMut};

use crate::aligned::LINE;

/// One cache line of storage.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Line([u64; LINE / 8]);

/// `len` values of `T` in cache lines: a slice of `T` (through `Deref`) whose first value
/// starts on a line.
///
/// ```
/// use sdae_lanes::LineVec;
/// let mut x = LineVec::from_elem(0.5, 3);
/// x[1] = 2.0;
/// x.resize(5, 1.0);
/// assert_eq!(&x[..], &[0.5, 2.0, 0.5, 1.0, 1.0]);
/// assert_eq!(x.as_ptr() as usize % 64, 0);
/// ```
pub struct LineVec<T: Copy> {
    lines: Vec<Line>,
    len: usize,
    values: PhantomData<T>,
}

impl<T: Copy> LineVec<T> {
    /// Values of `T` fit in lines: `T` asks for no more than a line's alignment.
    const FITS: () = assert!(align_of::<T>() <= LINE && size_of::<T>() > 0);

    /// An empty buffer.
    pub const fn new() -> Self {
        Self {
            lines: Vec::new(),
            len: 0,
            values: PhantomData,
        }
    }

    /// `len` copies of `value`.
    pub fn from_elem(value: T, len: usize) -> Self {
        let mut buffer = Self::new();
        buffer.resize(len, value);
        buffer
    }

    /// `len` copies of `value`, or `None` if the memory cannot be had.
    pub fn try_from_elem(value: T, len: usize) -> Option<Self> {
        let bytes = len.checked_mul(size_of::<T>())?;
        let mut buffer = Self::new();
        buffer.lines.try_reserve_exact(bytes.div_ceil(LINE)).ok()?;
        buffer.resize(len, value);
        Some(buffer)
    }

    /// The number of values.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds no value.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Resizes to `len` values; new ones are copies of `value`.
    pub fn resize(&mut self, len: usize, value: T) {
        let () = Self::FITS;
        let bytes = len
            .checked_mul(size_of::<T>())
            .expect("a buffer's size overflows usize");
        let lines = bytes.div_ceil(LINE);
        if lines > self.lines.len() {
            self.lines.resize(lines, Line([0; LINE / 8]));
        }
        let start = self.len;
        self.len = len;
        if len > start {
            let base = self.lines.as_mut_ptr().cast::<T>();
            for i in start..len {
                // SAFETY: `lines` holds at least `len * size_of::<T>()` bytes starting on a
                // line, which is aligned for `T` (FITS), and `i < len`.
                unsafe { base.add(i).write(value) };
            }
        }
    }
}

impl<T: Copy> Default for LineVec<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy> Deref for LineVec<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: the first `len` values were written ([`LineVec::resize`]) in storage aligned
        // for `T`; an empty `Vec<Line>`'s pointer is non-null and line-aligned.
        unsafe { std::slice::from_raw_parts(self.lines.as_ptr().cast::<T>(), self.len) }
    }
}

impl<T: Copy> DerefMut for LineVec<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, with the buffer borrowed mutably.
        unsafe { std::slice::from_raw_parts_mut(self.lines.as_mut_ptr().cast::<T>(), self.len) }
    }
}

impl<T: Copy> AsRef<[T]> for LineVec<T> {
    #[inline(always)]
    fn as_ref(&self) -> &[T] {
        self
    }
}

impl<T: Copy> AsMut<[T]> for LineVec<T> {
    #[inline(always)]
    fn as_mut(&mut self) -> &mut [T] {
        self
    }
}

impl<'a, T: Copy> IntoIterator for &'a LineVec<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T: Copy> IntoIterator for &'a mut LineVec<T> {
    type Item = &'a mut T;
    type IntoIter = std::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

impl<T: Copy> Clone for LineVec<T> {
    fn clone(&self) -> Self {
        // The values are `Copy`: the lines' bytes are the values.
        Self {
            lines: self.lines.clone(),
            len: self.len,
            values: PhantomData,
        }
    }
}

impl<T: Copy + fmt::Debug> fmt::Debug for LineVec<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<T: Copy + PartialEq> PartialEq for LineVec<T> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Lanes;

    #[test]
    fn values_start_on_a_line_and_survive_growth_and_clones() {
        let mut x = LineVec::from_elem(1.5f64, 3);
        for len in [0, 1, 7, 8, 9, 100, 4] {
            x.resize(len, len as f64);
            assert_eq!(x.as_ptr() as usize % LINE, 0, "len {len}");
            assert_eq!(x.len(), len);
        }
        assert_eq!(&x[..], &[1.0, 7.0, 7.0, 7.0]);
        let y = x.clone();
        assert_eq!(y, x);
        assert_eq!(y.as_ptr() as usize % LINE, 0);
        assert!(LineVec::<f64>::new().is_empty());
        assert_eq!(LineVec::try_from_elem(0.25, 3).unwrap()[..], [0.25; 3]);
        assert!(LineVec::try_from_elem(0.0, usize::MAX / 4).is_none());
        assert_eq!(format!("{:?}", LineVec::from_elem(2.0, 2)), "[2.0, 2.0]");
    }

    #[test]
    fn lanes_of_every_width_fit() {
        let lanes = LineVec::from_elem(Lanes::splat(pulp::Scalar, 3.0), 5);
        assert_eq!(lanes.as_ptr() as usize % LINE, 0);
        assert!(lanes.iter().all(|x| x.lane(0) == 3.0));
        crate::LaneWidth::Best.dispatch(Widths);
    }

    struct Widths;
    impl pulp::WithSimd for Widths {
        type Output = ();
        fn with_simd<S: pulp::Simd>(self, simd: S) {
            let mut rows = LineVec::from_elem(Lanes::splat(simd, -1.0), 3);
            rows[2] = Lanes::splat(simd, 4.0);
            rows.resize(9, Lanes::splat(simd, 0.5));
            assert_eq!(rows.as_ptr() as usize % LINE, 0);
            let lane0: Vec<f64> = rows.iter().map(|x| x.lane(0)).collect();
            assert_eq!(lane0, [-1.0, -1.0, 4.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
        }
    }
}
