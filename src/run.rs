//! What `mbmf run` does, as a library entry: a few configurations of one task (in the CLI, one
//! per controller), `runs` runs of each, simulated in windows of batches and written as the
//! committed pair `runs.parquet` / `series.parquet` of one output folder.
//!
//! A front end fills a [`Job`] and either calls [`execute`] (check, size, open, simulate and
//! commit in one call) or the steps one by one, as the CLI does to show what each step found
//! before the next: [`Run::new`] checks every input and finds the [`Run::warnings`];
//! [`Run::size`] refuses a job the machine cannot hold and plans the batches; [`Run::open`]
//! checks the output folder and creates its staging folder; [`Open::simulate`] runs everything,
//! reporting progress and honouring a stop flag, and commits both files at once. Nothing is
//! printed: warnings, notes and the summary are data.
//!
//! ```no_run
//! use std::sync::{Arc, atomic::AtomicBool};
//! use mbmf::params::{Controller, Params};
//!
//! let spec = Arc::new(mbmf::env::load("tidy1")?);
//! let ec = Params { controller: Controller::Ec, steps: 2_000, ..Params::default() };
//! let job = mbmf::run::Job::new("tidy1", spec, vec![ec], "out/ec");
//! let done = mbmf::run::execute(job, &AtomicBool::new(false), |_| {})?;
//! let [runs, series] = &done.files; // the committed pair, in "out/ec"
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use arrow::record_batch::RecordBatch;

use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::env::registry::{self, Metric};
use crate::error::IoError;
use crate::output::{self, OutputError};
use crate::params::{Combine, ConfigError, Controller, Interaction, Params};
use crate::pipeline::{self, Interrupted, MemoryError};
use crate::schedule::{self, Schedule, ScheduleError};
use crate::sizing::{self, SizeError};

/// Batches whose configurations are built at once: enough to keep every thread busy, few
/// enough that the configurations of a million-run job are never all in memory.
const BATCHES_PER_WINDOW: usize = 16;

/// A job: what `mbmf run` is asked.
#[derive(Debug, Clone)]
pub struct Job {
    /// The task as the caller names it (in the summary and messages).
    pub task: String,
    /// The task itself.
    pub spec: Arc<Spec>,
    /// The configurations, each run `runs` times; configuration `c`'s runs are runs
    /// `c * runs ..` of the job (its `config_index` is `c`).
    pub configs: Vec<Params>,
    /// Runs per configuration, >= 1.
    pub runs: u32,
    /// Master seed; with the run index it fixes each run's random stream.
    pub seed: u64,
    /// Changes during every run.
    pub schedule: Schedule,
    /// Output folder of runs.parquet and series.parquet (created if needed).
    pub out: PathBuf,
    /// Replace the results of an earlier run in `out` (refused otherwise).
    pub force: bool,
    /// Runs simulated at once, lowered to fit memory; results do not depend on it.
    pub batch_size: usize,
    /// Parameters the caller set explicitly (registry names), for the warnings about settings
    /// that have no effect.
    pub set: Vec<&'static str>,
    /// The command recorded in both files' provenance (`mbmf_command`).
    pub command: String,
    /// Also write `trace.parquet`, one row per experiment step of every run (SPEC 14).
    pub trace: bool,
}

impl Job {
    /// A job of 20 runs of each configuration of `task` into `out`, with `mbmf run`'s defaults
    /// (seed 1, no change, batches of 4,096).
    pub fn new(task: &str, spec: Arc<Spec>, configs: Vec<Params>, out: impl Into<PathBuf>) -> Job {
        Job {
            task: task.to_string(),
            spec,
            configs,
            runs: 20,
            seed: 1,
            schedule: Schedule::default(),
            out: out.into(),
            force: false,
            batch_size: 4096,
            set: Vec::new(),
            command: format!("mbmf::run {task}"),
            trace: false,
        }
    }

    /// Run `i` of the job: run `i % runs` of configuration `i / runs`, built on demand so that
    /// memory does not grow with `runs`.
    fn config_at(&self, i: u64) -> RunConfig {
        let per = u64::from(self.runs);
        let config = i / per;
        pipeline::run_config(
            self.configs[config as usize],
            self.seed,
            config,
            per,
            i % per,
        )
    }

    /// Runs of the whole job.
    pub fn total(&self) -> u64 {
        self.configs.len() as u64 * u64::from(self.runs)
    }

