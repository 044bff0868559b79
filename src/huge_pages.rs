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

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel's transparent huge page mode (`always`, `madvise` or `never`), if it has them.
    fn thp_mode() -> Option<String> {
        let text = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").ok()?;
        let start = text.find('[')? + 1;
        let end = text[start..].find(']')? + start;
        Some(text[start..end].to_owned())
    }

    /// The `AnonHugePages` kilobytes of the mapping of /proc/self/smaps that holds `address`.
    fn huge_kib_at(address: usize) -> Option<u64> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ')
                && let Some((lo, hi)) = range.split_once('-')
                && let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
            {
                inside = (lo..hi).contains(&address);
            } else if inside && let Some(kib) = line.strip_prefix("AnonHugePages:") {
                return kib.trim().trim_end_matches("kB").trim().parse().ok();
            }
        }
        None
    }

    #[test]
    fn a_large_allocation_is_backed_by_huge_pages_and_keeps_its_contents() {
        // Above glibc's largest mapping threshold (32 MiB), so the block is mapped afresh, never
        // heap memory an earlier test touched (already backed by small pages).
        let bytes = 40 << 20;
        let layout = Layout::from_size_align(bytes, 8).expect("a valid layout");
        // SAFETY: the layout is not zero-sized; the memory is freed with the same layout.
        let pointer = unsafe { HugePageSystem.alloc_zeroed(layout) };
        assert!(!pointer.is_null());
        // SAFETY: `bytes` bytes from `pointer` were just allocated, zeroed, for this test.
        let memory = unsafe { std::slice::from_raw_parts_mut(pointer, bytes) };
        assert!(memory.iter().all(|&b| b == 0));
        for (i, b) in memory.iter_mut().enumerate() {
            *b = (i % 251) as u8;
        }
        assert!(
            memory
                .iter()
                .enumerate()
                .all(|(i, &b)| b == (i % 251) as u8)
        );
        let huge = huge_kib_at(pointer as usize + bytes / 2);
        // SAFETY: allocated above with this layout, not used after.
        unsafe { HugePageSystem.dealloc(pointer, layout) };
        match thp_mode().as_deref() {
            // Asked for, the kernel backs at least one of the whole huge pages inside (it may
            // fall back to small pages for some when memory is fragmented, not for all of 19).
            Some("madvise" | "always") => {
                let kib = huge.expect("the allocation's mapping in /proc/self/smaps");
                assert!(
                    kib >= 2048,
                    "{kib} KiB of huge pages in the allocation's mapping"
                );
            }
            mode => eprintln!("skipped the huge-page check: transparent huge pages {mode:?}"),
        }
    }
}
