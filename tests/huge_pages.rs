//! Large allocations advised to use transparent huge pages (`mbmf::huge_pages`): backed by them
//! where the kernel gives them on request, with their contents intact. Where the kernel has no
//! such mode, the check says it skips.

use std::alloc::{GlobalAlloc, Layout};

use mbmf::huge_pages::HugePageSystem;

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
            && let (Ok(lo), Ok(hi)) = (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
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
