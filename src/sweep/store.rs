//! The dataset folder of a sweep, written so that a process killed at any moment leaves a valid
//! dataset that `--resume` completes:
//!
//! ```text
//! DIR/sweep.toml                        the sweep text (a resume with another text is refused)
//! DIR/runs/part-FIRST-LAST.parquet      one row per run of one batch
//! DIR/series/part-FIRST-LAST.parquet    one row per checkpoint of the same runs
//! DIR/trace/part-FIRST-LAST.parquet     a traced sweep's: one row per step of the same runs
//! DIR/.lock-I-of-N                      held while shard I/N writes; names the holder's pid
//! ```
//!
//! Every file is written under a hidden temporary name, synced and renamed, so a final name
//! always holds a complete file. A batch writes its trace part (traced sweeps only) and its
//! series part first and its runs part last: the runs part is the commit. A series or trace
//! part without its runs part is a leftover of a killed process and is deleted by the next
//! process of the same shard. A sweep is traced when its `trace/` folder exists (created by
//! the first traced process), and then every committed part has its trace part. `FIRST` and `LAST` are the
//! batch's smallest and largest run index; the runs it holds are listed in its `run_index`
//! column (a resumed batch need not be contiguous).

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use arrow::array::{Array, Int64Array, RecordBatch, UInt64Array};
use parquet::arrow::ProjectionMask;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use super::shard::Shard;
use crate::output::{self, OutputError};

/// Name of the copy of the sweep text inside the dataset folder.
pub const SWEEP_FILE: &str = "sweep.toml";
/// Folder of the per-run tables.
pub const RUNS_DIR: &str = "runs";
/// Folder of the per-checkpoint tables.
pub const SERIES_DIR: &str = "series";
/// Folder of the per-step tables of a traced sweep (SPEC 14).
pub const TRACE_DIR: &str = "trace";

/// A dataset folder that cannot be used as asked.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The file system refused.
    // NOTE: the cause is a plain field, not `source`, so `{:#}` prints it once.
    #[error("cannot {action} {path}: {cause}")]
    Io {
        /// What was being done ("create", "write", "read", ...).
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// Another live process holds this shard's lock.
    #[error(
        "{dir} is being written by {holder} (lock file {lock}); wait for it to finish or stop it: \
         two processes must not write the same runs"
    )]
    Locked {
        /// The dataset folder.
        dir: PathBuf,
        /// Who holds it.
        holder: String,
        /// The lock file.
        lock: PathBuf,
    },
    /// A live process writes the folder with a different shard split.
    #[error(
        "{dir} is being written by {holder} as shard {theirs}, a different split from this \
         process's shard {ours}: every process writing one folder must use the same shard count"
    )]
    SplitConflict {
        /// The dataset folder.
        dir: PathBuf,
        /// Who holds the other lock.
        holder: String,
        /// Their shard.
        theirs: String,
        /// Ours.
        ours: Shard,
    },
    /// The folder holds a different sweep.
    #[error(
        "{dir} holds a different sweep: its sweep.toml differs from {file} (first difference at \
         line {line}); choose another --out, or run the sweep file stored there"
    )]
    DifferentSweep {
        /// The dataset folder.
        dir: PathBuf,
        /// The sweep file given.
        file: String,
        /// First line that differs.
        line: usize,
    },
    /// The folder holds something other than a sweep dataset.
    #[error(
        "{dir} is not empty and is not a sweep dataset (no sweep.toml; found '{example}'): choose \
         a new or empty folder with --out"
    )]
    NotADataset {
        /// The folder.
        dir: PathBuf,
        /// One of the unexpected entries.
        example: String,
    },
    /// Results of this shard exist and `--resume` was not given.
    #[error(
        "{dir} already holds {parts} part(s) of this sweep: pass --resume to run only what is \
         missing, or choose another --out"
    )]
    AlreadyStarted {
        /// The folder.
        dir: PathBuf,
        /// Parts found.
        parts: usize,
    },
    /// A part file that does not belong or cannot be read.
    #[error("{path}: {reason}")]
    BadPart {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        reason: String,
    },
    /// Writing a part failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A trace asked of a dataset whose committed parts were written without one.
    #[error(
        "{dir} holds {parts} part(s) written without the trace: a sweep is traced from its start \
         (every part has its trace part); resume it without --trace, or write the traced sweep \
         into another --out"
    )]
    UntracedParts {
        /// The dataset folder.
        dir: PathBuf,
        /// Committed parts found.
        parts: usize,
    },
}

impl StoreError {
    /// Whether the user asked for something that cannot be done (exit code 2), rather than the
    /// machine failing (exit code 1).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            StoreError::DifferentSweep { .. }
                | StoreError::NotADataset { .. }
                | StoreError::AlreadyStarted { .. }
                | StoreError::UntracedParts { .. }
                | StoreError::BadPart { .. }
        )
    }
}

fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> StoreError + 'a {
    move |cause| StoreError::Io {
        action,
        path: path.to_path_buf(),
        cause,
    }
}

/// The file name of the part holding runs `first..=last` of a sweep of `total` runs.
pub fn part_name(first: u64, last: u64, total: u64) -> String {
    let width = total.saturating_sub(1).to_string().len().max(6);
    format!("part-{first:0width$}-{last:0width$}.parquet")
}

/// The first run index of a part file name, for committed parts and their temporary files.
fn part_first(name: &str) -> Option<(u64, bool)> {
    let (committed, rest) = match name.strip_prefix(".part-") {
        Some(rest) => (false, rest.split_once(".parquet.tmp-")?.0),
        None => (true, name.strip_prefix("part-")?.strip_suffix(".parquet")?),
    };
    let (first, last) = rest.split_once('-')?;
    let first: u64 = first.parse().ok()?;
    last.parse::<u64>().ok()?;
    Some((first, committed))
}

/// Bytes of the committed part files in `dir` (every table) whose first run belongs to `shard`
/// of a sweep of `seeds` runs per configuration: the results a resume of that shard keeps, which
/// the size of the whole shard counts. Other shards' parts are not this shard's to count.
pub fn shard_bytes(dir: &Path, seeds: u64, shard: Shard) -> u64 {
    let mut bytes = 0;
    for sub in [RUNS_DIR, SERIES_DIR, TRACE_DIR] {
        let Ok(entries) = fs::read_dir(dir.join(sub)) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if let Some((first, true)) = part_first(&name)
                && shard.owns(first / seeds.max(1))
            {
                bytes += entry.metadata().map_or(0, |m| m.len());
            }
        }
    }
    bytes
}

