//! Sweeps (issue 4): a TOML file describing a grid of `mbmf run` parameters x seeds, expanded
//! into configurations, run in batches and streamed to a Parquet dataset that survives kills,
//! resumes, and splits into shards for job arrays. `sweeps/README.md` documents the file format.
//!
//! - [`file`]: parsing and validation (messages name the file, line and key), expansion.
//! - [`keys`]: the parameters a sweep may set and how they map to [`crate::params::Params`].
//! - [`shard`]: `--shard I/N` and the Slurm / Kubernetes environment.
//! - [`store`]: the dataset folder: atomic parts, lock, resume scan, compaction.
//! - [`runner`]: batching, simulation, progress, and the `--dry-run` estimate.

pub mod file;
pub mod keys;
pub mod runner;
pub mod shard;
pub mod store;

use std::path::PathBuf;

use anyhow::anyhow;
use clap::Args;

pub use file::{Sweep, SweepError};
pub use runner::{Options, Report, RunError, execute};
pub use shard::Shard;

use crate::cli::{Failure, runtime, usage};

const EXAMPLES: &str = "\
Examples:
  mbmf sweep sweeps/kappa.toml --dry-run            # configurations, runs, estimated time
  mbmf sweep sweeps/kappa.toml --out out/kappa      # run it
  mbmf sweep sweeps/kappa.toml --out out/kappa --resume     # after a crash: run what is missing
  mbmf sweep sweeps/kappa.toml --out out/kappa --shard 2/8  # one of 8 independent processes
  sbatch --export=ALL,SWEEP=sweeps/kappa.toml,OUT=out/kappa sweeps/slurm/sweep-array.sbatch

Read the result with polars: pl.scan_parquet(\"out/kappa/runs/*.parquet\").";

/// `mbmf sweep`.
#[derive(Debug, Clone, Args)]
#[command(after_long_help = EXAMPLES)]
pub struct SweepArgs {
    /// The sweep file (TOML), e.g. sweeps/kappa.toml (format: sweeps/README.md).
    pub file: PathBuf,
    /// Dataset folder: runs/ and series/ Parquet parts plus a copy of the sweep file
    /// [default: out/<FILE stem>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the number of configurations and runs and an estimate of the time; run nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Run only the runs missing from --out (after a crash, a kill, or another shard split).
    #[arg(long)]
    pub resume: bool,
    /// Run shard I of N: the configurations whose index is I modulo N, with all their seeds.
    #[arg(long, value_name = "I/N", conflicts_with = "shard_from_env")]
    pub shard: Option<Shard>,
    /// Take the shard from a Slurm job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT) or a
    /// Kubernetes indexed Job (JOB_COMPLETION_INDEX with --shard-count or MBMF_SHARD_COUNT).
    #[arg(long)]
    pub shard_from_env: bool,
    /// Number of shards for JOB_COMPLETION_INDEX [default: MBMF_SHARD_COUNT].
    #[arg(long, value_name = "N", requires = "shard_from_env")]
    pub shard_count: Option<u32>,
    /// Runs simulated at once and written per part file (bounds memory); results do not depend
    /// on it.
    #[arg(long, default_value_t = 256)]
    pub batch_size: usize,
    /// No progress bar and no summary line (for batch jobs); warnings and errors still print.
    #[arg(long)]
    pub quiet: bool,
}

impl SweepArgs {
    /// The dataset folder: `--out`, or `out/<file stem>`.
    pub fn out_dir(&self) -> PathBuf {
        self.out.clone().unwrap_or_else(|| {
            let stem = self
                .file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "sweep".into());
            PathBuf::from("out").join(stem)
        })
    }

    /// The shard this process runs.
    pub fn shard(&self) -> Result<Shard, shard::ShardError> {
        if self.shard_from_env {
            Shard::from_env(|name| std::env::var(name).ok(), self.shard_count)
        } else {
            Ok(self.shard.unwrap_or(Shard::ALL))
        }
    }
}

fn preview(values: &[String]) -> String {
    if values.len() <= 8 {
        values.join(", ")
    } else {
        format!(
            "{}, ..., {}",
            values[..5].join(", "),
            values[values.len() - 2..].join(", ")
        )
    }
}

