//! Sizing a job before it starts: its runs, agent-steps and series rows (counted, never by
//! enumerating a huge grid), the bytes it will write, a time estimate from a few timed sample
//! runs, and the limits beyond which it is refused rather than started. Shared by `mbmf run`
//! and `mbmf sweep` (and its `--dry-run`), so both print and refuse the same way.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::params::{ConfigError, Params};

/// Bytes a run's row takes in runs.parquet, compressed, beyond its file's footer: measured 99 B
/// (`sweeps/kappa.toml`) and 135 B (`sweeps/arbitration-tidy.toml`) where parameters vary
/// between runs, 9 to 51 B in a tidy1 file of one configuration; rounded up.
pub const RUN_ROW_DISK_BYTES: u64 = 128;
/// Bytes a checkpoint row takes in series.parquet, compressed: measured 11.4 B and 16.5 B in
/// the same sweeps (5.5 B in a tidy1 file of one configuration).
pub const SERIES_ROW_DISK_BYTES: u64 = 16;
/// Bytes a step's row takes in trace.parquet, compressed: measured 1.5 B on tidy1 (`ec`, 10,000
/// steps), 2.5 B in `sweeps/arbitration-tidy.toml` and 1.3 B on twostep, rounded up for larger
/// worlds (`docs/guide/trace.md`).
pub const TRACE_ROW_DISK_BYTES: u64 = 3;
/// Bytes of a runs file (a part of a sweep) beyond its rows: the footer (the Arrow schema with
/// every column's description, the provenance) and the column chunks' headers, measured 31 KB of
/// footer and 38 KB for a file of 6 rows.
pub const RUNS_FILE_DISK_BYTES: u64 = 40 << 10;
/// The same for a series file: 21 KB of footer, 26 KB for a file of 36 rows.
pub const SERIES_FILE_DISK_BYTES: u64 = 28 << 10;
/// The same for a trace file: 8 KB of footer.
pub const TRACE_FILE_DISK_BYTES: u64 = 10 << 10;
/// Longest estimated time accepted for one process: a job that would run for more than a year
/// on this machine is surely a mistake (or needs shards).
pub const MAX_SECONDS: f64 = 365.0 * 86_400.0;
/// Jobs of more agent-steps than this (several minutes on one core) print their size and
/// estimated time before they start.
pub const HUGE_AGENT_STEPS: u128 = 2_000_000_000;
/// Most runs a job may hold: run and configuration indices are `i64` columns.
pub const MAX_RUNS: u128 = i64::MAX as u128;

/// Longest sample run simulated: longer runs are timed on their start and scaled.
const SAMPLE_MAX_STEPS: u32 = 20_000;
const SAMPLE_MAX_BABBLING: u32 = 1_000;

/// What a job holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Size {
    /// Runs.
    pub runs: u128,
    /// Agent-steps, babbling included.
    pub agent_steps: u128,
    /// Checkpoint rows of series.parquet.
    pub series_rows: u128,
    /// Step rows of trace.parquet (0 without the trace).
    pub trace_rows: u128,
    /// Files written per table: 1 for `mbmf run`, a sweep's parts.
    pub parts: u128,
    /// False when the parts were estimated from a sample of the configurations.
    pub parts_exact: bool,
    /// False when the counts were extrapolated from a sample of the configurations (a shard of
    /// a huge grid): then they are estimates.
    pub exact: bool,
}

impl Default for Size {
    fn default() -> Self {
        Size {
            runs: 0,
            agent_steps: 0,
            series_rows: 0,
            trace_rows: 0,
            parts: 1,
            parts_exact: true,
            exact: true,
        }
    }
}

impl Size {
    /// Adds `runs` runs of `params`, with their trace rows when `trace`.
    pub fn add(&mut self, runs: u128, params: &Params, trace: bool) {
        let steps = u128::from(params.babbling) + u128::from(params.steps);
        let rows = crate::batch::checkpoint_count(params) as u128;
        self.runs = self.runs.saturating_add(runs);
        self.agent_steps = self.agent_steps.saturating_add(runs.saturating_mul(steps));
        self.series_rows = self.series_rows.saturating_add(runs.saturating_mul(rows));
        if trace {
            let rows = crate::batch::trace_rows(params) as u128;
            self.trace_rows = self.trace_rows.saturating_add(runs.saturating_mul(rows));
        }
    }