/// The temporary name [`output::ParquetSink`] writes `name` under.
fn sink_tmp_name(name: &str) -> String {
    format!(".{name}.tmp-{}", std::process::id())
}

/// Syncs a folder so renames inside it survive a power loss (a kill needs no sync).
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// The host name, for lock files.
fn host_name() -> String {
    fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unknown-host".into())
}

/// The refusal of `dir`, whose lock file `path` (open as `file`) another process holds.
fn locked(dir: &Path, file: &mut File, path: PathBuf) -> StoreError {
    let mut content = String::new();
    let _ = file.read_to_string(&mut content);
    StoreError::Locked {
        dir: dir.to_path_buf(),
        holder: describe_holder(&content),
        lock: path,
    }
}

fn describe_holder(content: &str) -> String {
    let field = |k: &str| {
        content
            .split_whitespace()
            .find_map(|w| w.strip_prefix(k).and_then(|v| v.strip_prefix('=')))
            .unwrap_or("?")
            .to_string()
    };
    if content.trim().is_empty() {
        return "another process (its lock file names no pid yet)".into();
    }
    format!("pid {} on host {}", field("pid"), field("host"))
}

/// The lock of one shard of a dataset folder: an advisory `flock` on `DIR/.lock-I-of-N`, which
/// the kernel releases when the holder dies, so a lock file left by a killed process is stale.
/// The file names the holder's pid and host for messages. Removed on drop.
#[derive(Debug)]
pub struct Lock {
    file: File,
    path: PathBuf,
}

impl Lock {
    /// Takes the lock of `shard` in `dir`. Returns a warning when a stale lock of a dead
    /// process was taken over. Refuses when a live process holds the same shard, or any shard
    /// of a different split.
    pub fn acquire(dir: &Path, shard: Shard) -> Result<(Lock, Option<String>), StoreError> {
        let name = format!(".lock-{}-of-{}", shard.index, shard.count);
        let path = dir.join(&name);
        let mut attempts = 0;
        let (mut file, previous) = loop {
            attempts += 1;
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io("create lock file", &path))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(fs::TryLockError::WouldBlock) => return Err(locked(dir, &mut file, path)),
                Err(fs::TryLockError::Error(e)) => return Err(io("lock", &path)(e)),
            }
            // The previous holder may have removed the file between our open and our lock:
            // then we locked a deleted file and must start again.
            let same = match (fs::metadata(&path), file.metadata()) {
                (Ok(a), Ok(b)) => a.ino() == b.ino() && a.dev() == b.dev(),
                _ => false,
            };
            if same {
                let mut content = String::new();
                let _ = file.read_to_string(&mut content);
                break (file, content);
            }
            if attempts > 20 {
                return Err(io("lock", &path)(std::io::Error::other(
                    "the lock file keeps being replaced by another process",
                )));
            }
        };
        let warning = (!previous.trim().is_empty()).then(|| {
            format!(
                "taking over the stale lock {} of {}, which is no longer running",
                path.display(),
                describe_holder(&previous)
            )
        });
        let started = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let record = format!(
            "pid={} host={} shard={shard} started={started}\n",
            std::process::id(),
            host_name()
        );
        file.set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| file.write_all(record.as_bytes()))
            .map_err(io("write lock file", &path))?;
        let lock = Lock { file, path };
        lock.check_other_splits(dir, shard)?;
        Ok((lock, warning))
    }

    /// Refuses if a live process holds a lock of a different shard count in `dir`.
    fn check_other_splits(&self, dir: &Path, ours: Shard) -> Result<(), StoreError> {
        let entries = fs::read_dir(dir).map_err(io("list", dir))?;
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let Some(rest) = name.strip_prefix(".lock-") else {
                continue;
            };
            let Some((_, count)) = rest.split_once("-of-") else {
                continue;
            };
            if count.parse::<u32>().ok() == Some(ours.count) {
                continue;
            }
            let Ok(mut other) = OpenOptions::new().read(true).write(true).open(entry.path()) else {
                continue;
            };
            if let Err(fs::TryLockError::WouldBlock) = other.try_lock() {
                let mut content = String::new();
                let _ = other.read_to_string(&mut content);
                return Err(StoreError::SplitConflict {
                    dir: dir.to_path_buf(),
                    holder: describe_holder(&content),
                    theirs: rest.replace("-of-", "/"),
                    ours,
                });
            }
            // Stale: nobody holds it. Remove it while we hold it (see the inode check above).
            let _ = fs::remove_file(entry.path());
        }
        Ok(())
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Remove while still holding the lock; the kernel drops the lock with the file handle.
        let _ = fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

/// The `sweep.toml` of `dir`, or `None` when there is none (nor a folder to hold one).
fn sweep_text(dir: &Path) -> Result<Option<String>, StoreError> {
    let sweep = dir.join(SWEEP_FILE);
    match fs::read_to_string(&sweep) {
        Ok(existing) => Ok(Some(existing)),
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory
            ) =>
        {
            Ok(None)
        }
        Err(e) => Err(io("read", &sweep)(e)),
    }
}

/// Refuses `dir` when it holds another sweep than `text` (its `sweep.toml` differs), reading
/// only: what [`check_folder`] says of a dataset, for a dry run that must change nothing.
pub fn same_sweep(dir: &Path, text: &str, file: &str) -> Result<(), StoreError> {
    match sweep_text(dir)? {
        Some(existing) => compare_text(dir, &existing, text, file),
        None => Ok(()),
    }
}

/// Creates `dir` if needed and checks that it is empty or a dataset of this sweep text.
pub fn check_folder(dir: &Path, text: &str, file: &str) -> Result<(), StoreError> {
    fs::create_dir_all(dir).map_err(io("create output folder", dir))?;
    if let Some(existing) = sweep_text(dir)? {
        return compare_text(dir, &existing, text, file);
    }
    // No sweep.toml: accept only what a process killed during start-up leaves behind.
    for entry in fs::read_dir(dir).map_err(io("list", dir))?.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let harmless = name.starts_with(".lock-")
            || name.starts_with(".sweep.toml.tmp-")
            || ((name == RUNS_DIR || name == SERIES_DIR || name == TRACE_DIR)
                && fs::read_dir(entry.path())
                    .map(|mut d| d.next().is_none())
                    .unwrap_or(false));
        if !harmless {
            return Err(StoreError::NotADataset {
                dir: dir.to_path_buf(),
                example: name,
            });
        }
    }
    Ok(())
}

