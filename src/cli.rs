//! The `mbmf` command line: argument definitions and the verbs' stories. Library errors are
//! turned into human messages here; [`Failure`] carries the exit code scripts rely on.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, anyhow};
use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::batch::{Batch, RunConfig};
use crate::env::tidy::Boxes;
use crate::env::{self, Spec};
use crate::error::ConfigError;
use crate::experiment;
use crate::output;
use crate::params::{
    CongratulationEffect, Controller, CostModel, HumanParams, Interaction, Params, Profile,
    RewardSource, Selection, cli_flag, default_steps,
};
use crate::schedule::Schedule;

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
#[command(
    name = "mbmf",
    version = crate::output::provenance::LONG_VERSION,
    about,
    long_about = None,
    help_expected = true,
    after_help = "Exit codes: 0 success, 1 runtime failure (e.g. a write that failed), 2 usage error (a bad flag, value, file or combination)."
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
    Run(Box<RunArgs>),
    /// Run a sweep file (grid of parameters x seeds) into a Parquet dataset.
    ///
    /// Example: mbmf sweep sweeps/kappa.toml --out out/kappa
    Sweep(Box<crate::sweep::SweepArgs>),
    /// Merge a finished sweep dataset's parts into large files, atomically.
    ///
    /// Example: mbmf compact out/kappa
    Compact(crate::sweep::CompactArgs),
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
        /// The json: task's files, if not beside the model.
        #[command(flatten)]
        files: TaskFiles,
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
        /// The json: task's files, if not beside the model.
        #[command(flatten)]
        files: TaskFiles,
    },
}

/// Where a `json:` task's keyStates.txt and spaces.txt are, when not beside the model file.
#[derive(Debug, Clone, Args, Default)]
pub struct TaskFiles {
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
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
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub alpha_mf: Option<f64>,
    /// MF discount, in [0, 1). Default 0.9.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub gamma_mf: Option<f64>,
    /// MB discount, in [0, 1). Default 0.95.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub gamma_mb: Option<f64>,
    /// Softmax temperature of MF, MB and the MC, > 0 (at least 1e-300). Default 0.02.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub tau: Option<f64>,
    /// Initial action values, from -1e12 to 1e12. Default 0 (paper).
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub q_init: Option<f64>,
    /// MB transition window N, 1 to 65535. Default 10.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub window_n: Option<u32>,
    /// Value iteration stops when a sweep's summed |dQ| is below this, > 0. Default 0.01.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub vi_epsilon: Option<f64>,
    /// Cap on value-iteration sweeps per inference, >= 1. A call that reaches it stops unconverged
    /// and is counted in the vi_capped column. Default 10000.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub vi_max_sweeps: Option<u32>,
    /// Weight of the new value in the moving averages, in (0, 1]. Default 0.6.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub filter_alpha: Option<f64>,
    /// kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7), >= 0. Default 9.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
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
    /// The human takes a cube just put in its box back out (SPEC 11.2).
    Nuisance,
}

/// Who brings the goal's reward (SPEC 11.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RewardSourceArg {
    /// The environment, at every arrival in the goal.
    Environment,
    /// Only an attentive human with budget left.
    Human,
}

/// How a congratulation acts (SPEC 11.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CongratulationEffectArg {
    /// A bias of zeta in the softmax (Eq. 8).
    Bias,
    /// Reward shaping: learned with r + zeta.
    Reward,
}

