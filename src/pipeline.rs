//! The one simulate-and-write pipeline of `mbmf run`, `mbmf sweep` and `mbmf reproduce`. The
//! verb builds [`Group`]s of runs of one task lazily (windows of `mbmf run`'s runs, a sweep's
//! batches of one task and one value of each text parameter) and hands each to a [`Job`], which
//! simulates it in batches that fit in memory and gives every finished batch to its [`Writer`]
//! (the [`Tables`] pair, or a sweep's parts) while the next is simulated (at most two batches
//! in memory, and one only when two would not fit), with progress reported through a callback
//! that can stop the work.

use std::ops::{ControlFlow, Range};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use arrow::array::{ArrayRef, Int64Array, RecordBatch, StringArray};
use arrow::datatypes::{Field, Schema};

use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::limits;
use crate::output::{self, OutputError, ParquetSink};
use crate::params::{ConfigError, Params};
use crate::schedule::Schedule;

/// Steps every run advances between two progress updates.
const PROGRESS_STRIDE: u64 = 2_000;

/// Agent-steps (babbling included) that simulating `configs` takes.
pub fn agent_steps(configs: &[RunConfig]) -> u64 {
    configs.iter().map(|c| run_steps(&c.params)).sum()
}

/// Agent-steps (babbling included) of one run of `params`.
pub fn run_steps(params: &Params) -> u64 {
    u64::from(params.babbling) + u64::from(params.steps)
}

/// Run `seed_index` of configuration `config` of `seeds` runs each: the one numbering of `mbmf
/// run` (each controller is a configuration) and `mbmf sweep`. With the master seed, its run
/// index fixes the run's random stream, so batching and sharding never change a result.
pub fn run_config(
    params: Params,
    master_seed: u64,
    config: u64,
    seeds: u64,
    seed_index: u64,
) -> RunConfig {
    RunConfig {
        params,
        seed: master_seed,
        run_index: config * seeds + seed_index,
    }
}

/// The work stopped before its end because its progress callback asked (in the CLI, after a
/// signal). Whatever was written before is all there is.
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

/// Runs of one task simulated and written together, built by the verb one group at a time so
/// that only a group's configurations are in memory.
#[derive(Debug, Default)]
pub struct Group {
    /// The runs.
    pub configs: Vec<RunConfig>,
    /// Per run, its index into the job's schedules.
    pub schedules: Vec<usize>,
    /// Per run, its index into the writer's profile names (empty: the engine's names).
    pub profiles: Vec<usize>,
}

impl Group {
    /// Adds a run following `schedule` whose `profile` column names `profile`.
    pub fn push(&mut self, config: RunConfig, schedule: usize, profile: usize) {
        self.configs.push(config);
        self.schedules.push(schedule);
        self.profiles.push(profile);
    }
}

/// Where finished batches go.
pub trait Writer {
    /// Why writing failed.
    type Error;
    /// Writes the rows of a finished batch; `profiles` as in [`Group::profiles`].
    fn write(&mut self, batch: &Batch, profiles: &[usize]) -> Result<(), Self::Error>;

    /// Whether the batches written record the per-step trace (SPEC 14).
    fn traces(&self) -> bool {
        false
    }
}

/// Simulation of groups of runs into one writer.
pub struct Job<'a, W> {
    /// The schedules of changes that runs refer to.
    pub schedules: &'a [Schedule],
    /// Runs simulated at once (results do not depend on it).
    pub batch_size: usize,
    /// Where the results go.
    pub writer: W,
}