fn compare_text(dir: &Path, existing: &str, text: &str, file: &str) -> Result<(), StoreError> {
    if existing == text {
        return Ok(());
    }
    let line = existing
        .lines()
        .zip(text.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| existing.lines().count().min(text.lines().count()))
        + 1;
    Err(StoreError::DifferentSweep {
        dir: dir.to_path_buf(),
        file: file.to_string(),
        line,
    })
}

/// Stores the sweep text as `DIR/sweep.toml` (atomically: written aside, then linked into place
/// only if absent) and creates `runs/` and `series/`. Call while holding the lock.
pub fn init_folder(dir: &Path, text: &str, file: &str) -> Result<(), StoreError> {
    let sweep = dir.join(SWEEP_FILE);
    if !sweep.exists() {
        let tmp = dir.join(format!(".sweep.toml.tmp-{}", std::process::id()));
        let written = File::create(&tmp)
            .and_then(|mut f| f.write_all(text.as_bytes()).and_then(|()| f.sync_all()));
        if let Err(e) = written {
            let _ = fs::remove_file(&tmp);
            return Err(io("write", &sweep)(e));
        }
        // hard_link fails if another shard stored it first; then compare below. File systems
        // without hard links get a plain rename (same text from every shard anyway).
        let linked = match fs::hard_link(&tmp, &sweep) {
            Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => fs::rename(&tmp, &sweep),
            other => other,
        };
        let _ = fs::remove_file(&tmp);
        match linked {
            Ok(()) => sync_dir(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            // Another shard stored it and cleared our copy as a leftover (see below).
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && sweep.exists() => {}
            Err(e) => return Err(io("write", &sweep)(e)),
        }
    }
    let existing = fs::read_to_string(&sweep).map_err(io("read", &sweep))?;
    compare_text(dir, &existing, text, file)?;
    // Copies of the text that processes killed during start-up left are of no use now. A live
    // process of another host whose copy goes too finds sweep.toml stored (see above).
    crate::whole_file::remove_dead_leftovers(dir, ".sweep.toml.tmp-");
    for sub in [RUNS_DIR, SERIES_DIR] {
        let path = dir.join(sub);
        fs::create_dir_all(&path).map_err(io("create", &path))?;
    }
    Ok(())
}

/// A fixed-size set of run indices.
#[derive(Debug, Clone)]
pub struct RunSet {
    words: Vec<u64>,
    len: u64,
}

impl RunSet {
    /// An empty set of runs `0..total`.
    pub fn new(total: u64) -> RunSet {
        RunSet {
            words: vec![0; total.div_ceil(64) as usize],
            len: 0,
        }
    }

    /// Whether `run` is in the set.
    pub fn contains(&self, run: u64) -> bool {
        self.words[(run / 64) as usize] & (1u64 << (run % 64)) != 0
    }

    /// Adds `run`; false if it was already there.
    pub fn insert(&mut self, run: u64) -> bool {
        let word = &mut self.words[(run / 64) as usize];
        let bit: u64 = 1 << (run % 64);
        let fresh = *word & bit == 0;
        *word |= bit;
        // NOTE: not `self.len += u64::from(fresh)`: rustc 1.95.0 at opt-level 2 drops the
        // comparison that defines `fresh` when a caller branches on the result, and adds garbage.
        if fresh {
            self.len += 1;
        }
        fresh
    }

    /// Number of runs in the set.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// What a dataset folder holds.
#[derive(Debug)]
pub struct Scan {
    /// Runs whose results are committed.
    pub done: RunSet,
    /// Committed parts (all shards).
    pub parts: usize,
    /// Committed parts whose first run belongs to this shard.
    pub own_parts: usize,
    /// Leftovers of killed processes of this shard: temporary files and uncommitted series
    /// parts, to delete before writing.
    pub leftovers: Vec<PathBuf>,
    /// Files that are not parts (copies such as `part-… (1).parquet`, files put there by
    /// hand): never counted, never deleted.
    pub strays: Vec<PathBuf>,
}

/// The files of `runs/`, `series/` and `trace/` (named `runs`, `series` and `trace`, listed in
/// `dir`) that are neither parts nor a writer's temporary files.
fn strays(dir: &Path, runs: &[String], series: &[String], trace: &[String]) -> Vec<PathBuf> {
    [(RUNS_DIR, runs), (SERIES_DIR, series), (TRACE_DIR, trace)]
        .into_iter()
        .flat_map(|(sub, names)| {
            names
                .iter()
                .filter(|n| !n.starts_with('.') && part_first(n).is_none())
                .map(move |n| dir.join(sub).join(n))
        })
        .collect()
}

/// The warning for a stray file of a dataset (see [`Scan::strays`]), the same for every verb.
pub fn stray_warning(file: &Path) -> String {
    format!(
        "ignoring {}: not a part the sweep committed (its parts are named \
         part-FIRST-LAST.parquet); it is not counted",
        file.display()
    )
}

/// The committed part among `names` (in `runs_dir`) that holds `run`, for messages.
fn holder_of(runs_dir: &Path, names: &[String], run: u64) -> Option<PathBuf> {
    names
        .iter()
        .filter(|n| matches!(part_first(n), Some((_, true))))
        .map(|n| runs_dir.join(n))
        .find(|path| read_runs_part(path).is_ok_and(|(runs, _)| runs.contains(&run)))
}

fn list(dir: &Path) -> Result<Vec<String>, StoreError> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .map_err(io("list", dir))?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    Ok(names)
}

/// Reads the `run_index` column and the mbmf version of a runs part.
fn read_runs_part(path: &Path) -> Result<(Vec<u64>, Option<String>), String> {
    let file = File::open(path).map_err(|e| e.to_string())?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| e.to_string())?;
    let version = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .and_then(|kv| kv.iter().find(|k| k.key == "mbmf_version"))
        .and_then(|k| k.value.clone());
    let column = builder
        .parquet_schema()
        .columns()
        .iter()
        .position(|c| c.name() == "run_index")
        .ok_or("no run_index column")?;
    let mask = ProjectionMask::leaves(builder.parquet_schema(), [column]);
    let reader = builder
        .with_projection(mask)
        .build()
        .map_err(|e| e.to_string())?;
    let mut runs = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|e| e.to_string())?;
        // Int64 since schema runs/2; UInt64 before. Both are read, so the check of an older
        // part can name its version instead of failing on the type.
        let col = batch.column(0).as_any();
        if let Some(col) = col.downcast_ref::<Int64Array>() {
            runs.extend(col.iter().flatten().filter_map(|r| u64::try_from(r).ok()));
        } else if let Some(col) = col.downcast_ref::<UInt64Array>() {
            runs.extend(col.iter().flatten());
        } else {
            return Err("run_index is not a 64-bit integer column".into());
        }
    }
    Ok((runs, version))
}

