//! `mbmf bench`: the headline speed figures in about a minute, for users checking their machine,
//! and (`--growth`) how time per step and memory per run grow with the number of states.
//!
//! Every figure is a median over a few timed windows of steps on copies of a batch brought to
//! the phase being measured, so setting up is never timed. Inputs come from a fixed seed. Timings
//! depend on what else the machine is doing: close other work for stable figures.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::batch::{Batch, RunConfig};
use crate::env::{self, Spec};
use crate::error::IoError;
use crate::params::{Combine, ConfigError, Controller, Params};
use crate::plot::{LineChart, PlotError, Series, line_chart};

/// Why a measurement could not be made or written. None is a usage error: the CLI checks its
/// flags before measuring.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The thread pool of a measurement could not start.
    #[error("cannot start {threads} worker threads: {cause}")]
    Threads {
        /// Threads asked for.
        threads: usize,
        /// What rayon said.
        cause: rayon::ThreadPoolBuildError,
    },
    /// A benchmark's task could not be built.
    #[error(transparent)]
    Env(#[from] env::EnvError),
    /// A growth size out of range.
    #[error(transparent)]
    Grid(#[from] env::grid::GridError),
    /// A benchmark's batch refused its parameters.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The output folder could not be created or a file written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A whole run could not be simulated or written.
    #[error(transparent)]
    Run(#[from] Box<crate::run::RunError>),
}

impl crate::error::Usage for BenchError {
    fn is_usage(&self) -> bool {
        false
    }
}

/// Every rule of SPEC 4 and 12 with `select`, `ec` first (the others are read against it),
/// then `combine = mix` wherever it applies: what `mbmf bench` and the criterion benches time.
pub fn every_rule() -> Vec<(Controller, Combine)> {
    std::iter::once(Controller::Ec)
        .chain(Controller::ALL.into_iter().filter(|&c| c != Controller::Ec))
        .map(|c| (c, Combine::Select))
        .chain(
            Controller::ALL
                .into_iter()
                .filter(|c| c.combines())
                .map(|c| (c, Combine::Mix)),
        )
        .collect()
}

/// Master seed of every input of `mbmf bench`.
pub const SEED: u64 = 20_200_831;

/// Steps per second of `runs` runs of `params` on `spec` over the `window` steps that end the run
/// (learning has settled), for each thread count in `threads`: the median of `repeats` windows.
///
/// The thread counts are timed in turn within each repeat, so a slow spell of the machine
/// weighs on all of them alike.
pub fn steady_rate(
    spec: &Arc<Spec>,
    params: Params,
    runs: usize,
    threads: &[usize],
    window: u64,
    repeats: usize,
) -> Result<Vec<f64>, BenchError> {
    let steady = Steady::new(spec, params, runs, window)?;
    let pools = threads
        .iter()
        .map(|&t| pool(t))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rates = vec![Vec::new(); threads.len()];
    for _ in 0..repeats.max(1) {
        for (pool, rates) in pools.iter().zip(&mut rates) {
            rates.push(steady.rate(pool));
        }
    }
    Ok(rates.into_iter().map(median).collect())
}

/// The median of `values` (the upper one of an even count).
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// A batch advanced to the start of the `window` steps that end its runs: every timed window
/// runs a clone of it, so windows are alike and the warm-up is paid once.
pub struct Steady {
    batch: Batch,
    window: u64,
}

impl Steady {
    /// `runs` runs of `params` on `spec`, advanced (on every core) to their last `window` steps.
    pub fn new(
        spec: &Arc<Spec>,
        params: Params,
        runs: usize,
        window: u64,
    ) -> Result<Steady, BenchError> {
        let total = u64::from(params.babbling) + u64::from(params.steps);
        let mut batch = Batch::new(Arc::clone(spec), configs(params, runs))?;
        let all = pool(std::thread::available_parallelism().map_or(1, |n| n.get()))?;
        all.install(|| batch.advance(total.saturating_sub(window)));
        Ok(Steady {
            batch,
            window: window.min(total),
        })
    }

    /// Agent-steps per second of one window on `pool`.
    pub fn rate(&self, pool: &rayon::ThreadPool) -> f64 {
        window_rate(&self.batch, pool, self.window)
    }
}

/// Steps per timed window of the rules' table (and of the steady rates).
pub const WINDOW: u64 = 1000;

/// `runs` runs of `controller` with `combine` on task `task` (`spec`), with the task's default
/// steps and babbling, advanced to their last [`WINDOW`] steps: a row of the rules' table.
pub fn rule_at_steady_state(
    spec: &Arc<Spec>,
    task: &str,
    (controller, combine): (Controller, Combine),
    runs: usize,
) -> Result<Steady, BenchError> {
    let params = Params {
        controller,
        combine,
        steps: env::registry::default_steps(task),
        babbling: env::registry::default_babbling(task),
        ..Params::default()
    };
    Steady::new(spec, params, runs, WINDOW)
}

/// A rule's steady rate against a base rule's, from windows of the two timed in turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paired {
    /// Median agent-steps per second of the rule.
    pub rate: f64,
    /// Median over the pairs of the rule's time per agent-step over the base's: a slow spell of
    /// the machine weighs on both windows of a pair alike, so this moves far less than the
    /// ratio of two medians timed apart.
    pub time_over_base: f64,
}

/// Times `repeats` pairs of windows (the base's, then the rule's) on `pool`.
pub fn paired(base: &Steady, rule: &Steady, pool: &rayon::ThreadPool, repeats: usize) -> Paired {
    let (mut rates, mut ratios) = (Vec::new(), Vec::new());
    for _ in 0..repeats.max(1) {
        let base_rate = base.rate(pool);
        let rate = rule.rate(pool);
        rates.push(rate);
        ratios.push(base_rate / rate);
    }
    Paired {
        rate: median(rates),
        time_over_base: median(ratios),
    }
}

/// `runs` runs of `params` with run indices 0.. under [`SEED`].
pub fn configs(params: Params, runs: usize) -> Vec<RunConfig> {
    (0..runs as u64)
        .map(|run_index| RunConfig {
            params,
            seed: SEED,
            run_index,
        })
        .collect()
}

/// A whole `mbmf run` command's work timed: the runs of one configuration from building their
/// configurations to both files committed, as one and as more threads do it.
#[derive(Debug, Clone, PartialEq)]
pub struct WholeRun {
    /// The configuration.
    pub params: Params,
    /// Its runs.
    pub runs: u32,
    /// Per thread count asked, the median wall seconds of the repeats.
    pub seconds: Vec<(usize, f64)>,
}

/// Times `repeats` whole runs of `runs` runs of `params` on `task` into a temporary folder
/// under `scratch`, for each thread count in `threads` in turn within each repeat (a slow
/// spell of the machine weighs on all alike); the median of each. Unlike the steady-state
/// rates, this includes allocating and starting the runs and encoding and writing the files:
/// what a user waits for.
pub fn whole_run(
    task: &str,
    params: Params,
    runs: u32,
    threads: &[usize],
    repeats: usize,
    scratch: &Path,
) -> Result<WholeRun, BenchError> {
    let spec = Arc::new(env::load(task)?);
    let pools = threads
        .iter()
        .map(|&t| pool(t))
        .collect::<Result<Vec<_>, _>>()?;
    let out = scratch.join(".mbmf-bench-whole-run");
    let mut times = vec![Vec::with_capacity(repeats); threads.len()];
    let stop = std::sync::atomic::AtomicBool::new(false);
    for _ in 0..repeats.max(1) {
        for (pool, times) in pools.iter().zip(&mut times) {
            let mut job = crate::run::Job::new(task, Arc::clone(&spec), vec![params], &out);
            job.runs = runs;
            job.force = true;
            job.seed = SEED;
            job.command = "mbmf bench".into();
            let started = Instant::now();
            pool.install(|| crate::run::execute(job, &stop, |_| {}))
                .map_err(Box::new)?;
            times.push(started.elapsed().as_secs_f64());
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    let seconds = threads
        .iter()
        .zip(times)
        .map(|(&t, v)| (t, median(v)))
        .collect();
    Ok(WholeRun {
        params,
        runs,
        seconds,
    })
}

/// Agent-steps per second of `window` steps of a clone of `template` on `pool`.
fn window_rate(template: &Batch, pool: &rayon::ThreadPool, window: u64) -> f64 {
    let mut batch = template.clone();
    let before: u64 = batch.cursors().iter().map(|c| c.t).sum();
    let started = Instant::now();
    pool.install(|| batch.advance(window));
    let seconds = started.elapsed().as_secs_f64();
    let after: u64 = batch.cursors().iter().map(|c| c.t).sum();
    (after - before) as f64 / seconds.max(1e-9)
}

/// A rayon pool of exactly `threads` threads (the benchmarks' too).
pub fn pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|cause| BenchError::Threads { threads, cause })
}

/// Memory of one run of a batch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Memory {
    /// Bytes of state per run by the batch's own account ([`Batch::state_bytes`]).
    pub layout_bytes: usize,
    /// Growth of the resident set per run when a batch is created and all its pages touched
    /// (Linux only).
    pub rss_bytes: Option<f64>,
}