impl From<InteractionArg> for Interaction {
    fn from(i: InteractionArg) -> Self {
        match i {
            InteractionArg::None => Interaction::None,
            InteractionArg::Congratulation => Interaction::Congratulation,
            InteractionArg::Takeover => Interaction::Takeover,
            InteractionArg::Punishment => Interaction::Punishment,
            InteractionArg::Nuisance => Interaction::Nuisance,
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
    /// Only the human brings reward, 300 times (forget 0), then leaves.
    RewardsThenLeaves,
    /// A nuisance with a budget of 300.
    Nuisance,
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
            ProfileArg::RewardsThenLeaves => Profile::RewardsThenLeaves,
            ProfileArg::Nuisance => Profile::Nuisance,
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
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub budget: Option<u32>,
    /// Bonus weight of a congratulation (or penalty of a punishment), 0 to 1e12. Default 0.1.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
    pub zeta: Option<f64>,
    /// Probability that the human is inattentive at an opportunity, in [0, 1]. Default 0.1.
    #[arg(long, value_parser = number, allow_hyphen_values = true)]
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
    /// Runs per controller, 1 to 1000000.
    #[arg(long, default_value_t = 20, value_parser = runs_count, allow_negative_numbers = true)]
    pub runs: u32,
    /// Master seed; with the run index it fixes each run's random stream.
    #[arg(long, default_value_t = 1, value_parser = seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// Experiment steps after babbling (default: 10,000 for tidy1 and json, 20,000 for tidy2).
    /// 0 runs the babbling only: one row per run with zero reward and cost, and no series rows.
    #[arg(long, value_parser = count, allow_negative_numbers = true)]
    pub steps: Option<u32>,
    /// Babbling steps before the experiment (reward withheld, no human).
    #[arg(long, default_value_t = 1000, value_parser = count, allow_negative_numbers = true)]
    pub babbling: u32,
    /// Write a series row every K experiment steps (and at the last); 0 writes no series rows.
    #[arg(long, default_value_t = 100, value_parser = count, allow_negative_numbers = true)]
    pub checkpoint: u32,
    /// Output folder for runs.parquet and series.parquet (created if needed).
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Replace the results of an earlier run in --out (refused without it).
    #[arg(long)]
    pub force: bool,
    /// Runs simulated at once, >= 1 (lowered if a batch would not fit in memory); results do
    /// not depend on it.
    #[arg(long, default_value_t = 4096, value_parser = batch_size, allow_negative_numbers = true)]
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
    /// A change during the run at experiment step STEP (repeatable; events at one step apply in
    /// the order given): world=json:PATH, goal=S[:R], delete=S-T,..., boxes=PERM (tidy1),
    /// interaction=, budget= (left), forget=, zeta=, profile=, reward_source=.
    /// Example: --change 1601:goal=34 --change 1601:world=json:PATH
    #[arg(long = "change", value_name = "STEP:KEY=VALUE")]
    pub change: Vec<String>,
    /// tidy1's box assignment for the whole run, a permutation of rgb (position i: the box of
    /// cube i). Default rgb.
    #[arg(long, value_parser = boxes)]
    pub boxes: Option<Boxes>,
    /// Who brings the goal's reward. Default environment.
    #[arg(long, value_enum)]
    pub reward_source: Option<RewardSourceArg>,
    /// How a congratulation acts: bias (Eq. 8) or reward (shaping). Default bias.
    #[arg(long, value_enum)]
    pub congratulation_effect: Option<CongratulationEffectArg>,
}

/// `--boxes`.
fn boxes(text: &str) -> Result<Boxes, String> {
    Boxes::parse(text)
}

/// Most runs per controller of one `mbmf run` (every configuration is held in memory).
pub const MAX_RUNS: u64 = 1_000_000;

/// Most worker threads `--threads` accepts.
pub const MAX_THREADS: u64 = 4096;

/// Parses a number flag. Ranges are checked by [`Params::validate`], so flags and sweep files
/// share one set of rules; NaN and infinities parse here and are refused there.
fn number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| "expected a number, such as 0.5 or 1e-3".to_string())
}

/// Parses a whole number in `min..=max`, saying which rule a bad value breaks.
fn whole(text: &str, min: u64, max: u64) -> Result<u64, String> {
    let range = if max == u64::MAX {
        format!("a whole number >= {min}")
    } else {
        format!("a whole number from {min} to {max}")
    };
    match text.trim().parse::<i128>() {
        Ok(n) if n < i128::from(min) => Err(format!("{n} is too small: expected {range}")),
        Ok(n) if n > i128::from(max) => Err(format!("{n} is too large: expected {range}")),
        Ok(n) => Ok(n as u64),
        Err(_) if text.trim().parse::<f64>().is_ok() => {
            Err(format!("not a whole number: expected {range}"))
        }
        Err(_) => Err(format!("expected {range}")),
    }
}

/// A count of steps, sweeps or interactions: 0 to 2^32 - 1.
fn count(text: &str) -> Result<u32, String> {
    whole(text, 0, u64::from(u32::MAX)).map(|n| n as u32)
}

