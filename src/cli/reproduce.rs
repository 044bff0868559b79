//! `mbmf reproduce`: the paper's experiments, with a progress bar and the summary table.

use std::path::PathBuf;

use clap::Args;

use super::args::{check_out_dir, runs_count, seed};
use super::{Failure, progress, runtime};
use crate::reproduce::{Options, reproduce};

/// `mbmf reproduce`.
#[derive(Debug, Clone, Args)]
pub struct ReproduceArgs {
    /// Output folder for the data, figures and report.md.
    #[arg(long, default_value = "out/reproduce")]
    pub out: PathBuf,
    /// A small version that runs in seconds (6 runs, 2,000 / 4,000 steps, the paper's budgets
    /// only); its numbers are for checking the pipeline, not for conclusions.
    #[arg(long)]
    pub quick: bool,
    /// Runs per condition, 1 to 1000000 (default 50, or 6 with --quick).
    #[arg(long, value_parser = runs_count, allow_negative_numbers = true)]
    pub runs: Option<u32>,
    /// Master seed, 0 to 2^64 - 1.
    #[arg(long, default_value_t = 2020, value_parser = seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// No progress bar; the table and the summary line still print on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `mbmf reproduce`.
pub fn command(args: &ReproduceArgs) -> Result<(), Failure> {
    check_out_dir(&args.out, "--out")?;
    let options = Options {
        out: args.out.clone(),
        quick: args.quick,
        runs: args.runs,
        seed: args.seed,
        command: super::command_line(),
    };
    let bar = progress::bar(0, args.quiet, false);
    let summary = reproduce(&options, |n| bar.set_length(n), |n| bar.inc(n));
    bar.finish_and_clear();
    let summary = summary.map_err(runtime)?;
    out!("{}", summary.table);
    outln!(
        "\n{} runs in {:.1} s; report: {}; figures: {}",
        summary.runs,
        summary.seconds,
        summary.report.display(),
        summary.figures.display()
    );
    Ok(())
}