/// Memory per run of a batch of `runs` paper-default `ec` runs on `spec`.
pub fn memory_per_instance(spec: &Arc<Spec>, runs: usize) -> Result<Memory, BenchError> {
    let params = Params {
        controller: Controller::Ec,
        steps: crate::env::registry::default_steps(&spec.name),
        babbling: crate::env::registry::default_babbling(&spec.name),
        ..Params::default()
    };
    let before = resident_bytes();
    // A new batch writes every run's initial tables, so all its pages are resident.
    let batch = Batch::new(Arc::clone(spec), configs(params, runs))?;
    let after = resident_bytes();
    let layout_bytes = batch.state_bytes() / runs.max(1);
    Ok(Memory {
        layout_bytes,
        rss_bytes: before
            .zip(after)
            .map(|(b, a)| a.saturating_sub(b) as f64 / runs.max(1) as f64),
    })
}

/// Bytes of state per run ([`Batch::state_bytes`], 100 paper-default runs) of each rule of
/// [`every_rule`] on `spec`, in that order.
pub fn state_by_rule(spec: &Arc<Spec>) -> Result<Vec<(Controller, Combine, usize)>, BenchError> {
    const RUNS: usize = 100;
    every_rule()
        .into_iter()
        .map(|(controller, combine)| {
            let params = Params {
                controller,
                combine,
                steps: crate::env::registry::default_steps(&spec.name),
                babbling: crate::env::registry::default_babbling(&spec.name),
                ..Params::default()
            };
            let batch = Batch::new(Arc::clone(spec), configs(params, RUNS))?;
            Ok((controller, combine, batch.state_bytes() / RUNS))
        })
        .collect()
}

