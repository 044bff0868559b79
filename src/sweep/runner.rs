//! Running a sweep (or one shard of it) into its dataset folder: find what is missing, pack the
//! missing runs into batches of heterogeneous runs of one task, simulate each batch and write it
//! as one part. Only one batch is in memory at a time.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::file::Sweep;
use super::shard::Shard;
use super::store::{self, Lock, StoreError};
use crate::batch::Batch;
use crate::env::Spec;
use crate::output::{self, OutputError};
use crate::params::ConfigError;
use crate::pipeline::{self, Group};

/// How to run a sweep.
#[derive(Debug, Clone)]
pub struct Options {
    /// The dataset folder.
    pub out: PathBuf,
    /// Run what is missing from `out` instead of refusing a folder that holds results.
    pub resume: bool,
    /// The slice of configurations this process runs.
    pub shard: Shard,
    /// Runs per batch, and so per part file (bounds memory; results do not depend on it).
    pub batch_size: usize,
    /// The command recorded in every file's provenance (`mbmf_command`).
    pub command: String,
}

/// What [`execute`] tells whoever watches it, in this order: warnings and the resume notice,
/// then the start, then progress.
#[derive(Debug, Clone, Copy)]
pub enum Event<'a> {
    /// Something the user should know, such as a stale lock taken over.
    Warning(&'a str),
    /// Some runs of the shard were already in the folder.
    Resuming {
        /// Runs of the shard already done.
        done: u64,
        /// Runs of the shard.
        of: u64,
        /// Runs left to run.
        to_run: u64,
    },
    /// Simulation starts: the agent-steps (babbling included) it will take.
    Started {
        /// Agent-steps to simulate.
        agent_steps: u64,
    },
    /// Agent-steps advanced since the last event.
    Advanced(u64),
    /// A part was written.
    Ran {
        /// Runs written so far.
        ran: u64,
        /// Runs this process writes.
        to_run: u64,
    },
}

/// A sweep that could not be run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The dataset folder refused.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Encoding results failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A configuration the engine refused (validation should have caught it).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// `stop` was set: the parts written before it are committed, nothing else of this run is
    /// left, and `--resume` runs the rest.
    #[error(transparent)]
    Interrupted(#[from] pipeline::Interrupted),
    /// A batch's memory could not be obtained.
    #[error(transparent)]
    Memory(#[from] pipeline::MemoryError),
}

impl RunError {
    /// Whether the user can fix it by changing the command or the folder (exit 2), rather than
    /// a failure while running (exit 1).
    pub fn is_usage(&self) -> bool {
        match self {
            RunError::Store(s) => s.is_usage(),
            RunError::Memory(m) => matches!(m, pipeline::MemoryError::RunTooLarge { .. }),
            _ => false,
        }
    }
}

/// What one process did.
#[derive(Debug, Clone)]
pub struct Report {
    /// The dataset folder.
    pub out: PathBuf,
    /// The shard run.
    pub shard: Shard,
    /// Runs of the sweep.
    pub total: u64,
    /// Runs of this shard.
    pub shard_runs: u64,
    /// Runs of this shard already in the folder at the start.
    pub shard_done_before: u64,
    /// Runs of the whole sweep in the folder at the start.
    pub done_before: u64,
    /// Runs simulated and written by this process.
    pub ran: u64,
    /// Parts written by this process.
    pub parts_written: usize,
    /// Runs per batch (and so per part): the requested size, lowered to fit in memory.
    pub batch_size: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl Report {
    /// The one-line summary printed at the end.
    pub fn line(&self) -> String {
        let rate = if self.seconds > 0.0 {
            self.ran as f64 / self.seconds
        } else {
            0.0
        };
        let dataset = self.done_before + self.ran;
        let whose = if self.shard == Shard::ALL {
            String::new()
        } else {
            format!(" (shard {})", self.shard)
        };
        let status = if dataset == self.total {
            format!("dataset complete: {} runs", self.total)
        } else {
            format!(
                "dataset holds {dataset} of {} runs (other shards add the rest)",
                self.total
            )
        };
        format!(
            "wrote {}{whose}: {} runs in {:.1} s ({rate:.1} runs/s), {} part(s); {status}",
            self.out.display(),
            self.ran,
            self.seconds,
            self.parts_written
        )
    }
}

/// Key-value metadata of every file written for `shard` of `sweep` by `command`: the
/// provenance, the sweep.
pub fn metadata(sweep: &Sweep, shard: Shard, command: &str) -> Vec<(String, String)> {
    let origin = output::SweepOrigin {
        text: &sweep.text,
        file: &sweep.file,
        runs: sweep.runs(),
        seeds: sweep.seeds,
        shard: (shard != Shard::ALL).then_some((shard.index, shard.count)),
    };
    output::metadata(command, sweep.master_seed, Some(&origin))
}

/// A sweep's dataset folder, written one part (a runs file and a series file, and a trace file
/// when traced) per batch.
struct Parts<'a> {
    sweep: &'a Sweep,
    dir: &'a Path,
    metadata: Vec<(String, String)>,
    trace: bool,
}

impl pipeline::Writer for Parts<'_> {
    type Error = StoreError;

    fn write(&mut self, batch: &Batch, profiles: &[usize]) -> Result<(), StoreError> {
        let sweep = self.sweep;
        let indices = batch.configs().iter().map(|c| c.run_index);
        let (first, last) = (indices.clone().min(), indices.max());
        let name = store::part_name(first.unwrap_or(0), last.unwrap_or(0), sweep.runs());
        let seeds = u64::from(sweep.seeds);
        let ([runs, series], trace) =
            pipeline::tables_and_trace(batch, seeds, &sweep.profile_names, profiles, self.trace)?;
        store::write_part(
            self.dir,
            &name,
            &runs,
            &series,
            trace.as_ref(),
            &self.metadata,
        )
    }

    fn traces(&self) -> bool {
        self.trace
    }
}