    /// Agent-steps (babbling included) of the whole job: what progress counts up to.
    pub fn agent_steps(&self) -> u64 {
        pipeline::agent_steps(&self.firsts()) * u64::from(self.runs)
    }

    /// The first run of each configuration: the runs of one differ only by their index.
    fn firsts(&self) -> Vec<RunConfig> {
        (0..self.configs.len() as u64)
            .map(|c| self.config_at(c * u64::from(self.runs)))
            .collect()
    }
}

/// Why a run could not be done.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A configuration's parameters are out of range or do not fit the task.
    #[error(transparent)]
    Invalid(ConfigError),
    /// The schedule of changes does not fit the task or a configuration.
    #[error(transparent)]
    Change(ScheduleError),
    /// No configuration, or no run per configuration.
    #[error("nothing to run: {0}")]
    Empty(&'static str),
    /// One run does not fit in the memory this process may use, or a batch's memory could not be
    /// obtained.
    #[error(transparent)]
    Memory(Box<MemoryError>),
    /// The job's output does not fit on the disk, or it would take too long.
    #[error(transparent)]
    Size(#[from] SizeError),
    /// The output folder cannot take the results (a file in the way, earlier results without
    /// `force`).
    #[error("{0}")]
    Out(String),
    /// A file system operation failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The summary's temporary file could not be written.
    #[error(transparent)]
    Spill(std::io::Error),
    /// A batch refused its runs.
    #[error(transparent)]
    Simulation(ConfigError),
    /// A Parquet file could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The stop flag was raised: nothing was written to the output folder.
    #[error(transparent)]
    Interrupted(#[from] Interrupted),
}

impl crate::error::Usage for RunError {
    fn is_usage(&self) -> bool {
        matches!(
            self,
            RunError::Invalid(_)
                | RunError::Change(_)
                | RunError::Empty(_)
                | RunError::Size(_)
                | RunError::Out(_)
        ) || matches!(self, RunError::Memory(m) if crate::error::Usage::is_usage(m.as_ref()))
    }
}

// Boxed: the refusal's message parts would make every `Result<_, RunError>` large.
impl From<MemoryError> for RunError {
    fn from(e: MemoryError) -> RunError {
        RunError::Memory(Box::new(e))
    }
}

impl From<ConfigError> for RunError {
    fn from(e: ConfigError) -> RunError {
        RunError::Simulation(e)
    }
}

/// An [`std::io::Error`] with what was being done.
fn io(what: String) -> impl FnOnce(std::io::Error) -> RunError {
    |cause| IoError::doing(what)(cause).into()
}

/// A checked job; see the module documentation for the steps.
#[derive(Debug)]
pub struct Run {
    job: Job,
    warnings: Vec<String>,
    batch_size: usize,
}

impl Run {
    /// Checks every configuration (ranges, fit with the task and the schedule) and finds the
    /// inputs that are legal but almost surely mistakes.
    pub fn new(job: Job) -> Result<Run, RunError> {
        if job.configs.is_empty() {
            return Err(RunError::Empty("no configuration"));
        }
        if job.runs == 0 {
            return Err(RunError::Empty("0 runs per configuration"));
        }
        for p in &job.configs {
            p.validate().map_err(RunError::Invalid)?;
        }
        for p in &job.configs {
            crate::env::registry::check_params(&job.spec, p).map_err(RunError::Invalid)?;
            schedule::compile(&job.spec, &job.schedule, p).map_err(RunError::Change)?;
        }
        let warnings = warnings(&job);
        let batch_size = job.batch_size;
        Ok(Run {
            job,
            warnings,
            batch_size,
        })
    }

    /// Legal inputs that are almost surely mistakes, each cause once, naming `mbmf run`'s flags.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The job.
    pub fn job(&self) -> &Job {
        &self.job
    }

    /// Sizes the job before anything is allocated: refuses one whose run does not fit in memory,
    /// whose results cannot fit on the disk or that would run for more than a year, and plans
    /// the batches. Returns a note with the estimated time and output of a huge job (the
    /// estimate of `mbmf sweep --dry-run`; measuring it simulates a few runs briefly).
    pub fn size(&mut self) -> Result<Option<String>, RunError> {
        let job = &self.job;
        // Memory first (a run that cannot fit is refused whatever the disk), on one run per
        // configuration: the batch plan depends on the largest run, not on how many there are.
        let firsts = job.firsts();
        pipeline::plan_batch_size(&job.spec, &firsts, job.batch_size, job.trace)?;
        let mut size = sizing::Size::default();
        for p in &job.configs {
            size.add(u128::from(job.runs), p, job.trace);
        }
        let shrink = sizing::Shrink {
            runs: "lower --runs (runs per controller) or give fewer --controller".into(),
            series: "raise --checkpoint (0 writes no series rows), or lower --steps or --runs"
                .into(),
            time: "lower --runs or --steps, or give fewer --controller".into(),
            parts: None,
        };
        // With `force` the results already there are replaced, so their space counts as free.
        let credit = if job.force {
            ["runs.parquet", "series.parquet", "trace.parquet"]
                .iter()
                .filter_map(|f| std::fs::metadata(job.out.join(f)).ok())
                .map(|m| m.len())
                .sum()
        } else {
            0
        };
        sizing::check_size(&size, &job.out, credit, &shrink)?;
        let mut note = None;
        if size.is_huge() {
            let per = u64::from(job.runs);
            let groups: Vec<sizing::SampleGroup> = (0..job.configs.len() as u64)
                .map(|c| sizing::SampleGroup {
                    task: 0,
                    samples: (0..per.min(2))
                        .map(|r| job.config_at(c * per + r))
                        .collect(),
                    agent_steps: u128::from(per)
                        * u128::from(pipeline::run_steps(&job.configs[c as usize])),
                })
                .collect();
            let estimate = sizing::time(std::slice::from_ref(&job.spec), &groups)
                .map_err(RunError::Invalid)?;
            sizing::check_time(&estimate, &shrink)?;
            note = Some(format!(
                "{}; estimated time: about {} with {} thread(s)",
                size.line(),
                sizing::human_duration(estimate.seconds),
                estimate.threads
            ));
        }
        self.batch_size = pipeline::plan_batch_size(&job.spec, &firsts, job.batch_size, job.trace)?;
        Ok(note)
    }

    /// Runs simulated at once: the job's batch size, lowered by [`Run::size`] so that a batch
    /// fits in memory.
    pub fn batch_size(&self) -> usize {
        self.batch_size
    }

    /// Checks and creates the output folder, and its staging folder where both files are
    /// written until the commit. A file in the way or earlier results without `force` are
    /// usage errors; a folder that cannot be created is not. Nothing is simulated yet.
    pub fn open(self) -> Result<Open, RunError> {
        let targets = prepare_out(&self.job.out, self.job.force)?;
        let staging = Staging::create(&self.job.out)?;
        Ok(Open {
            run: self,
            targets,
            staging,
        })
    }
}

/// A run whose output folder is ready: [`Open::simulate`] does the work.
#[derive(Debug)]
pub struct Open {
    run: Run,
    targets: [PathBuf; 2],
    staging: Staging,
}

/// One configuration's summary: (mean, sample sd) of total reward, total cost, MB share and
/// mean P(MB) over its runs (the last two over the runs that made decisions; `None` if none
/// did), and of the task's headline metrics.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The controller of the runs (configurations of one controller are merged).
    pub controller: Controller,
    /// Runs summarised.
    pub runs: usize,
    /// Total reward.
    pub reward: (f64, f64),
    /// Total cost.
    pub cost: (f64, f64),
    /// Share of decisions taken by the MB expert (with `combine = mix`: weighted above 1/2,
    /// SPEC 12.1).
    pub share: Option<(f64, f64)>,
    /// A run's P(MB) averaged over its decisions (`p_mb_mean` of the runs table).
    pub weight: Option<(f64, f64)>,
    /// The runs mixed the experts' values (`combine = mix`, for a rule that gives a weight).
    pub mixes: bool,
    /// The task's headline metrics ([`crate::env::registry::Task::headline`]), in its order.
    pub headline: Vec<Headline>,
}

/// A task metric summarised over one controller's runs: (mean, sample sd) over the runs where
/// it is defined, `None` where it is defined for none (a column of nulls).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Headline {
    /// How the summary heads it ("reward effect").
    pub heading: &'static str,
    /// Its column in the runs table ("stay_reward_effect").
    pub column: &'static str,
    /// Mean and sample sd over the runs where it is defined.
    pub value: Option<(f64, f64)>,
}

