//! `mbmf run`: one configuration (or a few controllers), simulated and written as runs.parquet
//! and series.parquet, with a summary table.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, anyhow};
use clap::Args;

use super::args::{ParamArgs, batch_size, explain, load_task, runs_count, seed};
use super::{Failure, progress, runtime, signal, usage};
use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::env::registry;
use crate::output;
use crate::params::{Controller, Params, Profile};
use crate::pipeline;
use crate::schedule::{self, Schedule};
use crate::sizing;

/// `mbmf run`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// The task (the list is the task registry's).
    #[arg(long, default_value = "tidy1", help = registry::short_help(), long_help = registry::help())]
    pub task: String,
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
    /// Controllers, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "mf,mb,rnd,ec"
    )]
    pub controller: Vec<Controller>,
    /// Runs per controller, 1 to 1000000.
    #[arg(long, default_value_t = 20, value_parser = runs_count, allow_negative_numbers = true)]
    pub runs: u32,
    /// Master seed; with the run index it fixes each run's random stream.
    #[arg(long, default_value_t = 1, value_parser = seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// Output folder for runs.parquet and series.parquet (created if needed).
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Replace the results of an earlier run in --out (refused without it).
    #[arg(long)]
    pub force: bool,
    /// Runs simulated at once, >= 1 (lowered if a batch would not fit in memory); results do
    /// not depend on it.
    #[arg(long, default_value_t = 4096, value_parser = batch_size, allow_negative_numbers = true)]
    pub batch_size: usize,
    /// No progress bar and no notes on stderr; the table and the files written still print on
    /// stdout, and warnings and errors on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print one JSON object on stdout instead of the table (files written, counts, timing and
    /// the per-controller rows); progress and notes stay on stderr.
    #[arg(long)]
    pub json: bool,
    /// A named human; the human's flags (--interaction, --budget, --zeta, --forget,
    /// --reward-source) override its fields.
    #[arg(long, value_enum)]
    pub profile: Option<Profile>,
    /// Every other parameter.
    #[command(flatten)]
    pub params: ParamArgs,
    /// A change during the run at experiment step STEP (repeatable; events at one step apply in
    /// the order given): world=json:PATH, goal=S[:R], delete=S-T,..., boxes=PERM (tidy1),
    /// interaction=, budget= (left), forget=, zeta=, profile=, reward_source=.
    /// Example: --change 1601:goal=34 --change 1601:world=json:PATH
    #[arg(long = "change", value_name = "STEP:KEY=VALUE")]
    pub change: Vec<String>,
}

/// Run `i` of `mbmf run`: its runs are `--runs` runs of each controller in turn (a controller is
/// a configuration, numbered in `--controller` order), built on demand so that memory does not
/// grow with `--runs`.
fn config_at(args: &RunArgs, params: &[Params], i: u64) -> RunConfig {
    let per = u64::from(args.runs);
    let config = i / per;
    pipeline::run_config(params[config as usize], args.seed, config, per, i % per)
}

/// Batches whose configurations are built at once: enough to keep every thread busy, few
/// enough that the configurations of a million-run job are never all in memory.
const BATCHES_PER_WINDOW: usize = 16;

/// The validated parameters of each controller's runs, in `--controller` order.
fn controller_params(args: &RunArgs) -> Result<Vec<Params>> {
    let mut all = Vec::new();
    for &controller in &args.controller {
        let profile = args.profile.unwrap_or(Profile::None);
        let mut params = Params {
            controller,
            human: profile.human(controller).unwrap_or_default(),
            profile,
            reward_source: profile.reward_source().unwrap_or_default(),
            steps: registry::default_steps(&args.task),
            babbling: registry::default_babbling(&args.task),
            ..Params::default()
        };
        args.params.apply(&mut params);
        // Setting the human's fields without a profile describes a custom human.
        if args.profile.is_none() && args.params.given.iter().any(|(p, _)| p.in_human) {
            params.profile = Profile::Custom;
        }
        params.validate().map_err(explain)?;
        all.push(params);
    }
    Ok(all)
}