/// What the runs of one part share: task, text parameters and profile (see [`plan`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct PartKey(usize, [&'static str; 4], usize);

impl PartKey {
    /// The key of a configuration's runs.
    pub fn of(resolved: &super::file::Resolved) -> PartKey {
        let p = &resolved.params;
        PartKey(
            resolved.task,
            [
                p.controller.name(),
                p.selection.name(),
                p.cost_model.name(),
                p.human.interaction.name(),
            ],
            resolved.profile,
        )
    }
}

/// Counts the parts [`plan`] makes of configurations added in order, without building their
/// runs: for sizing a sweep before it starts.
#[derive(Debug)]
pub struct PartCount {
    /// Runs per batch at most (at least 1).
    batch: u128,
    pending: std::collections::BTreeMap<PartKey, u128>,
    closed: u128,
    /// Configurations added in bulk, per key, of `seeds` runs each ([`PartCount::add_many`]).
    bulk: std::collections::BTreeMap<(PartKey, u128), u128>,
}

impl PartCount {
    /// No configuration yet, in batches of at most `batch_size` runs.
    pub fn new(batch_size: usize) -> PartCount {
        PartCount {
            batch: (batch_size as u128).max(1),
            pending: Default::default(),
            closed: 0,
            bulk: Default::default(),
        }
    }

    /// Adds `runs` runs of a configuration with `key`.
    pub fn add(&mut self, key: PartKey, runs: u128) {
        let batch = self.batch;
        let open = self.pending.entry(key).or_default();
        // As `plan`: a batch is closed before a configuration that would not fit.
        if *open > 0 && *open + runs > batch {
            self.closed += 1;
            *open = 0;
        }
        *open += runs;
        self.closed += *open / batch;
        *open %= batch;
    }

    /// Adds `configs` configurations of `seeds` runs each with `key` (a sample standing for
    /// many), counted in closed form once every one is added.
    pub fn add_many(&mut self, key: PartKey, configs: u128, seeds: u128) {
        *self.bulk.entry((key, seeds)).or_default() += configs;
    }

    /// The parts, once every configuration was added.
    pub fn parts(&self) -> u128 {
        let batch = self.batch;
        let bulk: u128 = self
            .bulk
            .iter()
            .map(|(&(_, seeds), &configs)| {
                let seeds = seeds.max(1);
                if seeds >= batch {
                    // Each configuration alone fills its batches: ceil(seeds / batch) parts.
                    configs.saturating_mul(seeds.div_ceil(batch))
                } else {
                    // batch / seeds whole configurations per part (the next would not fit).
                    configs.div_ceil(batch / seeds)
                }
            })
            .sum();
        self.closed + self.pending.values().filter(|&&n| n > 0).count() as u128 + bulk
    }
}

/// The runs of `shard` not in `done`, grouped into batches of one task of at most `batch_size`
/// runs, handed to `emit` one by one with their task's index (so only a few batches exist at a
/// time).
///
/// A batch holds one value of every text parameter (task, controller, selection, cost model,
/// interaction, profile), so each part's statistics show a single value and a reader filtering
/// on one (`controller == "ec"`) skips every other part. A batch is closed before a
/// configuration that would not fit, so a configuration's runs share a part unless it alone has
/// more than `batch_size` runs, and they come in seed order.
pub fn plan<E>(
    sweep: &Sweep,
    shard: Shard,
    done: &store::RunSet,
    batch_size: usize,
    mut emit: impl FnMut(usize, Group) -> Result<(), E>,
) -> Result<(), E> {
    let mut pending: std::collections::BTreeMap<PartKey, Group> = Default::default();
    let seeds = u64::from(sweep.seeds);
    let batch_size = batch_size.max(1);
    for config in shard.configs(sweep.configurations()) {
        let missing = missing_runs(done, config, seeds) as usize;
        if missing == 0 {
            continue;
        }
        let resolved = sweep.resolve(config);
        let key = PartKey::of(&resolved);
        let group = pending.entry(key).or_default();
        if !group.configs.is_empty() && group.configs.len() + missing > batch_size {
            emit(resolved.task, std::mem::take(group))?;
        }
        for s in (0..seeds).filter(|&s| !done.contains(config * seeds + s)) {
            let run = pipeline::run_config(resolved.params, sweep.master_seed, config, seeds, s);
            group.push(run, resolved.schedule, resolved.profile);
            if group.configs.len() >= batch_size {
                emit(resolved.task, std::mem::take(group))?;
            }
        }
    }
    for (PartKey(task, _, _), group) in pending {
        if !group.configs.is_empty() {
            emit(task, group)?;
        }
    }
    Ok(())
}