/// What a finished run wrote.
#[derive(Debug, Clone)]
pub struct Done {
    /// runs.parquet and series.parquet, committed.
    pub files: [PathBuf; 2],
    /// trace.parquet, committed with them, when the job asked for the trace.
    pub trace: Option<PathBuf>,
    /// Runs simulated.
    pub runs: u64,
    /// Seconds from the first step to the commit.
    pub seconds: f64,
    /// One row per controller, in order of first appearance.
    pub rows: Vec<Row>,
    /// The warnings of [`Run::warnings`].
    pub warnings: Vec<String>,
}

impl Open {
    /// The staging folder (removed when the run ends, committed or not): a front end that may
    /// exit without unwinding (a second signal) removes it itself.
    pub fn staging(&self) -> &Path {
        &self.staging.0
    }

    /// Simulates every run, in windows of whole batches, into the staging folder, then moves
    /// both files into the output folder as one commit. `progress` is told the agent-steps
    /// advanced every few thousand steps; once `stop` is set the work ends within one stride
    /// with [`RunError::Interrupted`], nothing written to the output folder.
    pub fn simulate(
        self,
        stop: &AtomicBool,
        mut progress: impl FnMut(u64) + Send,
    ) -> Result<Done, RunError> {
        let Open {
            run,
            targets,
            staging,
        } = self;
        let job = &run.job;
        let total = job.total();
        let per = u64::from(job.runs);
        let schedules = [job.schedule.clone()];
        let metadata = output::metadata(&job.command, job.seed, None);
        let mut writer = pipeline::Tables::new(&staging.0, metadata, per, vec![]);
        if job.trace {
            writer = writer.with_trace(&staging.0);
        }
        let mut pipeline_job = pipeline::Job {
            schedules: &schedules,
            batch_size: pipeline::overlapped(run.batch_size, total),
            writer,
        };
        let mut summary = Summary::new(&job.out, &job.task);
        let started = std::time::Instant::now();
        let progress = |n| {
            progress(n);
            pipeline::unless_stopped(stop)
        };
        windows(job, &mut pipeline_job, progress, |batch| summary.add(batch))?;
        let rows = summary.rows()?;
        let ([runs_staged, series_staged], trace_staged) = pipeline_job.writer.finish_all()?;
        // The last chance to stop with nothing written: after the commit the run is complete.
        if stop.load(Ordering::Relaxed) {
            return Err(Interrupted.into());
        }
        let [runs_target, series_target] = targets;
        let trace_target = job.out.join("trace.parquet");
        let mut tables = Vec::new();
        if let Some(staged) = &trace_staged {
            tables.push(("trace", staged.as_path(), trace_target.as_path()));
        }
        tables.push(("series", &series_staged, &series_target));
        output::atomic::commit(&tables, (&runs_staged, &runs_target)).map_err(io(format!(
            "cannot move the results into {}",
            job.out.display()
        )))?;
        drop(staging);
        Ok(Done {
            files: [runs_target, series_target],
            trace: trace_staged.map(|_| trace_target),
            runs: total,
            seconds: started.elapsed().as_secs_f64(),
            rows,
            warnings: run.warnings,
        })
    }
}

