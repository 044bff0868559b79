//! The `mbmf` command line: argument definitions and the verbs' stories. Library errors are
//! turned into human messages here; [`Failure`] carries the exit code scripts rely on.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, anyhow};
use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::batch::{Batch, RunConfig};
use crate::env::{self, Spec};
use crate::experiment;
use crate::output;
use crate::params::{
    Controller, CostModel, HumanParams, Interaction, Params, Profile, Selection, default_steps,
};

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

/// mbmf: batch simulation of MF/MB expert coordination under variable human feedback.
#[derive(Debug, Parser)]
#[command(name = "mbmf", version, about, long_about = None, help_expected = true)]
pub struct Cli {
    /// Worker threads (default: RAYON_NUM_THREADS, else every core). Results do not depend on it.
    #[arg(long, global = true)]
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
    Run(Box<RunArgs>),
    /// Run a sweep file (grid of parameters x seeds) into a Parquet dataset.
    ///
    /// Example: mbmf sweep sweeps/kappa.toml --out out/kappa
    Sweep(Box<crate::sweep::SweepArgs>),
    /// Pareto front over configurations of a dataset (reward, cost, learning quality).
    Pareto(crate::analysis::cli::ParetoArgs),
    /// Pairwise Wilcoxon-Mann-Whitney tests of a metric between groups of runs.
    Stats(crate::analysis::cli::StatsArgs),
    /// Smallest interaction budget reaching the best accumulation rate, per controller.
    MinBudget(crate::analysis::cli::MinBudgetArgs),
    /// Run the paper's experiments and write its figures and a claim-by-claim report.
    Reproduce(crate::reproduce::ReproduceArgs),
    /// Print the headline speed figures of this machine in about a minute.
    Bench(crate::bench::BenchArgs),
    /// Inspect or export an environment.
    #[command(subcommand)]
    Env(EnvCommand),
}

/// `mbmf env ...`
#[derive(Debug, Subcommand)]
pub enum EnvCommand {
    /// Print the state and action counts, the goal and a few state names.
    Info {
        /// tidy1, tidy2 or json:PATH.
        task: String,
    },
    /// Write a built-in task in the authors' transition-model format.
    ///
    /// Example: mbmf env export tidy1 --json out/tidy1
    Export {
        /// tidy1, tidy2 or json:PATH.
        task: String,
        /// Folder to write TASK.json, keyStates.txt and spaces.txt into.
        #[arg(long)]
        json: PathBuf,
    },
}

/// On/off switch for flags that take a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// Every parameter of SPEC 3–4 as a flag; unset flags keep the SPEC default.
#[derive(Debug, Clone, Args, Default)]
pub struct ModelArgs {
    /// MF learning rate (Eq. 4), in (0, 1]. Default 0.6.
    #[arg(long)]
    pub alpha_mf: Option<f64>,
    /// MF discount, in [0, 1). Default 0.9.
    #[arg(long)]
    pub gamma_mf: Option<f64>,
    /// MB discount, in [0, 1). Default 0.95.
    #[arg(long)]
    pub gamma_mb: Option<f64>,
    /// Softmax temperature of MF, MB and the MC, > 0. Default 0.02.
    #[arg(long)]
    pub tau: Option<f64>,
    /// Initial action values. Default 0 (paper).
    #[arg(long, allow_hyphen_values = true)]
    pub q_init: Option<f64>,
    /// MB transition window N, 1 to 65535. Default 10.
    #[arg(long)]
    pub window_n: Option<u32>,
    /// Value iteration stops when a sweep's summed |dQ| is below this. Default 0.01.
    #[arg(long)]
    pub vi_epsilon: Option<f64>,
    /// Cap on value-iteration sweeps per inference (capped calls are counted). Default 10000.
    #[arg(long)]
    pub vi_max_sweeps: Option<u32>,
    /// Weight of the new value in the moving averages, in (0, 1]. Default 0.6.
    #[arg(long)]
    pub filter_alpha: Option<f64>,
    /// kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7), >= 0. Default 9.
    #[arg(long)]
    pub kappa_coeff: Option<f64>,
    /// Normalise entropies by log2(|A|). Default on.
    #[arg(long, value_enum)]
    pub normalise_entropy: Option<Switch>,
    /// How the MC selects an expert. Default softmax (paper).
    #[arg(long, value_enum)]
    pub selection: Option<SelectionArg>,
    /// How inference cost is measured. Default ops (deterministic).
    #[arg(long, value_enum)]
    pub cost_model: Option<CostModelArg>,
}

/// The MC's selection rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SelectionArg {
    /// Softmax over the two expert values and a draw (paper).
    Softmax,
    /// The better value, ties broken uniformly (authors' code).
    Argmax,
}