/// The process's resident set size, from `/proc/self/status` (None elsewhere than Linux).
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Controllers of the growth study.
pub const GROWTH_CONTROLLERS: [Controller; 4] = [
    Controller::Mf,
    Controller::Mb,
    Controller::Rnd,
    Controller::Ec,
];

/// Grid sizes of the growth study: about three per decade from 100 to `max` states.
pub fn growth_sizes(max: usize) -> Vec<usize> {
    let mut sizes = Vec::new();
    let mut decade = 100;
    while decade <= max {
        for n in [decade, decade * 2, decade * 5] {
            if n <= max {
                sizes.push(n);
            }
        }
        decade *= 10;
    }
    if sizes.last() != Some(&max) {
        sizes.push(max);
    }
    sizes
}

/// One point of the growth study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrowthPoint {
    /// States of the grid world.
    pub states: usize,
    /// The controller.
    pub controller: Controller,
    /// Mean seconds per agent-step over the timed steps.
    pub seconds_per_step: f64,
    /// Bytes of state per run.
    pub bytes_per_run: usize,
    /// Mean reward per run (0: the goal was never reached, so MB's values stayed 0).
    pub reward: f64,
    /// Mean number of states the MB expert knows at the end (what its value iteration sweeps).
    pub known_states: f64,
    /// Mean value-iteration sweeps per call.
    pub sweeps_per_call: f64,
}

/// Steps timed per run in the growth study: whole runs of the paper's length (1,000 babbling
/// steps and 10,000 experiment steps).
pub const GROWTH_STEPS: u64 = 11_000;
/// Runs per point of the growth study.
pub const GROWTH_RUNS: usize = 4;

/// Time per step (whole runs of [`GROWTH_STEPS`] steps, one thread) and memory per run on
/// `grid:N` for each size and controller; `on_point` sees each point as it is measured.
pub fn growth(
    sizes: &[usize],
    controllers: &[Controller],
    mut on_point: impl FnMut(&GrowthPoint),
) -> Result<Vec<GrowthPoint>, BenchError> {
    let one = pool(1)?;
    let mut points = Vec::new();
    for &n in sizes {
        let spec = Arc::new(env::grid::build(n)?);
        for &controller in controllers {
            let params = Params {
                controller,
                ..Params::default()
            };
            // A clone has written every page, so the timed steps take no page faults.
            let mut batch = Batch::new(Arc::clone(&spec), configs(params, GROWTH_RUNS))?.clone();
            let bytes_per_run = batch.state_bytes() / GROWTH_RUNS;
            let started = Instant::now();
            one.install(|| batch.advance(GROWTH_STEPS));
            let seconds = started.elapsed().as_secs_f64();
            let steps: u64 = batch.cursors().iter().map(|c| c.t).sum();
            let runs = GROWTH_RUNS as f64;
            let stats = batch.stats();
            let vi_calls: u64 = stats.iter().map(|s| s.vi_calls).sum();
            let vi_sweeps: u64 = stats.iter().map(|s| s.vi_sweeps).sum();
            let point = GrowthPoint {
                states: n,
                controller,
                seconds_per_step: seconds / steps.max(1) as f64,
                bytes_per_run,
                reward: stats.iter().map(|s| s.total_reward).sum::<f64>() / runs,
                known_states: (0..GROWTH_RUNS)
                    .map(|r| batch.known_states(r) as f64)
                    .sum::<f64>()
                    / runs,
                sweeps_per_call: vi_sweeps as f64 / vi_calls.max(1) as f64,
            };
            on_point(&point);
            points.push(point);
        }
    }
    Ok(points)
}