impl Run {
    /// Simulates every run as [`Open::simulate`] does, writing no file: `each` is handed the
    /// runs and series tables of every finished batch of runs, in run order, with the columns
    /// of runs.parquet and series.parquet (their rows are those `mbmf run` writes, but for
    /// `wall_time_s`). `each` returning [`ControlFlow::Break`] ends the work at the next stride,
    /// as `stop` does, with [`RunError::Interrupted`], and `each` is not called again. Memory
    /// is planned as [`Run::size`] does; nothing is refused for disk space. Returns the runs
    /// simulated.
    pub fn stream(
        self,
        stop: &AtomicBool,
        mut progress: impl FnMut(u64) + Send,
        mut each: impl FnMut([RecordBatch; 2]) -> ControlFlow<()> + Send,
    ) -> Result<u64, RunError> {
        let job = &self.job;
        // A stream hands over runs and series only: its batches record no trace.
        let batch_size =
            pipeline::plan_batch_size(&job.spec, &job.firsts(), job.batch_size, false)?;
        let schedules = [job.schedule.clone()];
        let halted = AtomicBool::new(false);
        let mut pipeline_job = pipeline::Job {
            schedules: &schedules,
            batch_size,
            writer: Handed {
                seeds: u64::from(job.runs),
                each: &mut each,
                halted: &halted,
            },
        };
        let progress = |n| {
            progress(n);
            if halted.load(Ordering::Relaxed) {
                ControlFlow::Break(())
            } else {
                pipeline::unless_stopped(stop)
            }
        };
        windows(job, &mut pipeline_job, progress, |_| Ok(()))?;
        Ok(job.total())
    }
}

