//! The `mbmf` command line: every verb, everything printed for a person, and the exit codes.
//! Library modules return data (reports, estimates, tables) and typed errors; this layer turns
//! them into text, progress bars and [`Failure`]s.

use anyhow::anyhow;
use clap::{Parser, Subcommand};

/// Writes formatted text to standard output; see [`write_stdout`].
macro_rules! out {
    ($($arg:tt)*) => { $crate::cli::write_stdout(format_args!($($arg)*)) };
}

/// Writes a line to standard output; see [`write_stdout`].
macro_rules! outln {
    () => { $crate::cli::write_stdout(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::cli::write_stdout(format_args!("{}\n", format_args!($($arg)*))) };
}

pub mod analysis;
pub mod args;
pub mod bench;
pub mod docs;
pub mod env;
pub mod fit_human;
pub mod plot;
pub mod progress;
pub mod reproduce;
pub mod run;
pub mod signal;
pub mod sweep;
pub mod teach;

use args::threads_count;

/// Exit code for bad usage: unknown flags, values out of range, unreadable inputs.
pub const EXIT_USAGE: i32 = 2;
/// Exit code for failures while running: a write that failed, a full disk.
pub const EXIT_RUNTIME: i32 = 1;

/// An error with the exit code it should produce.
#[derive(Debug)]
pub struct Failure {
    /// 2 for usage errors, 1 for runtime failures.
    pub code: i32,
    /// What went wrong, with its causes.
    pub error: anyhow::Error,
}

/// Marks an error as a usage error (exit code 2).
pub fn usage(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: EXIT_USAGE,
        error: error.into(),
    }
}

/// Marks an error as a runtime failure (exit code 1).
pub fn runtime(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: EXIT_RUNTIME,
        error: error.into(),
    }
}

/// A library error with the exit code of its kind ([`crate::error::Usage`]): 2 for a usage
/// error, 1 for a failure while running.
pub fn failure<E>(error: E) -> Failure
where
    E: crate::error::Usage + std::error::Error + Send + Sync + 'static,
{
    if error.is_usage() {
        usage(error)
    } else {
        runtime(error)
    }
}

/// Writes to standard output. A closed pipe (`mbmf ... | head`) ends the process quietly with
/// success: the reader has what it wanted. Any other failure to write ends it with a message.
pub fn write_stdout(text: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(text).and_then(|()| stdout.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        let _ = writeln!(
            std::io::stderr(),
            "error: cannot write to standard output: {e}"
        );
        std::process::exit(EXIT_RUNTIME);
    }
}

