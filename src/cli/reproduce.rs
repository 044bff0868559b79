//! `mbmf reproduce`: the paper's experiments (or, with `--study arbitration`, the comparison of
//! the arbitration rules), with a progress bar and the summary table.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::{Args, ValueEnum};

use super::args::{check_out_dir, runs_count, seed};
use super::{Failure, progress, runtime, signal, usage};
use crate::reproduce::arbitration::{self, arbitration};
use crate::reproduce::{Options, reproduce};

/// Which study `mbmf reproduce` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Study {
    /// The paper's experiments (SPEC 9) and its claims one by one.
    Paper,
    /// Which arbitration rule (SPEC 12) wins: the sweeps sweeps/arbitration-*.toml.
    Arbitration,
}

/// `mbmf reproduce`.
#[derive(Debug, Clone, Args)]
pub struct ReproduceArgs {
    /// Which study: the paper's (default) or the comparison of the arbitration rules, which runs
    /// the shipped sweeps sweeps/arbitration-*.toml, resumably (rerunning continues where it
    /// stopped).
    #[arg(long, value_enum, default_value_t = Study::Paper)]
    pub study: Study,
    /// Output folder for the data, figures and report.md (default out/reproduce, or
    /// out/arbitration with --study arbitration).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A small version that runs in seconds (paper: 6 runs, 2,000 / 4,000 steps, the paper's
    /// budgets only; arbitration: 3 runs per cell, short experiments); its numbers are for
    /// checking the pipeline, not for conclusions.
    #[arg(long)]
    pub quick: bool,
    /// Runs per condition, 1 to 1000000 (default 50, or 6 with --quick; 3 for the arbitration
    /// study's --quick).
    #[arg(long, value_parser = runs_count, allow_negative_numbers = true)]
    pub runs: Option<u32>,
    /// Master seed of the paper study, 0 to 2^64 - 1 (default 2020). The arbitration sweeps
    /// fix their own.
    #[arg(long, value_parser = seed, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// No progress bar; the table and the summary line still print on stdout.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `mbmf reproduce`.
pub fn command(args: &ReproduceArgs) -> Result<(), Failure> {
    if args.study == Study::Arbitration {
        return arbitration_command(args);
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/reproduce"));
    check_out_dir(&out, "--out")?;
    let options = Options {
        out,
        quick: args.quick,
        runs: args.runs,
        seed: args.seed.unwrap_or(2020),
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

/// Runs `mbmf reproduce --study arbitration`.
fn arbitration_command(args: &ReproduceArgs) -> Result<(), Failure> {
    if args.seed.is_some() {
        return Err(usage(anyhow!(
            "--seed applies to the paper study; the arbitration sweeps \
             (sweeps/arbitration-*.toml) fix their own master seeds"
        )));
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/arbitration"));
    check_out_dir(&out, "--out")?;
    let options = arbitration::Options {
        out,
        quick: args.quick,
        runs: args.runs,
        sweeps_dir: arbitration::default_sweeps_dir(),
        command: super::command_line(),
    };
    let stop = signal::install();
    let bar = progress::bar(0, args.quiet, false);
    let summary = arbitration(&options, stop, |n| bar.set_length(n), |n| bar.inc(n));
    bar.finish_and_clear();
    let summary = summary.map_err(runtime)?;
    if !args.quiet {
        for note in &summary.notes {
            eprintln!("note: {note}");
        }
    }
    out!("{}", summary.table);
    outln!(
        "\n{} runs ({} simulated now, in {:.1} s); report: {}; figures: {}",
        summary.runs,
        summary.ran,
        summary.seconds,
        summary.report.display(),
        summary.figures.display()
    );
    Ok(())
}