impl<W: Writer> Job<'_, W> {
    /// Simulates `group` on `spec` in batches of at most `batch_size` runs, handing each finished
    /// batch to the writer and then to `observe` while the next batch is simulated (both are
    /// called from the work's threads, in batch order). `progress` is told the agent-steps advanced
    /// every few thousand steps and says whether to go on: after a [`ControlFlow::Break`] the
    /// batch in hand is dropped (written first if it had just finished) and [`Interrupted`] is
    /// returned. It is asked only between strides (and once before the group), so a stop costs
    /// nothing per step and takes at most one stride.
    pub fn simulate<E>(
        &mut self,
        spec: &Arc<Spec>,
        group: &Group,
        mut progress: impl FnMut(u64) -> ControlFlow<()> + Send,
        mut observe: impl FnMut(&Batch) -> Result<(), E> + Send,
    ) -> Result<(), E>
    where
        W: Send,
        E: From<ConfigError> + From<MemoryError> + From<Interrupted> + From<W::Error> + Send,
    {
        if progress(0).is_break() {
            return Err(Interrupted.into());
        }
        let writer = &mut self.writer;
        let trace = writer.traces();
        let flow = batches(
            spec,
            &group.configs,
            self.schedules,
            &group.schedules,
            (self.batch_size, trace),
            progress,
            |batch, first| {
                let profiles = group
                    .profiles
                    .get(first..first + batch.len())
                    .unwrap_or(&[]);
                writer.write(batch, profiles)?;
                observe(batch)
            },
        )?;
        match flow {
            ControlFlow::Continue(()) => Ok(()),
            ControlFlow::Break(()) => Err(Interrupted.into()),
        }
    }
}

/// Simulates `configs` on `spec` without changes, as [`Job::simulate`] does, handing each
/// finished batch to `on_batch`.
pub fn simulate<E: From<ConfigError> + From<MemoryError> + Send>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    batch_size: usize,
    mut progress: impl FnMut(u64) + Send,
    mut on_batch: impl FnMut(&Batch) -> Result<(), E> + Send,
) -> Result<(), E> {
    let go_on = |n| {
        progress(n);
        ControlFlow::Continue(())
    };
    batches(
        spec,
        configs,
        &[],
        &[],
        (batch_size, false),
        go_on,
        |b, _| on_batch(b),
    )
    .map(|_| ())
}

/// The loop of [`Job::simulate`]: `on_batch` gets each finished batch (of `batch_size` runs,
/// recording the trace when `trace`) and the position of its first run in `configs`; `Break`
/// when `progress` stopped it.
///
/// A finished batch is handed over while the next one is simulated, both on the work's
/// threads (`rayon::join`), so encoding and writing a batch no longer holds every thread but
/// one idle: at most two batches exist, the one simulated and the one waiting for or being
/// handed over, and only when the memory a batch may take holds two (otherwise the finished
/// batch is handed over first, as one thread would). Batches are handed over in order; the
/// next batch is allocated beside the hand-over too, in the memory of the batch handed over
/// before (its pages already mapped: a fresh batch's first touch of each page is a fault).
fn batches<E>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    schedules: &[Schedule],
    run_schedule: &[usize],
    (batch_size, trace): (usize, bool),
    mut progress: impl FnMut(u64) -> ControlFlow<()> + Send,
    mut on_batch: impl FnMut(&Batch, usize) -> Result<(), E> + Send,
) -> Result<ControlFlow<()>, E>
where
    E: From<ConfigError> + From<MemoryError> + Send,
{
    let size = batch_size.max(1);
    let bytes_of = |chunk: &[RunConfig]| -> u64 {
        chunk
            .iter()
            .map(|c| bytes_per_run(spec, &c.params, trace))
            .sum()
    };
    // Two batches at once only where the memory a batch may take holds two of the largest.
    let largest = configs.chunks(size).map(bytes_of).max().unwrap_or(0);
    let overlap = limits::memory().is_none_or(|b| largest.saturating_mul(2) <= b.batch_share());
    // A finished batch and the position of its first run, not handed over yet.
    let mut waiting: Option<(Batch, usize)> = None;
    // A batch handed over, whose memory the next batch may take.
    let mut spare: Option<Batch> = None;
    let cuts = cuts(
        configs.len(),
        size,
        overlap && rayon::current_num_threads() > 1,
    );
    for range in cuts {
        let (chunk, start) = (&configs[range.clone()], range.start);
        let which = run_schedule.get(range.clone()).unwrap_or(&[]);
        if !overlap && let Some((done, first)) = waiting.take() {
            on_batch(&done, first)?;
            spare = Some(done);
        }
        reserve(bytes_of(chunk), chunk.len())?;
        let recycled = spare.take();
        // No batch follows the last: the one handed over beside it is freed there, not after.
        let last = range.end == configs.len();
        // A failed hand-over stops the simulation beside it at its next stride.
        let failed = AtomicBool::new(false);
        let (handed, simulated) = rayon::join(
            || {
                let Some((done, first)) = waiting.take() else {
                    return Ok(None);
                };
                match on_batch(&done, first) {
                    Ok(()) => Ok((!last).then_some(done)),
                    Err(e) => {
                        failed.store(true, Ordering::Relaxed);
                        Err(e)
                    }
                }
            },
            || {
                let mut batch =
                    Batch::reusing(recycled, Arc::clone(spec), chunk.to_vec(), schedules, which)?;
                if trace {
                    batch.record_trace();
                }
                let (finished, flow) = simulate_strides(&mut batch, chunk, |n| {
                    if failed.load(Ordering::Relaxed) {
                        ControlFlow::Break(())
                    } else {
                        progress(n)
                    }
                });
                Ok::<_, E>((batch, finished, flow))
            },
        );
        spare = handed?;
        let (batch, finished, flow) = simulated?;
        // A batch that finished is kept even when the stop came with its last stride.
        if finished {
            waiting = Some((batch, start));
        }
        if flow.is_break() {
            if let Some((done, first)) = waiting.take() {
                on_batch(&done, first)?;
            }
            return Ok(flow);
        }
    }
    if let Some((done, first)) = waiting.take() {
        on_batch(&done, first)?;
    }
    Ok(ControlFlow::Continue(()))
}