/// Inputs that are legal but almost surely mistakes, as warnings naming the flag, each cause
/// once.
fn warnings(args: &RunArgs, schedule: &Schedule, params: &[Params], spec: &Spec) -> Vec<String> {
    let mut warnings = Vec::new();
    for (i, &c) in args.controller.iter().enumerate() {
        let times = args.controller.iter().filter(|&&k| k == c).count();
        if times > 1 && !args.controller[..i].contains(&c) {
            let times = match times {
                2 => "twice".to_string(),
                n => format!("{n} times"),
            };
            warnings.push(format!(
                "--controller lists {} {times}: each listing adds --runs {} runs (with other \
                 run indices), and the summary merges them into one row",
                c.name(),
                args.runs
            ));
        }
    }
    // A budget is spent by an interaction: from --interaction, the profile, or a later change.
    let changes_human = schedule.changes.iter().any(|c| {
        matches!(
            c.event,
            schedule::Event::Human(
                schedule::HumanChange::Interaction(_) | schedule::HumanChange::Profile(_)
            )
        )
    });
    if let Some((_, budget)) = args.params.given.iter().find(|(p, _)| p.name == "budget")
        && !changes_human
        && params
            .iter()
            .all(|p| p.human.interaction == crate::params::Interaction::None)
    {
        warnings.push(format!(
            "--budget {budget} has no effect: no interaction uses it (give --interaction, a \
             --profile with one, or a --change STEP:interaction=...)"
        ));
    }
    if !spec.can_move() {
        warnings.push(format!(
            "--task {}: the world has no transition at all, so the robot never moves and never \
             reaches the goal",
            args.task
        ));
    }
    warnings
}

/// `mbmf run`: every input is checked (flags, task files, the output folder, memory) before the
/// first step is simulated, so a mistake fails in a second rather than after the runs.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let spec = load_task(
        &args.task,
        args.key_states.as_deref(),
        args.spaces.as_deref(),
    )
    .map_err(usage)?;
    let spec = Arc::new(spec);
    let params = controller_params(args).map_err(usage)?;
    let schedule = Schedule::from_events(args.change.iter().map(String::as_str))
        .map_err(|e| usage(anyhow!("--change: {e}")))?;
    // Runs of one controller share their parameters: check each controller's.
    for p in &params {
        registry::check_params(&spec, p).map_err(|e| usage(explain(e)))?;
        schedule::compile(&spec, &schedule, p).map_err(|e| usage(anyhow!("--change: {e}")))?;
    }
    for warning in warnings(args, &schedule, &params, &spec) {
        eprintln!("warning: {warning}");
    }
    size_up(args, &spec, &params)?;
    let total = params.len() as u64 * u64::from(args.runs);
    // The runs of one controller differ only by their index: one of each sizes a batch.
    let firsts: Vec<RunConfig> = (0..params.len() as u64)
        .map(|c| config_at(args, &params, c * u64::from(args.runs)))
        .collect();
    let schedules = [schedule];
    let batch_size = pipeline::plan_batch_size(&spec, &firsts, args.batch_size).map_err(usage)?;
    let [runs_target, series_target] = prepare_out(&args.out, args.force)?;
    let stop = signal::install();
    let staging = Staging::create(&args.out)?;
    if (batch_size as u64) < (args.batch_size as u64).min(total) && !args.quiet {
        eprintln!(
            "note: simulating {batch_size} runs at a time instead of {} so that a batch fits in \
             memory (results do not depend on it)",
            args.batch_size
        );
    }
    let per = u64::from(args.runs);
    let mut job = pipeline::Job {
        schedules: &schedules,
        batch_size,
        writer: pipeline::Tables::new(&staging.0, output::metadata(args.seed, None), per, vec![]),
    };
    let bar = progress::bar(pipeline::agent_steps(&firsts) * per, args.quiet, false);
    let mut summary = Summary::new(&args.out);
    let started = std::time::Instant::now();
    // Windows are whole batches, so batches are cut where one call over every run cuts them.
    let window = batch_size.saturating_mul(BATCHES_PER_WINDOW) as u64;
    let mut simulated = Ok(());
    let mut start = 0;
    while start < total && simulated.is_ok() {
        let end = start.saturating_add(window).min(total);
        let group = pipeline::Group {
            configs: (start..end).map(|i| config_at(args, &params, i)).collect(),
            schedules: vec![0; (end - start) as usize],
            profiles: Vec::new(),
        };
        let progress = |n| {
            bar.inc(n);
            pipeline::unless_stopped(stop)
        };
        simulated = job.simulate(&spec, &group, progress, |batch| summary.add(batch));
        start = end;
    }
    bar.finish_and_clear();
    simulated.map_err(|e| interrupted(e, &args.out))?;
    let rows = summary.rows().map_err(runtime)?;
    let [runs_staged, series_staged] = job.writer.finish().map_err(runtime)?;
    // The last chance to stop with nothing written: after the commit the run is complete.
    if signal::requested() {
        return Err(interrupted(pipeline::Interrupted.into(), &args.out));
    }
    output::atomic::commit_pair(
        (&series_staged, &series_target),
        (&runs_staged, &runs_target),
    )
    .with_context(|| format!("cannot move the results into {}", args.out.display()))
    .map_err(runtime)?;
    drop(staging);
    let (runs_path, series_path) = (runs_target, series_target);
    if args.json {
        let report = serde_json::json!({
            "verb": "run",
            "task": args.task,
            "out": args.out.display().to_string(),
            "files": {
                "runs": runs_path.display().to_string(),
                "series": series_path.display().to_string(),
            },
            "runs": total,
            "seconds": started.elapsed().as_secs_f64(),
            "controllers": json_rows(&rows),
        });
        outln!("{report}");
    } else {
        out!(
            "{}",
            table(
                &rows,
                &args.task,
                total as usize,
                started.elapsed().as_secs_f64()
            )
        );
        outln!(
            "wrote {} and {}",
            runs_path.display(),
            series_path.display()
        );
    }
    Ok(())
}