/// Writes `growth.csv` and the log-log charts `growth_time` and `growth_memory` into `out`;
/// returns the files written, the CSV first.
pub fn write_growth(points: &[GrowthPoint], out: &Path) -> Result<Vec<PathBuf>, BenchError> {
    std::fs::create_dir_all(out)
        .map_err(IoError::doing(format!("cannot create {}", out.display())))?;
    let mut csv = String::from(
        "states,controller,us_per_step,steps_per_s,bytes_per_run,reward,known_states,sweeps_per_vi\n",
    );
    for p in points {
        csv.push_str(&format!(
            "{},{},{:.4},{:.0},{},{:.2},{:.1},{:.3}\n",
            p.states,
            p.controller.name(),
            p.seconds_per_step * 1e6,
            1.0 / p.seconds_per_step,
            p.bytes_per_run,
            p.reward,
            p.known_states,
            p.sweeps_per_call
        ));
    }
    let csv_path = out.join("growth.csv");
    std::fs::write(&csv_path, csv).map_err(IoError::doing(format!(
        "cannot write {}",
        csv_path.display()
    )))?;
    let series_of = |y: &dyn Fn(&GrowthPoint) -> f64| -> Vec<Series> {
        GROWTH_CONTROLLERS
            .iter()
            .filter_map(|&c| {
                let mine: Vec<&GrowthPoint> = points.iter().filter(|p| p.controller == c).collect();
                (!mine.is_empty()).then(|| Series {
                    label: c.name().to_uppercase(),
                    x: mine.iter().map(|p| p.states as f64).collect(),
                    y: mine.iter().map(|p| y(p)).collect(),
                    band: None,
                })
            })
            .collect()
    };
    let time = LineChart {
        title: format!("Time per step on grid:N (whole {GROWTH_STEPS}-step runs, one thread)"),
        x_label: "states".into(),
        y_label: "microseconds per step".into(),
        series: series_of(&|p| p.seconds_per_step * 1e6),
        log_x: true,
        log_y: true,
        x_marks: Vec::new(),
    };
    let mut written = line_chart(&time, &out.join("growth_time"))?;
    // Every controller allocates both experts' tables, so memory does not depend on it.
    let mut memory_series = series_of(&|p| p.bytes_per_run as f64 / 1024.0);
    memory_series.truncate(1);
    if let Some(s) = memory_series.first_mut() {
        s.label = "every controller".into();
    }
    let memory = LineChart {
        title: "Memory per run on grid:N".into(),
        x_label: "states".into(),
        y_label: "KiB of state per run".into(),
        series: memory_series,
        log_x: true,
        log_y: true,
        x_marks: Vec::new(),
    };
    written.extend(line_chart(&memory, &out.join("growth_memory"))?);
    written.insert(0, csv_path);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn growth_sizes_take_three_steps_per_decade_and_end_at_the_maximum() {
        assert_eq!(
            growth_sizes(10_000),
            vec![100, 200, 500, 1000, 2000, 5000, 10_000]
        );
        assert_eq!(growth_sizes(300), vec![100, 200, 300]);
    }

    #[test]
    fn a_tidy1_run_holds_under_64_kib_of_state() {
        let spec = Arc::new(env::load("tidy1").unwrap());
        let memory = memory_per_instance(&spec, 16).unwrap();
        assert!(memory.layout_bytes < 64 * 1024, "{memory:?}");
        // q_mf, q_mb and both averaged distributions alone: 4 x 112 x 7 doubles.
        assert!(memory.layout_bytes > 4 * 112 * 7 * 8, "{memory:?}");
    }

    #[test]
    fn timed_windows_count_every_step_of_every_run() {
        let spec = Arc::new(env::load("tidy1").unwrap());
        let params = Params {
            controller: Controller::Mf,
            steps: 200,
            babbling: 100,
            ..Params::default()
        };
        let rates = steady_rate(&spec, params, 3, &[1, 2], 50, 1).unwrap();
        assert_eq!(rates.len(), 2);
        assert!(rates.iter().all(|r| r.is_finite() && *r > 0.0), "{rates:?}");
    }
}