/// The writer of [`Run::stream`]: hands each finished batch's tables to the caller.
struct Handed<'a, F> {
    seeds: u64,
    each: &'a mut F,
    halted: &'a AtomicBool,
}

impl<F: FnMut([RecordBatch; 2]) -> ControlFlow<()> + Send> pipeline::Writer for Handed<'_, F> {
    type Error = OutputError;

    fn write(&mut self, batch: &Batch, profiles: &[usize]) -> Result<(), OutputError> {
        // A batch that finished with the stride that saw the stop is not handed over.
        if self.halted.load(Ordering::Relaxed) {
            return Ok(());
        }
        let tables = pipeline::tables(batch, self.seeds, &[], profiles)?;
        if (self.each)(tables).is_break() {
            self.halted.store(true, Ordering::Relaxed);
        }
        Ok(())
    }
}

/// Simulates every run of `job` in windows of whole batches into `pipeline_job`'s writer, so
/// that batches are cut where one call over every run cuts them and only a window's
/// configurations are in memory.
fn windows<W: pipeline::Writer + Send>(
    job: &Job,
    pipeline_job: &mut pipeline::Job<'_, W>,
    mut progress: impl FnMut(u64) -> ControlFlow<()> + Send,
    mut observe: impl FnMut(&Batch) -> Result<(), RunError> + Send,
) -> Result<(), RunError>
where
    RunError: From<W::Error>,
{
    let total = job.total();
    let window = pipeline_job.batch_size.saturating_mul(BATCHES_PER_WINDOW) as u64;
    let mut start = 0;
    while start < total {
        let end = start.saturating_add(window).min(total);
        let group = pipeline::Group {
            configs: (start..end).map(|i| job.config_at(i)).collect(),
            schedules: vec![0; (end - start) as usize],
            profiles: Vec::new(),
        };
        pipeline_job.simulate(&job.spec, &group, &mut progress, &mut observe)?;
        start = end;
    }
    Ok(())
}

/// Checks, sizes, opens and simulates `job` in one call: [`Run::new`], [`Run::size`],
/// [`Run::open`] and [`Open::simulate`].
pub fn execute(
    job: Job,
    stop: &AtomicBool,
    progress: impl FnMut(u64) + Send,
) -> Result<Done, RunError> {
    let mut run = Run::new(job)?;
    run.size()?;
    run.open()?.simulate(stop, progress)
}

/// Inputs that are legal but almost surely mistakes, as warnings naming the flag, each cause
/// once.
fn warnings(job: &Job) -> Vec<String> {
    let mut warnings = Vec::new();
    let controllers: Vec<Controller> = job.configs.iter().map(|p| p.controller).collect();
    for (first, times) in crate::suggest::repeats(&controllers) {
        warnings.push(format!(
            "--controller lists {} {times}: each listing adds --runs {} runs (with other run \
             indices), and the summary merges them into one row",
            controllers[first].name(),
            job.runs
        ));
    }
    // A budget is spent by an interaction: from the parameters, the profile, or a later change.
    let changes_human = job.schedule.changes.iter().any(|c| {
        matches!(
            c.event,
            schedule::Event::Human(
                schedule::HumanChange::Interaction(_) | schedule::HumanChange::Profile(_)
            )
        )
    });
    if job.set.contains(&"budget")
        && !changes_human
        && job
            .configs
            .iter()
            .all(|p| p.human.interaction == Interaction::None)
    {
        warnings.push(format!(
            "--budget {} has no effect: no interaction uses it (give --interaction, a \
             --profile with one, or a --change STEP:interaction=...)",
            job.configs[0].human.budget
        ));
    }
    // A rule's own parameter, or a mix, given to rules that ignore it: legal (sweeps cross
    // them with every rule on purpose), but in one run surely meant for a rule not listed.
    let mut listed: Vec<Controller> = Vec::new();
    for &c in &controllers {
        if !listed.contains(&c) {
            listed.push(c);
        }
    }
    for name in job.set.iter().copied() {
        let owners = Controller::readers(name);
        if !owners.is_empty() && !listed.iter().any(|c| owners.contains(c)) {
            warnings.push(format!(
                "{} changes nothing here: only {} reads it, and --controller lists {}",
                crate::params::cli_flag(name),
                Controller::names(&owners),
                Controller::names(&listed)
            ));
        }
    }
    if job.set.contains(&"combine") && job.configs.iter().any(|p| p.combine == Combine::Mix) {
        let ignoring: Vec<Controller> = listed.iter().copied().filter(|c| !c.combines()).collect();
        if !ignoring.is_empty() {
            let (run, their) = if ignoring.len() == 1 {
                ("runs as it would", "its rows record")
            } else {
                ("run as they would", "their rows record")
            };
            warnings.push(format!(
                "--combine mix does not apply to {}, which {run} with select ({their} \
                 combine = mix, as given)",
                Controller::names(&ignoring)
            ));
        }
    }
    if job.schedule.changes.is_empty() && !job.spec.unapplied.is_empty() {
        warnings.push(format!(
            "--task {}: {} schedules changes during the run, which mbmf applies only from \
             --change events (such as --change STEP:goal=STATE; the guide on changes during a run \
             gives the authors' goal change in full): this run's world does not change",
            job.task,
            job.spec.unapplied.join("; ")
        ));
    }
    if !job.spec.can_move() {
        warnings.push(format!("--{}", no_transition(&job.task)));
    }
    if let Some(w) = stale_analyses(job) {
        warnings.push(w);
    }
    warnings
}

