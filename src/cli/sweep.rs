//! `mbmf sweep`: a sweep file run into a Parquet dataset, with a progress bar and a summary line,
//! or (`--dry-run`) its plan and an estimate of its time.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::anyhow;
use clap::Args;

use super::{Failure, progress, runtime, signal, usage};
use crate::sizing;
use crate::sweep::{
    Event, Options, RunError, Shard, Sweep, describe_plan, execute, runner, shard, store,
};

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
    /// No progress bar and no notes on stderr (for batch jobs); the summary line still prints
    /// on stdout, and warnings and errors on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print one JSON object on stdout instead of the summary line (dataset folder, shard, run
    /// counts, parts written, timing); progress and warnings stay on stderr.
    #[arg(long)]
    pub json: bool,
    /// Also write trace/ parts: one row per experiment step of every run (as the sweep file's
    /// `trace = true`; a sweep is traced from its start, and --resume keeps tracing it).
    #[arg(long)]
    pub trace: bool,
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

/// Runs `mbmf sweep`.
pub fn command(args: &SweepArgs) -> Result<(), Failure> {
    if !args.dry_run {
        super::args::check_out_dir(&args.out_dir(), "--out")?;
    }
    let mut sweep = Sweep::load(&args.file).map_err(usage)?;
    sweep.trace |= args.trace;
    for warning in &sweep.warnings {
        eprintln!("warning: {warning}");
    }
    let shard = args.shard().map_err(usage)?;
    if args.batch_size == 0 {
        return Err(usage(anyhow!("--batch-size must be at least 1")));
    }
    // Sized by arithmetic before anything is loaded, checked or allocated: a grid too large
    // to run is refused in a moment, naming what shrinks it.
    let shrink = sweep.shrink();
    let out = args.out_dir();
    let size = sweep
        .check_size(shard, args.batch_size, &out, args.resume)
        .map_err(|e| usage(anyhow!("{}: {e}", args.file.display())))?;
    let specs = sweep.load_specs().map_err(usage)?;
    for (task, spec) in sweep.tasks.iter().zip(&specs) {
        if !spec.can_move() {
            eprintln!(
                "warning: {}: {}",
                sweep.place(crate::sweep::keys::Key::Task),
                super::args::no_transition(task)
            );
        }
    }
    sweep.check(&specs).map_err(usage)?;
    if args.dry_run || size.is_huge() {
        let e = runner::estimate(&sweep, &specs, shard).map_err(usage)?;
        let time = if e.seconds < 1.0 {
            "under a second".to_string()
        } else {
            format!("about {}", runner::human_duration(e.seconds))
        };
        let estimate = format!(
            "estimated time: {time} with {} thread(s) (timed on {} sample run(s) in {:.1} s)\n\
             estimated output: about {} ({} runs rows, {}{} series rows{}; {}{} part(s) per table of at \
             most {} runs)",
            e.threads,
            e.samples,
            e.calibration_seconds,
            sizing::human_bytes(size.output_bytes()),
            size.runs,
            if size.exact { "" } else { "about " },
            size.series_rows,
            if size.trace_rows > 0 {
                format!(", {} trace rows", size.trace_rows)
            } else {
                String::new()
            },
            if size.parts_exact { "" } else { "about " },
            size.parts,
            args.batch_size,
        );
        if args.dry_run {
            // With --resume, what is already written is left out of the run (the estimates
            // above are the whole shard's, as the disk check counts the files there as its own).
            let written = if args.resume {
                runner::already_written(&sweep, shard, &out).map_err(usage)?
            } else {
                0
            };
            if args.json {
                // u128 counts as numbers where JSON's doubles hold them exactly, else as text.
                let count = |n: u128| match u64::try_from(n) {
                    Ok(n) if n < (1 << 53) => serde_json::json!(n),
                    _ => serde_json::json!(n.to_string()),
                };
                let json = serde_json::json!({
                    "verb": "sweep",
                    "dry_run": true,
                    "file": args.file.display().to_string(),
                    "shard": shard.to_string(),
                    "configurations": sweep.configurations(),
                    "shard_configurations": shard.count_of(sweep.configurations()),
                    "seeds": sweep.seeds,
                    "master_seed": sweep.master_seed,
                    "runs": count(size.runs),
                    "agent_steps": count(e.agent_steps),
                    "exact": size.exact,
                    "estimated_seconds": e.seconds,
                    "threads": e.threads,
                    "estimated_output_bytes": count(size.output_bytes()),
                    "parts": count(size.parts),
                    "parts_exact": size.parts_exact,
                    "series_rows": count(size.series_rows),
                    "trace_rows": count(size.trace_rows),
                    "already_written": written,
                    "warnings": sweep.warnings,
                });
                outln!("{json}");
            } else {
                outln!("{}", describe_plan(&sweep, shard));
                outln!(
                    "  agent-steps: {}{} (babbling included)\n{estimate}",
                    if size.exact { "" } else { "about " },
                    e.agent_steps
                );
                if args.resume {
                    outln!(
                        "already written in {}: {written} of these {} runs; --resume runs the \
                         other {} (the estimates above are for all of them)",
                        out.display(),
                        size.runs,
                        size.runs.saturating_sub(u128::from(written))
                    );
                }
            }
            if let Err(refusal) = sizing::check_time(&e, &shrink) {
                return Err(usage(anyhow!("{}: {refusal}", args.file.display())));
            }
            return Ok(());
        }
        sizing::check_time(&e, &shrink)
            .map_err(|refusal| usage(anyhow!("{}: {refusal}", args.file.display())))?;
        if !args.quiet {
            eprintln!(
                "{}: {} runs, {} agent-steps; {estimate}",
                args.file.display(),
                size.runs,
                e.agent_steps
            );
        }
    }
    let options = Options {
        out: args.out_dir(),
        resume: args.resume,
        shard,
        batch_size: args.batch_size,
        command: super::command_line(),
    };
    let mut bar = None;
    let started = Instant::now();
    // Runs of the shard committed before this process, and its progress: what an interruption
    // reports as kept.
    let mut kept = (0u64, 0u64, 0u64);
    let mut on_event = |event: Event| match event {
        Event::Warning(w) => eprintln!("warning: {w}"),
        Event::Resuming { done, of, to_run } => {
            kept.0 = done;
            if !args.quiet {
                eprintln!(
                    "resuming {}: {done} of {of} runs{} already done, {to_run} to run",
                    options.out.display(),
                    if shard == Shard::ALL {
                        String::new()
                    } else {
                        format!(" of shard {shard}")
                    }
                );
            }
        }
        Event::Started { agent_steps } => {
            bar = Some(progress::bar(agent_steps, args.quiet, true));
        }
        Event::Advanced(steps) => {
            if let Some(b) = &bar {
                b.inc(steps);
            }
        }
        Event::Ran { ran, to_run } => {
            (kept.1, kept.2) = (ran, to_run);
            let secs = started.elapsed().as_secs_f64().max(1e-9);
            if let Some(b) = &bar {
                b.set_message(format!(
                    "{ran}/{to_run} runs, {:.1} runs/s",
                    ran as f64 / secs
                ));
            }
        }
    };
    let stop = signal::install();
    let report = execute(&sweep, &specs, &options, stop, &mut on_event);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let report = report.map_err(|e| match e {
        RunError::Interrupted(_) => interrupted(args, &options, kept),
        e if e.is_usage() => usage(e),
        e => runtime(e),
    })?;
    if args.json {
        let json = serde_json::json!({
            "verb": "sweep",
            "file": args.file.display().to_string(),
            "out": report.out.display().to_string(),
            "shard": report.shard.to_string(),
            "runs_total": report.total,
            "shard_runs": report.shard_runs,
            "shard_done_before": report.shard_done_before,
            "done_before": report.done_before,
            "ran": report.ran,
            "parts_written": report.parts_written,
            "batch_size": report.batch_size,
            "seconds": report.seconds,
        });
        outln!("{json}");
    } else {
        outln!("{}", report.line());
    }
    Ok(())
}

