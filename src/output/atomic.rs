//! The pair of files `mbmf run` writes (`runs.parquet`, `series.parquet`) committed as one: both
//! carry the same `mbmf_run_id`, the series file is moved into place first and the runs file
//! last (the commit), and the series file it replaces is kept as `.series-<old id>.parquet`
//! until the runs file has been replaced too. A process killed between the two moves leaves the
//! old runs file, the new series file and the old series file under its hidden name:
//! [`committed_file`] then names the old series file, so a reader that follows it sees the old
//! pair, and otherwise the new pair, never a mix. (Single files written whole are
//! [`crate::whole_file`]'s.) A traced run commits a triple the same way ([`commit`]): its
//! `trace.parquet` moves first, kept aside as `.trace-<old id>.parquet` likewise, and a trace
//! belongs to the committed run only when it carries the runs file's id ([`committed_trace`]).

use crate::whole_file::{remove_dead_leftovers, sync};
use std::fs::File;
use std::path::{Path, PathBuf};

use parquet::file::reader::{FileReader, SerializedFileReader};

/// Metadata key of the id shared by the two files of one `mbmf run`.
pub const RUN_ID_KEY: &str = "mbmf_run_id";

/// Test-only fault injection: `MBMF_FAULT=after-first-rename` aborts the process between the
/// two moves of [`commit_pair`], as a kill at that moment would.
pub const FAULT_ENV: &str = "MBMF_FAULT";

/// A new id for the files of one run: host, pid and time, hashed.
pub fn new_run_id() -> String {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    let seed = format!(
        "{} {} {}",
        super::provenance::host_name(),
        std::process::id(),
        now.as_nanos()
    );
    super::provenance::sha256_hex(seed.as_bytes())[..16].to_string()
}

/// The `mbmf_run_id` of a Parquet file, if it has one.
pub fn run_id(path: &Path) -> Option<String> {
    let reader = SerializedFileReader::new(File::open(path).ok()?).ok()?;
    reader
        .metadata()
        .file_metadata()
        .key_value_metadata()?
        .iter()
        .find(|k| k.key == RUN_ID_KEY)
        .and_then(|k| k.value.clone())
}

/// The hidden name of `table`'s file kept aside during a commit, under the id of its run.
fn backup_name(table: &str, id: &str) -> String {
    format!(".{table}-{id}.parquet")
}

/// The file of `table` ("runs" or "series") of the last committed run in `dir`: the runs
/// file, and the series file that has the runs file's id (the hidden copy an interrupted commit
/// left, when the visible one is newer).
pub fn committed_file(dir: &Path, table: &str) -> PathBuf {
    let visible = dir.join(format!("{table}.parquet"));
    if table == "runs" {
        return visible;
    }
    let Some(runs_id) = run_id(&dir.join("runs.parquet")) else {
        return visible;
    };
    if run_id(&visible).as_deref() == Some(runs_id.as_str()) {
        return visible;
    }
    let backup = dir.join(backup_name(table, &runs_id));
    if backup.is_file() { backup } else { visible }
}

/// The trace file (SPEC 14) of the last committed run in `dir`, if that run was traced: the
/// file named by [`committed_file`] when it carries the runs file's id. A trace left by an
/// earlier run that a later untraced run replaced is not the committed run's.
pub fn committed_trace(dir: &Path) -> Option<PathBuf> {
    let runs_id = run_id(&dir.join("runs.parquet"))?;
    let visible = dir.join("trace.parquet");
    if run_id(&visible).as_deref() == Some(runs_id.as_str()) {
        return Some(visible);
    }
    let backup = dir.join(backup_name("trace", &runs_id));
    (run_id(&backup).as_deref() == Some(runs_id.as_str())).then_some(backup)
}

/// Moves the staged `series` and `runs` files to their targets as one commit (see the module
/// documentation). On an error before the runs file moved, the previous pair is restored.
pub fn commit_pair(series: (&Path, &Path), runs: (&Path, &Path)) -> std::io::Result<()> {
    commit(&[("series", series.0, series.1)], runs)
}

/// Moves the staged files of `tables` ((table name, staged, target), e.g. the trace, then the
/// series) and last the `runs` file to their targets as one commit (see the module
/// documentation). On an error before the runs file moved, the previous files are restored.
pub fn commit(tables: &[(&str, &Path, &Path)], runs: (&Path, &Path)) -> std::io::Result<()> {
    let (runs_staged, runs_target) = runs;
    let dir = runs_target.parent().unwrap_or(Path::new("."));
    let old = run_id(runs_target);
    // Keep each file that belongs to the current runs file, under its id.
    let mut moved: Vec<(Option<PathBuf>, &Path)> = Vec::new();
    let restore = |moved: &[(Option<PathBuf>, &Path)]| {
        for (backup, target) in moved {
            if let Some(b) = backup {
                let _ = std::fs::rename(b, target);
            }
        }
    };
    for (k, &(table, staged, target)) in tables.iter().enumerate() {
        let backup = match (target.is_file(), &old) {
            (true, Some(old)) => {
                let backup = dir.join(backup_name(table, old));
                let _ = std::fs::remove_file(&backup);
                if let Err(e) = std::fs::hard_link(target, &backup) {
                    restore(&moved);
                    return Err(e);
                }
                Some(backup)
            }
            _ => None,
        };
        if let Err(e) = std::fs::rename(staged, target) {
            restore(&moved);
            return Err(e);
        }
        moved.push((backup, target));
        if k == 0 && std::env::var_os(FAULT_ENV).is_some_and(|v| v == "after-first-rename") {
            std::process::abort();
        }
    }
    if let Err(e) = std::fs::rename(runs_staged, runs_target) {
        restore(&moved);
        return Err(e);
    }
    sync(dir);
    // An untraced run replacing a traced one: the earlier run's trace.parquet would sit beside
    // the new pair, and a reader opening it by name (not through [`committed_trace`]) would
    // join one run's steps to another's runs. It was part of the results being replaced.
    if !tables.iter().any(|&(table, ..)| table == "trace") {
        remove_foreign_trace(dir, runs_target);
    }
    // Copies left by earlier interrupted commits are of no run now.
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let aside = name.starts_with(".series-") || name.starts_with(".trace-");
            if aside && name.ends_with(".parquet") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    remove_dead_staging(dir);
    Ok(())
}

/// Removes `dir`'s `trace.parquet` when an `mbmf run` wrote it and `runs`, the runs file just
/// committed, does not carry its id. A file of that name without an id is not ours: kept.
fn remove_foreign_trace(dir: &Path, runs: &Path) {
    let trace = dir.join("trace.parquet");
    if let Some(id) = run_id(&trace)
        && run_id(runs).as_deref() != Some(id.as_str())
    {
        let _ = std::fs::remove_file(&trace);
    }
}

/// Removes the staging folders (`.mbmf-run-PID`) that killed runs left in `dir`: those whose
/// process is no longer running. Another live run's folder, and this process's, are kept.
pub fn remove_dead_staging(dir: &Path) {
    remove_dead_leftovers(dir, ".mbmf-run-");
}