/// With `force` over earlier results, the analyses written beside them (`analysis/`), which
/// the new results will not match: named, never removed (they are the user's to keep).
fn stale_analyses(job: &Job) -> Option<String> {
    if !job.force || !job.out.join("runs.parquet").is_file() {
        return None;
    }
    let folder = crate::analysis::dataset::output_folder(&job.out);
    let mut names: Vec<String> = std::fs::read_dir(&folder)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    if names.is_empty() {
        return None;
    }
    names.sort();
    let shown = if names.len() > 3 {
        format!("{}, ...", names[..3].join(", "))
    } else {
        names.join(", ")
    };
    Some(format!(
        "--force replaces the results in {}, but {} keeps {} file(s) made from them ({shown}): \
         they will describe the replaced runs until the analyses are run again",
        job.out.display(),
        folder.display(),
        names.len()
    ))
}

/// The warning for a task whose world has no transition (every action leaves every state as
/// it is): legal, but its runs are surely a mistake. Shared by `run`, `sweep` and `env info`.
pub fn no_transition(task: &str) -> String {
    format!(
        "task {task}: the world has no transition at all (every action leaves every state \
         as it is), so the robot never moves and never reaches the goal"
    )
}

/// Checks and creates the output folder; returns the paths of runs.parquet and series.parquet.
fn prepare_out(out: &Path, force: bool) -> Result<[PathBuf; 2], RunError> {
    // The nearest existing ancestor (the folder itself included) must be a folder.
    for ancestor in out.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        if let Ok(metadata) = std::fs::metadata(ancestor) {
            if !metadata.is_dir() {
                return Err(RunError::Out(format!(
                    "--out {}: {} is a file, not a folder; give a folder to write runs.parquet \
                     and series.parquet into",
                    out.display(),
                    ancestor.display()
                )));
            }
            break;
        }
    }
    std::fs::create_dir_all(out)
        .map_err(io(format!("cannot create output folder {}", out.display())))?;
    let targets = [out.join("runs.parquet"), out.join("series.parquet")];
    for target in &targets {
        if target.is_dir() {
            return Err(RunError::Out(format!(
                "--out {}: {} is a folder, so the results cannot be written under that name; \
                 remove it or choose another --out",
                out.display(),
                target.display()
            )));
        }
    }
    let earlier: Vec<String> = targets
        .iter()
        .filter(|t| t.exists())
        .map(|t| t.display().to_string())
        .collect();
    if !earlier.is_empty() && !force {
        return Err(RunError::Out(format!(
            "--out {}: it holds the results of an earlier run ({}); pass --force to replace \
             them, or choose another --out",
            out.display(),
            earlier.join(", ")
        )));
    }
    Ok(targets)
}

/// A private folder inside the output folder where both Parquet files are written; they are
/// moved into place as one commit ([`output::atomic::commit_pair`]) only when both are
/// complete. The folder and anything left in it are removed when the value is dropped.
#[derive(Debug)]
struct Staging(PathBuf);