/// The runs of each batch of a job of `runs` runs: `size` at a time, except that when batches
/// overlap (`overlap`) a last batch of at least twice [`MIN_HALVED_BATCH`] runs is cut in two:
/// the hand-over of the last batch, after every simulation, is the job's serial tail.
fn cuts(runs: usize, size: usize, overlap: bool) -> Vec<Range<usize>> {
    let size = size.max(1);
    let mut cuts: Vec<Range<usize>> = (0..runs)
        .step_by(size)
        .map(|start| start..(start + size).min(runs))
        .collect();
    if overlap && cuts.len() > 1 {
        let last = cuts.pop().expect("more than one");
        if last.len() >= 2 * MIN_HALVED_BATCH {
            let middle = last.start + last.len() / 2;
            cuts.extend([last.start..middle, middle..last.end]);
        } else {
            cuts.push(last);
        }
    }
    cuts
}

/// Fewest runs of each half of a last batch cut in two by [`cuts`].
const MIN_HALVED_BATCH: usize = 64;

/// Advances `batch` (the runs `chunk`) to its end, a stride at a time, telling `progress` the
/// agent-steps of each stride; whether it finished, and the flow `progress` last returned.
fn simulate_strides(
    batch: &mut Batch,
    chunk: &[RunConfig],
    mut progress: impl FnMut(u64) -> ControlFlow<()>,
) -> (bool, ControlFlow<()>) {
    let longest = chunk
        .iter()
        .map(|c| run_steps(&c.params))
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
                let end = run_steps(&c.params);
                end.min(done) - end.min(done - stride)
            })
            .sum();
        flow = progress(advanced);
    }
    (done == longest, flow)
}

/// Fewest runs of a batch cut for [`overlapped`]: below this, a batch's fixed costs (its
/// views, allocation and Parquet pages) outweigh what the overlap saves.
const MIN_OVERLAPPED_BATCH: usize = 256;

/// Runs per batch for a job of `runs` runs whose batches may hold `batch_size`: on more than
/// one thread, at least four batches of at least `MIN_OVERLAPPED_BATCH` runs, so that even a
/// job that fits in one batch writes its first batches while simulating the next ones (on one
/// thread nothing overlaps: `batch_size`). Results do not depend on the batch size.
pub fn overlapped(batch_size: usize, runs: u64) -> usize {
    if rayon::current_num_threads() < 2 {
        return batch_size;
    }
    let quarter = usize::try_from(runs.div_ceil(4)).unwrap_or(usize::MAX);
    batch_size.min(quarter.max(MIN_OVERLAPPED_BATCH)).max(1)
}