/// The command line, one space between arguments, as every file written records it. Lossy: an
/// argument that is not UTF-8 (a path) must not stop the command.
pub fn command_line() -> String {
    std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// mbmf: batch simulation of MF/MB expert coordination under variable human feedback.
#[derive(Debug, Parser)]
#[command(
    name = "mbmf",
    version = crate::output::provenance::LONG_VERSION,
    about,
    long_about = None,
    help_expected = true,
    after_help = "Exit codes: 0 success, 1 runtime failure (e.g. a write that failed), 2 usage error (a bad flag, value, file or combination), 130 / 143 run or sweep stopped by SIGINT / SIGTERM."
)]
pub struct Cli {
    /// Worker threads, 1 to 4096 (default: RAYON_NUM_THREADS, else every core). Results do not
    /// depend on it.
    #[arg(long, global = true, value_parser = threads_count, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run one configuration (or a few controllers) and write runs.parquet and series.parquet.
    ///
    /// With no flags: task 1, controllers mf, mb, rnd and ec, 20 runs each, 10,000 steps.
    ///
    /// Example: mbmf run --task tidy1 --controller ec --interaction takeover --budget 50 --out out/ec
    Run(Box<run::RunArgs>),
    /// Run a sweep file (grid of parameters x seeds) into a Parquet dataset.
    ///
    /// Example: mbmf sweep sweeps/kappa.toml --out out/kappa
    Sweep(Box<sweep::SweepArgs>),
    /// Merge a finished sweep dataset's parts into large files, atomically.
    ///
    /// Example: mbmf compact out/kappa
    Compact(sweep::CompactArgs),
    /// Pareto front over configurations of a dataset (reward, cost, learning quality).
    Pareto(analysis::ParetoArgs),
    /// Pairwise Wilcoxon-Mann-Whitney tests of a metric between groups of runs.
    Stats(analysis::StatsArgs),
    /// Smallest interaction budget reaching the best accumulation rate, per controller.
    MinBudget(analysis::MinBudgetArgs),
    /// Two-step task: stay probabilities and reward / interaction effects per group, with tests.
    Stay(analysis::StayArgs),
    /// Fit the simulated human (forget_prob, error_prob) to traced sessions; write a profile file.
    FitHuman(fit_human::FitHumanArgs),
    /// Mean curves per group (with a standard-error band) from a dataset's series, changes marked.
    Plot(plot::PlotArgs),
    /// Run the paper's experiments and write its figures and a claim-by-claim report.
    Reproduce(reproduce::ReproduceArgs),
    /// Print the headline speed figures of this machine in about a minute.
    Bench(bench::BenchArgs),
    /// Serve a web page on which a person teaches a live run (each tab a session, saved as it
    /// goes).
    ///
    /// Example: mbmf teach --controller ec --task tidy1 --budget 100
    Teach(Box<teach::TeachArgs>),
    /// Replay a traced run (simulated or a person's session) in the web page.
    ///
    /// Example: mbmf view sessions --run 0
    View(teach::ViewArgs),
    /// Inspect or export an environment.
    #[command(subcommand)]
    Env(env::EnvCommand),
    /// Print a shell completion script (bash, zsh, fish, powershell, elvish).
    ///
    /// Example: mbmf completions bash > ~/.local/share/bash-completion/completions/mbmf
    Completions(docs::CompletionsArgs),
    /// Print the man page, or write one page per verb with --out DIR.
    ///
    /// Example: mbmf man --out man/man1
    Man(docs::ManArgs),
}

/// Adds a "similar subcommand" tip, by the rule of [`crate::suggest`], to an unknown verb that
/// clap found none for (`rnu` for `run`: clap's own rule misses transpositions).
pub fn suggest_verb(e: &mut clap::Error) {
    use clap::CommandFactory as _;
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if e.kind() != ErrorKind::InvalidSubcommand || e.get(ContextKind::SuggestedSubcommand).is_some()
    {
        return;
    }
    let Some(ContextValue::String(verb)) = e.get(ContextKind::InvalidSubcommand) else {
        return;
    };
    let command = Cli::command();
    let names = command.get_subcommands().map(|c| c.get_name());
    if let Some(name) = crate::suggest::closest(verb, names) {
        let suggestion = ContextValue::Strings(vec![name.to_string()]);
        e.insert(ContextKind::SuggestedSubcommand, suggestion);
    }
}

/// Turns an error and its causes into one line, each cause once: a cause whose text an earlier
/// message already holds (a Parquet error that quotes its I/O error, which it also gives as its
/// source) is not repeated, and Parquet's `External: ` prefix is dropped.
pub fn error_line(error: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        let text = text.replace("External: ", "");
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Runs the verb of parsed arguments.
pub fn execute(cli: &Cli) -> Result<(), Failure> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| runtime(anyhow!("cannot start {n} worker threads: {e}")))?;
    }
    match &cli.command {
        Command::Run(args) => run::run(args),
        Command::Sweep(args) => sweep::command(args),
        Command::Compact(args) => sweep::compact(args),
        Command::Pareto(args) => analysis::pareto(args),
        Command::Stats(args) => analysis::stats(args),
        Command::Stay(args) => analysis::stay(args),
        Command::MinBudget(args) => analysis::min_budget(args),
        Command::FitHuman(args) => fit_human::fit_human(args),
        Command::Plot(args) => plot::plot(args),
        Command::Reproduce(args) => reproduce::command(args),
        Command::Bench(args) => bench::command(args),
        Command::Teach(args) => teach::teach(args),
        Command::View(args) => teach::view(args),
        Command::Env(cmd) => env::command(cmd),
        Command::Completions(args) => docs::completions(args),
        Command::Man(args) => docs::man(args),
    }
}
