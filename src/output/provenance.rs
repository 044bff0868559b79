//! Provenance of every file mbmf writes, as Parquet key-value metadata: which build (commit,
//! dirty flag, rustc, target) wrote it, where (host, Slurm job), when (UTC start and end), how
//! (command line, threads, shard) and in which schema version, so a file found months later
//! names what made it. One builder serves `run`, `sweep`, `reproduce` and the analysis verbs.

use std::time::{SystemTime, UNIX_EPOCH};

/// Schema version of the runs table (2: signed counts, `master_seed`, `config_index`).
pub const RUNS_SCHEMA: &str = "runs/2";
/// Schema version of the series table.
pub const SERIES_SCHEMA: &str = "series/2";
/// Version of the trace table's schema (SPEC 14).
pub const TRACE_SCHEMA: &str = "trace/1";
/// Schema version of `mbmf pareto`'s table.
pub const PARETO_SCHEMA: &str = "pareto/1";
/// Schema version of `mbmf min-budget`'s table.
pub const MIN_BUDGET_SCHEMA: &str = "min_budget/1";

/// Metadata key of the start time of the command that wrote a file.
pub const STARTED_KEY: &str = "mbmf_started_utc";

/// Metadata key of the end time, added when a file is closed.
pub const ENDED_KEY: &str = "mbmf_ended_utc";

/// Git commit of the build ("unknown" outside a git checkout).
pub const GIT_COMMIT: &str = env!("MBMF_GIT_COMMIT");
/// Whether the build's work tree had uncommitted changes: "true", "false" or "unknown".
pub const GIT_DIRTY: &str = env!("MBMF_GIT_DIRTY");

/// `mbmf --version`: the package version, the commit (with `-dirty`) and the compiler.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("MBMF_GIT_COMMIT"),
    ", dirty ",
    env!("MBMF_GIT_DIRTY"),
    "; ",
    env!("MBMF_RUSTC"),
    ", ",
    env!("MBMF_TARGET"),
    ")"
);

/// What varies between the files of one command beyond the build and the host.
#[derive(Debug, Clone, Default)]
pub struct Context<'a> {
    /// When the command started.
    pub started: Option<SystemTime>,
    /// Shard `I/N` of a sweep, when not the whole sweep.
    pub shard: Option<(u32, u32)>,
    /// The sweep text, whose sha256 is recorded.
    pub sweep_text: Option<&'a str>,
    /// The command that wrote the file, as the front end states it (the CLI gives its own
    /// command line; a library caller whatever names its request).
    pub command: &'a str,
}

/// The key-value metadata of a file of table `schema` (e.g. [`RUNS_SCHEMA`]): build, host,
/// Slurm ids, start time, threads, command line, shard and sweep digest. The end time is added
/// by [`super::ParquetSink`] when it closes the file.
pub fn provenance(schema: &str, context: &Context<'_>) -> Vec<(String, String)> {
    let mut kv: Vec<(String, String)> = vec![
        ("mbmf_version".into(), env!("CARGO_PKG_VERSION").into()),
        ("mbmf_schema".into(), schema.into()),
        ("mbmf_git_commit".into(), GIT_COMMIT.into()),
        ("mbmf_git_dirty".into(), GIT_DIRTY.into()),
        ("mbmf_rustc".into(), env!("MBMF_RUSTC").into()),
        ("mbmf_target".into(), env!("MBMF_TARGET").into()),
        ("mbmf_host".into(), host_name()),
        (
            STARTED_KEY.into(),
            utc(context.started.unwrap_or_else(SystemTime::now)),
        ),
        (
            "mbmf_threads".into(),
            rayon::current_num_threads().to_string(),
        ),
        ("mbmf_command".into(), context.command.to_string()),
    ];
    if let Some((index, count)) = context.shard {
        kv.push(("mbmf_shard".into(), format!("{index}/{count}")));
    }
    for (key, var) in [
        ("slurm_job_id", "SLURM_JOB_ID"),
        ("slurm_array_job_id", "SLURM_ARRAY_JOB_ID"),
        ("slurm_array_task_id", "SLURM_ARRAY_TASK_ID"),
    ] {
        if let Some(v) = std::env::var_os(var) {
            kv.push((key.into(), v.to_string_lossy().into_owned()));
        }
    }
    if let Some(text) = context.sweep_text {
        kv.push(("mbmf_sweep_sha256".into(), sha256_hex(text.as_bytes())));
    }
    kv
}

/// The host name ("unknown-host" when the kernel does not say).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown-host".into())
}

/// Lower-case hex sha256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `time` as RFC 3339 UTC with milliseconds, e.g. `2026-12-01T16:55:22.123Z`.
pub fn utc(time: SystemTime) -> String {
    let d = time.duration_since(UNIX_EPOCH).unwrap_or_default();
    let secs = d.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, day) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60,
        d.subsec_millis()
    )
}

/// Proleptic Gregorian date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn utc_times_match_known_dates() {
        assert_eq!(utc(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
        // 2000-02-29 12:34:56.789 UTC = 951827696.789 s.
        let t = UNIX_EPOCH + Duration::from_millis(951_827_696_789);
        assert_eq!(utc(t), "2000-02-29T12:34:56.789Z");
        let t = UNIX_EPOCH + Duration::from_secs(1_795_888_522);
        assert_eq!(utc(t), "2026-11-28T17:55:22.000Z");
    }

    #[test]
    fn sha256_of_a_known_text() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn provenance_names_schema_shard_and_sweep_digest() {
        let kv = provenance(
            RUNS_SCHEMA,
            &Context {
                started: Some(UNIX_EPOCH),
                shard: Some((1, 4)),
                sweep_text: Some("abc"),
                command: "mbmf sweep s.toml",
            },
        );
        let get = |k: &str| kv.iter().find(|(key, _)| key == k).map(|(_, v)| v.as_str());
        assert_eq!(get("mbmf_schema"), Some("runs/2"));
        assert_eq!(get("mbmf_shard"), Some("1/4"));
        assert_eq!(get("mbmf_started_utc"), Some("1970-01-01T00:00:00.000Z"));
        assert_eq!(get("mbmf_sweep_sha256").map(|s| &s[..8]), Some("ba7816bf"));
        assert_eq!(get("mbmf_git_commit"), Some(GIT_COMMIT));
        assert_eq!(get("mbmf_command"), Some("mbmf sweep s.toml"));
        assert!(get("mbmf_rustc").is_some());
    }
}