    /// Estimated bytes of every table on disk: the rows, and each file's footer and headers
    /// (most of a small sweep's output).
    pub fn output_bytes(&self) -> u128 {
        let per_file = RUNS_FILE_DISK_BYTES
            + SERIES_FILE_DISK_BYTES
            + if self.trace_rows > 0 {
                TRACE_FILE_DISK_BYTES
            } else {
                0
            };
        let terms = [
            (self.runs, RUN_ROW_DISK_BYTES),
            (self.series_rows, SERIES_ROW_DISK_BYTES),
            (self.trace_rows, TRACE_ROW_DISK_BYTES),
            (self.parts, per_file),
        ];
        terms.iter().fold(0u128, |sum, &(n, bytes)| {
            sum.saturating_add(n.saturating_mul(u128::from(bytes)))
        })
    }

    /// Whether the job is large enough to print its size and time before it starts.
    pub fn is_huge(&self) -> bool {
        self.agent_steps > HUGE_AGENT_STEPS || self.output_bytes() > 1 << 30
    }

    /// `N runs, A agent-steps, about B of output (R runs rows, S series rows[, T trace
    /// rows])`.
    pub fn line(&self) -> String {
        let about = if self.exact { "" } else { "about " };
        format!(
            "{about}{} runs, {about}{} agent-steps (babbling included), about {} of output \
             ({})",
            self.runs,
            self.agent_steps,
            human_bytes(self.output_bytes()),
            self.rows()
        )
    }

    /// `R runs rows, S series rows` and, with the trace, `, T trace rows`.
    fn rows(&self) -> String {
        let mut rows = format!("{} runs rows, {} series rows", self.runs, self.series_rows);
        if self.trace_rows > 0 {
            rows += &format!(", {} trace rows", self.trace_rows);
        }
        rows
    }
}

/// What shrinks each dimension of a job, for messages (flags of `mbmf run`, keys of a sweep).
#[derive(Debug, Clone)]
pub struct Shrink {
    /// What lowers the number of runs.
    pub runs: String,
    /// What lowers the number of series rows.
    pub series: String,
    /// What lowers the time.
    pub time: String,
    /// What lowers the number of part files (a sweep's), when something does.
    pub parts: Option<String>,
}

/// A job refused before it starts because of its size.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SizeError {
    /// More runs than the index columns hold.
    #[error("{runs} runs is more than run indices hold ({max}, an i64 column): {fix}", max = MAX_RUNS)]
    TooManyRuns {
        /// Runs of the job.
        runs: u128,
        /// What shrinks it.
        fix: String,
    },
    /// The results would not fit on the disk.
    #[error(
        "the results would take about {size}, more than the {free} free on the disk of {dir}: {fix}"
    )]
    TooLarge {
        /// Estimated size, with the rows of both tables.
        size: String,
        /// Free space.
        free: String,
        /// The folder written.
        dir: String,
        /// What shrinks it.
        fix: String,
    },
    /// The job would run for more than [`MAX_SECONDS`].
    #[error(
        "the job would take about {time} ({steps} agent-steps on {threads} thread(s)), more \
         than the 1-year limit: {fix}"
    )]
    TooLong {
        /// Estimated duration.
        time: String,
        /// Agent-steps.
        steps: u128,
        /// Threads assumed.
        threads: usize,
        /// What shrinks it.
        fix: String,
    },
}

