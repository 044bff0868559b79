//! `mbmf fit-human`: the simulated human fitted to traced sessions (SPEC 15), printed as a table
//! (or `--json`) and written as a profile file that `mbmf run --profile-file` and sweep files
//! read.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::Args;

use super::analysis::{Dataset, render, warn};
use super::{Failure, runtime, usage};
use crate::analysis::dataset::{self, Filter};
use crate::analysis::fit_human::{self, EVENT_NAMES, Estimate, HumanFit, Session};

/// The profile file `mbmf fit-human` writes.
pub const PROFILE_FILE: &str = "fitted_humans.toml";

/// `mbmf fit-human`.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:
  mbmf run --controller ec --interaction congratulation --budget 300 --error-prob 0.1 --trace --out out/h
  mbmf fit-human out/h                     # one human per run
  mbmf fit-human out/h --by controller     # runs pooled per controller
  mbmf run --profile-file out/h/analysis/fitted_humans.toml --profile-name fitted-run-0")]
pub struct FitHumanArgs {
    /// The dataset (written with --trace) and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Read the trace from this file or folder (trace.parquet, a trace/ folder, or a folder of
    /// .parquet files) as it is, e.g. a session log kept apart from its runs (default: the trace
    /// committed with the dataset's runs).
    #[arg(long, value_name = "PATH")]
    pub trace: Option<PathBuf>,
    /// Pool the runs that share the values of these columns of the runs table into one
    /// session (repeatable, or comma-separated), e.g. --by controller.
    #[arg(long, value_name = "COLUMN", value_delimiter = ',', value_parser = super::args::column)]
    pub by: Vec<String>,
    /// Steps per window of the interaction rate over the session.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(1..))]
    pub window: u32,
    /// Folder for fitted_humans.toml (default: analysis/ in the dataset's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout instead of the table (the file written, each session's
    /// estimates, intervals, counts, shares and rates).
    #[arg(long)]
    pub json: bool,
}

/// Runs `mbmf fit-human`.
pub fn fit_human(args: &FitHumanArgs) -> Result<(), Failure> {
    let folder = args
        .out
        .clone()
        .unwrap_or_else(|| dataset::output_folder(&args.data.dir));
    super::args::check_out_dir(&folder, "--out")?;
    let read = dataset::read_table(&args.data.dir, "runs", &args.data.options()).map_err(usage)?;
    warn(&read.warnings);
    let runs = Filter::apply_all(&read.table, &args.data.filters).map_err(usage)?;
    let trace = match &args.trace {
        Some(path) => fit_human::read_trace_at(path).map_err(usage)?,
        None => {
            let read = dataset::read_table(&args.data.dir, "trace", &args.data.options())
                .map_err(|e| usage(anyhow!("{e} (fit-human needs runs written with --trace)")))?;
            warn(&read.warnings);
            read.table
        }
    };
    let fitted = fit_human::fit_humans(&runs, &trace, &args.by, args.window).map_err(usage)?;
    for note in &fitted.notes {
        eprintln!("note: {note}");
    }
    std::fs::create_dir_all(&folder).map_err(|e| {
        runtime(anyhow!(
            "cannot create output folder {}: {e}",
            folder.display()
        ))
    })?;
    let path = folder.join(PROFILE_FILE);
    crate::whole_file::write_atomic(
        &path,
        fitted.profile_file(&super::command_line()).as_bytes(),
    )
    .map_err(|(p, e)| runtime(anyhow!("cannot write {}: {e}", p.display())))?;
    if args.json {
        outln!("{}", json(&fitted, &path));
    } else {
        print(&fitted);
        outln!("wrote {}", path.display());
    }
    Ok(())
}

/// An estimate as `0.102 [0.081, 0.125]`, or `-` when not identified.
fn shown(e: &Estimate) -> String {
    match e.value {
        Some(v) => format!("{v:.3} [{:.3}, {:.3}]", e.low, e.high),
        None => "-".to_owned(),
    }
}

