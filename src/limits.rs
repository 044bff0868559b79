//! The memory this process may still use: the smallest of the memory available on the machine
//! (`MemAvailable` of /proc/meminfo), the headroom under the memory limit of its cgroup (v2
//! `memory.max` minus `memory.current`, v1 `memory.limit_in_bytes` minus
//! `memory.usage_in_bytes`, at its own cgroup and every parent up to the mount), and the
//! headroom under its address-space and data-size limits (`ulimit -v` / RLIMIT_AS minus VmSize,
//! `ulimit -d` / RLIMIT_DATA minus VmData). A Slurm job with `--mem=2G` on a large node, or a
//! container with a memory limit, is planned for its limit rather than for the node.

use std::cell::Cell;
use std::fmt;
use std::path::{Path, PathBuf};

/// Environment variable naming a folder read in place of `/` for /proc/meminfo,
/// /proc/self/cgroup, /proc/self/status and /sys/fs/cgroup: a testing hook, so that a fake
/// cgroup tree can stand for the real one. The resource limits themselves always come from the
/// kernel.
pub const ROOT_VAR: &str = "MBMF_SYSTEM_ROOT";

/// Limits this large mean "no limit" (cgroup v1 writes one just under `i64::MAX`).
const UNLIMITED: u64 = 1 << 62;

/// Address space a worker thread may reserve beyond what is mapped when the limits are read:
/// its stack (2 MiB). Counted only against RLIMIT_AS, which charges reservations as well as
/// memory in use.
const ADDRESS_SPACE_PER_THREAD: u64 = 2 << 20;

/// Address space of the malloc arenas beside the main one under an address-space limit
/// ([`fit_malloc_to_limits`]): one of 64 MiB on 64-bit glibc, shared by every thread.
const ARENA_BYTES: u64 = 64 << 20;

/// Under an address-space limit (`ulimit -v`), caps glibc's malloc at one arena beside the
/// main one: each thread that allocates otherwise reserves an arena of 64 MiB of address space
/// (up to 8 per core), which the limit charges though almost none of it is used, so a job
/// planned for the limit would run out of address space midway. Without such a limit nothing
/// changes. Call once, early, before threads start.
pub fn fit_malloc_to_limits() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if Rlimits::current().address_space.is_some() {
        // SAFETY: mallopt only sets a tunable of the allocator; no other thread runs yet.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 2);
        }
    }
}

thread_local! {
    /// Set while this thread asks for memory it can do without ([`can_reserve`]).
    static PROBING: Cell<bool> = const { Cell::new(false) };
}

/// Whether this thread is asking for memory it can do without ([`can_reserve`]): an allocator
/// that ends the process when memory runs out (the binary's) lets this failure through.
pub fn probing() -> bool {
    PROBING.with(Cell::get)
}

/// Whether `bytes` of address space can be had now: reserved and released at once, nothing
/// touched. Under `ulimit -v` this fails as the allocation itself would.
///
/// On Unix the probe maps and unmaps the memory itself, as the allocator maps a large block,
/// rather than allocating and freeing it through the allocator: glibc's malloc takes the free
/// of a mapped block as a hint to raise its mapping threshold to that size, after which the
/// batch's tables (allocated zeroed) would come from reused heap memory that `calloc` has to
/// clear, instead of fresh zero pages.
#[cfg(unix)]
pub fn can_reserve(bytes: u64) -> bool {
    let Ok(len) = usize::try_from(bytes) else {
        return false;
    };
    if len == 0 {
        return true;
    }
    // SAFETY: an anonymous private mapping at an address of the kernel's choosing aliases
    // nothing; it is never read or written, and unmapped at once with the length it was made
    // with.
    unsafe {
        let p = libc::mmap(
            std::ptr::null_mut(),
            len,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        );
        if p == libc::MAP_FAILED {
            return false;
        }
        libc::munmap(p, len);
    }
    true
}

/// Whether `bytes` of address space can be had now: reserved and released at once, nothing
/// touched.
#[cfg(not(unix))]
pub fn can_reserve(bytes: u64) -> bool {
    PROBING.with(|p| p.set(true));
    let mut probe: Vec<u8> = Vec::new();
    let reserved = usize::try_from(bytes)
        .ok()
        .is_some_and(|n| probe.try_reserve_exact(n).is_ok());
    PROBING.with(|p| p.set(false));
    reserved
}