/// `--runs`: 1 to [`MAX_RUNS`].
fn runs_count(text: &str) -> Result<u32, String> {
    whole(text, 1, MAX_RUNS).map(|n| n as u32)
}

/// `--seed`: any 64-bit unsigned integer.
fn seed(text: &str) -> Result<u64, String> {
    whole(text, 0, u64::MAX)
}

/// `--batch-size`: at least 1.
fn batch_size(text: &str) -> Result<usize, String> {
    whole(text, 1, usize::MAX as u64).map(|n| n as usize)
}

/// `--threads`: 1 to [`MAX_THREADS`].
fn threads_count(text: &str) -> Result<usize, String> {
    whole(text, 1, MAX_THREADS).map(|n| n as usize)
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
        if path.is_empty() {
            return Err(anyhow!(
                "task 'json:' names no file: expected json:PATH, the transition-model file \
                 (e.g. json:data/navworld/realisticNavWorld.json)"
            ));
        }
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
        let flag = if key_states.is_some() {
            "--key-states"
        } else {
            "--spaces"
        };
        return Err(anyhow!(
            "{flag} only applies to json:PATH tasks, not '{task}': the built-in tasks have no files"
        ));
    }
    Ok(env::load(task)?)
}

/// A library configuration error in command-line terms: parameters are named by their flags.
pub fn explain(error: ConfigError) -> anyhow::Error {
    match error {
        ConfigError::InvalidParam {
            name,
            value,
            accepted,
        } => anyhow!(
            "invalid value '{value}' for '{}': expected {accepted}",
            cli_flag(name)
        ),
        other => other.into(),
    }
}

/// Builds the configurations of `mbmf run`: for each controller, `runs` runs with consecutive
/// run indices (controller-major). Every parameter is validated.
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
        if let Some(source) = args
            .human
            .profile
            .and_then(|p| Profile::from(p).reward_source())
        {
            params.reward_source = source;
        }
        if let Some(source) = args.reward_source {
            params.reward_source = match source {
                RewardSourceArg::Environment => RewardSource::Environment,
                RewardSourceArg::Human => RewardSource::Human,
            };
        }
        if let Some(effect) = args.congratulation_effect {
            params.congratulation_effect = match effect {
                CongratulationEffectArg::Bias => CongratulationEffect::Bias,
                CongratulationEffectArg::Reward => CongratulationEffect::Reward,
            };
        }
        if let Some(b) = args.boxes {
            params.boxes = b;
        }
        params.validate().map_err(explain)?;
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

/// `mbmf run`: every input is checked (flags, task files, the output folder, memory) before the
/// first step is simulated, so a mistake fails in a second rather than after the runs.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let spec = load_task(
        &args.task,
        args.key_states.as_deref(),
        args.spaces.as_deref(),
    )
    .map_err(usage)?;
    let spec = Arc::new(spec);
    let configs = run_configs(args).map_err(usage)?;
    let schedule = Schedule::from_events(args.change.iter().map(String::as_str))
        .map_err(|e| usage(anyhow!("--change: {e}")))?;
    // Runs of one controller share their parameters: check the first of each.
    for c in configs.iter().step_by(args.runs.max(1) as usize) {
        crate::batch::validate_for_spec(&spec, &c.params).map_err(|e| usage(explain(e)))?;
        c.params
            .validate_for_reward(spec.goal_reward)
            .map_err(|e| usage(explain(e)))?;
        crate::schedule::compile(&spec, &schedule, &c.params)
            .map_err(|e| usage(anyhow!("--change: {e}")))?;
    }
    let schedules = [schedule];
    let run_schedule = vec![0; configs.len()];
    let batch_size = plan_batch_size(&spec, &configs, args.batch_size).map_err(usage)?;
    let [runs_target, series_target] = prepare_out(&args.out, args.force)?;
    let staging = Staging::create(&args.out)?;
    if batch_size < args.batch_size.min(configs.len()) && !args.quiet {
        eprintln!(
            "note: simulating {batch_size} runs at a time instead of {} so that a batch fits in \
             memory (results do not depend on it)",
            args.batch_size
        );
    }
    let [runs_meta, series_meta] = output::pair_metadata(args.seed);
    let mut runs_sink = output::ParquetSink::new(&staging.0.join("runs.parquet"), runs_meta);
    let mut series_sink = output::ParquetSink::new(&staging.0.join("series.parquet"), series_meta);
    let bar = experiment::progress_bar(experiment::agent_steps(&configs), args.quiet);
    let mut summary = Summary::default();
    let started = std::time::Instant::now();
    let per = u64::from(args.runs);
    experiment::simulate_with_schedules(
        &spec,
        &configs,
        &schedules,
        &run_schedule,
        batch_size,
        &bar,
        |batch: &Batch| {
            runs_sink.write(&output::with_run_indices(output::runs_batch(batch)?, per)?)?;
            series_sink.write(&output::with_run_indices(
                output::series_batch(batch)?,
                per,
            )?)?;
            summary.add(batch);
            Ok::<(), anyhow::Error>(())
        },
    )
    .map_err(runtime)?;
    bar.finish_and_clear();
    let runs_staged = runs_sink.finish().map_err(runtime)?;
    let series_staged = series_sink.finish().map_err(runtime)?;
    output::atomic::commit_pair(
        (&series_staged, &series_target),
        (&runs_staged, &runs_target),
    )
    .with_context(|| format!("cannot move the results into {}", args.out.display()))
    .map_err(runtime)?;
    drop(staging);
    let (runs_path, series_path) = (runs_target, series_target);
    if !args.quiet {
        print_stdout(&summary.table(&args.task, configs.len(), started.elapsed().as_secs_f64()))?;
        eprintln!(
            "wrote {} and {}",
            runs_path.display(),
            series_path.display()
        );
    }
    Ok(())
}