/// The session's key, as the table's first column.
fn label(s: &Session) -> String {
    s.key
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn print(fitted: &HumanFit) {
    outln!(
        "{}: simulated human fitted per {} (SPEC 15; maximum likelihood, 95% profile-likelihood \
         intervals; opportunities after the budget is spent are not counted)",
        fitted.source,
        if fitted.by.is_empty() {
            "run".to_owned()
        } else {
            fitted.by.join(", ")
        }
    );
    let headers: Vec<String> = [
        "session",
        "runs",
        "steps",
        "types",
        "merited k/n",
        "other k/n",
        "holds k/n",
        "forget_prob [95%]",
        "error_prob [95%]",
    ]
    .map(String::from)
    .to_vec();
    let frac = |(n, k): (u64, u64)| format!("{k}/{n}");
    let rows: Vec<Vec<String>> = fitted
        .sessions
        .iter()
        .map(|s| {
            vec![
                label(s),
                s.runs.to_string(),
                s.steps.to_string(),
                s.types.join(","),
                frac(s.counts.merited),
                frac(s.counts.other),
                frac(s.counts.holds),
                shown(&s.fit.forget),
                shown(&s.fit.error),
            ]
        })
        .collect();
    out!("{}", render(&headers, &rows, 1));
    outln!();
    outln!(
        "interaction shares and rate per 1,000 steps in windows of {} steps:",
        fitted.window
    );
    for s in &fitted.sessions {
        let shares: Vec<String> = EVENT_NAMES
            .iter()
            .zip(s.shares())
            .filter_map(|(name, share)| {
                share
                    .filter(|&x| x > 0.0)
                    .map(|x| format!("{name} {:.0}%", 100.0 * x))
            })
            .collect();
        let rates: Vec<String> = s
            .rates()
            .iter()
            .map(|r| r.map_or_else(|| "-".to_owned(), |x| format!("{x:.1}")))
            .collect();
        outln!(
            "  {}: {} interactions ({}); rate {}",
            label(s),
            s.events.iter().sum::<u64>(),
            if shares.is_empty() {
                "none".to_owned()
            } else {
                shares.join(", ")
            },
            rates.join(" ")
        );
    }
}

/// The `--json` report: one object per session.
fn json(fitted: &HumanFit, path: &std::path::Path) -> serde_json::Value {
    let estimate =
        |e: &Estimate| serde_json::json!({ "value": e.value, "low": e.low, "high": e.high });
    let pair = |(n, k): (u64, u64)| serde_json::json!({ "opportunities": n, "interactions": k });
    let sessions: Vec<serde_json::Value> = fitted
        .sessions
        .iter()
        .map(|s| {
            let key: serde_json::Map<String, serde_json::Value> = s
                .key
                .iter()
                .map(|(k, v)| (k.clone(), serde_json::json!(v.to_string())))
                .collect();
            let events: serde_json::Map<String, serde_json::Value> = EVENT_NAMES
                .iter()
                .zip(s.events)
                .map(|(n, k)| ((*n).to_owned(), serde_json::json!(k)))
                .collect();
            let shares: serde_json::Map<String, serde_json::Value> = EVENT_NAMES
                .iter()
                .zip(s.shares())
                .map(|(n, x)| ((*n).to_owned(), serde_json::json!(x)))
                .collect();
            serde_json::json!({
                "session": key,
                "profile": s.profile_name(),
                "runs": s.runs,
                "steps": s.steps,
                "types": s.types,
                "merited": pair(s.counts.merited),
                "other": pair(s.counts.other),
                "holds": pair(s.counts.holds),
                "forget_prob": estimate(&s.fit.forget),
                "error_prob": estimate(&s.fit.error),
                "log_likelihood": s.fit.log_likelihood,
                "interactions": events,
                "shares": shares,
                "rate_per_1000": s.rates(),
                "interaction": s.interaction,
                "budget": s.budget,
            })
        })
        .collect();
    serde_json::json!({
        "verb": "fit-human",
        "source": fitted.source,
        "by": fitted.by,
        "window": fitted.window,
        "interval": "95% profile likelihood",
        "files": [path.display().to_string()],
        "notes": fitted.notes,
        "sessions": sessions,
    })
}