impl Staging {
    /// Creates the folder; this is also the check that the output folder accepts new files,
    /// done before anything is simulated.
    fn create(out: &Path) -> Result<Staging, RunError> {
        // Staging folders of killed runs hold nothing of use.
        output::atomic::remove_dead_staging(out);
        let dir = out.join(format!(".mbmf-run-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(io(format!(
            "cannot write into output folder {}",
            out.display()
        )))?;
        Ok(Staging(dir))
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        // Best effort: after a commit only the empty folder is left.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One controller's values of the summary, spilled to an unnamed temporary file (32 bytes per
/// run) so that memory does not grow with the runs, and read back in passes to compute the
/// exact two-pass statistics of [`mean_sd`] (a one-pass formula would move the last printed
/// digit of some means).
struct Spill {
    controller: Controller,
    mixes: bool,
    runs: usize,
    file: std::io::BufWriter<std::fs::File>,
}

/// Per-controller results, accumulated batch by batch.
struct Summary {
    /// Where the spill files are created (unnamed: nothing is left behind, even after a kill).
    dir: PathBuf,
    /// The task's headline metrics: (heading, metric).
    headline: Vec<(&'static str, &'static Metric)>,
    spills: Vec<Spill>,
}

impl Summary {
    fn new(dir: &Path, task: &str) -> Summary {
        let headline = registry::find(task).map_or(&[][..], |t| t.headline);
        Summary {
            dir: dir.to_path_buf(),
            headline: headline
                .iter()
                .filter_map(|&(heading, name)| Some((heading, registry::metric(name)?)))
                .collect(),
            spills: Vec::new(),
        }
    }

    /// Values per run in a spill file: total reward, total cost, MB share, mean P(MB), then
    /// the headline metrics (NaN where null).
    fn width(&self) -> usize {
        4 + self.headline.len()
    }

    fn add(&mut self, batch: &Batch) -> Result<(), RunError> {
        use std::io::Write as _;
        for (r, (config, stats)) in batch.configs().iter().zip(batch.stats()).enumerate() {
            let c = config.params.controller;
            let i = match self.spills.iter().position(|s| s.controller == c) {
                Some(i) => i,
                None => {
                    let file = tempfile::tempfile_in(&self.dir).map_err(io(format!(
                        "cannot create a temporary file in {}",
                        self.dir.display()
                    )))?;
                    self.spills.push(Spill {
                        controller: c,
                        mixes: c.combines() && config.params.combine == Combine::Mix,
                        runs: 0,
                        file: std::io::BufWriter::new(file),
                    });
                    self.spills.len() - 1
                }
            };
            let per_decision = |x: f64| {
                if stats.decisions > 0 {
                    x / stats.decisions as f64
                } else {
                    f64::NAN
                }
            };
            let share = per_decision(stats.mb_decisions as f64);
            let weight = per_decision(stats.p_mb_sum);
            let spill = &mut self.spills[i];
            spill.runs += 1;
            let metrics = self
                .headline
                .iter()
                .map(|(_, m)| (m.value)(batch.tally(r)).unwrap_or(f64::NAN));
            for x in [stats.total_reward, stats.cost_total(), share, weight]
                .into_iter()
                .chain(metrics)
            {
                spill
                    .file
                    .write_all(&x.to_le_bytes())
                    .map_err(RunError::Spill)?;
            }
        }
        Ok(())
    }

    /// The rows, in order of first appearance.
    fn rows(self) -> Result<Vec<Row>, RunError> {
        let read_back = || io("cannot read back the summary's temporary file".to_string());
        let width = self.width();
        let headline = self.headline;
        self.spills
            .into_iter()
            .map(|spill| {
                let (runs, controller, mixes) = (spill.runs, spill.controller, spill.mixes);
                let file = spill
                    .file
                    .into_inner()
                    .map_err(|e| RunError::Spill(e.into_error()))?;
                let column = |k| passes(&file, k, width).map_err(read_back());
                let (reward, cost, share, weight) =
                    (column(0)?, column(1)?, column(2)?, column(3)?);
                let headline = headline
                    .iter()
                    .enumerate()
                    .map(|(k, &(heading, metric))| {
                        let value = column(4 + k)?;
                        Ok(Headline {
                            heading,
                            column: metric.name,
                            value: (!value.0.is_nan()).then_some(value),
                        })
                    })
                    .collect::<Result<_, RunError>>()?;
                Ok(Row {
                    controller,
                    runs,
                    reward,
                    cost,
                    // Shares and weights are finite, so NaN means no run made a decision.
                    share: (!share.0.is_nan()).then_some(share),
                    weight: (!weight.0.is_nan()).then_some(weight),
                    mixes,
                    headline,
                })
            })
            .collect()
    }
}

/// Runs the arithmetic of [`mean_sd`] over column `k` of a spill file of `width` values per run
/// (NaN: no value), reading it once per pass.
fn passes(file: &std::fs::File, k: usize, width: usize) -> std::io::Result<(f64, f64)> {
    use std::io::{Read as _, Seek as _};
    let values = |f: &mut dyn FnMut(f64)| -> std::io::Result<()> {
        let mut handle = file;
        handle.rewind()?;
        let mut reader = std::io::BufReader::new(handle);
        let mut record = vec![0u8; 8 * width];
        loop {
            match reader.read_exact(&mut record) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(()),
                Err(e) => return Err(e),
            }
            let x = f64::from_le_bytes(record[8 * k..8 * k + 8].try_into().expect("8 bytes"));
            if !x.is_nan() {
                f(x);
            }
        }
    };
    let mut error = None;
    let stats = mean_sd_passes(|f| {
        if let Err(e) = values(f) {
            error.get_or_insert(e);
        }
    });
    match error {
        Some(e) => Err(e),
        None => Ok(stats),
    }
}

