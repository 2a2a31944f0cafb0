//! A global allocator that backs large allocations with transparent huge pages
//! (Linux), so the engine's big per-particle and per-pair arrays cost one TLB
//! entry per 2 MiB instead of one per 4 KiB.
//!
//! # Why
//!
//! A 50,000-particle bed keeps about 35 MB of arrays that every step sweeps
//! (particle state, packed records, the pair list, its contact history and the
//! per-pair force buffer), with partners read up to one cell slab (≈ 1,000
//! particles) away. With 4 KiB pages that is ≈ 8,500 pages, more than the
//! second-level TLB holds, and the sweep pays page walks; a 5,120-particle bed
//! (≈ 850 pages) does not. Debian's default `transparent_hugepage=madvise`
//! gives huge pages only to memory that asks for them, which the system
//! allocator never does.
//!
//! The price is paid once per allocation: the first touch of each 2 MiB page
//! zeroes all of it and may wait for the kernel to compact memory (Debian's
//! default `defrag=madvise`).
//!
//! Measurements and what was tried: docs/performance.md ("src/huge_pages.rs").
//!
//! # How
//!
//! Allocations of at least [`HUGE_THRESHOLD_BYTES`] are mapped directly with
//! `mmap`, aligned to 2 MiB (the x86-64 and aarch64 huge page size), and
//! marked `MADV_HUGEPAGE` before anything touches them, so page faults fill
//! them with huge pages when the kernel has some. Smaller allocations go to the
//! system allocator unchanged. Where the kernel has no transparent huge pages
//! (`never`, or not built in) the advice fails silently and the mapping works
//! with ordinary pages. Nothing here changes any computed value.

use std::alloc::{GlobalAlloc, Layout, System};
use std::ptr;

/// Huge page size assumed for alignment and advice, bytes (2 MiB).
pub const HUGE_PAGE_BYTES: usize = 2 << 20;
/// Allocations at least this large (bytes, 512 KiB) get their own huge-page
/// mapping: low enough to cover a 50,000-particle bed's per-particle arrays of
/// 16 bytes per particle and up (a 4 MiB threshold would leave half of the
/// swept memory on 4 KiB pages), high enough that the padding to whole 2 MiB
/// pages wastes at most 1.5 MiB on each of a few dozen arrays.
pub const HUGE_THRESHOLD_BYTES: usize = 1 << 19;

/// The allocator: install it with `#[global_allocator]` in a binary.
#[derive(Clone, Copy, Debug, Default)]
pub struct HugePageAlloc;

/// `size` rounded up to whole huge pages (None on overflow).
fn mapped_len(size: usize) -> Option<usize> {
    size.checked_add(HUGE_PAGE_BYTES - 1)
        .map(|s| s & !(HUGE_PAGE_BYTES - 1))
}

/// Whether `layout` is served by a huge-page mapping.
fn is_huge(layout: &Layout) -> bool {
    layout.size() >= HUGE_THRESHOLD_BYTES && layout.align() <= HUGE_PAGE_BYTES
}

