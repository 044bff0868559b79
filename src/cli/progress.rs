//! Progress bars on stderr. Their length is agent-steps, so the ETA weighs long and short runs
//! right; they are hidden when asked (`--quiet`) or when stderr is not a terminal.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `total_agent_steps`; `message` says whether the template shows a message (the runs
/// done) and drops the steps-per-second rate.
pub fn bar(total_agent_steps: u64, quiet: bool, message: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total_agent_steps);
    let template = if message {
        "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% {msg}, ETA {eta}"
    } else {
        "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% {msg} ({per_sec}, ETA {eta})"
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}