/// The plan printed by `--dry-run`.
pub fn describe_plan(sweep: &Sweep, shard: Shard) -> String {
    let mut lines = vec![format!(
        "{}: {} configurations x {} seeds = {} runs (master seed {})",
        sweep.file,
        sweep.configurations(),
        sweep.seeds,
        sweep.runs(),
        sweep.master_seed
    )];
    for axis in &sweep.axes {
        let names: Vec<&str> = axis.keys.iter().map(|k| k.name()).collect();
        let values: Vec<String> = axis
            .values
            .iter()
            .map(|row| {
                let items: Vec<String> = row.iter().map(|v| v.to_string()).collect();
                if items.len() == 1 {
                    items[0].clone()
                } else {
                    format!("({})", items.join(", "))
                }
            })
            .collect();
        lines.push(format!(
            "  {} {}: {} values: {}",
            axis.section,
            names.join(", "),
            values.len(),
            preview(&values)
        ));
    }
    if !sweep.fixed.is_empty() {
        let fixed: Vec<String> = sweep
            .fixed
            .iter()
            .map(|(k, v)| format!("{} = {v}", k.name()))
            .collect();
        lines.push(format!("  [fixed] {}", fixed.join(", ")));
    }
    for p in &sweep.profiles {
        let values: Vec<String> = p
            .values
            .iter()
            .map(|(k, v)| format!("{} = {v}", k.name()))
            .collect();
        lines.push(format!("  [profiles.{}] {}", p.name, values.join(", ")));
    }
    if shard != Shard::ALL {
        let configs = shard.configs(sweep.configurations()).count() as u64;
        lines.push(format!(
            "  shard {shard}: {configs} configurations, {} runs",
            configs * u64::from(sweep.seeds)
        ));
    }
    lines.join("\n")
}

/// `mbmf compact`.
#[derive(Debug, Clone, Args)]
pub struct CompactArgs {
    /// A finished sweep dataset (the --out folder of mbmf sweep).
    pub dir: PathBuf,
    /// Runs per merged file (parts with different text parameters are never merged, so a
    /// filter on controller or interaction still skips files).
    #[arg(long, default_value_t = 50_000, value_name = "N")]
    pub runs_per_file: u64,
}

/// Runs `mbmf compact`: merges the parts of a finished dataset into large files, swapped in at
/// once.
pub fn compact_command(args: &CompactArgs) -> Result<(), Failure> {
    if args.runs_per_file == 0 {
        return Err(usage(anyhow!(
            "--runs-per-file 0: give at least 1 run per file"
        )));
    }
    let done = store::compact(&args.dir, args.runs_per_file).map_err(|e| match &e {
        store::StoreError::Io { .. } | store::StoreError::Output(_) => runtime(e),
        _ => usage(e),
    })?;
    println!(
        "{}: {} runs in {} part(s) per table, {} before",
        args.dir.display(),
        done.runs,
        done.parts_after,
        done.parts_before
    );
    Ok(())
}

/// Runs `mbmf sweep`.
pub fn command(args: &SweepArgs) -> Result<(), Failure> {
    let sweep = Sweep::load(&args.file).map_err(usage)?;
    let shard = args.shard().map_err(usage)?;
    if args.batch_size == 0 {
        return Err(usage(anyhow!("--batch-size must be at least 1")));
    }
    let specs = sweep.load_specs().map_err(usage)?;
    sweep.check(&specs).map_err(usage)?;
    if args.dry_run {
        println!("{}", describe_plan(&sweep, shard));
        let e = runner::estimate(&sweep, &specs, shard).map_err(usage)?;
        let time = if e.seconds < 1.0 {
            "under a second".to_string()
        } else {
            format!("about {}", runner::human_duration(e.seconds))
        };
        println!(
            "  agent-steps: {} (babbling included)\nestimated time: {time} with {} thread(s) \
             (timed on {} sample run(s) in {:.1} s)",
            e.agent_steps, e.threads, e.samples, e.calibration_seconds
        );
        return Ok(());
    }
    let options = Options {
        out: args.out_dir(),
        resume: args.resume,
        shard,
        batch_size: args.batch_size,
        quiet: args.quiet,
    };
    let report = execute(&sweep, &specs, &options, &mut |w| eprintln!("warning: {w}")).map_err(
        |e| match &e {
            RunError::Store(s) if s.is_usage() => usage(e),
            _ => runtime(e),
        },
    )?;
    if !args.quiet {
        println!("{}", report.line());
    }
    Ok(())
}
