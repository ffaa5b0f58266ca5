//! jemalloc, with large blocks backed by transparent huge pages where the kernel offers them
//! (`madvise` mode, the common default).
//!
//! jemalloc rather than the system's: glibc maps every block above 32 MiB on its own and unmaps it
//! when freed, so each of the build's and the viewer's large temporaries (the hierarchy's passes,
//! the pages decoded, the merging state) came as fresh pages that the kernel faults in and clears,
//! over and over. jemalloc keeps freed blocks for reuse (for about ten seconds), so the same pages
//! serve the next array.
//!
//! A build's arrays are a few large blocks, each filled once: with 4 KiB pages the kernel takes a
//! fault and clears a page for every 4 KiB of them, about 115,000 faults on the dragon. With huge
//! pages that is one fault per 2 MiB (glibc does the same under `GLIBC_TUNABLES=glibc.malloc.hugetlb=1`,
//! which a program cannot set for itself). Resident memory stays as it was: the blocks are filled
//! anyway.

use std::alloc::{GlobalAlloc, Layout};
use tikv_jemallocator::Jemalloc as Inner;

/// Blocks from this size up are advised: below it a huge page would be mostly empty.
const HUGE: usize = 2 << 20;

pub struct HugePages;

/// Asks for huge pages on the whole 4 KiB pages of `len` bytes at `p` (the kernel uses them on
/// each 2 MiB-aligned stretch).
fn advise(p: *mut u8, len: usize) {
    const PAGE: usize = 4096;
    let start = (p as usize).next_multiple_of(PAGE);
    let end = (p as usize + len) & !(PAGE - 1);
    if end > start {
        // SAFETY: the range lies inside a block the allocator just gave out; advice does not
        // change its contents, and a refusal (no THP support) is harmless.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

// SAFETY: every call goes to jemalloc, which upholds `GlobalAlloc`'s contract; the advice only
// changes how the kernel backs the pages.
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let p = unsafe { Inner.alloc(layout) };
        if layout.size() >= HUGE && !p.is_null() {
            advise(p, layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let p = unsafe { Inner.alloc_zeroed(layout) };
        if layout.size() >= HUGE && !p.is_null() {
            advise(p, layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract, passed on.
        unsafe { Inner.dealloc(p, layout) }
    }

    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let q = unsafe { Inner.realloc(p, layout, new_size) };
        if new_size >= HUGE && !q.is_null() {
            advise(q, new_size);
        }
        q
    }
}
