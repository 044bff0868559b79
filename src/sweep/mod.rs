//! Sweeps: a TOML file describing a grid of `mbmf run` parameters x seeds, expanded
//! into configurations, run in batches and streamed to a Parquet dataset that survives kills,
//! resumes, and splits into shards for job arrays. `sweeps/README.md` documents the file format.
//!
//! - [`builder`]: sweeps built in code, with their canonical text.
//! - [`file`](mod@file): parsing and validation (messages name the file, line and key), expansion.
//! - [`keys`]: the parameters a sweep may set and how they map to [`crate::params::Params`].
//! - [`shard`]: `--shard I/N` and the Slurm / Kubernetes environment.
//! - [`store`]: the dataset folder: atomic parts, lock, resume scan, compaction.
//! - [`runner`]: batching, simulation, progress, and the `--dry-run` estimate.

pub mod builder;
pub mod file;
pub mod keys;
pub mod runner;
pub mod shard;
pub mod store;

pub use builder::Builder;
pub use file::{Sweep, SweepError};
pub use runner::{Event, Options, Report, RunError, execute};
pub use shard::Shard;

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
        let configs = shard.count_of(sweep.configurations());
        lines.push(format!(
            "  shard {shard}: {configs} configurations, {} runs",
            u128::from(configs) * u128::from(sweep.seeds)
        ));
    }
    lines.join("\n")
}