/// Sizes the job before anything is allocated: refuses one whose results cannot fit on the disk
/// or that would run for more than a year, and prints the estimated time and output of a huge
/// one (the estimate of `mbmf sweep --dry-run`).
fn size_up(args: &RunArgs, spec: &Arc<Spec>, params: &[Params]) -> Result<(), Failure> {
    // Memory first (a run that cannot fit is refused whatever the disk), on one run per
    // controller: the batch plan depends on the largest run, not on how many there are.
    let one_each: Vec<RunConfig> = (0..params.len() as u64)
        .map(|c| config_at(args, params, c * u64::from(args.runs)))
        .collect();
    pipeline::plan_batch_size(spec, &one_each, args.batch_size).map_err(usage)?;
    let mut size = sizing::Size::default();
    for p in params {
        size.add(u128::from(args.runs), p);
    }
    let shrink = sizing::Shrink {
        runs: "lower --runs (runs per controller) or give fewer --controller".into(),
        series: "raise --checkpoint (0 writes no series rows), or lower --steps or --runs".into(),
        time: "lower --runs or --steps, or give fewer --controller".into(),
    };
    // With --force the results already there are replaced, so their space counts as free.
    let credit = if args.force {
        ["runs.parquet", "series.parquet"]
            .iter()
            .filter_map(|f| std::fs::metadata(args.out.join(f)).ok())
            .map(|m| m.len())
            .sum()
    } else {
        0
    };
    sizing::check_size(&size, &args.out, credit, &shrink).map_err(usage)?;
    if !size.is_huge() {
        return Ok(());
    }
    let per = u64::from(args.runs);
    let groups: Vec<sizing::SampleGroup> = (0..params.len() as u64)
        .map(|c| sizing::SampleGroup {
            task: 0,
            samples: (0..per.min(2))
                .map(|r| config_at(args, params, c * per + r))
                .collect(),
            agent_steps: u128::from(per) * u128::from(pipeline::run_steps(&params[c as usize])),
        })
        .collect();
    let estimate =
        sizing::time(std::slice::from_ref(spec), &groups).map_err(|e| usage(explain(e)))?;
    sizing::check_time(&estimate, &shrink).map_err(usage)?;
    if !args.quiet {
        eprintln!(
            "note: {}; estimated time: about {} with {} thread(s)",
            size.line(),
            sizing::human_duration(estimate.seconds),
            estimate.threads
        );
    }
    Ok(())
}

