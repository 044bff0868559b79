//! The one simulate-and-write pipeline of `mbmf run`, `mbmf sweep` and `mbmf reproduce`: runs
//! of one environment simulated in batches that fit in memory, each finished batch handed to a
//! writer ([`Tables`] for a runs.parquet / series.parquet pair, or a sweep's parts) before the
//! next is allocated, with progress reported through a callback.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Result, anyhow};

use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::output::{self, OutputError, ParquetSink};
use crate::params::{ConfigError, Params};
use crate::schedule::Schedule;

/// Steps every run advances between two progress updates.
const PROGRESS_STRIDE: u64 = 2_000;

/// Agent-steps (babbling included) that simulating `configs` takes.
pub fn agent_steps(configs: &[RunConfig]) -> u64 {
    configs
        .iter()
        .map(|c| u64::from(c.params.babbling) + u64::from(c.params.steps))
        .sum()
}

/// The work stopped before its end because its progress callback asked (in the CLI, after a
/// signal). Whatever `on_batch` received before is all there is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("stopped on request before every run was simulated")]
pub struct Interrupted;

/// The answer of a progress callback for work that `stop` cancels: `Break` once it is set.
pub fn unless_stopped(stop: &AtomicBool) -> ControlFlow<()> {
    if stop.load(Ordering::Relaxed) {
        ControlFlow::Break(())
    } else {
        ControlFlow::Continue(())
    }
}

/// Simulates `configs` on `spec` in batches of at most `batch_size` runs, handing each finished
/// batch to `on_batch` (which writes it out) before the next is allocated, so memory stays
/// bounded by one batch. `progress` is told the agent-steps advanced every few thousand steps.
pub fn simulate<E: From<ConfigError>>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    batch_size: usize,
    mut progress: impl FnMut(u64),
    on_batch: impl FnMut(&Batch) -> Result<(), E>,
) -> Result<(), E> {
    let go_on = |n| {
        progress(n);
        ControlFlow::Continue(())
    };
    batches(spec, configs, &[], &[], batch_size, go_on, on_batch).map(|_| ())
}

/// [`simulate`] where run `i` follows `schedules[run_schedule[i]]` (SPEC 10; an empty
/// `run_schedule` means no changes) and `progress` says whether to go on: after a
/// [`ControlFlow::Break`] the batch in hand is dropped (written first if it had just finished)
/// and [`Interrupted`] is returned. It is asked only between strides, so a stop costs nothing
/// per step and takes at most one stride.
pub fn simulate_with_schedules<E: From<ConfigError> + From<Interrupted>>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    schedules: &[Schedule],
    run_schedule: &[usize],
    batch_size: usize,
    progress: impl FnMut(u64) -> ControlFlow<()>,
    on_batch: impl FnMut(&Batch) -> Result<(), E>,
) -> Result<(), E> {
    let flow = batches(
        spec,
        configs,
        schedules,
        run_schedule,
        batch_size,
        progress,
        on_batch,
    )?;
    match flow {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Interrupted.into()),
    }
}

/// The loop of [`simulate_with_schedules`]; `Break` when `progress` stopped it.
fn batches<E: From<ConfigError>>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    schedules: &[Schedule],
    run_schedule: &[usize],
    batch_size: usize,
    mut progress: impl FnMut(u64) -> ControlFlow<()>,
    mut on_batch: impl FnMut(&Batch) -> Result<(), E>,
) -> Result<ControlFlow<()>, E> {
    let size = batch_size.max(1);
    for (k, chunk) in configs.chunks(size).enumerate() {
        let which = if run_schedule.is_empty() {
            &[][..]
        } else {
            &run_schedule[k * size..k * size + chunk.len()]
        };
        let mut batch = Batch::with_schedules(Arc::clone(spec), chunk.to_vec(), schedules, which)?;
        let longest = chunk
            .iter()
            .map(|c| u64::from(c.params.babbling) + u64::from(c.params.steps))
            .max()
            .unwrap_or(0);
        let mut done = 0;
        let mut flow = ControlFlow::Continue(());
        while done < longest && flow.is_continue() {
            let stride = PROGRESS_STRIDE.min(longest - done);
            batch.advance(stride);
            done += stride;
            let advanced: u64 = chunk
                .iter()
                .map(|c| {
                    let end = u64::from(c.params.babbling) + u64::from(c.params.steps);
                    end.min(done) - end.min(done - stride)
                })
                .sum();
            flow = progress(advanced);
        }
        // A batch that finished is kept even when the stop came with its last stride.
        if done == longest {
            on_batch(&batch)?;
        }
        if flow.is_break() {
            return Ok(flow);
        }
    }
    Ok(ControlFlow::Continue(()))
}

/// A runs.parquet and a series.parquet being written side by side in one folder, batch by
/// batch, each under a temporary name until [`Tables::finish`].
pub struct Tables {
    runs: ParquetSink,
    series: ParquetSink,
}

impl Tables {
    /// Prepares `dir/runs.parquet` and `dir/series.parquet`, each carrying its metadata
    /// ([`output::pair_metadata`]).
    pub fn new(dir: &Path, [runs, series]: [Vec<(String, String)>; 2]) -> Tables {
        Tables {
            runs: ParquetSink::new(&dir.join("runs.parquet"), runs),
            series: ParquetSink::new(&dir.join("series.parquet"), series),
        }
    }

    /// Appends the rows of a finished batch to both tables.
    pub fn write(&mut self, batch: &Batch) -> Result<(), OutputError> {
        self.runs.write(&output::runs_batch(batch)?)?;
        self.series.write(&output::series_batch(batch)?)
    }