/// Checks and creates the output folder of `mbmf run`; returns the paths of runs.parquet and
/// series.parquet. A file in the way is a usage error (2); a folder that cannot be created is a
/// runtime failure (1). Both are found before anything is simulated.
fn prepare_out(out: &Path, force: bool) -> Result<[PathBuf; 2], Failure> {
    // The nearest existing ancestor (the folder itself included) must be a folder.
    for ancestor in out.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        if let Ok(metadata) = std::fs::metadata(ancestor) {
            if !metadata.is_dir() {
                return Err(usage(anyhow!(
                    "--out {}: {} is a file, not a folder; give a folder to write runs.parquet \
                     and series.parquet into",
                    out.display(),
                    ancestor.display()
                )));
            }
            break;
        }
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output folder {}", out.display()))
        .map_err(runtime)?;
    let targets = [out.join("runs.parquet"), out.join("series.parquet")];
    for target in &targets {
        if target.is_dir() {
            return Err(usage(anyhow!(
                "--out {}: {} is a folder, so the results cannot be written under that name; \
                 remove it or choose another --out",
                out.display(),
                target.display()
            )));
        }
    }
    let earlier: Vec<String> = targets
        .iter()
        .filter(|t| t.exists())
        .map(|t| t.display().to_string())
        .collect();
    if !earlier.is_empty() && !force {
        return Err(usage(anyhow!(
            "--out {}: it holds the results of an earlier run ({}); pass --force to replace              them, or choose another --out",
            out.display(),
            earlier.join(", ")
        )));
    }
    Ok(targets)
}

/// A private folder inside the output folder where both Parquet files are written; they are
/// moved into place as one commit ([`output::atomic::commit_pair`]) only when both are
/// complete. The folder and anything left in it are removed when the value is dropped.
struct Staging(PathBuf);