/// Checks the run count, and the estimated output against the free space of the disk that
/// holds `out` (or its nearest existing parent) plus `credit`, the bytes of results already
/// there that the job replaces or resumes: cheap arithmetic, done before anything is allocated
/// or simulated.
pub fn check_size(size: &Size, out: &Path, credit: u64, shrink: &Shrink) -> Result<(), SizeError> {
    if size.runs > MAX_RUNS {
        return Err(SizeError::TooManyRuns {
            runs: size.runs,
            fix: shrink.runs.clone(),
        });
    }
    if let Some(free) = free_bytes(out) {
        let bytes = size.output_bytes();
        let free = free.saturating_add(credit);
        if bytes > u128::from(free) {
            let series = size
                .series_rows
                .saturating_mul(u128::from(SERIES_ROW_DISK_BYTES));
            let trace = size
                .trace_rows
                .saturating_mul(u128::from(TRACE_ROW_DISK_BYTES));
            let runs = size.runs.saturating_mul(u128::from(RUN_ROW_DISK_BYTES));
            let files = bytes - series - trace - runs;
            let fix = match &shrink.parts {
                Some(fix) if files > series.max(trace).max(runs) => fix.clone(),
                _ if trace > series && trace > runs => "leave out the trace (--trace, or trace = \
                     true in a sweep file), or lower the steps or the runs"
                    .to_string(),
                _ if series > runs => shrink.series.clone(),
                _ => shrink.runs.clone(),
            };
            return Err(SizeError::TooLarge {
                size: format!("{} ({})", human_bytes(bytes), size.rows()),
                free: human_bytes(u128::from(free)),
                dir: out.display().to_string(),
                fix,
            });
        }
    }
    Ok(())
}

/// Refuses an estimate beyond [`MAX_SECONDS`].
pub fn check_time(estimate: &Estimate, shrink: &Shrink) -> Result<(), SizeError> {
    if estimate.seconds > MAX_SECONDS {
        return Err(SizeError::TooLong {
            time: human_duration(estimate.seconds),
            steps: estimate.agent_steps,
            threads: estimate.threads,
            fix: shrink.time.clone(),
        });
    }
    Ok(())
}

/// Free bytes for an unprivileged writer on the file system of `path`, or of its nearest
/// existing parent (the folder may not exist yet).
pub fn free_bytes(path: &Path) -> Option<u64> {
    let existing = nearest_existing(path)?;
    let st = rustix::fs::statvfs(existing).ok()?;
    if st.f_blocks == 0 {
        // A pseudo file system (/proc, /sys) has no size: writing there fails on its own.
        return None;
    }
    let free = st.f_bavail.saturating_mul(st.f_frsize);
    Some(free)
}

/// `path` itself or its nearest ancestor that exists, a relative path's empty ancestor read as
/// `.`; `None` when nothing of it exists.
pub fn nearest_existing(path: &Path) -> Option<&Path> {
    path.ancestors()
        .map(|a| {
            if a.as_os_str().is_empty() {
                Path::new(".")
            } else {
                a
            }
        })
        .find(|a| a.exists())
}

/// A rough duration of a job on this machine, from simulating a few sample runs.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// Estimated wall-clock seconds.
    pub seconds: f64,
    /// Worker threads assumed.
    pub threads: usize,
    /// Sample runs simulated.
    pub samples: usize,
    /// Seconds the samples took.
    pub calibration_seconds: f64,
    /// Agent-steps (babbling included) of the runs estimated.
    pub agent_steps: u128,
}

/// Runs of similar cost (one task, one controller): a few samples stand for them all.
#[derive(Debug, Clone)]
pub struct SampleGroup {
    /// Index into the `specs` given to [`time`].
    pub task: usize,
    /// Sample runs (shortened to a few thousand steps before they are timed).
    pub samples: Vec<RunConfig>,
    /// Agent-steps of all the runs the group stands for.
    pub agent_steps: u128,
}

/// Estimates the time of `groups` by timing their samples (each group's per-step rate times its
/// agent-steps, spread over the worker threads).
pub fn time(specs: &[Arc<Spec>], groups: &[SampleGroup]) -> Result<Estimate, ConfigError> {
    let started = Instant::now();
    let mut rates: Vec<Vec<f64>> = groups.iter().map(|_| Vec::new()).collect();
    let mut samples = 0;
    for (task, spec) in specs.iter().enumerate() {
        let mut configs = Vec::new();
        let mut owners = Vec::new();
        for (gi, g) in groups.iter().enumerate().filter(|(_, g)| g.task == task) {
            for sample in &g.samples {
                let mut config = *sample;
                config.params.steps = config.params.steps.min(SAMPLE_MAX_STEPS);
                config.params.babbling = config.params.babbling.min(SAMPLE_MAX_BABBLING);
                configs.push(config);
                owners.push(gi);
            }
        }
        if configs.is_empty() {
            continue;
        }
        samples += configs.len();
        let mut batch = Batch::new(Arc::clone(spec), configs)?;
        batch.run_to_end();
        for ((config, stats), gi) in batch.configs().iter().zip(batch.stats()).zip(owners) {
            let steps = u64::from(config.params.babbling) + u64::from(config.params.steps);
            rates[gi].push(stats.wall_time_s / steps.max(1) as f64);
        }
    }
    let cpu: f64 = groups
        .iter()
        .zip(&rates)
        .map(|(g, r)| {
            let rate = r.iter().sum::<f64>() / r.len().max(1) as f64;
            rate * g.agent_steps as f64
        })
        .sum();
    let threads = rayon::current_num_threads().max(1);
    Ok(Estimate {
        seconds: cpu / threads as f64,
        threads,
        samples,
        calibration_seconds: started.elapsed().as_secs_f64(),
        agent_steps: groups.iter().map(|g| g.agent_steps).sum(),
    })
}