/// Mean and sample standard deviation (NaN for no value, 0 for one). Values are scaled by the
/// largest magnitude first, so huge rewards (1e300) give a finite mean and deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    mean_sd_passes(|f| xs.iter().copied().for_each(f))
}

/// [`mean_sd`] over values that `each` hands to its argument, once per pass (three passes), so
/// the values need not be held in memory.
fn mean_sd_passes(mut each: impl FnMut(&mut dyn FnMut(f64))) -> (f64, f64) {
    let mut n = 0usize;
    let mut scale = 0.0f64;
    each(&mut |x| {
        n += 1;
        scale = scale.max(x.abs());
    });
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    if scale == 0.0 || !scale.is_finite() {
        let mean = if scale == 0.0 { 0.0 } else { f64::NAN };
        return (mean, if scale == 0.0 { 0.0 } else { f64::NAN });
    }
    let count = n as f64;
    // Summed in order from -0.0, as `Iterator::sum` does, so results equal a slice's sum.
    let mut sum = -0.0f64;
    each(&mut |x| sum += x / scale);
    let mean = sum / count;
    if n < 2 {
        return (mean * scale, 0.0);
    }
    let mut squares = -0.0f64;
    each(&mut |x| squares += (x / scale - mean).powi(2));
    let var = squares / (count - 1.0);
    (mean * scale, var.sqrt() * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_deviation_stay_finite_for_huge_values() {
        let (m, s) = mean_sd(&[1e305, 3e305, 1e305, 3e305]);
        assert!((m - 2e305).abs() < 1e290, "{m}");
        // Deviations of ±1e305: variance 4/3 x 1e610, computed without overflowing.
        let expected = (4.0f64 / 3.0).sqrt() * 1e305;
        assert!((s - expected).abs() / expected < 1e-12, "{s}");
        assert_eq!(mean_sd(&[2.0, 4.0]), (3.0, 2f64.sqrt()));
        assert_eq!(mean_sd(&[0.0, 0.0]), (0.0, 0.0));
        assert!(mean_sd(&[]).0.is_nan());
    }

    #[test]
    fn statistics_in_passes_equal_those_of_a_slice_bit_for_bit() {
        let cases: [&[f64]; 6] = [
            &[3.0],
            &[2.0, 4.0],
            &[1098.5, 1200.25, 870.0, 1500.75, 999.0],
            &[1e305, 3e305, -1e305, 3e305, 2e300],
            &[0.5, 1e-300, 7.0, f64::INFINITY],
            &[0.1, 0.2, 0.3, 0.4, 0.7, 1.1],
        ];
        for xs in cases {
            let old = two_pass(xs);
            let new = mean_sd(xs);
            assert_eq!(
                (old.0.to_bits(), old.1.to_bits()),
                (new.0.to_bits(), new.1.to_bits()),
                "{xs:?}"
            );
        }
    }

    /// The slice formula the table always used.
    fn two_pass(xs: &[f64]) -> (f64, f64) {
        let scale = xs.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if scale == 0.0 || !scale.is_finite() {
            let mean = if scale == 0.0 { 0.0 } else { f64::NAN };
            return (mean, if scale == 0.0 { 0.0 } else { f64::NAN });
        }
        let n = xs.len() as f64;
        let mean = xs.iter().map(|x| x / scale).sum::<f64>() / n;
        if xs.len() < 2 {
            return (mean * scale, 0.0);
        }
        let var = xs.iter().map(|x| (x / scale - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean * scale, var.sqrt() * scale)
    }
}