/// The cost measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CostModelArg {
    /// Q values read per inference (deterministic).
    Ops,
    /// Measured seconds per inference (not reproducible).
    Wallclock,
}

/// Controllers as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ControllerArg {
    /// Model-free alone.
    Mf,
    /// Model-based alone.
    Mb,
    /// Random choice between MF and MB.
    Rnd,
    /// Entropy and cost (the paper's MC).
    Ec,
    /// Entropy only.
    Entropy,
}

impl From<ControllerArg> for Controller {
    fn from(c: ControllerArg) -> Self {
        match c {
            ControllerArg::Mf => Controller::Mf,
            ControllerArg::Mb => Controller::Mb,
            ControllerArg::Rnd => Controller::Rnd,
            ControllerArg::Ec => Controller::Ec,
            ControllerArg::Entropy => Controller::Entropy,
        }
    }
}

/// Interaction types as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InteractionArg {
    /// No human.
    None,
    /// Bonus zeta on relevant actions (Eq. 8).
    Congratulation,
    /// The human puts the held cube in place.
    Takeover,
    /// Penalty zeta on errors.
    Punishment,
}

impl From<InteractionArg> for Interaction {
    fn from(i: InteractionArg) -> Self {
        match i {
            InteractionArg::None => Interaction::None,
            InteractionArg::Congratulation => Interaction::Congratulation,
            InteractionArg::Takeover => Interaction::Takeover,
            InteractionArg::Punishment => Interaction::Punishment,
        }
    }
}

/// Human profiles as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// No interaction.
    None,
    /// Congratulation, the paper's minimal budget per controller, forget 0.1, zeta 0.1.
    PaperCongratulation,
    /// Takeover, the paper's minimal budget per controller, forget 0.1.
    PaperTakeover,
    /// Congratulation on every relevant action (forget 0), budget 1000.
    Generous,
    /// Congratulation, forget 0.7, budget 300.
    Stingy,
    /// Congratulation, budget 10, then silence.
    StopsEarly,
}

impl From<ProfileArg> for Profile {
    fn from(p: ProfileArg) -> Self {
        match p {
            ProfileArg::None => Profile::None,
            ProfileArg::PaperCongratulation => Profile::PaperCongratulation,
            ProfileArg::PaperTakeover => Profile::PaperTakeover,
            ProfileArg::Generous => Profile::Generous,
            ProfileArg::Stingy => Profile::Stingy,
            ProfileArg::StopsEarly => Profile::StopsEarly,
        }
    }
}

/// The simulated human's flags (SPEC 5).
#[derive(Debug, Clone, Args, Default)]
pub struct HumanArgs {
    /// A named human; the flags below override its fields.
    #[arg(long, value_enum)]
    pub profile: Option<ProfileArg>,
    /// Interaction type. Default none.
    #[arg(long, value_enum)]
    pub interaction: Option<InteractionArg>,
    /// Interactions the human gives per run before stopping.
    #[arg(long)]
    pub budget: Option<u32>,
    /// Bonus weight of a congratulation (or penalty of a punishment). Default 0.1.
    #[arg(long)]
    pub zeta: Option<f64>,
    /// Probability that the human is inattentive at an opportunity, in [0, 1]. Default 0.1.
    #[arg(long)]
    pub forget: Option<f64>,
}

/// `mbmf run`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// tidy1, tidy2 or json:PATH (the authors' format, keyStates.txt and spaces.txt beside it).
    #[arg(long, default_value = "tidy1")]
    pub task: String,
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
    /// Controllers, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "mf,mb,rnd,ec"
    )]
    pub controller: Vec<ControllerArg>,
    /// Runs per controller.
    #[arg(long, default_value_t = 20)]
    pub runs: u32,
    /// Master seed; with the run index it fixes each run's random stream.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Experiment steps after babbling (default: 10,000 for tidy1 and json, 20,000 for tidy2).
    #[arg(long)]
    pub steps: Option<u32>,
    /// Babbling steps before the experiment (reward withheld, no human).
    #[arg(long, default_value_t = 1000)]
    pub babbling: u32,
    /// Write a series row every K experiment steps (and at the last).
    #[arg(long, default_value_t = 100)]
    pub checkpoint: u32,
    /// Output folder for runs.parquet and series.parquet.
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Runs simulated at once (bounds memory); results do not depend on it.
    #[arg(long, default_value_t = 4096)]
    pub batch_size: usize,
    /// No progress bar and no summary table.
    #[arg(long)]
    pub quiet: bool,
    /// Model parameters.
    #[command(flatten)]
    pub model: ModelArgs,
    /// The simulated human.
    #[command(flatten)]
    pub human: HumanArgs,
}

