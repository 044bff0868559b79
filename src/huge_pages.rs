//! Large allocations on transparent huge pages, where the kernel gives them on request.
//!
//! A batch's tables are tens of megabytes, written once when the batch starts and then read at
//! random, run by run. On 4 KiB pages their first touch costs a page fault (and a cgroup charge)
//! per page, and the random reads a TLB miss each; on 2 MiB pages both shrink by 512. Linux
//! gives huge pages to anonymous memory either always or only where a process asks with
//! `madvise(MADV_HUGEPAGE)` (Debian's default, `madvise`): [`HugePageSystem`] asks for every
//! allocation large enough to hold one. EC's early phase (1,024 runs x 1,000 steps, one thread)
//! runs about a tenth faster (benches/README.md). Results do not depend on it.

use std::alloc::{GlobalAlloc, Layout, System};

/// The size of a transparent huge page on x86-64 and most aarch64 kernels.
const HUGE_PAGE: usize = 2 << 20;

/// Allocations from this size up are advised: they hold at least one whole aligned huge page.
pub const ADVISED_FROM: usize = 2 * HUGE_PAGE;

/// The system allocator, with every allocation of at least [`ADVISED_FROM`] bytes advised to
/// use huge pages (the aligned huge pages inside it: memory it does not own is never advised).
/// Where the kernel has no transparent huge pages, or gives them always, nothing changes.
pub struct HugePageSystem;

/// Asks the kernel to back the whole huge pages inside `bytes` bytes from `pointer` with huge
/// pages when they are first touched. Advice only: a refusal changes nothing and is ignored.
pub fn advise(pointer: *mut u8, bytes: usize) {
    if pointer.is_null() || bytes < ADVISED_FROM {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        let start = (pointer as usize).next_multiple_of(HUGE_PAGE);
        let end = (pointer as usize).saturating_add(bytes) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: [start, end) lies inside the allocation the caller owns; MADV_HUGEPAGE
            // changes how its pages are backed, never its contents.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
}

// SAFETY: every call is forwarded to `System` with its arguments unchanged; the advice after
// an allocation touches no byte of it.
unsafe impl GlobalAlloc for HugePageSystem {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let pointer = unsafe { System.alloc(layout) };
        advise(pointer, layout.size());
        pointer
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let pointer = unsafe { System.alloc_zeroed(layout) };
        advise(pointer, layout.size());
        pointer
    }

    unsafe fn realloc(&self, pointer: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let pointer = unsafe { System.realloc(pointer, layout, new_size) };
        advise(pointer, new_size);
        pointer
    }

    unsafe fn dealloc(&self, pointer: *mut u8, layout: Layout) {
        unsafe { System.dealloc(pointer, layout) }
    }
}
