//! Running many runs of one environment in batches, with progress: the loop shared by `mbmf run`,
//! `mbmf sweep` and `mbmf reproduce`.

use std::sync::Arc;

use indicatif::{ProgressBar, ProgressStyle};

use crate::batch::{Batch, RunConfig};
use crate::env::Spec;
use crate::error::ConfigError;
use crate::schedule::Schedule;

/// Steps every run advances between two progress updates.
const PROGRESS_STRIDE: u64 = 2_000;

/// A progress bar on stderr counting agent-steps, hidden when `quiet` or when stderr is not a
/// terminal.
pub fn progress_bar(total_agent_steps: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total_agent_steps);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% {msg} ({per_sec}, ETA {eta})",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar
}

/// Agent-steps (babbling included) that simulating `configs` takes.
pub fn agent_steps(configs: &[RunConfig]) -> u64 {
    configs
        .iter()
        .map(|c| u64::from(c.params.babbling) + u64::from(c.params.steps))
        .sum()
}

/// Simulates `configs` on `spec` in batches of at most `batch_size` runs, handing each finished
/// batch to `on_batch` (which writes it out) before the next is allocated, so memory stays
/// bounded by one batch.
pub fn simulate<E: From<ConfigError>>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    batch_size: usize,
    bar: &ProgressBar,
    on_batch: impl FnMut(&Batch) -> Result<(), E>,
) -> Result<(), E> {
    simulate_with_schedules(spec, configs, &[], &[], batch_size, bar, on_batch)
}

/// [`simulate`] where run `i` follows `schedules[run_schedule[i]]` (SPEC 10; an empty
/// `run_schedule` means no changes).
pub fn simulate_with_schedules<E: From<ConfigError>>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    schedules: &[Schedule],
    run_schedule: &[usize],
    batch_size: usize,
    bar: &ProgressBar,
    mut on_batch: impl FnMut(&Batch) -> Result<(), E>,
) -> Result<(), E> {
    let size = batch_size.max(1);
    for (k, chunk) in configs.chunks(size).enumerate() {
        let which = if run_schedule.is_empty() {
            &[][..]
        } else {
            &run_schedule[k * size..k * size + chunk.len()]
        };
        let mut batch = Batch::with_schedules(Arc::clone(spec), chunk.to_vec(), schedules, which)?;
        let longest = chunk
            .iter()
            .map(|c| u64::from(c.params.babbling) + u64::from(c.params.steps))
            .max()
            .unwrap_or(0);
        let mut done = 0;
        while done < longest {
            let stride = PROGRESS_STRIDE.min(longest - done);
            batch.advance(stride);
            done += stride;
            let advanced: u64 = chunk
                .iter()
                .map(|c| {
                    let end = u64::from(c.params.babbling) + u64::from(c.params.steps);
                    end.min(done) - end.min(done - stride)
                })
                .sum();
            bar.inc(advanced);
        }
        on_batch(&batch)?;
    }
    Ok(())
}