/// The runs and series tables of a finished batch with `config_index` and `seed_index` after
/// `master_seed` (from each run's index, for configurations of `seeds` runs) and, unless
/// `profiles` is empty, the `profile` column written with `names[profiles[run]]` (a sweep's
/// user-defined profiles are `custom` to the engine).
pub fn tables(
    batch: &Batch,
    seeds: u64,
    names: &[String],
    profiles: &[usize],
) -> Result<[RecordBatch; 2], OutputError> {
    let runs: Vec<usize> = (0..batch.len()).collect();
    let series: Vec<usize> = (0..batch.len())
        .flat_map(|r| std::iter::repeat_n(r, batch.series(r).len()))
        .collect();
    let label = |table: RecordBatch, rows: &[usize]| {
        let seeds = seeds.max(1);
        let index = |f: fn(u64, u64) -> u64| -> ArrayRef {
            let values = rows.iter().map(|&r| batch.configs()[r].run_index);
            Arc::new(Int64Array::from_iter_values(
                values.map(|i| f(i, seeds) as i64),
            ))
        };
        let schema = table.schema();
        let mut out: Vec<(Field, ArrayRef)> = Vec::with_capacity(schema.fields().len() + 2);
        // The columns added are never null.
        let new = |name: &str, column: ArrayRef| {
            let field = output::columns::field(name, column.data_type().clone(), false);
            (field, column)
        };
        for (field, column) in schema.fields().iter().zip(table.columns()) {
            if field.name() == "profile" && !profiles.is_empty() {
                let named = rows.iter().map(|&r| Some(names[profiles[r]].as_str()));
                out.push(new("profile", Arc::new(named.collect::<StringArray>())));
                continue;
            }
            out.push((field.as_ref().clone(), Arc::clone(column)));
            if field.name() == "master_seed" {
                out.push(new("config_index", index(|i, s| i / s)));
                out.push(new("seed_index", index(|i, s| i % s)));
            }
        }
        let (fields, columns): (Vec<Field>, Vec<ArrayRef>) = out.into_iter().unzip();
        let schema = Schema::new_with_metadata(fields, schema.metadata().clone());
        RecordBatch::try_new(Arc::new(schema), columns)
    };
    // Two independent tables: built side by side on the work's threads.
    let (runs, series) = rayon::join(
        || Ok::<_, OutputError>(label(output::runs_batch(batch)?, &runs)?),
        || Ok::<_, OutputError>(label(output::series_batch(batch)?, &series)?),
    );
    Ok([runs?, series?])
}

/// [`tables`] of a finished batch and, when `traced`, its trace table, built side by side.
pub fn tables_and_trace(
    batch: &Batch,
    seeds: u64,
    names: &[String],
    profiles: &[usize],
    traced: bool,
) -> Result<([RecordBatch; 2], Option<RecordBatch>), OutputError> {
    let (tables, trace) = rayon::join(
        || tables(batch, seeds, names, profiles),
        || traced.then(|| output::trace_batch(batch)),
    );
    Ok((tables?, trace.transpose()?))
}

/// A runs.parquet and a series.parquet (and, when traced, a trace.parquet) being written side
/// by side in one folder, batch by batch, each under a temporary name until
/// [`Tables::finish`]. All carry the same run id, so a reader can tell they belong together.
pub struct Tables {
    runs: ParquetSink,
    series: ParquetSink,
    trace: Option<ParquetSink>,
    seeds: u64,
    names: Vec<String>,
}