/// Runs of configuration `config` (of `seeds` runs each) not in `done`.
fn missing_runs(done: &store::RunSet, config: u64, seeds: u64) -> u64 {
    let first = config * seeds;
    (0..seeds).filter(|s| !done.contains(first + s)).count() as u64
}

/// Runs of `shard` already committed in `out` (0 when it holds no dataset): what a `--resume`
/// would not run again; a folder of another sweep is refused, as the resume refuses it. Reads
/// the parts' run indices without locking, writing or deleting.
pub fn already_written(sweep: &Sweep, shard: Shard, out: &Path) -> Result<u64, StoreError> {
    // Another sweep's runs are not this one's (the resume itself refuses that folder).
    store::same_sweep(out, &sweep.text, &sweep.file)?;
    if !out.join(store::RUNS_DIR).is_dir() {
        return Ok(0);
    }
    let seeds = u64::from(sweep.seeds);
    let owned = |first_run: u64| shard.owns(first_run / seeds);
    let scan = store::scan(out, sweep.runs(), &owned)?;
    Ok(shard
        .configs(sweep.configurations())
        .map(|config| seeds - missing_runs(&scan.done, config, seeds))
        .sum())
}

/// Runs `sweep` (the shard of `options`) into `options.out`, telling `events` what happens.
/// Once `stop` is set, the run ends within one simulation stride with
/// [`RunError::Interrupted`], its lock released and no temporary file left.
pub fn execute(
    sweep: &Sweep,
    specs: &[Arc<Spec>],
    options: &Options,
    stop: &AtomicBool,
    events: &mut (dyn FnMut(Event<'_>) + Send),
) -> Result<Report, RunError> {
    let started = Instant::now();
    let out = &options.out;
    let shard = options.shard;
    let total = sweep.runs();
    let seeds = u64::from(sweep.seeds);
    // Fail in a second, not after an hour: the folder is checked and locked before simulating.
    store::check_folder(out, &sweep.text, &sweep.file)?;
    let (_lock, stale) = Lock::acquire(out, shard)?;
    if let Some(w) = stale {
        events(Event::Warning(&w));
    }
    store::init_folder(out, &sweep.text, &sweep.file)?;
    let owned = |first_run: u64| shard.owns(first_run / seeds);
    let scan = store::scan(out, total, &owned)?;
    for stray in &scan.strays {
        events(Event::Warning(&store::stray_warning(stray)));
    }
    if !options.resume && (scan.own_parts > 0 || !scan.leftovers.is_empty()) {
        return Err(StoreError::AlreadyStarted {
            dir: out.clone(),
            parts: scan.own_parts + scan.leftovers.len(),
        }
        .into());
    }
    store::remove_leftovers(&scan.leftovers)?;
    // A sweep is traced from its start: asked by its file (or `--trace`), or found traced.
    let trace_dir = out.join(store::TRACE_DIR);
    let trace = sweep.trace || trace_dir.is_dir();
    if trace && !trace_dir.is_dir() {
        if scan.parts > 0 {
            return Err(StoreError::UntracedParts {
                dir: out.clone(),
                parts: scan.parts,
            }
            .into());
        }
        std::fs::create_dir_all(&trace_dir).map_err(|cause| StoreError::Io {
            action: "create",
            path: trace_dir.clone(),
            cause,
        })?;
    }

    let mut shard_runs = 0u64;
    let mut shard_done = 0u64;
    let mut steps_to_run = 0u64;
    // The run needing the most memory (its task and configuration) sizes the batches.
    let mut largest: Option<(u64, usize, crate::batch::RunConfig)> = None;
    for config in shard.configs(sweep.configurations()) {
        shard_runs += seeds;
        let missing = missing_runs(&scan.done, config, seeds);
        shard_done += seeds - missing;
        if missing > 0 {
            let resolved = sweep.resolve(config);
            steps_to_run += missing * pipeline::run_steps(&resolved.params);
            let bytes = pipeline::bytes_per_run(&specs[resolved.task], &resolved.params, trace);
            if largest.is_none_or(|(b, _, _)| bytes > b) {
                let run =
                    pipeline::run_config(resolved.params, sweep.master_seed, config, seeds, 0);
                largest = Some((bytes, resolved.task, run));
            }
        }
    }
    let batch_size = match largest {
        Some((_, task, run)) => {
            pipeline::plan_batch_size(&specs[task], &[run], options.batch_size, trace)?
        }
        None => options.batch_size.max(1),
    };
    let to_run = shard_runs - shard_done;
    if shard_done > 0 {
        events(Event::Resuming {
            done: shard_done,
            of: shard_runs,
            to_run,
        });
    }
    events(Event::Started {
        agent_steps: steps_to_run,
    });
    let mut job = pipeline::Job {
        schedules: &sweep.schedules,
        batch_size,
        writer: Parts {
            sweep,
            dir: out,
            metadata: metadata(sweep, shard, &options.command),
            trace,
        },
    };
    let mut ran = 0u64;
    let mut parts_written = 0usize;
    events(Event::Ran { ran: 0, to_run });
    plan(sweep, shard, &scan.done, job.batch_size, |task, group| {
        let progress = |n| {
            events(Event::Advanced(n));
            pipeline::unless_stopped(stop)
        };
        job.simulate(&specs[task], &group, progress, |_| Ok::<(), RunError>(()))?;
        ran += group.configs.len() as u64;
        parts_written += 1;
        events(Event::Ran { ran, to_run });
        Ok::<(), RunError>(())
    })?;
    Ok(Report {
        out: out.clone(),
        shard,
        total,
        shard_runs,
        shard_done_before: shard_done,
        done_before: scan.done.len(),
        ran,
        parts_written,
        batch_size,
        seconds: started.elapsed().as_secs_f64(),
    })
}

pub use crate::sizing::{Estimate, human_duration};

/// Configurations resolved to estimate a shard: beyond this, a shard stands for them through
/// the axes that set the cost of a run ([`Sweep::representatives`]).
pub const ENUMERATE_LIMIT: u64 = 100_000;

/// Estimates the time of the runs of `shard` by timing up to eight sample runs of every (task,
/// controller) group, the factors that set a run's cost.
pub fn estimate(sweep: &Sweep, specs: &[Arc<Spec>], shard: Shard) -> Result<Estimate, ConfigError> {
    use super::keys::Key;
    struct Group {
        task: usize,
        controller: crate::params::Controller,
        agent_steps: u128,
        configs: u64,
        samples: Vec<u64>,
    }
    /// Sample runs per group, spread evenly over the group's configurations.
    const SAMPLES: u64 = 8;
    let mut groups: Vec<Group> = Vec::new();
    let seeds = u64::from(sweep.seeds);
    let group_of = |groups: &[Group], r: &super::file::Resolved| {
        groups
            .iter()
            .position(|g| g.task == r.task && g.controller == r.params.controller)
    };
    let keys = [
        Key::Task,
        Key::named("controller"),
        Key::named("steps"),
        Key::named("babbling"),
    ];
    let reps = sweep.representatives(shard, &keys, ENUMERATE_LIMIT);
    for &(config, weight) in &reps.configs {
        let r = sweep.resolve(config);
        let steps = weight * u128::from(seeds) * u128::from(pipeline::run_steps(&r.params));
        match group_of(&groups, &r) {
            Some(g) => {
                groups[g].agent_steps += steps;
                groups[g].configs += 1;
            }
            None => groups.push(Group {
                task: r.task,
                controller: r.params.controller,
                agent_steps: steps,
                configs: 1,
                samples: Vec::new(),
            }),
        }
    }
    // Second pass: the k-th of SAMPLES evenly spaced positions within each group.
    let mut seen = vec![0u64; groups.len()];
    for &(config, _) in &reps.configs {
        let r = sweep.resolve(config);
        let Some(g) = group_of(&groups, &r) else {
            continue;
        };
        let n = groups[g].configs;
        let k = SAMPLES.min(n);
        let next = groups[g].samples.len() as u64;
        if next < k && seen[g] == (next * (n - 1)).checked_div(k - 1).unwrap_or(0) {
            groups[g].samples.push(config);
        }
        seen[g] += 1;
    }
    let groups: Vec<crate::sizing::SampleGroup> = groups
        .iter()
        .map(|g| crate::sizing::SampleGroup {
            task: g.task,
            samples: g
                .samples
                .iter()
                .map(|&config| {
                    let params = sweep.resolve(config).params;
                    pipeline::run_config(params, sweep.master_seed, config, seeds, 0)
                })
                .collect(),
            agent_steps: g.agent_steps,
        })
        .collect();
    crate::sizing::time(specs, &groups)
}
