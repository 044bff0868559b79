//! Progress bars on stderr. Their length is agent-steps, so the rate has a unit a reader can
//! compare across runs of any size and the ETA weighs long and short runs right. They are drawn
//! only on a terminal and never under `--quiet`, so logs and pipes get no control characters.

use std::io::IsTerminal as _;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

/// A bar of `total_agent_steps` showing the elapsed time, the share done, the rate in
/// agent-steps per second and the ETA; `message` says whether the template also shows a
/// message (e.g. the runs done) before the rate.
pub fn bar(total_agent_steps: u64, quiet: bool, message: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total_agent_steps), ProgressDrawTarget::stderr());
    let template = if message {
        "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% {msg}, {rate}, ETA {eta}"
    } else {
        "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% {rate}, ETA {eta}"
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        let style = style
            .with_key(
                "rate",
                |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&rate(state.per_sec()));
                },
            )
            .progress_chars("=> ");
        bar.set_style(style);
    }
    if message {
        // Until the caller's first message, so the line never starts with a bare comma.
        bar.set_message("0 runs");
    }
    bar
}

/// A rate of agent-steps per second with an SI prefix: `950 agent-steps/s`,
/// `12.3 k agent-steps/s`, `4.56 M agent-steps/s`, three significant digits.
pub fn rate(per_sec: f64) -> String {
    const UNIT: &str = "agent-steps/s";
    if !per_sec.is_finite() || per_sec < 0.0 {
        return format!("- {UNIT}");
    }
    let (value, prefix) = [(1e9, "G "), (1e6, "M "), (1e3, "k ")]
        .into_iter()
        .find(|&(scale, _)| per_sec >= scale)
        .map_or((per_sec, ""), |(scale, prefix)| (per_sec / scale, prefix));
    let decimals = if value >= 100.0 || prefix.is_empty() {
        0
    } else if value >= 10.0 {
        1
    } else {
        2
    };
    format!("{value:.decimals$} {prefix}{UNIT}")
}

#[cfg(test)]
mod tests {
    use super::rate;

    #[test]
    fn rates_carry_a_prefix_and_the_unit() {
        assert_eq!(rate(0.0), "0 agent-steps/s");
        assert_eq!(rate(950.4), "950 agent-steps/s");
        assert_eq!(rate(12_345.0), "12.3 k agent-steps/s");
        assert_eq!(rate(4_560_000.0), "4.56 M agent-steps/s");
        assert_eq!(rate(123_400_000.0), "123 M agent-steps/s");
        assert_eq!(rate(2.5e9), "2.50 G agent-steps/s");
        assert_eq!(rate(f64::NAN), "- agent-steps/s");
    }
}