impl Staging {
    /// Creates the folder; this is also the check that the output folder accepts new files,
    /// done before anything is simulated.
    fn create(out: &Path) -> Result<Staging, Failure> {
        let dir = out.join(format!(".mbmf-run-{}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot write into output folder {}", out.display()))
            .map_err(runtime)?;
        Ok(Staging(dir))
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        // Best effort: after a commit only the empty folder is left.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Estimated bytes of an Arrow/Parquet series row beyond the task name: about 35 numeric
/// columns, 6 short strings and the writer's buffered encoding.
const SERIES_ROW_BYTES: u64 = 512;

/// Estimated bytes of a run's row in runs.parquet and its per-run records.
const RUN_ROW_BYTES: u64 = 2048;

/// Bytes one run of `params` on `spec` holds while its batch is simulated and written: the
/// per-run tables of [`Batch`] (Q tables, averaged distributions, MB window and model, per-state
/// costs) and its checkpoint rows, also as Arrow columns. An estimate, accurate to a few percent
/// where it matters (large worlds, long windows, many checkpoints).
pub fn bytes_per_run(spec: &Spec, params: &Params) -> u64 {
    memory_parts(spec, params).iter().map(|&(b, _)| b).sum()
}

/// The parts of [`bytes_per_run`], each with the flag that shrinks it.
fn memory_parts(spec: &Spec, params: &Params) -> [(u64, &'static str); 3] {
    let pairs = (spec.n_states * spec.n_actions) as u64;
    let states = spec.n_states as u64;
    let outcomes = spec.outcome_state.len() as u64;
    // Q (MF, MB) and averaged distributions: 4 x f64; G: u8; window length and position: 2 x u16.
    let tables = pairs * (4 * 8 + 1 + 2 * 2)
        + outcomes * (2 + 8)
        + states * (2 * 8 + 2)
        + spec.n_actions as u64 * 16
        + RUN_ROW_BYTES;
    let window = pairs.saturating_mul(2 * u64::from(params.window_n));
    let rows = crate::batch::checkpoint_count(params) as u64;
    let row_bytes = std::mem::size_of::<crate::batch::Checkpoint>() as u64
        + SERIES_ROW_BYTES
        + spec.name.len() as u64;
    [
        (tables, "the task is too large"),
        (window, "lower --window-n"),
        (
            rows.saturating_mul(row_bytes),
            "raise --checkpoint or lower --steps",
        ),
    ]
}

/// Memory of this machine: (available now, installed), in bytes, when the system says.
fn system_memory() -> Option<(u64, u64)> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let field = |name: &str| {
        info.lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| {
                rest.trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<u64>()
                    .ok()
            })
            .map(|kib| kib.saturating_mul(1024))
    };
    Some((field("MemAvailable:")?, field("MemTotal:")?))
}

/// Memory a batch may use when the system does not say how much there is.
const DEFAULT_BATCH_BYTES: u64 = 2 << 30;

/// Runs to simulate at once: `requested`, lowered so that a batch fits in half of the memory
/// available now. A run that alone needs more than the machine's memory is refused, naming the
/// flag that would shrink it, instead of failing an allocation midway.
pub fn plan_batch_size(spec: &Spec, configs: &[RunConfig], requested: usize) -> Result<usize> {
    let Some(largest) = configs
        .iter()
        .max_by_key(|c| bytes_per_run(spec, &c.params))
    else {
        return Ok(requested.max(1));
    };
    let per_run = bytes_per_run(spec, &largest.params).max(1);
    let (budget, installed) = match system_memory() {
        Some((available, total)) => (available / 2, total),
        None => (DEFAULT_BATCH_BYTES, u64::MAX),
    };
    if per_run > installed {
        let parts = memory_parts(spec, &largest.params);
        let (_, fix) = parts.iter().max_by_key(|&&(b, _)| b).expect("three parts");
        return Err(anyhow!(
            "one run needs about {} of memory, more than this machine's {}: {fix} \
             ({} states x {} actions, window-n {}, {} series rows per run)",
            gib(per_run),
            gib(installed),
            spec.n_states,
            spec.n_actions,
            largest.params.window_n,
            crate::batch::checkpoint_count(&largest.params)
        ));
    }
    let fit = usize::try_from(budget / per_run).unwrap_or(usize::MAX);
    Ok(requested.min(fit).max(1))
}

/// A byte count in GiB, for messages.
fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
}

/// Writes `text` to stdout. A closed pipe (`mbmf ... | head`) is not an error: the reader has
/// what it wanted.
fn print_stdout(text: &str) -> Result<(), Failure> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(runtime(anyhow!("cannot write to standard output: {e}")))
        }
        _ => Ok(()),
    }
}

/// One run in the summary table: total reward, total cost, MB share (if it made decisions).
type RunSummary = (f64, f64, Option<f64>);

/// Per-controller results for the table printed after a run.
#[derive(Default)]
struct Summary {
    rows: Vec<(Controller, Vec<RunSummary>)>,
}

