//! The pair of files `mbmf run` writes (`runs.parquet`, `series.parquet`) committed as one: both
//! carry the same `mbmf_run_id`, the series file is moved into place first and the runs file
//! last (the commit), and the series file it replaces is kept as `.series-<old id>.parquet`
//! until the runs file has been replaced too. A process killed between the two moves leaves the
//! old runs file, the new series file and the old series file under its hidden name:
//! [`committed_file`] then names the old series file, so a reader that follows it sees the old
//! pair, and otherwise the new pair, never a mix. (Single files written whole are
//! [`crate::whole_file`]'s.)

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