/// Lists the committed runs of `dir` (a sweep of `total` runs), and the leftovers that `owned`
/// (a part's first run belongs to this shard) says this process may delete.
pub fn scan(dir: &Path, total: u64, owned: &dyn Fn(u64) -> bool) -> Result<Scan, StoreError> {
    let runs_dir = dir.join(RUNS_DIR);
    let series_dir = dir.join(SERIES_DIR);
    let mut done = RunSet::new(total);
    let mut scan_parts = 0;
    let mut own_parts = 0;
    let mut leftovers = Vec::new();
    let runs_names = if runs_dir.exists() {
        list(&runs_dir)?
    } else {
        Vec::new()
    };
    let series_names = if series_dir.exists() {
        list(&series_dir)?
    } else {
        Vec::new()
    };
    let trace_dir = dir.join(TRACE_DIR);
    let traced = trace_dir.is_dir();
    let trace_names = if traced {
        list(&trace_dir)?
    } else {
        Vec::new()
    };
    let version = env!("CARGO_PKG_VERSION");
    for (i, name) in runs_names.iter().enumerate() {
        let Some((first, committed)) = part_first(name) else {
            continue;
        };
        let path = runs_dir.join(name);
        if !committed {
            if owned(first) {
                leftovers.push(path);
            }
            continue;
        }
        if !series_names.contains(name) {
            return Err(StoreError::BadPart {
                path,
                reason: format!(
                    "has no matching {SERIES_DIR}/{name} (was it deleted?): delete this runs part \
                     too, then resume to run its runs again"
                ),
            });
        }
        let (runs, part_version) = read_runs_part(&path).map_err(|e| StoreError::BadPart {
            path: path.clone(),
            reason: format!("cannot be read ({e}): delete it and its series part, then resume"),
        })?;
        if part_version.as_deref() != Some(version) {
            return Err(StoreError::BadPart {
                path,
                reason: format!(
                    "was written by mbmf {}, this is mbmf {version}: finish the sweep with that \
                     version or start a new --out",
                    part_version.as_deref().unwrap_or("(unknown)")
                ),
            });
        }
        for run in runs {
            if run >= total {
                return Err(StoreError::BadPart {
                    path,
                    reason: format!(
                        "holds run {run}, but this sweep has {total} runs: not a part of this sweep"
                    ),
                });
            }
            if !done.insert(run) {
                // Found again only on this error path, so a scan holds no run-to-part map.
                let other = holder_of(&runs_dir, &runs_names[..i], run)
                    .map_or_else(|| "another part".to_owned(), |p| p.display().to_string());
                return Err(StoreError::BadPart {
                    path,
                    reason: format!(
                        "holds run {run}, which {other} holds too (a copy under another part \
                         name?): delete one of the two parts (with its series part) and resume"
                    ),
                });
            }
        }
        let series_path = series_dir.join(name);
        let readable = |path: &Path| {
            File::open(path)
                .map_err(|e| e.to_string())
                .and_then(|f| {
                    ParquetRecordBatchReaderBuilder::try_new(f).map_err(|e| e.to_string())
                })
                .map(|_| ())
        };
        if let Err(e) = readable(&series_path) {
            return Err(StoreError::BadPart {
                path: series_path,
                reason: format!("cannot be read ({e}): delete it and its runs part, then resume"),
            });
        }
        if traced {
            let trace_path = trace_dir.join(name);
            if !trace_names.contains(name) {
                return Err(StoreError::BadPart {
                    path,
                    reason: format!(
                        "has no matching {TRACE_DIR}/{name} in this traced sweep (was it \
                         deleted?): delete this runs part and its series part too, then resume \
                         to run its runs again"
                    ),
                });
            }
            if let Err(e) = readable(&trace_path) {
                return Err(StoreError::BadPart {
                    path: trace_path,
                    reason: format!(
                        "cannot be read ({e}): delete it and its runs and series parts, then \
                         resume"
                    ),
                });
            }
        }
        scan_parts += 1;
        // NOTE: `+= usize::from(bool)` is avoided: rustc 1.95 miscompiles it at opt-level 2 when
        // the bool is also branched on (see RunSet::insert).
        if owned(first) {
            own_parts += 1;
        }
    }
    for (sub, names) in [(&series_dir, &series_names), (&trace_dir, &trace_names)] {
        for name in names {
            let Some((first, committed)) = part_first(name) else {
                continue;
            };
            let uncommitted = !committed || !runs_names.contains(name);
            if uncommitted && owned(first) {
                leftovers.push(sub.join(name));
            }
        }
    }
    Ok(Scan {
        done,
        parts: scan_parts,
        own_parts,
        leftovers,
        strays: strays(dir, &runs_names, &series_names, &trace_names),
    })
}

/// Deletes leftovers found by [`scan`].
pub fn remove_leftovers(leftovers: &[PathBuf]) -> Result<(), StoreError> {
    for path in leftovers {
        match fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io("remove", path)(e)),
        }
    }
    Ok(())
}

/// Writes one batch as the part `name`: the trace (when given) and the series first, runs last
/// (the commit), each atomically, with `metadata` (its `mbmf_schema` set per table). On failure
/// nothing of the part is left behind.
pub fn write_part(
    dir: &Path,
    name: &str,
    runs: &RecordBatch,
    series: &RecordBatch,
    trace: Option<&RecordBatch>,
    metadata: &[(String, String)],
) -> Result<(), StoreError> {
    let series_dir = dir.join(SERIES_DIR);
    let runs_dir = dir.join(RUNS_DIR);
    let trace_dir = dir.join(TRACE_DIR);
    let series_path = series_dir.join(name);
    let runs_path = runs_dir.join(name);
    let trace_path = trace_dir.join(name);
    // NOTE: a sink whose finish fails keeps its temporary file; remove it here.
    let series_meta = output::with_schema(metadata, output::provenance::SERIES_SCHEMA);
    let runs_meta = output::with_schema(metadata, output::provenance::RUNS_SCHEMA);
    if let Some(trace) = trace {
        let trace_meta = output::with_schema(metadata, output::provenance::TRACE_SCHEMA);
        if let Err(e) = output::write_parquet(&trace_path, trace, trace_meta) {
            let _ = fs::remove_file(trace_dir.join(sink_tmp_name(name)));
            return Err(e.into());
        }
        sync_dir(&trace_dir);
    }
    let remove_trace = || {
        if trace.is_some() {
            let _ = fs::remove_file(&trace_path);
        }
    };
    if let Err(e) = output::write_parquet(&series_path, series, series_meta) {
        let _ = fs::remove_file(series_dir.join(sink_tmp_name(name)));
        remove_trace();
        return Err(e.into());
    }
    sync_dir(&series_dir);
    if let Err(e) = output::write_parquet(&runs_path, runs, runs_meta) {
        let _ = fs::remove_file(runs_dir.join(sink_tmp_name(name)));
        let _ = fs::remove_file(&series_path);
        remove_trace();
        return Err(e.into());
    }
    sync_dir(&runs_dir);
    Ok(())
}

