//! The pair of files `mbmf run` writes (`runs.parquet`, `series.parquet`) committed as one: both
//! carry the same `mbmf_run_id`, the series file is moved into place first and the runs file
//! last (the commit), and the series file it replaces is kept as `.series-<old id>.parquet`
//! until the runs file has been replaced too. A process killed between the two moves leaves the
//! old runs file, the new series file and the old series file under its hidden name:
//! [`committed_file`] then names the old series file, so a reader that follows it sees the old
//! pair, and otherwise the new pair, never a mix.

use std::fs::{self, File};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

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

fn backup_name(id: &str) -> String {
    format!(".series-{id}.parquet")
}

/// The file of `table` ("runs" or "series") of the last committed run in `dir`: the runs
/// file, and the series file that has the runs file's id (the hidden copy an interrupted commit
/// left, when the visible one is newer).
pub fn committed_file(dir: &Path, table: &str) -> PathBuf {
    let visible = dir.join(format!("{table}.parquet"));
    if table != "series" {
        return visible;
    }
    let Some(runs_id) = run_id(&dir.join("runs.parquet")) else {
        return visible;
    };
    if run_id(&visible).as_deref() == Some(runs_id.as_str()) {
        return visible;
    }
    let backup = dir.join(backup_name(&runs_id));
    if backup.is_file() { backup } else { visible }
}

/// Moves the staged `series` and `runs` files to their targets as one commit (see the module
/// documentation). On an error before the runs file moved, the previous pair is restored.
pub fn commit_pair(series: (&Path, &Path), runs: (&Path, &Path)) -> std::io::Result<()> {
    let (series_staged, series_target) = series;
    let (runs_staged, runs_target) = runs;
    let dir = runs_target.parent().unwrap_or(Path::new("."));
    // Keep the series file that belongs to the current runs file, under its id.
    let backup = match (series_target.is_file(), run_id(runs_target)) {
        (true, Some(old)) => {
            let backup = dir.join(backup_name(&old));
            let _ = std::fs::remove_file(&backup);
            std::fs::hard_link(series_target, &backup)?;
            Some(backup)
        }
        _ => None,
    };
    std::fs::rename(series_staged, series_target)?;
    if std::env::var_os(FAULT_ENV).is_some_and(|v| v == "after-first-rename") {
        std::process::abort();
    }
    if let Err(e) = std::fs::rename(runs_staged, runs_target) {
        if let Some(b) = &backup {
            let _ = std::fs::rename(b, series_target);
        }
        return Err(e);
    }
    sync(dir);
    // Copies left by earlier interrupted commits are of no run now.
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(".series-") && name.ends_with(".parquet") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    remove_dead_staging(dir);
    Ok(())
}

/// Removes the staging folders (`.mbmf-run-PID`) that killed runs left in `dir`: those whose
/// process is no longer running. Another live run's folder, and this process's, are kept.
pub fn remove_dead_staging(dir: &Path) {
    remove_dead_leftovers(dir, ".mbmf-run-");
}

/// Removes the entries of `dir` (files or folders) named `PREFIX` + a pid, where that pid is
/// not running on this host (nor this process): what a killed process left under its pid.
pub fn remove_dead_leftovers(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let dead = name
            .strip_prefix(prefix)
            .and_then(|pid| pid.parse::<u32>().ok())
            .is_some_and(|pid| {
                pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists()
            });
        if dead {
            let path = e.path();
            let _ = std::fs::remove_dir_all(&path).or_else(|_| std::fs::remove_file(&path));
        }
    }
}

fn sync(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// A hidden name beside `path` for writing it, unique within this process and across
/// processes, in the same folder so that moving it into place is a rename.
pub fn temp_path(path: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let unique = NEXT.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.{}.{unique}.tmp", std::process::id()))
}

/// Writes `bytes` to a temporary file beside `path`, syncs it, then renames it over `path`. On
/// failure, returns the file that could not be written (the temporary one or `path`) with the
/// error, and removes the temporary file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), (PathBuf, std::io::Error)> {
    let tmp = temp_path(path);
    let written = fs::File::create(&tmp)
        .and_then(|mut file| {
            file.write_all(bytes)?;
            file.sync_all()
        })
        .map_err(|e| (tmp.clone(), e))
        .and_then(|()| fs::rename(&tmp, path).map_err(|e| (path.to_path_buf(), e)));
    if written.is_err() {
        // Best effort: the temporary file may not even exist.
        let _ = fs::remove_file(&tmp);
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_replaces_the_file_and_leaves_nothing_beside_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("report.md");
        write_atomic(&path, b"old").unwrap();
        write_atomic(&path, b"new").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
        let (failed, _) = write_atomic(&dir.path().join("no/such/folder"), b"x").unwrap_err();
        assert!(
            failed.starts_with(dir.path().join("no")),
            "{}",
            failed.display()
        );
    }
}