/// Maps `len` bytes (a multiple of [`HUGE_PAGE_BYTES`]) aligned to a huge page
/// and advises huge pages for them; null on failure.
///
/// # Safety
/// `len` must be a non-zero multiple of [`HUGE_PAGE_BYTES`].
unsafe fn map_huge(len: usize) -> *mut u8 {
    let Some(padded) = len.checked_add(HUGE_PAGE_BYTES) else {
        return ptr::null_mut();
    };
    // SAFETY: an anonymous private mapping with no address hint; the kernel
    // checks every argument.
    let raw = unsafe {
        libc::mmap(
            ptr::null_mut(),
            padded,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if raw == libc::MAP_FAILED {
        return ptr::null_mut();
    }
    let start = raw as usize;
    let aligned = (start + HUGE_PAGE_BYTES - 1) & !(HUGE_PAGE_BYTES - 1);
    let head = aligned - start;
    let tail = padded - head - len;
    // SAFETY: both ranges lie inside the mapping just made, start on page
    // boundaries (mmap returns page-aligned memory; `aligned` and `len` are
    // multiples of the huge page) and are not used by anyone.
    unsafe {
        if head > 0 {
            libc::munmap(raw, head);
        }
        if tail > 0 {
            libc::munmap((aligned + len) as *mut libc::c_void, tail);
        }
        // Advice only: failure (no THP in this kernel) leaves ordinary pages.
        libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
    }
    aligned as *mut u8
}

// SAFETY: huge allocations are fresh, exclusive mappings of at least
// `layout.size()` bytes aligned to 2 MiB (so to `layout.align()`), unmapped
// with the same length in `dealloc` (the length is a function of the size);
// everything else is delegated to `System`.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !is_huge(&layout) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.alloc(layout) };
        }
        match mapped_len(layout.size()) {
            // SAFETY: `len` is a non-zero multiple of the huge page.
            Some(len) => unsafe { map_huge(len) },
            None => ptr::null_mut(),
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !is_huge(&layout) {
            // SAFETY: forwarded with the caller's guarantees.
            return unsafe { System.alloc_zeroed(layout) };
        }
        // A fresh anonymous mapping reads as zeros.
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { self.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if !is_huge(&layout) {
            // SAFETY: `ptr` came from `System.alloc` with this layout.
            return unsafe { System.dealloc(ptr, layout) };
        }
        if let Some(len) = mapped_len(layout.size()) {
            // SAFETY: `ptr` is the start of a mapping of exactly `len` bytes.
            unsafe { libc::munmap(ptr as *mut libc::c_void, len) };
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY (whole body): the caller guarantees `layout` describes `ptr`
        // and `new_size` is valid for `layout.align()`.
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        match (is_huge(&layout), is_huge(&new_layout)) {
            (false, false) => return unsafe { System.realloc(ptr, layout, new_size) },
            // Same mapping length: the mapping already fits; nothing to move.
            (true, true) if mapped_len(layout.size()) == mapped_len(new_size) => return ptr,
            _ => {}
        }
        let new = unsafe { self.alloc(new_layout) };
        if !new.is_null() {
            unsafe {
                ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_allocations_are_huge_page_aligned_zeroed_and_resizable() {
        let a = HugePageAlloc;
        let layout = Layout::from_size_align(HUGE_THRESHOLD_BYTES + 12_345, 8).unwrap();
        unsafe {
            let p = a.alloc_zeroed(layout);
            assert!(!p.is_null());
            assert_eq!(p as usize % HUGE_PAGE_BYTES, 0);
            let s = std::slice::from_raw_parts_mut(p, layout.size());
            assert!(s.iter().all(|&b| b == 0));
            s[layout.size() - 1] = 7;
            s[0] = 3;
            // Grow within the 2 MiB mapping (stays in place), then past it
            // (moves), then shrink below the threshold: contents survive.
            let within = a.realloc(p, layout, 3 * HUGE_THRESHOLD_BYTES);
            assert_eq!(within, p);
            let mid = Layout::from_size_align(3 * HUGE_THRESHOLD_BYTES, 8).unwrap();
            let grown = a.realloc(within, mid, 2 * HUGE_PAGE_BYTES + 1);
            assert_eq!(grown as usize % HUGE_PAGE_BYTES, 0);
            assert_eq!(*grown, 3);
            assert_eq!(*grown.add(layout.size() - 1), 7);
            let big = Layout::from_size_align(2 * HUGE_PAGE_BYTES + 1, 8).unwrap();
            let small = a.realloc(grown, big, 1024);
            assert_eq!(*small, 3);
            a.dealloc(small, Layout::from_size_align(1024, 8).unwrap());
        }
    }

    #[test]
    fn small_allocations_go_to_the_system_allocator() {
        let layout = Layout::from_size_align(1000, 16).unwrap();
        assert!(!is_huge(&layout));
        assert!(is_huge(
            &Layout::from_size_align(HUGE_THRESHOLD_BYTES, 64).unwrap()
        ));
        assert_eq!(mapped_len(1), Some(HUGE_PAGE_BYTES));
        assert_eq!(mapped_len(usize::MAX), None);
    }
}