/// A duration for people: `45 s`, `3 min 20 s`, `2 h 05 min`, `12 days`.
pub fn human_duration(seconds: f64) -> String {
    let s = seconds.max(0.0).round();
    if s >= 2.0 * 86_400.0 {
        return format!("{:.0} days", s / 86_400.0);
    }
    let s = s as u64;
    match s {
        0..=59 => format!("{} s", s.max(1)),
        60..=3599 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

/// A byte count for people: `512 B`, `3.2 MiB`, `41.0 TiB`.
pub fn human_bytes(bytes: u128) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut x = bytes as f64 / 1024.0;
    let mut unit = 0;
    while x >= 1024.0 && unit + 1 < UNITS.len() {
        x /= 1024.0;
        unit += 1;
    }
    format!("{x:.1} {}", UNITS[unit])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_count_runs_steps_and_rows() {
        let params = Params {
            steps: 1000,
            babbling: 10,
            checkpoint: 300,
            ..Params::default()
        };
        let mut size = Size::default();
        size.add(3, &params, false);
        // 1000 steps every 300: rows at 300, 600, 900 and the last.
        assert_eq!(
            (size.runs, size.agent_steps, size.series_rows),
            (3, 3030, 12)
        );
        let files = 68 << 10;
        assert_eq!(size.output_bytes(), 3 * 128 + 12 * 16 + files);
        // The trace: a row per experiment step, babbling not traced.
        size.add(2, &params, true);
        assert_eq!(size.trace_rows, 2000);
        let files = files + (10 << 10);
        assert_eq!(size.output_bytes(), 5 * 128 + 20 * 16 + 2000 * 3 + files);
        // A sweep writes a runs, series and trace file per part.
        size.parts = 3;
        assert_eq!(
            size.output_bytes(),
            5 * 128 + 20 * 16 + 2000 * 3 + 3 * files
        );
        assert!(
            size.line()
                .ends_with("(5 runs rows, 20 series rows, 2000 trace rows)")
        );
    }

    #[test]
    fn an_impossible_size_is_refused_with_its_fix() {
        let shrink = Shrink {
            runs: "lower R".into(),
            series: "lower S".into(),
            time: "lower T".into(),
            parts: Some("fewer P".into()),
        };
        let runs = Size {
            runs: MAX_RUNS + 1,
            ..Size::default()
        };
        let e = check_size(&runs, Path::new("/tmp"), 0, &shrink).unwrap_err();
        assert!(e.to_string().contains("lower R"), "{e}");
        let rows = Size {
            runs: 10,
            series_rows: u128::from(u64::MAX),
            ..Size::default()
        };
        let e = check_size(&rows, Path::new("/tmp/does/not/exist"), 0, &shrink).unwrap_err();
        assert!(
            e.to_string().contains("lower S") && e.to_string().contains("/tmp/does"),
            "{e}"
        );
        assert_eq!(
            check_size(&Size::default(), Path::new("/tmp"), 0, &shrink),
            Ok(())
        );
    }

    #[test]
    fn durations_and_bytes_read_naturally() {
        assert_eq!(human_duration(0.2), "1 s");
        assert_eq!(human_duration(200.0), "3 min 20 s");
        assert_eq!(human_duration(7500.0), "2 h 05 min");
        assert_eq!(human_duration(86_400.0 * 40.0), "40 days");
        assert_eq!(human_bytes(512), "512 B");
        assert_eq!(human_bytes(3 << 20), "3.0 MiB");
    }
}