impl Tables {
    /// Prepares `dir/runs.parquet` and `dir/series.parquet` with `metadata`
    /// ([`output::metadata`]) for configurations of `seeds` runs whose profiles are `names`.
    pub fn new(
        dir: &Path,
        mut metadata: Vec<(String, String)>,
        seeds: u64,
        names: Vec<String>,
    ) -> Tables {
        let id = output::atomic::new_run_id();
        metadata.push((output::atomic::RUN_ID_KEY.to_string(), id));
        let series = output::with_schema(&metadata, output::provenance::SERIES_SCHEMA);
        Tables {
            runs: ParquetSink::new(&dir.join("runs.parquet"), metadata),
            series: ParquetSink::new(&dir.join("series.parquet"), series),
            trace: None,
            seeds,
            names,
        }
    }

    /// Also writes `dir/trace.parquet`, the per-step trace (SPEC 14), with the batches
    /// recording it.
    pub fn with_trace(mut self, dir: &Path) -> Tables {
        let metadata = output::with_schema(self.runs.metadata(), output::provenance::TRACE_SCHEMA);
        self.trace = Some(ParquetSink::new(&dir.join("trace.parquet"), metadata));
        self
    }

    /// Completes both files; returns their paths (runs first).
    pub fn finish(self) -> Result<[PathBuf; 2], OutputError> {
        let (pair, trace) = self.finish_all()?;
        debug_assert!(trace.is_none(), "a traced run commits three files");
        Ok(pair)
    }

    /// Completes every file; returns the paths of runs and series, and of the trace when
    /// written. The files are completed side by side: each compresses its last pages, writes
    /// its footer and waits for its sync, after the simulation.
    pub fn finish_all(self) -> Result<([PathBuf; 2], Option<PathBuf>), OutputError> {
        let Tables {
            runs,
            series,
            trace,
            ..
        } = self;
        let (trace, (runs, series)) = rayon::join(
            || trace.map(ParquetSink::finish).transpose(),
            || rayon::join(|| runs.finish(), || series.finish()),
        );
        Ok(([runs?, series?], trace?))
    }
}

impl Writer for Tables {
    type Error = OutputError;

    fn write(&mut self, batch: &Batch, profiles: &[usize]) -> Result<(), OutputError> {
        let traced = self.trace.is_some();
        let ([runs, series], trace) =
            tables_and_trace(batch, self.seeds, &self.names, profiles, traced)?;
        // Side by side: each file's columns are encoded in parallel already, but a table of
        // few columns leaves a thread idle.
        let (trace_written, (runs_written, series_written)) = rayon::join(
            || match (&mut self.trace, trace) {
                (Some(sink), Some(trace)) => sink.write(&trace),
                _ => Ok(()),
            },
            || rayon::join(|| self.runs.write(&runs), || self.series.write(&series)),
        );
        trace_written.and(runs_written).and(series_written)
    }

    fn traces(&self) -> bool {
        self.trace.is_some()
    }
}

/// Estimated bytes of an Arrow/Parquet series row beyond the task name: about 35 numeric
/// columns, 6 short strings and the writer's buffered encoding.
const SERIES_ROW_BYTES: u64 = 512;

/// Estimated bytes of a run's row in runs.parquet and its per-run records.
const RUN_ROW_BYTES: u64 = 2048;

/// Estimated bytes of a trace row as Arrow columns (about 41: 8 for the run index, 4 each for
/// step and states, 2 for the action, 8 each for reward and p_mb, a byte per dictionary code)
/// and in the Parquet writer's buffers until its row group is flushed.
pub const TRACE_ROW_BYTES: u64 = 64;

/// Bytes one run of `params` on `spec` holds while its batch is simulated and written: the
/// per-run tables of [`Batch`] (Q tables, averaged distributions, MB window and model, per-state
/// costs) and its checkpoint rows, also as Arrow columns, and with `trace` its trace rows (one
/// per experiment step) likewise. An estimate, accurate to a few percent where it matters
/// (large worlds, long windows, many checkpoints).
pub fn bytes_per_run(spec: &Spec, params: &Params, trace: bool) -> u64 {
    memory_parts(spec, params, trace)
        .iter()
        .map(|&(b, _)| b)
        .sum()
}