/// The limit that leaves the least memory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Bound {
    /// `MemAvailable` of /proc/meminfo.
    Available {
        /// Bytes available.
        available: u64,
    },
    /// A cgroup's memory limit.
    Cgroup {
        /// The file holding the limit (`memory.max` or `memory.limit_in_bytes`).
        file: PathBuf,
        /// The limit, bytes.
        limit: u64,
        /// The cgroup's use, bytes.
        usage: u64,
    },
    /// RLIMIT_AS (`ulimit -v`) and the process's VmSize.
    AddressSpace {
        /// The limit, bytes.
        limit: u64,
        /// Bytes mapped, plus the reservation of the worker threads.
        usage: u64,
    },
    /// RLIMIT_DATA (`ulimit -d`) and the process's VmData.
    Data {
        /// The limit, bytes.
        limit: u64,
        /// Bytes of data mapped.
        usage: u64,
    },
}

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = |n: u64| crate::sizing::human_bytes(u128::from(n));
        match self {
            Bound::Available { available } => {
                write!(
                    f,
                    "the memory available on this machine ({})",
                    b(*available)
                )
            }
            Bound::Cgroup { file, limit, usage } => write!(
                f,
                "the memory limit of this process's cgroup ({} in {}, {} in use)",
                b(*limit),
                file.display(),
                b(*usage)
            ),
            Bound::AddressSpace { limit, usage } => write!(
                f,
                "the address-space limit (ulimit -v: {}, {} in use)",
                b(*limit),
                b(*usage)
            ),
            Bound::Data { limit, usage } => write!(
                f,
                "the data-size limit (ulimit -d: {}, {} in use)",
                b(*limit),
                b(*usage)
            ),
        }
    }
}

impl Bound {
    /// Bytes of [`Bound::headroom`] a batch may take. Half of memory, the other half kept for
    /// the Parquet encoding buffers, the allocator and the rest of the process; a quarter under
    /// a resource limit, which also charges what malloc and the compression library reserve
    /// without using (their arenas and buffers grow with the work, beyond the resident memory).
    pub fn batch_share(&self) -> u64 {
        match self {
            Bound::Available { .. } | Bound::Cgroup { .. } => self.headroom() / 2,
            Bound::AddressSpace { .. } | Bound::Data { .. } => self.headroom() / 4,
        }
    }

    /// Bytes this limit leaves.
    pub fn headroom(&self) -> u64 {
        match self {
            Bound::Available { available } => *available,
            Bound::Cgroup { limit, usage, .. }
            | Bound::AddressSpace { limit, usage }
            | Bound::Data { limit, usage } => limit.saturating_sub(*usage),
        }
    }
}

/// The process's resource limits, bytes (`None`: unlimited).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Rlimits {
    /// RLIMIT_AS.
    pub address_space: Option<u64>,
    /// RLIMIT_DATA.
    pub data: Option<u64>,
}

impl Rlimits {
    /// This process's soft limits.
    pub fn current() -> Rlimits {
        let read = |resource| {
            let mut limit = std::mem::MaybeUninit::<libc::rlimit>::uninit();
            // SAFETY: `limit` is a properly sized out-parameter, filled when the call succeeds.
            let rc = unsafe { libc::getrlimit(resource, limit.as_mut_ptr()) };
            if rc != 0 {
                return None;
            }
            // SAFETY: getrlimit succeeded, so it filled `limit`.
            let cur = unsafe { limit.assume_init() }.rlim_cur;
            (cur != libc::RLIM_INFINITY && cur < UNLIMITED).then_some(cur)
        };
        Rlimits {
            address_space: read(libc::RLIMIT_AS),
            data: read(libc::RLIMIT_DATA),
        }
    }
}

/// The tightest limit on this process's memory now, or `None` when the system says nothing.
pub fn memory() -> Option<Bound> {
    let root = std::env::var_os(ROOT_VAR).map_or_else(|| PathBuf::from("/"), PathBuf::from);
    memory_under(&root, Rlimits::current(), rayon::current_num_threads())
}

/// [`memory`] with the system files read under `root`, the given limits and `threads` worker
/// threads.
pub fn memory_under(root: &Path, rlimits: Rlimits, threads: usize) -> Option<Bound> {
    let status = std::fs::read_to_string(root.join("proc/self/status")).unwrap_or_default();
    let mut bounds = Vec::new();
    if let Some(available) = kib_field(
        &std::fs::read_to_string(root.join("proc/meminfo")).unwrap_or_default(),
        "MemAvailable:",
    ) {
        bounds.push(Bound::Available { available });
    }
    bounds.extend(cgroup(root));
    if let Some(limit) = rlimits.address_space {
        let reserved = ADDRESS_SPACE_PER_THREAD
            .saturating_mul(threads as u64)
            .saturating_add(ARENA_BYTES);
        let usage = kib_field(&status, "VmSize:")
            .unwrap_or(0)
            .saturating_add(reserved);
        bounds.push(Bound::AddressSpace { limit, usage });
    }
    if let Some(limit) = rlimits.data {
        let usage = kib_field(&status, "VmData:").unwrap_or(0);
        bounds.push(Bound::Data { limit, usage });
    }
    bounds.into_iter().min_by_key(Bound::headroom)
}

/// A `Name:   123 kB` field of /proc/meminfo or /proc/self/status, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let rest = text.lines().find_map(|l| l.strip_prefix(name))?;
    let kib = rest
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse::<u64>()
        .ok()?;
    Some(kib.saturating_mul(1024))
}