/// The failure of a sweep stopped by a signal: what is committed, and the command that runs the
/// rest. `kept` is (runs of the shard done before, runs this process committed, runs it had to
/// run).
fn interrupted(args: &SweepArgs, options: &Options, kept: (u64, u64, u64)) -> Failure {
    let (before, ran, to_run) = kept;
    let whose = if options.shard == Shard::ALL {
        String::new()
    } else {
        format!(" of shard {}", options.shard)
    };
    let mut resume = format!(
        "mbmf sweep {} --out {} --resume",
        shell_word(&args.file.to_string_lossy()),
        shell_word(&options.out.to_string_lossy())
    );
    if args.shard_from_env {
        resume.push_str(" --shard-from-env");
        if let Some(n) = args.shard_count {
            resume.push_str(&format!(" --shard-count {n}"));
        }
    } else if let Some(s) = args.shard {
        resume.push_str(&format!(" --shard {s}"));
    }
    Failure {
        code: signal::exit_code(),
        error: anyhow!(
            "interrupted by {}: {} holds {} of {} runs{whose} ({ran} committed by this process, \
             no partial part left, lock released); run the rest with: {resume}",
            signal::received(),
            options.out.display(),
            before + ran,
            before + to_run,
        ),
    }
}

/// `word` as one shell word: unchanged when it is plain, else in single quotes.
fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
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
pub fn compact(args: &CompactArgs) -> Result<(), Failure> {
    if args.runs_per_file == 0 {
        return Err(usage(anyhow!(
            "--runs-per-file 0: give at least 1 run per file"
        )));
    }
    // As sweep --resume: a bad folder or part is the input's fault (2), a live writer or a
    // failed write is not (1).
    let done = store::compact(&args.dir, args.runs_per_file, &super::command_line())
        .map_err(|e| if e.is_usage() { usage(e) } else { runtime(e) })?;
    for stray in &done.strays {
        eprintln!("warning: {}", store::stray_warning(stray));
    }
    if done.parts_after == done.parts_before {
        outln!(
            "{}: {} runs in {} part(s) per table: nothing to merge (at most {} runs per file, \
             parts of other text parameters kept apart), left as it was",
            args.dir.display(),
            done.runs,
            done.parts_after,
            args.runs_per_file
        );
    } else {
        outln!(
            "{}: {} runs in {} part(s) per table, {} before",
            args.dir.display(),
            done.runs,
            done.parts_after,
            done.parts_before
        );
    }
    Ok(())
}