/// What [`compact`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Compacted {
    /// Runs in the dataset.
    pub runs: u64,
    /// Part files before (per table).
    pub parts_before: usize,
    /// Part files after (per table).
    pub parts_after: usize,
    /// Files of `runs/` and `series/` that are not parts: left out of the merge and kept as
    /// they are.
    pub strays: Vec<PathBuf>,
}

/// Why a dataset cannot be compacted (besides the errors of [`StoreError`]).
fn refuse(dir: &Path, reason: String) -> StoreError {
    StoreError::BadPart {
        path: dir.to_path_buf(),
        reason,
    }
}

/// The text parameters of a part's first row: parts are merged only with parts of the same
/// values, so a compacted file still holds one value of each and filters still skip files.
fn part_group(batch: &RecordBatch) -> Vec<String> {
    use arrow::util::display::array_value_to_string;
    [
        "task",
        "controller",
        "selection",
        "cost_model",
        "interaction",
        "profile",
    ]
    .iter()
    .map(|name| {
        batch
            .column_by_name(name)
            .filter(|c| !c.is_empty())
            .and_then(|c| array_value_to_string(c, 0).ok())
            .unwrap_or_default()
    })
    .collect()
}

/// A part's record batches and its key-value metadata.
type PartContents = (Vec<RecordBatch>, Vec<(String, String)>);

fn read_all(path: &Path) -> Result<PartContents, StoreError> {
    let bad = |e: String| StoreError::BadPart {
        path: path.to_path_buf(),
        reason: format!("cannot be read ({e})"),
    };
    let file = File::open(path).map_err(io("read", path))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| bad(e.to_string()))?;
    let kv = pairs(builder.metadata().file_metadata());
    let reader = builder.build().map_err(|e| bad(e.to_string()))?;
    let batches = reader
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(e.to_string()))?;
    Ok((batches, kv))
}

/// Swaps two folders atomically (Linux `renameat2(RENAME_EXCHANGE)`). Where the file system
/// cannot, `b` is moved aside and `a` into its place: readers then briefly find no folder,
/// never a mix of old and new files.
fn exchange(a: &Path, b: &Path, aside: &Path) -> std::io::Result<()> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    use rustix::io::Errno;
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        // `a` now holds the old contents of `b`.
        Ok(()) => fs::rename(a, aside),
        Err(Errno::INVAL | Errno::NOSYS | Errno::XDEV) => {
            fs::rename(b, aside)?;
            fs::rename(a, b)
        }
        Err(e) => Err(e.into()),
    }
}