impl Summary {
    fn add(&mut self, batch: &Batch) {
        for (config, stats) in batch.configs().iter().zip(batch.stats()) {
            let c = config.params.controller;
            let share =
                (stats.decisions > 0).then(|| stats.mb_decisions as f64 / stats.decisions as f64);
            let entry = match self.rows.iter_mut().position(|(k, _)| *k == c) {
                Some(i) => &mut self.rows[i].1,
                None => {
                    self.rows.push((c, Vec::new()));
                    &mut self.rows.last_mut().expect("just pushed").1
                }
            };
            entry.push((stats.total_reward, stats.cost_total(), share));
        }
    }

    /// The table: mean ± standard deviation per controller ("-" where no run has a value).
    fn table(&self, task: &str, runs: usize, seconds: f64) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let _ = writeln!(out, "{task}: {runs} runs in {seconds:.2} s");
        let _ = writeln!(
            out,
            "{:<10} {:>5} {:>22} {:>26} {:>18}",
            "controller", "runs", "total reward", "total cost (ops)", "MB share"
        );
        for (controller, values) in &self.rows {
            let (r, rs) = mean_sd(&values.iter().map(|v| v.0).collect::<Vec<_>>());
            let (c, cs) = mean_sd(&values.iter().map(|v| v.1).collect::<Vec<_>>());
            let shares: Vec<f64> = values.iter().filter_map(|v| v.2).collect();
            let share = if shares.is_empty() {
                format!("{:>18}", "-")
            } else {
                let (m, ms) = mean_sd(&shares);
                format!("{m:>8.3} ± {ms:<6.3}")
            };
            let _ = writeln!(
                out,
                "{:<10} {:>5} {:>12.1} ± {:<7.1} {:>15.4e} ± {:<8.2e} {share}",
                controller.name(),
                values.len(),
                r,
                rs,
                c,
                cs,
            );
        }
        out
    }
}

/// Mean and sample standard deviation (NaN for no value, 0 for one). Values are scaled by the
/// largest magnitude first, so huge rewards (1e300) give a finite mean and deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let scale = xs.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if scale == 0.0 || !scale.is_finite() {
        let mean = if scale == 0.0 { 0.0 } else { f64::NAN };
        return (mean, if scale == 0.0 { 0.0 } else { f64::NAN });
    }
    let n = xs.len() as f64;
    let mean = xs.iter().map(|x| x / scale).sum::<f64>() / n;
    if xs.len() < 2 {
        return (mean * scale, 0.0);
    }
    let var = xs.iter().map(|x| (x / scale - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean * scale, var.sqrt() * scale)
}

/// `mbmf env ...`.
pub fn env_command(cmd: &EnvCommand) -> Result<(), Failure> {
    match cmd {
        EnvCommand::Info { task, files } => {
            let spec = load_task(task, files.key_states.as_deref(), files.spaces.as_deref())
                .map_err(usage)?;
            print_stdout(&env_info(&spec))
        }
        EnvCommand::Export { task, json, files } => {
            if json.exists() && !json.is_dir() {
                return Err(usage(anyhow!(
                    "--json {} is a file, not a folder; give a folder to write the model, \
                     keyStates.txt and spaces.txt into",
                    json.display()
                )));
            }
            let spec = load_task(task, files.key_states.as_deref(), files.spaces.as_deref())
                .map_err(usage)?;
            let paths = env::json::export(&spec, json).map_err(runtime)?;
            print_stdout(&format!(
                "wrote {}, {} and {}\n",
                paths.model.display(),
                paths.key_states.display(),
                paths.spaces.display()
            ))
        }
    }
}

/// Initial states shown by `mbmf env info` before "...".
const SHOWN_INITIAL: usize = 10;

