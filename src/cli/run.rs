//! `mbmf run`: one configuration (or a few controllers), simulated and written as runs.parquet
//! and series.parquet, with a summary table.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, anyhow};
use clap::Args;

use super::args::{ParamArgs, batch_size, explain, load_task, runs_count, seed};
use super::{Failure, progress, runtime, signal, usage};
use crate::batch::{Batch, RunConfig};
use crate::output;
use crate::params::{Controller, Params, Profile, default_steps};
use crate::pipeline;
use crate::schedule::{self, Schedule};

/// `mbmf run`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// tidy1, tidy2 or json:PATH (the authors' format, keyStates.txt and spaces.txt beside it).
    #[arg(long, default_value = "tidy1")]
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

/// Builds the configurations of `mbmf run`: for each controller, `runs` runs with consecutive
/// run indices (controller-major). Every parameter is validated.
pub fn run_configs(args: &RunArgs) -> Result<Vec<RunConfig>> {
    let mut configs = Vec::new();
    for (ci, &controller) in args.controller.iter().enumerate() {
        let profile = args.profile.unwrap_or(Profile::None);
        let mut params = Params {
            controller,
            human: profile.human(controller).unwrap_or_default(),
            profile,
            reward_source: profile.reward_source().unwrap_or_default(),
            steps: default_steps(&args.task),
            ..Params::default()
        };
        args.params.apply(&mut params);
        // Setting the human's fields without a profile describes a custom human.
        if args.profile.is_none() && args.params.given.iter().any(|(p, _)| p.in_human) {
            params.profile = Profile::Custom;
        }
        params.validate().map_err(explain)?;
        for r in 0..args.runs {
            configs.push(RunConfig {
                params,
                seed: args.seed,
                run_index: ci as u64 * u64::from(args.runs) + u64::from(r),
            });
        }
    }
    Ok(configs)
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
    let configs = run_configs(args).map_err(usage)?;
    let schedule = Schedule::from_events(args.change.iter().map(String::as_str))
        .map_err(|e| usage(anyhow!("--change: {e}")))?;
    // Runs of one controller share their parameters: check the first of each.
    for c in configs.iter().step_by(args.runs.max(1) as usize) {
        c.params
            .validate_for(&spec)
            .map_err(|e| usage(explain(e)))?;
        schedule::compile(&spec, &schedule, &c.params)
            .map_err(|e| usage(anyhow!("--change: {e}")))?;
    }
    let schedules = [schedule];
    let run_schedule = vec![0; configs.len()];
    let batch_size = pipeline::plan_batch_size(&spec, &configs, args.batch_size).map_err(usage)?;
    let [runs_target, series_target] = prepare_out(&args.out, args.force)?;
    let stop = signal::install();
    let staging = Staging::create(&args.out)?;
    if batch_size < args.batch_size.min(configs.len()) && !args.quiet {
        eprintln!(
            "note: simulating {batch_size} runs at a time instead of {} so that a batch fits in \
             memory (results do not depend on it)",
            args.batch_size
        );
    }
    let [runs_meta, series_meta] = output::pair_metadata(args.seed);
    let mut runs_sink = output::ParquetSink::new(&staging.0.join("runs.parquet"), runs_meta);
    let mut series_sink = output::ParquetSink::new(&staging.0.join("series.parquet"), series_meta);
    let bar = progress::bar(pipeline::agent_steps(&configs), args.quiet, false);
    let mut summary = Summary::default();
    let started = std::time::Instant::now();
    let per = u64::from(args.runs);
    let simulated = pipeline::simulate_with_schedules(
        &spec,
        &configs,
        &schedules,
        &run_schedule,
        batch_size,
        |n| {
            bar.inc(n);
            pipeline::unless_stopped(stop)
        },
        |batch: &Batch| {
            runs_sink.write(&output::with_run_indices(output::runs_batch(batch)?, per)?)?;
            series_sink.write(&output::with_run_indices(
                output::series_batch(batch)?,
                per,
            )?)?;
            summary.add(batch);
            Ok::<(), anyhow::Error>(())
        },
    );
    bar.finish_and_clear();
    simulated.map_err(|e| interrupted(e, &args.out))?;
    let runs_staged = runs_sink.finish().map_err(runtime)?;
    let series_staged = series_sink.finish().map_err(runtime)?;
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
            "runs": configs.len(),
            "seconds": started.elapsed().as_secs_f64(),
            "controllers": summary.json_rows(),
        });
        outln!("{report}");
    } else {
        out!(
            "{}",
            summary.table(&args.task, configs.len(), started.elapsed().as_secs_f64())
        );
        outln!(
            "wrote {} and {}",
            runs_path.display(),
            series_path.display()
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

/// One run in the summary table: total reward, total cost, MB share (if it made decisions).
type RunSummary = (f64, f64, Option<f64>);

/// Per-controller results for the table printed after a run.
#[derive(Default)]
struct Summary {
    rows: Vec<(Controller, Vec<RunSummary>)>,
}

impl Summary {
    fn add(&mut self, batch: &Batch) {
        for (config, stats) in batch.configs().iter().zip(batch.stats()) {
            let c = config.params.controller;
            let share =
                (stats.decisions > 0).then(|| stats.mb_decisions as f64 / stats.decisions as f64);
            let entry = match self.rows.iter_mut().position(|(k, _)| *k == c) {
                Some(i) => &mut self.rows[i].1,
                None => {
                    self.rows.push((c, Vec::new()));
                    &mut self.rows.last_mut().expect("just pushed").1
                }
            };
            entry.push((stats.total_reward, stats.cost_total(), share));
        }
    }

    /// The table's rows as JSON objects: means and sample standard deviations (null where no run
    /// has a value).
    fn json_rows(&self) -> Vec<serde_json::Value> {
        self.rows
            .iter()
            .map(|(controller, values)| {
                let (r, rs) = mean_sd(&values.iter().map(|v| v.0).collect::<Vec<_>>());
                let (c, cs) = mean_sd(&values.iter().map(|v| v.1).collect::<Vec<_>>());
                let shares: Vec<f64> = values.iter().filter_map(|v| v.2).collect();
                let (m, ms) = mean_sd(&shares);
                serde_json::json!({
                    "controller": controller.name(),
                    "runs": values.len(),
                    "total_reward_mean": r,
                    "total_reward_sd": rs,
                    "total_cost_mean": c,
                    "total_cost_sd": cs,
                    "mb_share_mean": m,
                    "mb_share_sd": ms,
                })
            })
            .collect()
    }

    /// The table: mean ± standard deviation per controller ("-" where no run has a value).
    fn table(&self, task: &str, runs: usize, seconds: f64) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let _ = writeln!(out, "{task}: {runs} runs in {seconds:.2} s");
        let _ = writeln!(
            out,
            "{:<10} {:>5} {:>22} {:>26} {:>18}",
            "controller", "runs", "total reward", "total cost (ops)", "MB share"
        );
        for (controller, values) in &self.rows {
            let (r, rs) = mean_sd(&values.iter().map(|v| v.0).collect::<Vec<_>>());
            let (c, cs) = mean_sd(&values.iter().map(|v| v.1).collect::<Vec<_>>());
            let shares: Vec<f64> = values.iter().filter_map(|v| v.2).collect();
            let share = if shares.is_empty() {
                format!("{:>18}", "-")
            } else {
                let (m, ms) = mean_sd(&shares);
                format!("{m:>8.3} ± {ms:.3}")
            };
            let _ = writeln!(
                out,
                "{:<10} {:>5} {:>12.1} ± {:<7.1} {:>15.4e} ± {:<8.2e} {share}",
                controller.name(),
                values.len(),
                r,
                rs,
                c,
                cs,
            );
        }
        out
    }
}

/// Mean and sample standard deviation (NaN for no value, 0 for one). Values are scaled by the
/// largest magnitude first, so huge rewards (1e300) give a finite mean and deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
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
}