/// Merges the parts of a finished sweep dataset into files of about `target_runs` runs each,
/// keeping the `part-FIRST-LAST` names (so every reader of parts reads them unchanged) and
/// merging only parts that hold the same text parameters. The dataset is rebuilt in a sibling
/// folder and swapped in at once, so a reader or a kill sees the old or the new dataset, never
/// a mix; a `--resume` afterwards finds it complete. Refuses a dataset that a live process is
/// writing or that misses runs. `command` is recorded in the merged files (`mbmf_compacted_by`).
pub fn compact(dir: &Path, target_runs: u64, command: &str) -> Result<Compacted, StoreError> {
    match fs::metadata(dir.join(SWEEP_FILE)) {
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(refuse(
                dir,
                format!(
                    "is not a sweep dataset (no {SWEEP_FILE}): mbmf compact takes the --out folder of mbmf sweep"
                ),
            ));
        }
        Err(e) => return Err(io("read", &dir.join(SWEEP_FILE))(e)),
    }
    // Any live writer, of any split, refuses; our own lock keeps new writers out meanwhile.
    for name in list(dir)? {
        if !name.starts_with(".lock-") {
            continue;
        }
        let path = dir.join(&name);
        if let Ok(mut f) = OpenOptions::new().read(true).write(true).open(&path)
            && let Err(fs::TryLockError::WouldBlock) = f.try_lock()
        {
            return Err(locked(dir, &mut f, path));
        }
    }
    let (lock, _) = Lock::acquire(dir, Shard::ALL)?;
    let runs_dir = dir.join(RUNS_DIR);
    let series_dir = dir.join(SERIES_DIR);
    let trace_dir = dir.join(TRACE_DIR);
    let traced = trace_dir.is_dir();
    let names: Vec<String> = list(&runs_dir)?
        .into_iter()
        .filter(|n| matches!(part_first(n), Some((_, true))))
        .collect();
    let Some(first_name) = names.first() else {
        return Err(refuse(dir, "holds no runs: nothing to compact".into()));
    };
    let (_, kv) = read_all(&runs_dir.join(first_name))?;
    let total: u64 = kv
        .iter()
        .find(|(k, _)| k == "mbmf_sweep_runs")
        .and_then(|(_, v)| v.parse().ok())
        .ok_or_else(|| {
            refuse(
                &runs_dir.join(first_name),
                "names no sweep size (mbmf_sweep_runs): not written by mbmf sweep".into(),
            )
        })?;
    let scan = scan(dir, total, &|_| true)?;
    if scan.done.len() < total || !scan.leftovers.is_empty() {
        return Err(refuse(
            dir,
            format!(
                "is incomplete: {} of {total} runs are written{}; finish it with mbmf sweep \
                 {} --out {} --resume, then compact",
                scan.done.len(),
                if scan.leftovers.is_empty() {
                    String::new()
                } else {
                    format!(" and {} unfinished file(s) remain", scan.leftovers.len())
                },
                // The dataset's own copy of the sweep file, which --resume accepts.
                dir.join(SWEEP_FILE).display(),
                dir.display()
            ),
        ));
    }

    // Group the parts (in run order within a group), then cut each group every target_runs.
    let mut groups: std::collections::BTreeMap<Vec<String>, Vec<(String, u64)>> =
        Default::default();
    for name in &names {
        let (batches, _) = read_all(&runs_dir.join(name))?;
        let key = batches.first().map(part_group).unwrap_or_default();
        let rows = batches.iter().map(|b| b.num_rows() as u64).sum();
        groups.entry(key).or_default().push((name.clone(), rows));
    }
    // Cut each group every target_runs (a part larger than that stays whole).
    let target = target_runs.max(1);
    let mut chunks: Vec<Vec<&(String, u64)>> = Vec::new();
    for parts in groups.values() {
        let mut chunk: Vec<&(String, u64)> = Vec::new();
        let mut runs_in_chunk = 0u64;
        for part in parts {
            if !chunk.is_empty() && runs_in_chunk + part.1 > target {
                chunks.push(std::mem::take(&mut chunk));
                runs_in_chunk = 0;
            }
            runs_in_chunk += part.1;
            chunk.push(part);
        }
        if !chunk.is_empty() {
            chunks.push(chunk);
        }
    }
    // Nothing to merge: the dataset stays as it is (not rewritten, its provenance untouched).
    if chunks.iter().all(|c| c.len() == 1) {
        return Ok(Compacted {
            runs: total,
            parts_before: names.len(),
            parts_after: names.len(),
            strays: scan.strays,
        });
    }
    let parent = dir
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let base = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "dataset".into());
    let staging = parent.join(format!(".{base}.compact-{}", std::process::id()));
    let aside = parent.join(format!(".{base}.pre-compact-{}", std::process::id()));
    let _ = fs::remove_dir_all(&staging);
    let result = (|| {
        let subs: &[&str] = if traced {
            &[RUNS_DIR, SERIES_DIR, TRACE_DIR]
        } else {
            &[RUNS_DIR, SERIES_DIR]
        };
        for sub in subs {
            fs::create_dir_all(staging.join(sub)).map_err(io("create", &staging.join(sub)))?;
        }
        fs::copy(dir.join(SWEEP_FILE), staging.join(SWEEP_FILE))
            .map_err(io("write", &staging.join(SWEEP_FILE)))?;
        // Not ours to delete: strays move over with the dataset, unmerged.
        for stray in &scan.strays {
            let to = staging.join(stray.strip_prefix(dir).unwrap_or(stray));
            fs::copy(stray, &to).map_err(io("write", &to))?;
        }
        let trace = traced.then_some(trace_dir.as_path());
        for chunk in &chunks {
            write_merged(
                (&runs_dir, &series_dir, trace),
                &staging,
                chunk,
                total,
                command,
            )?;
        }
        let parts_after = chunks.len();
        // The copy must hold every run exactly once before it replaces the original.
        let check = self::scan(&staging, total, &|_| true)?;
        if check.done.len() != total || !check.leftovers.is_empty() {
            // The copy's fault, not the input's: a runtime failure (exit 1).
            return Err(StoreError::Io {
                action: "verify",
                path: staging.clone(),
                cause: std::io::Error::other(format!(
                    "the merged copy holds {} of {total} runs; the dataset was left as it was",
                    check.done.len()
                )),
            });
        }
        for sub in subs {
            sync_dir(&staging.join(sub));
        }
        Ok(parts_after)
    })();
    let parts_after = match result {
        Ok(n) => n,
        Err(e) => {
            let _ = fs::remove_dir_all(&staging);
            return Err(e);
        }
    };
    // Kept until the swap: no writer can start while the old folder is locked.
    drop(lock);
    exchange(&staging, dir, &aside).map_err(|e| {
        let _ = fs::remove_dir_all(&staging);
        io("replace", dir)(e)
    })?;
    sync_dir(parent);
    let _ = fs::remove_dir_all(&aside);
    let _ = fs::remove_dir_all(&staging);
    Ok(Compacted {
        runs: total,
        parts_before: names.len(),
        parts_after,
        strays: scan.strays,
    })
}

/// Writes the parts of `chunk` (runs, series and, for a traced sweep, trace) as one part of
/// `staging`.
fn write_merged(
    (runs_dir, series_dir, trace_dir): (&Path, &Path, Option<&Path>),
    staging: &Path,
    chunk: &[&(String, u64)],
    total: u64,
    command: &str,
) -> Result<(), StoreError> {
    let first = chunk
        .iter()
        .filter_map(|p| part_first(&p.0))
        .map(|f| f.0)
        .min()
        .unwrap_or(0);
    let mut last = first;
    for (part, _) in chunk {
        let path = runs_dir.join(part);
        let (runs, _) = read_runs_part(&path).map_err(|e| StoreError::BadPart {
            path: path.clone(),
            reason: format!("cannot be read ({e})"),
        })?;
        last = runs.into_iter().fold(last, u64::max);
    }
    let name = part_name(first, last, total);
    // Trace and series first, runs last, as a sweep commits a part.
    let tables = trace_dir
        .map(|t| (t, TRACE_DIR))
        .into_iter()
        .chain([(series_dir, SERIES_DIR), (runs_dir, RUNS_DIR)]);
    if let [(part, _)] = chunk {
        // A part merged with nothing is kept as it is, provenance and all.
        for (from, sub) in tables {
            let to = staging.join(sub).join(&name);
            fs::copy(from.join(part), &to).map_err(io("write", &to))?;
        }
        return Ok(());
    }
    for (from, sub) in tables {
        let mut sink: Option<output::ParquetSink> = None;
        for (part, _) in chunk {
            let (batches, _) = read_all(&from.join(part))?;
            for b in &batches {
                let sink = match &mut sink {
                    Some(s) => s,
                    None => {
                        let kv = merged_provenance(chunk, from, command)?;
                        sink.insert(output::ParquetSink::new(&staging.join(sub).join(&name), kv))
                    }
                };
                sink.write(b)?;
            }
        }
        if let Some(s) = sink {
            s.finish()?;
        }
    }
    Ok(())
}

