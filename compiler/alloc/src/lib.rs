//! The global allocator of the `vrsc` binary, its benchmarks and profiling harnesses: mimalloc.
//!
//! `mimalloc::MiMalloc` passes every request to `mi_malloc_aligned`, whose alignment handling
//! costs about 3% of a composition's instructions (callgrind over `compose_repeat`). Nearly every
//! Rust allocation asks for at most the alignment `mi_malloc` already guarantees, so those take
//! the plain entry points and only larger alignments the aligned ones.
//!
//! Public API: [`MiMalloc`], the allocator, to be declared as the binary's
//! `#[global_allocator]`:
//!
//! ```ignore
//! #[global_allocator]
//! static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;
//! ```

use libmimalloc_sys as mi;
use std::alloc::{GlobalAlloc, Layout};
use std::ffi::c_void;

/// Largest alignment `mi_malloc` guarantees (`MI_MAX_ALIGN_SIZE`), for blocks at least that
/// large; a smaller block is aligned to the largest power of two not above its size.
const PLAIN_ALIGN: usize = 16;

/// Whether the plain entry points serve `layout` (the rule `std`'s own `System` allocator uses).
#[inline]
fn plain(layout: Layout) -> bool {
    layout.align() <= PLAIN_ALIGN && layout.align() <= layout.size()
}

/// mimalloc as a [`GlobalAlloc`].
pub struct MiMalloc;

// SAFETY: every method forwards to the mimalloc function with the same contract; blocks of
// alignment above `PLAIN_ALIGN` are only ever made and resized by the aligned functions, and
// `mi_free` frees blocks of either kind.
unsafe impl GlobalAlloc for MiMalloc {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        unsafe {
            if plain(layout) {
                mi::mi_malloc(layout.size()).cast()
            } else {
                mi::mi_malloc_aligned(layout.size(), layout.align()).cast()
            }
        }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        unsafe {
            if plain(layout) {
                mi::mi_zalloc(layout.size()).cast()
            } else {
                mi::mi_zalloc_aligned(layout.size(), layout.align()).cast()
            }
        }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, _layout: Layout) {
        unsafe { mi::mi_free(ptr.cast::<c_void>()) }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        unsafe {
            if plain(layout) {
                mi::mi_realloc(ptr.cast::<c_void>(), new_size).cast()
            } else {
                mi::mi_realloc_aligned(ptr.cast::<c_void>(), new_size, layout.align()).cast()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_have_the_alignment_asked_for_and_keep_their_contents() {
        for (size, align) in [(100, 1), (100, 8), (100, 16), (4, 16), (100, 32), (100, 64), (100, 4096)] {
            let layout = Layout::from_size_align(size, align).unwrap();
            unsafe {
                let p = MiMalloc.alloc(layout);
                assert!(!p.is_null());
                assert_eq!(p as usize % align, 0, "alignment {align}");
                p.write_bytes(7, size);
                let q = MiMalloc.realloc(p, layout, 5000);
                assert_eq!(q as usize % align, 0, "alignment {align} after realloc");
                assert!((0..size).all(|i| *q.add(i) == 7), "contents kept at alignment {align}");
                MiMalloc.dealloc(q, Layout::from_size_align(5000, align).unwrap());
                let z = MiMalloc.alloc_zeroed(layout);
                assert_eq!(z as usize % align, 0);
                assert!((0..size).all(|i| *z.add(i) == 0), "zeroed at alignment {align}");
                MiMalloc.dealloc(z, layout);
            }
        }
    }
}