impl ModelArgs {
    /// Applies the flags that were given to `p`.
    pub fn apply(&self, p: &mut Params) {
        macro_rules! set {
            ($($field:ident),*) => { $( if let Some(v) = self.$field { p.$field = v; } )* };
        }
        set!(
            alpha_mf,
            gamma_mf,
            gamma_mb,
            tau,
            q_init,
            window_n,
            vi_epsilon,
            vi_max_sweeps
        );
        set!(filter_alpha, kappa_coeff);
        if let Some(s) = self.normalise_entropy {
            p.normalise_entropy = s == Switch::On;
        }
        if let Some(s) = self.selection {
            p.selection = match s {
                SelectionArg::Softmax => Selection::Softmax,
                SelectionArg::Argmax => Selection::Argmax,
            };
        }
        if let Some(c) = self.cost_model {
            p.cost_model = match c {
                CostModelArg::Ops => CostModel::Ops,
                CostModelArg::Wallclock => CostModel::Wallclock,
            };
        }
    }
}

impl HumanArgs {
    /// The human for `controller`: the profile's preset (or no interaction), then the flags.
    pub fn resolve(&self, controller: Controller) -> (HumanParams, Profile) {
        let (mut human, profile) = match self.profile {
            Some(p) => {
                let p = Profile::from(p);
                (p.human(controller).unwrap_or_default(), p)
            }
            None => (HumanParams::default(), Profile::None),
        };
        let mut custom = false;
        if let Some(i) = self.interaction {
            human.interaction = i.into();
            custom = true;
        }
        if let Some(b) = self.budget {
            human.budget = b;
            custom = true;
        }
        if let Some(z) = self.zeta {
            human.zeta = z;
            custom = true;
        }
        if let Some(f) = self.forget {
            human.forget_prob = f;
            custom = true;
        }
        let profile = if custom && self.profile.is_none() {
            Profile::Custom
        } else {
            profile
        };
        (human, profile)
    }
}

/// Loads the environment named by `task`, with explicit keyStates / spaces paths if given.
pub fn load_task(task: &str, key_states: Option<&Path>, spaces: Option<&Path>) -> Result<Spec> {
    if let Some(path) = task.strip_prefix("json:") {
        let mut paths = env::JsonPaths::beside(path);
        if let Some(k) = key_states {
            paths.key_states = k.to_path_buf();
        }
        if let Some(s) = spaces {
            paths.spaces = s.to_path_buf();
        }
        return Ok(env::json::load(&paths, task)?);
    }
    if key_states.is_some() || spaces.is_some() {
        return Err(anyhow!(
            "--key-states and --spaces only apply to json:PATH tasks, not '{task}'"
        ));
    }
    Ok(env::load(task)?)
}

/// Builds the configurations of `mbmf run`: for each controller, `runs` runs with consecutive
/// run indices (controller-major).
pub fn run_configs(args: &RunArgs) -> Result<Vec<RunConfig>> {
    let mut configs = Vec::new();
    for (ci, &controller) in args.controller.iter().enumerate() {
        let (human, profile) = args.human.resolve(controller.into());
        let mut params = Params {
            controller: controller.into(),
            human,
            profile,
            steps: args.steps.unwrap_or_else(|| default_steps(&args.task)),
            babbling: args.babbling,
            checkpoint: args.checkpoint,
            ..Params::default()
        };
        args.model.apply(&mut params);
        params.validate()?;
        for r in 0..args.runs {
            configs.push(RunConfig {
                params,
                seed: args.seed,
                run_index: ci as u64 * u64::from(args.runs) + u64::from(r),
            });
        }
    }
    Ok(configs)
}

/// `mbmf run`.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    if args.runs == 0 {
        return Err(usage(anyhow!("--runs must be at least 1")));
    }
    let spec = load_task(
        &args.task,
        args.key_states.as_deref(),
        args.spaces.as_deref(),
    )
    .map_err(usage)?;
    let spec = Arc::new(spec);
    let configs = run_configs(args).map_err(usage)?;
    for c in &configs {
        crate::batch::validate_for_spec(&spec, &c.params).map_err(usage)?;
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output folder {}", args.out.display()))
        .map_err(runtime)?;
    let metadata = vec![
        (
            "mbmf_version".to_string(),
            env!("CARGO_PKG_VERSION").to_string(),
        ),
        (
            "mbmf_command".to_string(),
            std::env::args().collect::<Vec<_>>().join(" "),
        ),
        ("master_seed".to_string(), args.seed.to_string()),
    ];
    let mut runs_sink = output::ParquetSink::new(&args.out.join("runs.parquet"), metadata.clone());
    let mut series_sink = output::ParquetSink::new(&args.out.join("series.parquet"), metadata);
    let bar = experiment::progress_bar(experiment::agent_steps(&configs), args.quiet);
    let mut summary = Summary::default();
    let started = std::time::Instant::now();
    experiment::simulate(&spec, &configs, args.batch_size, &bar, |batch: &Batch| {
        runs_sink.write(&output::runs_batch(batch)?)?;
        series_sink.write(&output::series_batch(batch)?)?;
        summary.add(batch);
        Ok::<(), anyhow::Error>(())
    })
    .map_err(runtime)?;
    bar.finish_and_clear();
    let runs_path = runs_sink.finish().map_err(runtime)?;
    let series_path = series_sink.finish().map_err(runtime)?;
    if !args.quiet {
        summary.print(&args.task, configs.len(), started.elapsed().as_secs_f64());
        eprintln!(
            "wrote {} and {}",
            runs_path.display(),
            series_path.display()
        );
    }
    Ok(())
}