/// Metadata key of a merged file: per part merged into it, what of its provenance differs from
/// the first part's (a JSON array of objects, each with the part's name under `part`).
pub const MERGED_PARTS_KEY: &str = "mbmf_merged_parts";
/// Metadata key of a merged file: the command that merged it.
pub const COMPACTED_BY_KEY: &str = "mbmf_compacted_by";
/// Metadata key of a merged file: when it was merged.
pub const COMPACTED_UTC_KEY: &str = "mbmf_compacted_utc";
/// The value of a provenance key on which a merged file's parts disagree.
pub const DIFFERS: &str = "(differs between the merged parts: see mbmf_merged_parts)";

/// The provenance of a file merging `chunk`'s parts of the table in `from`: the keys on which
/// the parts agree as they are; a key on which they disagree (another shard's command, host,
/// build) as [`DIFFERS`], or for the start time the earliest; the compaction's own keys; and
/// [`MERGED_PARTS_KEY`] with, per part, its name, end time and values of the keys that differ
/// (a part merged before nests its own records), so merging never hides which build wrote which
/// runs.
fn merged_provenance(
    chunk: &[&(String, u64)],
    from: &Path,
    command: &str,
) -> Result<Vec<(String, String)>, StoreError> {
    // A merged file's own compaction keys and end time are replaced, not merged.
    let own = [
        output::provenance::ENDED_KEY,
        MERGED_PARTS_KEY,
        COMPACTED_BY_KEY,
        COMPACTED_UTC_KEY,
    ];
    let mut all = Vec::with_capacity(chunk.len());
    for (part, _) in chunk {
        let kv: Vec<(String, String)> = key_values(&from.join(part))?
            .into_iter()
            .filter(|(k, _)| k != "ARROW:schema")
            .collect();
        all.push((part, kv));
    }
    let value = |kv: &[(String, String)], key: &str| {
        kv.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
    };
    // Every key of any part, in the first part's order, then the others'.
    let mut keys: Vec<String> = Vec::new();
    for (_, kv) in &all {
        for (k, _) in kv {
            if !own.contains(&k.as_str()) && !keys.contains(k) {
                keys.push(k.clone());
            }
        }
    }
    let differs = |key: &str| {
        let first = value(&all[0].1, key);
        all.iter().any(|(_, kv)| value(kv, key) != first)
    };
    let differing: Vec<&String> = keys.iter().filter(|k| differs(k)).collect();
    let mut kv: Vec<(String, String)> = Vec::new();
    for key in &keys {
        let merged = if !differing.contains(&key) {
            value(&all[0].1, key)
        } else if key == output::provenance::STARTED_KEY {
            all.iter().filter_map(|(_, kv)| value(kv, key)).min()
        } else {
            Some(DIFFERS.to_string())
        };
        if let Some(v) = merged {
            kv.push((key.clone(), v));
        }
    }
    let mut parts = Vec::with_capacity(all.len());
    for (part, part_kv) in &all {
        let mut record = serde_json::Map::new();
        record.insert("part".into(), part.to_string().into());
        for key in differing
            .iter()
            .map(|k| k.as_str())
            .chain([output::provenance::ENDED_KEY])
        {
            if let Some(v) = value(part_kv, key) {
                record.insert(key.to_string(), v.into());
            }
        }
        if let Some(v) = value(part_kv, MERGED_PARTS_KEY) {
            let nested = serde_json::from_str(&v).unwrap_or_else(|_| v.into());
            record.insert(MERGED_PARTS_KEY.to_string(), nested);
        }
        parts.push(serde_json::Value::Object(record));
    }
    kv.push((COMPACTED_BY_KEY.into(), command.to_string()));
    kv.push((
        COMPACTED_UTC_KEY.into(),
        output::provenance::utc(std::time::SystemTime::now()),
    ));
    kv.push((
        MERGED_PARTS_KEY.into(),
        serde_json::Value::Array(parts).to_string(),
    ));
    Ok(kv)
}

/// The key-value metadata of a Parquet file, read from its footer alone.
fn key_values(path: &Path) -> Result<Vec<(String, String)>, StoreError> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let file = File::open(path).map_err(io("read", path))?;
    let reader = SerializedFileReader::new(file).map_err(|e| StoreError::BadPart {
        path: path.to_path_buf(),
        reason: format!("cannot be read ({e})"),
    })?;
    Ok(pairs(reader.metadata().file_metadata()))
}

/// A file's key-value metadata as (key, value) pairs (a key without value: empty).
fn pairs(metadata: &parquet::file::metadata::FileMetaData) -> Vec<(String, String)> {
    metadata
        .key_value_metadata()
        .map(|kv| {
            kv.iter()
                .map(|k| (k.key.clone(), k.value.clone().unwrap_or_default()))
                .collect()
        })
        .unwrap_or_default()
}

/// What a reader finds committed in a sweep dataset folder, found without locking, writing or
/// deleting anything (see [`committed`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Committed {
    /// The committed parts, in name order: each name is a runs part and its series part (and,
    /// in a traced sweep, its trace part).
    pub parts: Vec<String>,
    /// The sweep is traced (SPEC 14): every committed part has its `trace/` part.
    pub traced: bool,
    /// Files of `runs/` and `series/` that are neither committed parts nor a writer's own
    /// temporary files or uncommitted series parts: copies (`part-… (1).parquet`), files put
    /// there by hand. No reader should count them.
    pub strays: Vec<PathBuf>,
    /// Runs of the whole sweep, as its parts record (`mbmf_sweep_runs`); `None` before the first
    /// part is committed.
    pub total: Option<u64>,
    /// Distinct runs in the committed parts.
    pub done: u64,
    /// The live writers of the folder, described for messages (pid, host, lock file).
    pub writers: Vec<String>,
}

impl Committed {
    /// Whether every run of the sweep is committed and no process is still writing.
    pub fn is_complete(&self) -> bool {
        self.writers.is_empty() && self.total.is_some_and(|t| self.done == t)
    }
}

/// The values of `keys` in a Parquet file's key-value metadata, read from its footer only.
fn footer_values<const N: usize>(
    path: &Path,
    keys: [&str; N],
) -> Result<[Option<String>; N], String> {
    let file = File::open(path).map_err(|e| e.to_string())?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| e.to_string())?;
    let kv = builder.metadata().file_metadata().key_value_metadata();
    Ok(keys.map(|key| {
        kv.and_then(|kv| kv.iter().find(|k| k.key == key))
            .and_then(|k| k.value.clone())
    }))
}