/// What `mbmf env info` prints.
fn env_info(spec: &Spec) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(out, "task      {}", spec.name);
    let _ = writeln!(out, "states    {}", spec.n_states);
    let _ = writeln!(out, "actions   {}", spec.n_actions);
    let _ = writeln!(
        out,
        "outcomes  {} (max {} per state-action pair)",
        spec.outcome_state.len(),
        spec.max_branching()
    );
    let initial = &spec.initial_states;
    let _ = if initial.len() > SHOWN_INITIAL {
        writeln!(
            out,
            "initial   {:?} ... ({} states)",
            &initial[..SHOWN_INITIAL],
            initial.len()
        )
    } else {
        writeln!(out, "initial   {initial:?}")
    };
    let goal_name = spec
        .state_names
        .get(spec.goal as usize)
        .map_or("?", String::as_str);
    let _ = writeln!(
        out,
        "goal      {} ({goal_name}), reward {}",
        spec.goal, spec.goal_reward
    );
    let _ = writeln!(
        out,
        "human     {}",
        if spec.human.is_some() {
            "defined"
        } else {
            "not defined (no interactions)"
        }
    );
    for (i, name) in spec.state_names.iter().enumerate().take(5) {
        let _ = writeln!(out, "  state {i:>4}: {name}");
    }
    out
}

/// Parses the arguments and runs the verb. Help and version requests print and exit 0; argument
/// errors print clap's message (with its suggestion for a typo) and exit 2.
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
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| runtime(anyhow!("cannot start {n} worker threads: {e}")))?;
    }
    match &cli.command {
        Command::Run(args) => run(args),
        Command::Sweep(args) => crate::sweep::command(args),
        Command::Compact(args) => crate::sweep::compact_command(args),
        Command::Pareto(args) => crate::analysis::cli::pareto(args),
        Command::Stats(args) => crate::analysis::cli::stats(args),
        Command::MinBudget(args) => crate::analysis::cli::min_budget(args),
        Command::Reproduce(args) => crate::reproduce::command(args),
        Command::Bench(args) => crate::bench::command(args),
        Command::Env(cmd) => env_command(cmd),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_estimate_of_a_run_covers_the_batch_state_it_allocates() {
        let spec = Arc::new(env::load("tidy1").expect("tidy1"));
        for (window_n, steps, checkpoint) in [(1, 100, 10), (10, 1000, 100), (2000, 50, 1)] {
            let params = Params {
                window_n,
                steps,
                checkpoint,
                ..Params::default()
            };
            let configs: Vec<RunConfig> = (0..4)
                .map(|r| RunConfig {
                    params,
                    seed: 1,
                    run_index: r,
                })
                .collect();
            let batch = Batch::new(Arc::clone(&spec), configs).expect("valid");
            let actual = batch.state_bytes() as f64 / 4.0;
            let estimate = bytes_per_run(&spec, &params) as f64;
            // The estimate adds the Arrow rows written from the batch: at least the state, at
            // most the state plus those rows and a few percent.
            let rows = crate::batch::checkpoint_count(&params) as f64;
            let arrow = rows * (SERIES_ROW_BYTES + spec.name.len() as u64) as f64;
            assert!(
                estimate >= actual,
                "window {window_n}: {estimate} < {actual}"
            );
            assert!(
                estimate <= 1.1 * actual + arrow + RUN_ROW_BYTES as f64,
                "window {window_n}: {estimate} for {actual}"
            );
        }
    }

    #[test]
    fn whole_number_flags_say_which_rule_a_bad_value_breaks() {
        assert_eq!(count("12"), Ok(12));
        assert!(count("-1").unwrap_err().contains("-1 is too small"));
        assert!(count("4294967296").unwrap_err().contains("too large"));
        assert!(count("2.5").unwrap_err().contains("not a whole number"));
        assert!(runs_count("0").unwrap_err().contains("from 1 to 1000000"));
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert!(number("x").is_err());
        assert!(number("nan").is_ok_and(f64::is_nan));
    }

    #[test]
    fn mean_and_deviation_stay_finite_for_huge_values() {
        let (m, s) = mean_sd(&[1e305, 3e305, 1e305, 3e305]);
        assert!((m - 2e305).abs() < 1e290, "{m}");
        // Deviations of ±1e305: variance 4/3 x 1e610, computed without overflowing.
        let expected = (4.0f64 / 3.0).sqrt() * 1e305;
        assert!((s - expected).abs() / expected < 1e-12, "{s}");
        assert_eq!(mean_sd(&[2.0, 4.0]), (3.0, 2f64.sqrt()));
        assert_eq!(mean_sd(&[0.0, 0.0]), (0.0, 0.0));
        assert!(mean_sd(&[]).0.is_nan());
    }
}