/// The parts of [`bytes_per_run`], each with the flag that shrinks it.
fn memory_parts(spec: &Spec, params: &Params, trace: bool) -> [(u64, &'static str); 4] {
    // The batch's own table of per-run arrays, sized for this run alone; the MB window's ring
    // apart, as it has its own flag.
    let sizes = crate::batch::Sizes::of(spec, std::iter::once(params), spec.outcome_state.len());
    let unwindowed = crate::batch::Sizes {
        window_cap: 0,
        ..sizes
    };
    let tables = (unwindowed.bytes() + crate::batch::RUN_RECORD_BYTES) as u64 + RUN_ROW_BYTES;
    let window = (sizes.bytes() - unwindowed.bytes()) as u64;
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
        (
            if trace {
                let rows = crate::batch::trace_rows(params) as u64;
                rows.saturating_mul(crate::batch::trace::ROW_BYTES as u64 + TRACE_ROW_BYTES)
            } else {
                0
            },
            "lower --steps, or leave out --trace",
        ),
    ]
}

/// Memory a batch may use when the system does not say how much there is.
const DEFAULT_BATCH_BYTES: u64 = 2 << 30;

/// A batch size planned for the memory this process may use.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatchPlan {
    /// Runs simulated at once.
    pub size: usize,
    /// Estimated bytes of the largest run ([`bytes_per_run`]).
    pub per_run: u64,
    /// Bytes a batch may take: a share of what the tightest limit leaves
    /// ([`limits::Bound::batch_share`]).
    pub budget: u64,
    /// The tightest limit ([`limits::memory`]), `None` when the system says nothing.
    pub bound: Option<limits::Bound>,
}

/// A job that cannot get the memory it needs.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MemoryError {
    /// One run alone needs more than the tightest limit leaves: refused before the first step.
    #[error(
        "one run needs about {need} of memory, more than the {room} left by {bound}: {fix} \
         ({states} states x {actions} actions, window-n {window_n}, {rows} series rows per run)"
    )]
    RunTooLarge {
        /// Estimated bytes of the run.
        need: String,
        /// Bytes the limit leaves.
        room: String,
        /// The limit that binds.
        bound: String,
        /// The flag that shrinks the run.
        fix: &'static str,
        /// States of the task.
        states: usize,
        /// Actions of the task.
        actions: usize,
        /// The run's window.
        window_n: u32,
        /// Its checkpoint rows.
        rows: usize,
    },
    /// The memory of a batch could not be obtained when it was about to be allocated.
    #[error(
        "cannot allocate about {need} for a batch of {runs} run(s): out of memory under {bound}; \
         lower --batch-size, or raise --checkpoint or lower --steps (fewer series rows per run)"
    )]
    Allocation {
        /// Bytes asked for.
        need: String,
        /// Runs of the batch.
        runs: usize,
        /// The tightest limit when it failed.
        bound: String,
    },
}

/// Runs to simulate at once: `requested`, lowered so that a batch fits in a share (half, a
/// quarter under a resource limit) of the memory the tightest limit leaves (the memory available, the cgroup's limit, `ulimit -v` or
/// `ulimit -d`; [`limits::memory`]). A run that alone needs more than that limit leaves is
/// refused, naming the limit and the flag that would shrink it, instead of failing an
/// allocation midway.
pub fn plan_batch(
    spec: &Spec,
    configs: &[RunConfig],
    requested: usize,
    trace: bool,
) -> Result<BatchPlan, MemoryError> {
    let bound = limits::memory();
    let Some(largest) = configs
        .iter()
        .max_by_key(|c| bytes_per_run(spec, &c.params, trace))
    else {
        return Ok(BatchPlan {
            size: requested.max(1),
            per_run: 0,
            budget: bound
                .as_ref()
                .map_or(DEFAULT_BATCH_BYTES, |b| b.batch_share()),
            bound,
        });
    };
    let per_run = bytes_per_run(spec, &largest.params, trace).max(1);
    if let Some(b) = &bound
        && per_run > b.headroom()
    {
        let parts = memory_parts(spec, &largest.params, trace);
        let (_, fix) = parts.iter().max_by_key(|&&(b, _)| b).expect("four parts");
        return Err(MemoryError::RunTooLarge {
            need: human(per_run),
            room: human(b.headroom()),
            bound: b.to_string(),
            fix,
            states: spec.n_states,
            actions: spec.n_actions,
            window_n: largest.params.window_n,
            rows: crate::batch::checkpoint_count(&largest.params),
        });
    }
    Ok(fit_batch(per_run, requested, bound))
}