/// Checks and creates the output folder of `mbmf run`; returns the paths of runs.parquet and
/// series.parquet. A file in the way is a usage error (2); a folder that cannot be created is a
/// runtime failure (1). Both are found before anything is simulated.
fn prepare_out(out: &Path, force: bool) -> Result<[PathBuf; 2], Failure> {
    // The nearest existing ancestor (the folder itself included) must be a folder.
    for ancestor in out.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        if let Ok(metadata) = std::fs::metadata(ancestor) {
            if !metadata.is_dir() {
                return Err(usage(anyhow!(
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
        .with_context(|| format!("cannot create output folder {}", out.display()))
        .map_err(runtime)?;
    let targets = [out.join("runs.parquet"), out.join("series.parquet")];
    for target in &targets {
        if target.is_dir() {
            return Err(usage(anyhow!(
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
        return Err(usage(anyhow!(
            "--out {}: it holds the results of an earlier run ({}); pass --force to replace \
             them, or choose another --out",
            out.display(),
            earlier.join(", ")
        )));
    }
    Ok(targets)
}

/// A failure of the simulation; after a signal, one saying that nothing was written (the
/// staging folder is removed as the caller returns) and that earlier results are untouched.
fn interrupted(error: anyhow::Error, out: &Path) -> Failure {
    if error.downcast_ref::<pipeline::Interrupted>().is_none() {
        return runtime(error);
    }
    let earlier = if out.join("runs.parquet").exists() {
        "the results already there are untouched"
    } else {
        "it holds no results"
    };
    Failure {
        code: signal::exit_code(),
        error: anyhow!(
            "interrupted by {}: nothing was written to {} ({earlier}); run the command again to \
             start over",
            signal::received(),
            out.display()
        ),
    }
}

/// A private folder inside the output folder where both Parquet files are written; they are
/// moved into place as one commit ([`output::atomic::commit_pair`]) only when both are
/// complete. The folder and anything left in it are removed when the value is dropped.
struct Staging(PathBuf);

impl Staging {
    /// Creates the folder; this is also the check that the output folder accepts new files,
    /// done before anything is simulated.
    fn create(out: &Path) -> Result<Staging, Failure> {
        // Staging folders of killed runs hold nothing of use.
        output::atomic::remove_dead_staging(out);
        let dir = out.join(format!(".mbmf-run-{}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot write into output folder {}", out.display()))
            .map_err(runtime)?;
        signal::remove_on_forced_exit(dir.clone());
        Ok(Staging(dir))
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        // Best effort: after a commit only the empty folder is left.
        let _ = std::fs::remove_dir_all(&self.0);
        signal::keep_on_forced_exit(&self.0);
    }
}

/// One controller's values of the summary table, spilled to an unnamed temporary file (24 bytes
/// per run) so that memory does not grow with `--runs`, and read back in passes to compute the
/// exact two-pass statistics of [`mean_sd`] (a one-pass formula would move the last printed
/// digit of some means).
struct Spill {
    controller: Controller,
    runs: usize,
    file: std::io::BufWriter<std::fs::File>,
}

/// A controller's row of the table: (mean, sd) of total reward, total cost and MB share (over
/// the runs that made decisions; `None` if none did).
struct Row {
    controller: Controller,
    runs: usize,
    reward: (f64, f64),
    cost: (f64, f64),
    share: Option<(f64, f64)>,
}

/// Per-controller results for the table printed after a run, accumulated batch by batch.
struct Summary {
    /// Where the spill files are created (unnamed: nothing is left behind, even after a kill).
    dir: PathBuf,
    spills: Vec<Spill>,
}

impl Summary {
    fn new(dir: &Path) -> Summary {
        Summary {
            dir: dir.to_path_buf(),
            spills: Vec::new(),
        }
    }

    fn add(&mut self, batch: &Batch) -> Result<()> {
        use std::io::Write as _;
        for (config, stats) in batch.configs().iter().zip(batch.stats()) {
            let c = config.params.controller;
            let i = match self.spills.iter().position(|s| s.controller == c) {
                Some(i) => i,
                None => {
                    let file = tempfile::tempfile_in(&self.dir).with_context(|| {
                        format!("cannot create a temporary file in {}", self.dir.display())
                    })?;
                    self.spills.push(Spill {
                        controller: c,
                        runs: 0,
                        file: std::io::BufWriter::new(file),
                    });
                    self.spills.len() - 1
                }
            };
            let share = if stats.decisions > 0 {
                stats.mb_decisions as f64 / stats.decisions as f64
            } else {
                f64::NAN
            };
            let spill = &mut self.spills[i];
            spill.runs += 1;
            for x in [stats.total_reward, stats.cost_total(), share] {
                spill.file.write_all(&x.to_le_bytes())?;
            }
        }
        Ok(())
    }

    /// The rows, in order of first appearance.
    fn rows(self) -> Result<Vec<Row>> {
        self.spills
            .into_iter()
            .map(|spill| {
                let runs = spill.runs;
                let controller = spill.controller;
                let file = spill.file.into_inner().map_err(|e| e.into_error())?;
                let reward = passes(&file, 0)?;
                let cost = passes(&file, 1)?;
                let share = passes(&file, 2)?;
                Ok(Row {
                    controller,
                    runs,
                    reward,
                    cost,
                    // Shares are finite, so NaN means no run made a decision.
                    share: (!share.0.is_nan()).then_some(share),
                })
            })
            .collect()
    }
}

/// Runs the arithmetic of [`mean_sd`] over column `k` of a spill file (NaN: no value), reading it
/// once per pass.
fn passes(file: &std::fs::File, k: usize) -> Result<(f64, f64)> {
    use std::io::{Read as _, Seek as _};
    let values = |f: &mut dyn FnMut(f64)| -> Result<()> {
        let mut handle = file;
        handle.rewind()?;
        let mut reader = std::io::BufReader::new(handle);
        let mut record = [0u8; 24];
        loop {
            match reader.read_exact(&mut record) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return Ok(()),
                Err(e) => return Err(e.into()),
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
        Some(e) => Err(e.context("cannot read back the summary's temporary file")),
        None => Ok(stats),
    }
}

/// The table's rows as JSON objects: means and sample standard deviations (null where no run
/// has a value).
fn json_rows(rows: &[Row]) -> Vec<serde_json::Value> {
    rows.iter()
        .map(|row| {
            let (m, ms) = row.share.unwrap_or((f64::NAN, f64::NAN));
            serde_json::json!({
                "controller": row.controller.name(),
                "runs": row.runs,
                "total_reward_mean": row.reward.0,
                "total_reward_sd": row.reward.1,
                "total_cost_mean": row.cost.0,
                "total_cost_sd": row.cost.1,
                "mb_share_mean": m,
                "mb_share_sd": ms,
            })
        })
        .collect()
}

/// The table: mean ± standard deviation per controller ("-" where no run has a value).
fn table(rows: &[Row], task: &str, runs: usize, seconds: f64) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(out, "{task}: {runs} runs in {seconds:.2} s");
    let _ = writeln!(
        out,
        "{:<10} {:>5} {:>22} {:>26} {:>18}",
        "controller", "runs", "total reward", "total cost (ops)", "MB share"
    );
    for row in rows {
        let ((r, rs), (c, cs)) = (row.reward, row.cost);
        let share = match row.share {
            None => format!("{:>18}", "-"),
            Some((m, ms)) => format!("{m:>8.3} ± {ms:.3}"),
        };
        let _ = writeln!(
            out,
            "{:<10} {:>5} {:>12.1} ± {:<7.1} {:>15.4e} ± {:<8.2e} {share}",
            row.controller.name(),
            row.runs,
            r,
            rs,
            c,
            cs,
        );
    }
    out
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