/// Lists what the sweep dataset `dir` has committed, the way [`scan`] counts it for `--resume`
/// (a part counts once its runs part and its series part both exist under their final names),
/// and checks that the parts form one dataset: every part records the same sweep (the digest of
/// `DIR/sweep.toml`) and size, and no run is held twice or lies outside the sweep. Unlike
/// [`scan`], parts of another mbmf version are accepted (an old dataset stays readable), and a
/// live writer is reported rather than refused. Lock files are probed with a shared lock held
/// only for the probe.
pub fn committed(dir: &Path) -> Result<Committed, StoreError> {
    let sweep_file = dir.join(SWEEP_FILE);
    let text = fs::read(&sweep_file).map_err(io("read", &sweep_file))?;
    let digest = output::provenance::sha256_hex(&text);
    let mut writers = Vec::new();
    for name in list(dir)? {
        if !name.starts_with(".lock-") {
            continue;
        }
        let path = dir.join(&name);
        let Ok(mut f) = File::open(&path) else {
            continue;
        };
        if let Err(fs::TryLockError::WouldBlock) = f.try_lock_shared() {
            let mut content = String::new();
            let _ = f.read_to_string(&mut content);
            writers.push(format!(
                "{} (lock file {})",
                describe_holder(&content),
                path.display()
            ));
        }
    }
    let names_in = |sub: &str| -> Result<Vec<String>, StoreError> {
        let path = dir.join(sub);
        if path.is_dir() {
            list(&path)
        } else {
            Ok(Vec::new())
        }
    };
    let runs_names = names_in(RUNS_DIR)?;
    let series_names = names_in(SERIES_DIR)?;
    let trace_names = names_in(TRACE_DIR)?;
    let traced = dir.join(TRACE_DIR).is_dir();
    let strays = strays(dir, &runs_names, &series_names, &trace_names);
    let mut parts = Vec::new();
    let mut total: Option<u64> = None;
    let mut holder: Vec<(u64, usize)> = Vec::new();
    for name in &runs_names {
        if !matches!(part_first(name), Some((_, true))) {
            continue;
        }
        let path = dir.join(RUNS_DIR).join(name);
        if !series_names.contains(name) {
            return Err(StoreError::BadPart {
                path,
                reason: format!(
                    "has no matching {SERIES_DIR}/{name} (was it deleted?): its runs cannot be \
                     read as one dataset with their series"
                ),
            });
        }
        if traced && !trace_names.contains(name) {
            return Err(StoreError::BadPart {
                path,
                reason: format!(
                    "has no matching {TRACE_DIR}/{name} in this traced sweep (was it deleted?): \
                     its runs cannot be read as one dataset with their trace"
                ),
            });
        }
        let bad = |reason: String| StoreError::BadPart {
            path: path.clone(),
            reason,
        };
        let unreadable = |e: String| bad(format!("cannot be read ({e})"));
        let [size, sha] =
            footer_values(&path, ["mbmf_sweep_runs", "mbmf_sweep_sha256"]).map_err(unreadable)?;
        let Some(size) = size.and_then(|s| s.parse::<u64>().ok()) else {
            return Err(bad(format!(
                "names no sweep size (mbmf_sweep_runs): not a part written by mbmf sweep; move \
                 it out of {}",
                dir.join(RUNS_DIR).display()
            )));
        };
        if sha.as_deref() != Some(digest.as_str()) {
            let what = match sha {
                Some(_) => "belongs to another sweep: its sweep digest (mbmf_sweep_sha256) is not",
                None => "records no sweep digest (mbmf_sweep_sha256), so it cannot be shown to be",
            };
            return Err(bad(format!(
                "{what} that of {}; move it out of {}",
                sweep_file.display(),
                dir.join(RUNS_DIR).display()
            )));
        }
        match total {
            Some(t) if t != size => {
                return Err(bad(format!(
                    "records a sweep of {size} runs, the earlier parts {t}: not one dataset"
                )));
            }
            _ => total = Some(size),
        }
        let (runs, _) = read_runs_part(&path).map_err(unreadable)?;
        for run in runs {
            if run >= size {
                return Err(bad(format!(
                    "holds run {run}, but this sweep has {size} runs: not a part of this sweep"
                )));
            }
            holder.push((run, parts.len()));
        }
        parts.push(name.clone());
    }
    holder.sort_unstable();
    for pair in holder.windows(2) {
        if pair[0].0 == pair[1].0 {
            let (run, a, b) = (pair[0].0, &parts[pair[0].1], &parts[pair[1].1]);
            return Err(StoreError::BadPart {
                path: dir.join(RUNS_DIR).join(b),
                reason: format!(
                    "holds run {run}, which {} holds too (a copy under another part name?): the \
                     same run would be counted twice; delete one of the two parts (with its \
                     series part) and resume",
                    dir.join(RUNS_DIR).join(a).display()
                ),
            });
        }
    }
    Ok(Committed {
        parts,
        traced,
        strays,
        total,
        done: holder.len() as u64,
        writers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_names_round_trip_to_their_first_run() {
        let name = part_name(12, 511, 1000);
        assert_eq!(name, "part-000012-000511.parquet");
        assert_eq!(part_first(&name), Some((12, true)));
        assert_eq!(part_first(&format!(".{name}.tmp-4242")), Some((12, false)));
        assert_eq!(part_first("notes.txt"), None);
        assert_eq!(part_name(5, 6, 10_000_000), "part-0000005-0000006.parquet");
    }

    #[test]
    fn run_sets_count_distinct_runs() {
        let mut s = RunSet::new(130);
        assert!(s.insert(129) && s.insert(0) && !s.insert(129));
        assert_eq!(s.len(), 2);
        assert!(s.contains(129) && !s.contains(64));
    }

    #[test]
    fn a_lock_is_refused_while_held_and_taken_over_when_stale() {
        let dir = tempfile::tempdir().unwrap();
        let shard = Shard::ALL;
        let (held, warning) = Lock::acquire(dir.path(), shard).unwrap();
        assert!(warning.is_none());
        let err = Lock::acquire(dir.path(), shard).unwrap_err().to_string();
        assert!(
            err.contains(&format!("pid {}", std::process::id())),
            "{err}"
        );
        let other_split = Lock::acquire(dir.path(), Shard { index: 0, count: 2 });
        assert!(matches!(other_split, Err(StoreError::SplitConflict { .. })));
        drop(held);
        fs::write(dir.path().join(".lock-0-of-1"), "pid=999999999 host=gone\n").unwrap();
        let (_lock, warning) = Lock::acquire(dir.path(), shard).unwrap();
        assert!(warning.unwrap().contains("pid 999999999"));
    }
}