    /// Completes both files; returns their paths (runs first).
    pub fn finish(self) -> Result<[PathBuf; 2], OutputError> {
        Ok([self.runs.finish()?, self.series.finish()?])
    }
}

/// Estimated bytes of an Arrow/Parquet series row beyond the task name: about 35 numeric
/// columns, 6 short strings and the writer's buffered encoding.
const SERIES_ROW_BYTES: u64 = 512;

/// Estimated bytes of a run's row in runs.parquet and its per-run records.
const RUN_ROW_BYTES: u64 = 2048;

/// Bytes one run of `params` on `spec` holds while its batch is simulated and written: the
/// per-run tables of [`Batch`] (Q tables, averaged distributions, MB window and model, per-state
/// costs) and its checkpoint rows, also as Arrow columns. An estimate, accurate to a few percent
/// where it matters (large worlds, long windows, many checkpoints).
pub fn bytes_per_run(spec: &Spec, params: &Params) -> u64 {
    memory_parts(spec, params).iter().map(|&(b, _)| b).sum()
}

/// The parts of [`bytes_per_run`], each with the flag that shrinks it.
fn memory_parts(spec: &Spec, params: &Params) -> [(u64, &'static str); 3] {
    let pairs = (spec.n_states * spec.n_actions) as u64;
    let states = spec.n_states as u64;
    let outcomes = spec.outcome_state.len() as u64;
    // Q (MF, MB) and averaged distributions: 4 x f64; G: u8; window length and position: 2 x u16.
    let tables = pairs * (4 * 8 + 1 + 2 * 2)
        + outcomes * (2 + 8)
        + states * (2 * 8 + 2)
        + spec.n_actions as u64 * 16
        + RUN_ROW_BYTES;
    let window = pairs.saturating_mul(2 * u64::from(params.window_n));
    let rows = crate::batch::checkpoint_count(params) as u64;
    let row_bytes = std::mem::size_of::<crate::batch::Checkpoint>() as u64
        + SERIES_ROW_BYTES
        + spec.name.len() as u64;
    [
        (tables, "the task is too large"),
        (window, "lower --window-n"),
        (
            rows.saturating_mul(row_bytes),
            "raise --checkpoint or lower --steps",
        ),
    ]
}

/// Memory of this machine: (available now, installed), in bytes, when the system says.
fn system_memory() -> Option<(u64, u64)> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let field = |name: &str| {
        info.lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| {
                rest.trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<u64>()
                    .ok()
            })
            .map(|kib| kib.saturating_mul(1024))
    };
    Some((field("MemAvailable:")?, field("MemTotal:")?))
}

/// Memory a batch may use when the system does not say how much there is.
const DEFAULT_BATCH_BYTES: u64 = 2 << 30;

/// Runs to simulate at once: `requested`, lowered so that a batch fits in half of the memory
/// available now. A run that alone needs more than the machine's memory is refused, naming the
/// flag that would shrink it, instead of failing an allocation midway.
pub fn plan_batch_size(spec: &Spec, configs: &[RunConfig], requested: usize) -> Result<usize> {
    let Some(largest) = configs
        .iter()
        .max_by_key(|c| bytes_per_run(spec, &c.params))
    else {
        return Ok(requested.max(1));
    };
    let per_run = bytes_per_run(spec, &largest.params).max(1);
    let (budget, installed) = match system_memory() {
        Some((available, total)) => (available / 2, total),
        None => (DEFAULT_BATCH_BYTES, u64::MAX),
    };
    if per_run > installed {
        let parts = memory_parts(spec, &largest.params);
        let (_, fix) = parts.iter().max_by_key(|&&(b, _)| b).expect("three parts");
        return Err(anyhow!(
            "one run needs about {} of memory, more than this machine's {}: {fix} \
             ({} states x {} actions, window-n {}, {} series rows per run)",
            gib(per_run),
            gib(installed),
            spec.n_states,
            spec.n_actions,
            largest.params.window_n,
            crate::batch::checkpoint_count(&largest.params)
        ));
    }
    let fit = usize::try_from(budget / per_run).unwrap_or(usize::MAX);
    Ok(requested.min(fit).max(1))
}

/// A byte count in GiB, for messages.
fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_estimate_of_a_run_covers_the_batch_state_it_allocates() {
        let spec = Arc::new(crate::env::load("tidy1").expect("tidy1"));
        for (window_n, steps, checkpoint) in [(1, 100, 10), (10, 1000, 100), (2000, 50, 1)] {
            let params = Params {
                window_n,
                steps,
                checkpoint,
                ..Params::default()
            };
            let configs: Vec<RunConfig> = (0..4)
                .map(|r| RunConfig {
                    params,
                    seed: 1,
                    run_index: r,
                })
                .collect();
            let batch = Batch::new(Arc::clone(&spec), configs).expect("valid");
            let actual = batch.state_bytes() as f64 / 4.0;
            let estimate = bytes_per_run(&spec, &params) as f64;
            // The estimate adds the Arrow rows written from the batch: at least the state, at
            // most the state plus those rows and a few percent.
            let rows = crate::batch::checkpoint_count(&params) as f64;
            let arrow = rows * (SERIES_ROW_BYTES + spec.name.len() as u64) as f64;
            assert!(
                estimate >= actual,
                "window {window_n}: {estimate} < {actual}"
            );
            assert!(
                estimate <= 1.1 * actual + arrow + RUN_ROW_BYTES as f64,
                "window {window_n}: {estimate} for {actual}"
            );
        }
    }
}
