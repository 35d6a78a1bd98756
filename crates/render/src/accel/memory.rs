//! Storage for the large, read-only arrays of the BVH (nodes, triangle
//! blocks), backed by transparent huge pages where the OS offers them.
//!
//! Incoherent rays touch the tree at random: with 4 KiB pages nearly every
//! node load of a million-triangle mesh also misses the TLB, and under a
//! hypervisor each such miss is a two-level page walk. 2 MiB pages cover the
//! whole tree with a few dozen TLB entries.

use std::alloc::{alloc, dealloc, handle_alloc_error, Layout};
use std::ops::Deref;
use std::ptr::NonNull;

/// Arrays at least this large are aligned to, and advised as, huge pages.
const HUGE_PAGE: usize = 2 << 20;

/// An immutable array of `Copy` values; dereferences to a slice.
pub struct HugeArray<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    layout: Option<Layout>,
}

// SAFETY: the array owns its values and is immutable after construction.
unsafe impl<T: Copy + Send> Send for HugeArray<T> {}
unsafe impl<T: Copy + Sync> Sync for HugeArray<T> {}

impl<T: Copy> HugeArray<T> {
    /// A copy of `values` (empty arrays allocate nothing).
    pub fn from_slice(values: &[T]) -> HugeArray<T> {
        let bytes = std::mem::size_of_val(values);
        if bytes == 0 {
            return HugeArray::default();
        }
        let (ptr, layout) = Self::allocate(bytes);
        // SAFETY: the allocation holds `values.len()` values of T and does not
        // overlap `values`.
        unsafe { std::ptr::copy_nonoverlapping(values.as_ptr(), ptr.as_ptr(), values.len()) };
        HugeArray { ptr, len: values.len(), layout: Some(layout) }
    }
}

impl<T: Copy> HugeArray<T> {
    /// `len` values of all-zero bytes, to be filled in place (building in
    /// place saves a copy and a second round of page faults).
    ///
    /// # Safety
    /// All-zero bytes must be a valid T (plain floats and integers).
    pub unsafe fn zeroed(len: usize) -> HugeArray<T> {
        let bytes = len * std::mem::size_of::<T>();
        if bytes == 0 {
            return HugeArray::default();
        }
        let (ptr, layout) = Self::allocate(bytes);
        // SAFETY: the allocation is `layout.size() >= bytes` bytes long.
        unsafe { std::ptr::write_bytes(ptr.as_ptr() as *mut u8, 0, bytes) };
        HugeArray { ptr, len, layout: Some(layout) }
    }

    /// An uninitialised allocation of `bytes` > 0, advised as huge pages
    /// when large, before anything touches it.
    fn allocate(bytes: usize) -> (NonNull<T>, Layout) {
        let align = if bytes >= HUGE_PAGE { HUGE_PAGE } else { std::mem::align_of::<T>() };
        let layout = Layout::from_size_align(bytes.next_multiple_of(align), align).expect("array layout");
        // SAFETY: the layout has a non-zero size.
        let raw = unsafe { alloc(layout) };
        let Some(ptr) = NonNull::new(raw as *mut T) else { handle_alloc_error(layout) };
        #[cfg(target_os = "linux")]
        if align == HUGE_PAGE {
            // A refusal only costs speed, so the result is ignored.
            // SAFETY: the range is exactly the allocation made above.
            unsafe { libc::madvise(raw as *mut libc::c_void, layout.size(), libc::MADV_HUGEPAGE) };
        }
        (ptr, layout)
    }
}

impl<T: Copy> std::ops::DerefMut for HugeArray<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`; `&mut self` makes the access unique.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Default for HugeArray<T> {
    fn default() -> Self {
        HugeArray { ptr: NonNull::dangling(), len: 0, layout: None }
    }
}

impl<T: Copy> Drop for HugeArray<T> {
    fn drop(&mut self) {
        if let Some(layout) = self.layout {
            // SAFETY: allocated in `from_slice` with this layout.
            unsafe { dealloc(self.ptr.as_ptr() as *mut u8, layout) };
        }
    }
}

impl<T: Copy> Deref for HugeArray<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised values (or is dangling with len 0).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Clone for HugeArray<T> {
    fn clone(&self) -> Self {
        HugeArray::from_slice(self)
    }
}

impl<T: Copy> std::fmt::Debug for HugeArray<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "HugeArray({} values)", self.len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_values_small_and_huge() {
        for n in [0usize, 1, 1000, (HUGE_PAGE / 4) + 3] {
            let v: Vec<u32> = (0..n as u32).map(|i| i.wrapping_mul(2654435761)).collect();
            let a = HugeArray::from_slice(&v);
            assert_eq!(&a[..], &v[..]);
            assert_eq!(&a.clone()[..], &v[..]);
            // SAFETY: zero is a valid u32.
            let mut z = unsafe { HugeArray::<u32>::zeroed(n) };
            assert!(z.iter().all(|&x| x == 0));
            z.copy_from_slice(&v);
            assert_eq!(&z[..], &v[..]);
            if n * 4 >= HUGE_PAGE {
                assert_eq!(a.as_ptr() as usize % HUGE_PAGE, 0);
            }
        }
    }
}