/// The tightest memory limit of the process's cgroup and its parents, read from
/// /proc/self/cgroup and the hierarchy mounted at /sys/fs/cgroup (v1's memory controller when
/// it has one, else v2's unified hierarchy).
fn cgroup(root: &Path) -> Option<Bound> {
    let table = std::fs::read_to_string(root.join("proc/self/cgroup")).ok()?;
    let mount = root.join("sys/fs/cgroup");
    // Lines are `id:controllers:path`; v2's is `0::path`.
    let entry = |v1: bool| {
        table.lines().find_map(|line| {
            let mut fields = line.splitn(3, ':');
            let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
            let found = if v1 {
                controllers.split(',').any(|c| c == "memory")
            } else {
                controllers.is_empty()
            };
            found.then(|| path.trim_start_matches('/').to_string())
        })
    };
    let (base, files) = match entry(true) {
        Some(path) => (
            (mount.join("memory"), path),
            ("memory.limit_in_bytes", "memory.usage_in_bytes"),
        ),
        None => ((mount, entry(false)?), ("memory.max", "memory.current")),
    };
    let (mount, path) = base;
    // Inside a cgroup namespace the mount is the process's own cgroup and the path may not
    // exist under it: then the mount's files are the ones that apply.
    let own = mount.join(&path);
    let start = if own.is_dir() { own } else { mount.clone() };
    let read = |file: &Path| -> Option<u64> {
        let text = std::fs::read_to_string(file).ok()?;
        text.trim().parse::<u64>().ok()
    };
    start
        .ancestors()
        .take_while(|dir| dir.starts_with(&mount))
        .filter_map(|dir| {
            let file = dir.join(files.0);
            // `max` (v2) fails to parse: no limit at that level.
            let limit = read(&file).filter(|&l| l < UNLIMITED)?;
            let usage = read(&dir.join(files.1)).unwrap_or(0);
            Some(Bound::Cgroup { file, limit, usage })
        })
        .min_by_key(Bound::headroom)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(root: &Path, path: &str, text: &str) {
        let file = root.join(path);
        std::fs::create_dir_all(file.parent().expect("parent")).expect("mkdir");
        std::fs::write(file, text).expect("write");
    }

    #[test]
    fn a_cgroup_v2_limit_binds_with_its_use_subtracted() {
        let dir = tempfile::tempdir().expect("tempdir");
        let root = dir.path();
        write(
            root,
            "proc/meminfo",
            "MemTotal: 1000000 kB\nMemAvailable: 800000 kB\n",
        );
        write(root, "proc/self/cgroup", "0::/job/step\n");
        write(root, "sys/fs/cgroup/job/memory.max", "209715200\n");
        write(root, "sys/fs/cgroup/job/memory.current", "52428800\n");
        write(root, "sys/fs/cgroup/job/step/memory.max", "max\n");
        let bound = memory_under(root, Rlimits::default(), 2).expect("a bound");
        assert_eq!(bound.headroom(), 150 << 20);
        assert!(bound.to_string().contains("job/memory.max"), "{bound}");
        // Without the limit, the machine's available memory binds.
        write(root, "sys/fs/cgroup/job/memory.max", "max\n");
        let bound = memory_under(root, Rlimits::default(), 2).expect("a bound");
        assert_eq!(
            bound,
            Bound::Available {
                available: 800_000 * 1024
            }
        );
    }

    #[test]
    fn a_cgroup_v1_limit_is_read_from_the_memory_controller() {
        let dir = tempfile::tempdir().expect("tempdir");
        let root = dir.path();
        write(
            root,
            "proc/self/cgroup",
            "5:cpu:/\n4:memory:/slurm/job7\n0::/\n",
        );
        write(
            root,
            "sys/fs/cgroup/memory/memory.limit_in_bytes",
            "9223372036854771712\n",
        );
        write(
            root,
            "sys/fs/cgroup/memory/slurm/job7/memory.limit_in_bytes",
            "2147483648\n",
        );
        write(
            root,
            "sys/fs/cgroup/memory/slurm/job7/memory.usage_in_bytes",
            "1073741824\n",
        );
        let bound = memory_under(root, Rlimits::default(), 1).expect("a bound");
        assert_eq!(bound.headroom(), 1 << 30);
    }

    #[test]
    fn resource_limits_count_what_is_already_mapped() {
        let dir = tempfile::tempdir().expect("tempdir");
        let root = dir.path();
        write(
            root,
            "proc/self/status",
            "VmSize:\t  102400 kB\nVmData:\t   10240 kB\n",
        );
        let limits = Rlimits {
            address_space: Some(1 << 30),
            data: Some(600 << 20),
        };
        // 1 GiB - 100 MiB - 2 threads x 2 MiB - 64 MiB = 856 MiB; 600 MiB - 10 MiB = 590 MiB
        // binds.
        let bound = memory_under(root, limits, 2).expect("a bound");
        assert_eq!(bound.headroom(), 590 << 20);
        let limits = Rlimits {
            data: None,
            ..limits
        };
        assert_eq!(
            memory_under(root, limits, 2).expect("a bound").headroom(),
            856 << 20
        );
        assert_eq!(memory_under(root, Rlimits::default(), 2), None);
    }
}