/// [`plan_batch`]'s size alone.
pub fn plan_batch_size(
    spec: &Spec,
    configs: &[RunConfig],
    requested: usize,
    trace: bool,
) -> Result<usize, MemoryError> {
    plan_batch(spec, configs, requested, trace).map(|p| p.size)
}

/// The plan for runs of at most `per_run` bytes under `bound`: `requested`, lowered to what the
/// bound's share for batches holds, at least 1.
pub fn fit_batch(per_run: u64, requested: usize, bound: Option<limits::Bound>) -> BatchPlan {
    let budget = bound
        .as_ref()
        .map_or(DEFAULT_BATCH_BYTES, |b| b.batch_share());
    let fit = usize::try_from(budget / per_run.max(1)).unwrap_or(usize::MAX);
    BatchPlan {
        size: requested.min(fit).max(1),
        per_run,
        budget,
        bound,
    }
}

/// Checks, just before a batch of `runs` runs is allocated, that the process can still get its
/// `bytes` and half as much again for encoding it: the address space is reserved and released
/// at once (nothing is touched), so that a limit reached turns into an error that cleans up
/// rather than an abort in the middle of an allocation.
fn reserve(bytes: u64, runs: usize) -> Result<(), MemoryError> {
    let want = bytes.saturating_add(bytes / 2);
    if limits::can_reserve(want) {
        return Ok(());
    }
    Err(MemoryError::Allocation {
        need: human(want),
        runs,
        bound: limits::memory().map_or_else(|| "the system's memory".into(), |b| b.to_string()),
    })
}

/// A byte count for messages.
fn human(bytes: u64) -> String {
    crate::sizing::human_bytes(u128::from(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_than_one_thread_cuts_a_job_into_four_batches_of_at_least_256_runs() {
        let on = |threads: usize, batch_size: usize, runs: u64| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| overlapped(batch_size, runs))
        };
        assert_eq!(on(1, 4096, 4096), 4096, "one thread: as planned");
        assert_eq!(on(2, 4096, 4096), 1024);
        assert_eq!(on(2, 4096, 1024), 256);
        assert_eq!(on(2, 4096, 1000), 256, "a quarter, rounded up to 256");
        assert_eq!(on(2, 4096, 100), 256, "a small job stays one batch");
        assert_eq!(on(2, 512, 100_000), 512, "never above the planned size");
        assert_eq!(on(2, 1, 4096), 1);
    }

    #[test]
    fn overlapping_batches_cut_the_last_in_two_when_each_half_holds_64_runs() {
        assert_eq!(
            cuts(1024, 256, true),
            [0..256, 256..512, 512..768, 768..896, 896..1024]
        );
        assert_eq!(
            cuts(1024, 256, false),
            [0..256, 256..512, 512..768, 768..1024]
        );
        assert_eq!(
            cuts(1000, 256, true),
            [0..256, 256..512, 512..768, 768..884, 884..1000]
        );
        assert_eq!(
            cuts(300, 256, true),
            [0..256, 256..300],
            "a last batch of 44 runs"
        );
        let one = cuts(1024, 4096, true);
        assert_eq!(one.len(), 1, "one batch: nothing to overlap");
        assert_eq!(one[0], 0..1024);
        assert_eq!(cuts(0, 256, true), Vec::<Range<usize>>::new());
        assert_eq!(cuts(5, 0, false), [0..1, 1..2, 2..3, 3..4, 4..5]);
    }

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
            let estimate = bytes_per_run(&spec, &params, false) as f64;
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