/// Per-controller totals for the table printed after a run.
#[derive(Default)]
struct Summary {
    rows: Vec<(Controller, Vec<[f64; 3]>)>,
}

impl Summary {
    fn add(&mut self, batch: &Batch) {
        for (config, stats) in batch.configs().iter().zip(batch.stats()) {
            let c = config.params.controller;
            let share = if stats.decisions > 0 {
                stats.mb_decisions as f64 / stats.decisions as f64
            } else {
                0.0
            };
            let entry = match self.rows.iter_mut().position(|(k, _)| *k == c) {
                Some(i) => &mut self.rows[i].1,
                None => {
                    self.rows.push((c, Vec::new()));
                    &mut self.rows.last_mut().expect("just pushed").1
                }
            };
            entry.push([stats.total_reward, stats.cost_total(), share]);
        }
    }

    fn print(&self, task: &str, runs: usize, seconds: f64) {
        println!("{task}: {runs} runs in {seconds:.2} s");
        println!(
            "{:<10} {:>5} {:>22} {:>26} {:>18}",
            "controller", "runs", "total reward", "total cost (ops)", "MB share"
        );
        for (controller, values) in &self.rows {
            let col = |i: usize| mean_sd(&values.iter().map(|v| v[i]).collect::<Vec<_>>());
            let (r, rs) = col(0);
            let (c, cs) = col(1);
            let (m, ms) = col(2);
            println!(
                "{:<10} {:>5} {:>12.1} ± {:<7.1} {:>15.4e} ± {:<8.2e} {:>8.3} ± {:<6.3}",
                controller.name(),
                values.len(),
                r,
                rs,
                c,
                cs,
                m,
                ms
            );
        }
    }
}

/// Mean and sample standard deviation (0 for fewer than two values).
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = xs.iter().sum::<f64>() / n;
    if xs.len() < 2 {
        return (mean, 0.0);
    }
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// `mbmf env ...`.
pub fn env_command(cmd: &EnvCommand) -> Result<(), Failure> {
    match cmd {
        EnvCommand::Info { task } => {
            let spec = load_task(task, None, None).map_err(usage)?;
            println!("task      {}", spec.name);
            println!("states    {}", spec.n_states);
            println!("actions   {}", spec.n_actions);
            println!(
                "outcomes  {} (max {} per state-action pair)",
                spec.outcome_state.len(),
                spec.max_branching()
            );
            println!("initial   {:?}", spec.initial_states);
            println!(
                "goal      {} ({}), reward {}",
                spec.goal, spec.state_names[spec.goal as usize], spec.goal_reward
            );
            println!(
                "human     {}",
                if spec.human.is_some() {
                    "defined"
                } else {
                    "not defined (no interactions)"
                }
            );
            for (i, name) in spec.state_names.iter().enumerate().take(5) {
                println!("  state {i:>4}: {name}");
            }
            Ok(())
        }
        EnvCommand::Export { task, json } => {
            let spec = load_task(task, None, None).map_err(usage)?;
            let paths = env::json::export(&spec, json).map_err(runtime)?;
            println!(
                "wrote {}, {} and {}",
                paths.model.display(),
                paths.key_states.display(),
                paths.spaces.display()
            );
            Ok(())
        }
    }
}

/// Parses the arguments and runs the verb.
pub fn main_with_args(args: impl IntoIterator<Item = std::ffi::OsString>) -> Result<(), Failure> {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { EXIT_USAGE } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    if let Some(n) = cli.threads {
        if n == 0 {
            return Err(usage(anyhow!("--threads must be at least 1")));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| runtime(anyhow!("cannot start {n} worker threads: {e}")))?;
    }
    match &cli.command {
        Command::Run(args) => run(args),
        Command::Sweep(args) => crate::sweep::command(args),
        Command::Pareto(args) => crate::analysis::cli::pareto(args),
        Command::Stats(args) => crate::analysis::cli::stats(args),
        Command::MinBudget(args) => crate::analysis::cli::min_budget(args),
        Command::Reproduce(args) => crate::reproduce::command(args),
        Command::Bench(args) => crate::bench::command(args),
        Command::Env(cmd) => env_command(cmd),
    }
}
