//! `mbmf reproduce`: runs the paper's experiments (SPEC 9), draws the equivalents of its figures
//! and writes `report.md`, which goes through the paper's claims one by one with the numbers.
//!
//! Conditions, each with `runs` runs (50 by default, as in the paper):
//! - task 1 (10,000 steps): the four controllers without interaction, and with congratulation
//!   and takeover at every budget of [`FULL_BUDGETS`] (the paper's own minimal budgets among
//!   them), which also gives the data of claim 6 (minimal budgets);
//! - task 1, EC with the authors' argmax selection, at the paper's budgets (claim 3 is reported
//!   under both selections, SPEC 9);
//! - task 2 (20,000 steps): the four controllers without interaction and with both interaction
//!   types at budget [`TASK2_BUDGET`] (the paper gives no exact task-2 budget: "several hundred").

use std::fmt::Write as _;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::analysis::dataset::DatasetError;
use crate::analysis::stats::{self, Alternative};
use crate::batch::{Batch, Checkpoint, RunStats};
use crate::error::IoError;
use crate::output::OutputError;
use crate::params::{Controller, Interaction, Profile, Selection, paper_budget};
use crate::pipeline;
use crate::plot::{self, PlotError};
use crate::sweep::keys::{Key, Value};
use crate::sweep::store::RunSet;
use crate::sweep::{Builder, RunError, Shard, runner};

pub mod arbitration;

/// Budgets of the task-1 budget scan (0 is the no-interaction condition).
pub const FULL_BUDGETS: [u32; 7] = [10, 20, 30, 50, 100, 200, 300];
/// Budget of both interaction types in task 2 (decision: the paper says "several hundred").
pub const TASK2_BUDGET: u32 = 300;
/// Share of the experiment over which the "fast start" is measured.
const EARLY: f64 = 0.2;
/// The paper's four controllers.
const CONTROLLERS: [Controller; 4] = [
    Controller::Mf,
    Controller::Mb,
    Controller::Rnd,
    Controller::Ec,
];

/// What to reproduce, and where.
#[derive(Debug, Clone)]
pub struct Options {
    /// Output folder for the data, figures and report.md.
    pub out: PathBuf,
    /// The small version (6 runs, 2,000 / 4,000 steps, the paper's budgets only).
    pub quick: bool,
    /// Runs per condition (default 50, or 6 with `quick`).
    pub runs: Option<u32>,
    /// Master seed.
    pub seed: u64,
    /// The command recorded in the data files' provenance (`mbmf_command`).
    pub command: String,
}

/// Why a reproduction failed. Its conditions are built in and its options checked by the
/// caller, so none is a usage error.
#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    /// A folder could not be created or a file written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The conditions' sweep could not be built or its tasks loaded.
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
    /// The simulation failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The data files could not be completed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The data just written could not be read back.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// The minimal budgets could not be computed.
    #[error(transparent)]
    Analysis(#[from] crate::analysis::AnalysisError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

impl crate::error::Usage for ReproduceError {
    fn is_usage(&self) -> bool {
        false
    }
}

/// What a reproduction did.
#[derive(Debug, Clone)]
pub struct Summary {
    /// The table of means per condition, as in the report.
    pub table: String,
    /// Runs simulated.
    pub runs: usize,
    /// Seconds spent simulating.
    pub seconds: f64,
    /// The report written.
    pub report: PathBuf,
    /// The folder of the figures.
    pub figures: PathBuf,
}

/// The scale of a reproduction.
#[derive(Debug, Clone)]
struct Scale {
    runs: u32,
    steps_task1: u32,
    steps_task2: u32,
    babbling: u32,
    checkpoint: u32,
    budgets: Vec<u32>,
}

impl Scale {
    fn new(args: &Options) -> Scale {
        if args.quick {
            Scale {
                runs: args.runs.unwrap_or(6),
                steps_task1: 2_000,
                steps_task2: 4_000,
                babbling: 300,
                checkpoint: 100,
                budgets: Vec::new(),
            }
        } else {
            Scale {
                runs: args.runs.unwrap_or(50),
                steps_task1: 10_000,
                steps_task2: 20_000,
                babbling: 1_000,
                checkpoint: 100,
                budgets: FULL_BUDGETS.to_vec(),
            }
        }
    }
}

/// One experimental condition.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Condition {
    task: &'static str,
    controller: Controller,
    interaction: Interaction,
    budget: u32,
    selection: Selection,
}

impl Condition {
    fn label(&self) -> String {
        let mut s = self.controller.name().to_uppercase();
        if self.selection == Selection::Argmax {
            s.push_str(" (argmax)");
        }
        s
    }
}

/// The results of one condition.
struct Outcome {
    condition: Condition,
    runs: Vec<RunStats>,
    series: Vec<Vec<Checkpoint>>,
}

impl Outcome {
    fn metric(&self, f: impl Fn(&RunStats) -> f64) -> Vec<f64> {
        self.runs.iter().map(f).collect()
    }
    fn reward(&self) -> Vec<f64> {
        self.metric(|r| r.total_reward)
    }
    fn cost(&self) -> Vec<f64> {
        self.metric(|r| r.cost_total())
    }
    fn last10(&self) -> Vec<f64> {
        self.metric(|r| r.reward_last10)
    }
    /// First reward step; runs that never reached the goal count as one step past the end.
    fn first_reward(&self) -> Vec<f64> {
        self.runs
            .iter()
            .zip(&self.series)
            .map(|(r, s)| {
                if r.first_reward_step > 0 {
                    f64::from(r.first_reward_step)
                } else {
                    f64::from(s.last().map_or(0, |c| c.step) + 1)
                }
            })
            .collect()
    }
    /// Cumulative reward at the first checkpoint at or after `fraction` of the experiment: how
    /// early a controller accumulates reward ("fast start", claims 1 and 2).
    fn early_reward(&self, fraction: f64) -> Vec<f64> {
        self.series
            .iter()
            .map(|s| {
                let end = s.last().map_or(0, |c| c.step);
                let at = (f64::from(end) * fraction).ceil() as u32;
                s.iter()
                    .find(|c| c.step >= at)
                    .map_or(f64::NAN, |c| c.cum_reward)
            })
            .collect()
    }

    /// Mean and standard error across runs of a series value, per checkpoint (NaNs skipped).
    fn curve(&self, f: impl Fn(&Checkpoint) -> f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n_points = self.series.iter().map(Vec::len).min().unwrap_or(0);
        let mut steps = Vec::with_capacity(n_points);
        let mut means = Vec::with_capacity(n_points);
        let mut ses = Vec::with_capacity(n_points);
        for i in 0..n_points {
            let values: Vec<f64> = self
                .series
                .iter()
                .map(|s| f(&s[i]))
                .filter(|v| v.is_finite())
                .collect();
            steps.push(f64::from(self.series[0][i].step));
            means.push(if values.is_empty() {
                f64::NAN
            } else {
                stats::mean(&values)
            });
            ses.push(if values.len() < 2 {
                0.0
            } else {
                stats::sem(&values)
            });
        }
        (steps, means, ses)
    }
}

/// All conditions of a reproduction at this scale, in run order.
fn conditions(scale: &Scale) -> Vec<Condition> {
    let mut out = Vec::new();
    let base = |task, controller, interaction, budget, selection| Condition {
        task,
        controller,
        interaction,
        budget,
        selection,
    };
    for &c in &CONTROLLERS {
        out.push(base("tidy1", c, Interaction::None, 0, Selection::Softmax));
    }
    for interaction in [Interaction::Congratulation, Interaction::Takeover] {
        for &c in &CONTROLLERS {
            let mut budgets = scale.budgets.clone();
            let paper = paper_budget(c, interaction);
            if !budgets.contains(&paper) {
                budgets.push(paper);
                budgets.sort_unstable();
            }
            for b in budgets {
                out.push(base("tidy1", c, interaction, b, Selection::Softmax));
            }
        }
    }
    for interaction in [
        Interaction::None,
        Interaction::Congratulation,
        Interaction::Takeover,
    ] {
        let budget = paper_budget(Controller::Ec, interaction);
        out.push(base(
            "tidy1",
            Controller::Ec,
            interaction,
            budget,
            Selection::Argmax,
        ));
    }
    for interaction in [
        Interaction::None,
        Interaction::Congratulation,
        Interaction::Takeover,
    ] {
        let budget = if interaction == Interaction::None {
            0
        } else {
            TASK2_BUDGET
        };
        for &c in &CONTROLLERS {
            out.push(base("tidy2", c, interaction, budget, Selection::Softmax));
        }
    }
    out
}

/// The profile a condition's runs name: the paper's human where it has the paper's budget on
/// task 1, a custom one at other budgets.
fn profile_of(condition: &Condition) -> Profile {
    let paper = condition.task == "tidy1"
        && condition.budget == paper_budget(condition.controller, condition.interaction);
    match condition.interaction {
        Interaction::None => Profile::None,
        Interaction::Congratulation if paper => Profile::PaperCongratulation,
        Interaction::Takeover if paper => Profile::PaperTakeover,
        _ => Profile::Custom,
    }
}

/// The conditions as a sweep: one `[[zip]]` entry per condition, in order, so that run `r` of
/// the sweep is run `r % runs` of condition `r / runs`.
fn conditions_sweep(conditions: &[Condition], scale: &Scale, seed: u64, quick: bool) -> Builder {
    let column = |name: &str, value: &dyn Fn(&Condition) -> Value| {
        let key = if name == "task" {
            Key::Task
        } else {
            Key::named(name)
        };
        (key, conditions.iter().map(value).collect())
    };
    let steps = |c: &Condition| {
        Value::Count(if c.task == "tidy2" {
            scale.steps_task2
        } else {
            scale.steps_task1
        })
    };
    Builder::new()
        .comment(&format!(
            "The conditions of `mbmf reproduce{}` (seed {seed}); `mbmf sweep` runs them again.",
            if quick { " --quick" } else { "" }
        ))
        .seeds(scale.runs)
        .master_seed(seed)
        .fixed(Key::named("babbling"), Value::Count(scale.babbling))
        .fixed(Key::named("checkpoint"), Value::Count(scale.checkpoint))
        .zip(vec![
            column("task", &|c| Value::Text(c.task.to_string())),
            column("controller", &|c| Value::Choice(c.controller.name())),
            column("selection", &|c| Value::Choice(c.selection.name())),
            column("interaction", &|c| Value::Choice(c.interaction.name())),
            column("budget", &|c| Value::Count(c.budget)),
            column("steps", &steps),
            column("profile", &|c| {
                Value::Text(profile_of(c).name().to_string())
            }),
        ])
}

/// Runs the paper's experiments into `options.out` and writes the report; `total` is told the
/// agent-steps to simulate before the first step, `progress` the agent-steps advanced.
pub fn reproduce(
    options: &Options,
    total: impl FnOnce(u64),
    progress: impl FnMut(u64) + Send,
) -> Result<Summary, ReproduceError> {
    let started = Instant::now();
    let scale = Scale::new(options);
    let outcomes = simulate_all(options, &scale, total, progress)?;
    let seconds = started.elapsed().as_secs_f64();
    let min_budgets = min_budgets(&options.out.join("data"))?;
    let report = Report {
        outcomes: &outcomes,
        min_budgets: &min_budgets,
        scale: &scale,
        args: options,
        seconds,
    };
    let figures = report.figures()?;
    let text = report.markdown(&figures);
    let path = report_path(&options.out);
    write_atomic(&path, &text)?;
    Ok(Summary {
        table: report.summary_table(),
        runs: outcomes.iter().map(|o| o.runs.len()).sum(),
        seconds,
        report: path,
        figures: options.out.join("figures"),
    })
}

fn write_atomic(path: &Path, text: &str) -> Result<(), ReproduceError> {
    crate::whole_file::write_atomic(path, text.as_bytes()).map_err(|(path, cause)| {
        IoError::doing(format!("cannot write {}", path.display()))(cause).into()
    })
}

/// Runs per batch of a reproduction.
const BATCH_SIZE: usize = 1024;

/// Runs the conditions as an in-memory sweep (also written as `sweep.toml`) into
/// `data/runs.parquet` and `data/series.parquet`, keeping every run's results per condition.
fn simulate_all(
    args: &Options,
    scale: &Scale,
    total: impl FnOnce(u64),
    mut progress: impl FnMut(u64) + Send,
) -> Result<Vec<Outcome>, ReproduceError> {
    let conditions = conditions(scale);
    let file = args.out.join("sweep.toml");
    let sweep = conditions_sweep(&conditions, scale, args.seed, args.quick)
        .build(&file.display().to_string(), &args.out)?;
    let specs = sweep.load_specs()?;
    let data = args.out.join("data");
    std::fs::create_dir_all(&data).map_err(IoError::doing(format!(
        "cannot create output folder {}",
        data.display()
    )))?;
    write_atomic(&file, &sweep.text)?;
    let seeds = u64::from(sweep.seeds);
    total(
        (0..sweep.configurations())
            .map(|c| seeds * pipeline::run_steps(&sweep.resolve(c).params))
            .sum(),
    );
    let metadata = runner::metadata(&sweep, Shard::ALL, &args.command);
    let names = sweep.profile_names.clone();
    let mut job = pipeline::Job {
        schedules: &sweep.schedules,
        batch_size: BATCH_SIZE,
        writer: pipeline::Tables::new(&data, metadata, seeds, names),
    };
    let mut outcomes: Vec<Outcome> = conditions
        .iter()
        .map(|&condition| Outcome {
            condition,
            runs: Vec::new(),
            series: Vec::new(),
        })
        .collect();
    let none = RunSet::new(sweep.runs());
    runner::plan(&sweep, Shard::ALL, &none, BATCH_SIZE, |task, group| {
        let progress = |n| {
            progress(n);
            ControlFlow::Continue(())
        };
        job.simulate(&specs[task], &group, progress, |batch: &Batch| {
            for (r, config) in batch.configs().iter().enumerate() {
                let outcome = &mut outcomes[(config.run_index / seeds) as usize];
                outcome.runs.push(batch.stats()[r]);
                outcome.series.push(batch.series(r).to_vec());
            }
            Ok::<(), RunError>(())
        })
    })?;
    job.writer.finish()?;
    Ok(outcomes)
}

/// Claim 6's data: the SPEC 9 minimal budget of every task-1 controller and interaction type
/// (softmax MC), by `mbmf min-budget`'s own rule on the runs just written.
fn min_budgets(data: &Path) -> Result<Vec<MinBudgetRow>, ReproduceError> {
    use crate::analysis::dataset::{Value, read_dataset};
    use crate::analysis::min_budget::{DEFAULT_ALPHA, min_budget};
    let table = read_dataset(data, "runs")?;
    let found = min_budget(&table, "total_reward", DEFAULT_ALPHA)?;
    let text = |g: usize, name: &str| match found.key_value(g, name) {
        Some(Value::Str(s)) => s.clone(),
        _ => String::new(),
    };
    let mut rows = Vec::new();
    for interaction in [Interaction::Congratulation, Interaction::Takeover] {
        for &c in &CONTROLLERS {
            let name = interaction.name();
            let group = (0..found.groups.len()).find(|&g| {
                text(g, "task") == "tidy1"
                    && text(g, "controller") == c.name()
                    && text(g, "interaction") == name
                    && text(g, "selection") == "softmax"
            });
            rows.push(match group {
                Some(g) => {
                    let group = &found.groups[g];
                    (
                        c,
                        interaction,
                        Some(group.chosen_budget() as u32),
                        group.not_monotone.is_empty(),
                    )
                }
                None => (c, interaction, None, true),
            });
        }
    }
    Ok(rows)
}

/// Significance marks of a p-value, "n.s." when not significant.
fn stars(p: f64) -> &'static str {
    match stats::significance_stars(p) {
        "" => "n.s.",
        marks => marks,
    }
}

/// One-sided Mann-Whitney p-value that `x` tends to be larger than `y` (1 when undefined).
fn p_greater(x: &[f64], y: &[f64]) -> f64 {
    stats::mann_whitney(x, y, Alternative::Greater).map_or(1.0, |m| m.p_value)
}

/// Two-sided Mann-Whitney p-value (1 when undefined).
fn p_two_sided(x: &[f64], y: &[f64]) -> f64 {
    stats::mann_whitney(x, y, Alternative::TwoSided).map_or(1.0, |m| m.p_value)
}

fn fmt_p(p: f64) -> String {
    if p < 1e-4 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}

fn mean_sd(xs: &[f64]) -> String {
    format!(
        "{:.1} ± {:.1}",
        stats::mean(xs),
        if xs.len() > 1 { stats::sd(xs) } else { 0.0 }
    )
}

fn mean_sd_sci(xs: &[f64]) -> String {
    format!(
        "{:.3e} ± {:.2e}",
        stats::mean(xs),
        if xs.len() > 1 { stats::sd(xs) } else { 0.0 }
    )
}

/// The minimal budget found for (controller, interaction), and whether the rule was monotone.
type MinBudgetRow = (Controller, Interaction, Option<u32>, bool);

struct Report<'a> {
    outcomes: &'a [Outcome],
    min_budgets: &'a [MinBudgetRow],
    scale: &'a Scale,
    args: &'a Options,
    seconds: f64,
}

/// A claim's verdict and the sentence of numbers behind it.
struct Claim {
    id: &'static str,
    text: &'static str,
    verdict: &'static str,
    evidence: String,
}

impl Report<'_> {
    fn find(
        &self,
        task: &str,
        controller: Controller,
        interaction: Interaction,
        selection: Selection,
    ) -> Option<&Outcome> {
        let budget = |c: Controller| match (task, interaction) {
            (_, Interaction::None) => 0,
            ("tidy2", _) => TASK2_BUDGET,
            _ => paper_budget(c, interaction),
        };
        self.outcomes.iter().find(|o| {
            let c = &o.condition;
            c.task == task
                && c.controller == controller
                && c.interaction == interaction
                && c.selection == selection
                && c.budget == budget(controller)
        })
    }

    fn get(&self, task: &str, controller: Controller, interaction: Interaction) -> &Outcome {
        self.find(task, controller, interaction, Selection::Softmax)
            .expect("condition simulated")
    }

    /// The main conditions: per task, controller and interaction at the paper's budgets.
    fn main_conditions(&self) -> Vec<&Outcome> {
        let mut out = Vec::new();
        for task in ["tidy1", "tidy2"] {
            for interaction in [
                Interaction::None,
                Interaction::Congratulation,
                Interaction::Takeover,
            ] {
                for &c in &CONTROLLERS {
                    out.push(self.get(task, c, interaction));
                }
                if let Some(o) = self.find(task, Controller::Ec, interaction, Selection::Argmax) {
                    out.push(o);
                }
            }
        }
        out
    }

    fn summary_table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "| task | controller | interaction | budget | runs | total reward | reward, last 10% | total cost (ops) | MB share |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
        for o in self.main_conditions() {
            let c = &o.condition;
            let share: Vec<f64> = o.metric(|r| {
                if r.decisions > 0 {
                    r.mb_decisions as f64 / r.decisions as f64
                } else {
                    0.0
                }
            });
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {:.3} |",
                c.task,
                c.label(),
                c.interaction.name(),
                c.budget,
                o.runs.len(),
                mean_sd(&o.reward()),
                mean_sd(&o.last10()),
                mean_sd_sci(&o.cost()),
                stats::mean(&share)
            );
        }
        s
    }

    fn claims(&self) -> Vec<Claim> {
        use Controller::{Ec, Mb, Mf, Rnd};
        use Interaction::{Congratulation, None as NoHuman, Takeover};
        let t1 = |c| self.get("tidy1", c, NoHuman);
        let mut claims = Vec::new();

        // Claim 1. "Earlier" is measured as reward over the first 20% of the experiment: with
        // q_init = 0 every controller random-walks until its first reward (SPEC 7), so the first
        // reward step cannot separate them; it is reported as well.
        let (mf, mb) = (t1(Mf), t1(Mb));
        let p_early = p_greater(&mb.early_reward(EARLY), &mf.early_reward(EARLY));
        let p_final = p_greater(&mf.last10(), &mb.last10());
        claims.push(Claim {
            id: "1",
            text: "Without interaction, MB accumulates reward earlier than MF, but MF reaches a higher final rate.",
            verdict: verdict(&[p_early < 0.05, p_final < 0.05]),
            evidence: format!(
                "Reward over the first 20% of steps: MB {}, MF {} (one-sided p that MB is higher = {}); first reward step (mean): MB {:.0}, MF {:.0}. \
                 Reward in the last 10% of steps: MF {}, MB {} (one-sided p that MF is higher = {}).",
                mean_sd(&mb.early_reward(EARLY)),
                mean_sd(&mf.early_reward(EARLY)),
                fmt_p(p_early),
                stats::mean(&mb.first_reward()),
                stats::mean(&mf.first_reward()),
                mean_sd(&mf.last10()),
                mean_sd(&mb.last10()),
                fmt_p(p_final)
            ),
        });

        // Claim 2.
        let mut ok = Vec::new();
        let mut ev = String::new();
        for c in [Rnd, Ec] {
            let o = t1(c);
            let p_slower_than_mb = p_greater(&mb.early_reward(EARLY), &o.early_reward(EARLY));
            let p_below_mf = p_greater(&mf.last10(), &o.last10());
            ok.push(p_slower_than_mb >= 0.05);
            ok.push(p_below_mf >= 0.05);
            let _ = write!(
                ev,
                "{}: reward over the first 20% {} (MB {}; p that it is below MB's = {}), last-10% reward {} (MF {}; p that it is below MF's = {}). ",
                c.name().to_uppercase(),
                mean_sd(&o.early_reward(EARLY)),
                mean_sd(&mb.early_reward(EARLY)),
                fmt_p(p_slower_than_mb),
                mean_sd(&o.last10()),
                mean_sd(&mf.last10()),
                fmt_p(p_below_mf)
            );
        }
        claims.push(Claim {
            id: "2",
            text: "RND and EC get the fast start (of MB) and the high final rate (of MF).",
            verdict: verdict(&ok),
            evidence: format!("{ev}Rule: holds where neither is significantly worse (one-sided Mann-Whitney, 0.05)."),
        });

        // Claim 3, under both selections.
        for selection in [Selection::Softmax, Selection::Argmax] {
            let Some(ec) = self.find("tidy1", Ec, NoHuman, selection) else {
                continue;
            };
            let (mf_c, mb_c, rnd_c, ec_c) = (
                stats::mean(&t1(Mf).cost()),
                stats::mean(&t1(Mb).cost()),
                stats::mean(&t1(Rnd).cost()),
                stats::mean(&ec.cost()),
            );
            let ordered = mb_c > rnd_c && rnd_c > mf_c;
            // "Close to MF": nearer to MF's cost than to MB's on a log scale, and within 2x.
            let close = ec_c <= 2.0 * mf_c;
            let log_nearer = (ec_c.ln() - mf_c.ln()).abs() < (mb_c.ln() - ec_c.ln()).abs();
            claims.push(Claim {
                id: if selection == Selection::Softmax { "3 (softmax MC)" } else { "3 (argmax MC)" },
                text: "Computation cost: MB much higher than MF; RND in between; EC close to MF.",
                verdict: verdict(&[ordered, close]),
                evidence: format!(
                    "Mean total cost (ops): MF {:.3e}, MB {:.3e}, RND {:.3e}, EC {:.3e} (EC/MF = {:.1}, MB/MF = {:.1}; EC is {} MF than to MB on a log scale). \
                     Rule: holds if MB > RND > MF and EC <= 2 x MF.",
                    mf_c,
                    mb_c,
                    rnd_c,
                    ec_c,
                    ec_c / mf_c,
                    mb_c / mf_c,
                    if log_nearer { "nearer to" } else { "not nearer to" }
                ),
            });
        }

        // Claim 4.
        let ec = t1(Ec);
        let (_, p_mb, _) = ec.curve(|c| c.p_mb_mean);
        let finite: Vec<f64> = p_mb.into_iter().filter(|v| v.is_finite()).collect();
        let first = finite.first().copied().unwrap_or(f64::NAN);
        let last = finite.last().copied().unwrap_or(f64::NAN);
        let peak = finite.iter().copied().fold(f64::NAN, f64::max);
        claims.push(Claim {
            id: "4",
            text: "EC: MB has most of the control right after babbling; MF takes over later (Fig. 4).",
            verdict: verdict(&[first > 0.5, last < 0.5]),
            evidence: format!(
                "EC's mean P(MB) over the first {} experiment steps: {:.3}; highest window: {:.3}; last window: {:.3}.",
                self.scale.checkpoint, first, peak, last
            ),
        });

        // Claim 5.
        let mut gains = Vec::new();
        let mut all_improve = Vec::new();
        let mut takeover_more = Vec::new();
        let mut ev = String::new();
        for &c in &CONTROLLERS {
            let none = self.get("tidy1", c, NoHuman).reward();
            let cong = self.get("tidy1", c, Congratulation).reward();
            let take = self.get("tidy1", c, Takeover).reward();
            let p_c = p_greater(&cong, &none);
            let p_t = p_greater(&take, &none);
            let p_tc = p_greater(&take, &cong);
            all_improve.push(p_c < 0.05);
            all_improve.push(p_t < 0.05);
            takeover_more.push(stats::mean(&take) > stats::mean(&cong));
            gains.push((
                c,
                stats::mean(&cong) - stats::mean(&none),
                stats::mean(&take) - stats::mean(&none),
            ));
            let _ = write!(
                ev,
                "{}: none {:.1}, congratulation {:.1} (p = {}), takeover {:.1} (p = {}; takeover > congratulation p = {}). ",
                c.name().to_uppercase(),
                stats::mean(&none),
                stats::mean(&cong),
                fmt_p(p_c),
                stats::mean(&take),
                fmt_p(p_t),
                fmt_p(p_tc)
            );
        }
        let mf_gain_largest = gains
            .iter()
            .all(|&(c, g_c, g_t)| c == Mf || (gains[0].1 >= g_c && gains[0].2 >= g_t));
        claims.push(Claim {
            id: "5",
            text: "Interactions improve reward, most for MF; takeover more than congratulation.",
            verdict: verdict(&[
                all_improve.iter().all(|&x| x),
                mf_gain_largest,
                takeover_more.iter().all(|&x| x),
            ]),
            evidence: format!(
                "{ev}Gains over no interaction (congratulation, takeover): {}. One-sided Mann-Whitney p that the interaction raises total reward.",
                gains
                    .iter()
                    .map(|(c, a, b)| format!("{} +{:.1} / +{:.1}", c.name().to_uppercase(), a, b))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });

        // Claim 6.
        claims.push(self.claim_min_budget());

        // Task 2.
        let mut ev = String::new();
        let mut matches = Vec::new();
        for (c, paper_loss) in [(Mf, 0.40), (Mb, 0.20), (Rnd, 0.30), (Ec, 0.30)] {
            let t1_total = stats::mean(&t1(c).reward());
            let o2 = self.get("tidy2", c, NoHuman);
            let at_10k: Vec<f64> = o2
                .series
                .iter()
                .map(|s| {
                    s.iter()
                        .find(|k| k.step == self.scale.steps_task1)
                        .map_or(f64::NAN, |k| k.cum_reward)
                })
                .collect();
            let loss = 1.0 - stats::mean(&at_10k) / t1_total;
            matches.push((loss - paper_loss).abs() <= 0.1);
            let _ = write!(
                ev,
                "{} loss {:.0}% (paper ~{:.0}%). ",
                c.name().to_uppercase(),
                100.0 * loss,
                100.0 * paper_loss
            );
        }
        claims.push(Claim {
            id: "T2-a",
            text: "Task 2: after 10k actions, MF loses about 40% of its task-1 reward, MB about 20%, RND and EC about 30%.",
            verdict: verdict(&matches),
            evidence: format!(
                "{ev}Loss = 1 - (task-2 cumulative reward at step {}) / (task-1 total reward), on the means (SPEC 9). Holds where within 10 points of the paper.",
                self.scale.steps_task1
            ),
        });
        let (mf2, mb2, ec2) = (
            self.get("tidy2", Mf, NoHuman),
            self.get("tidy2", Mb, NoHuman),
            self.get("tidy2", Ec, NoHuman),
        );
        let best_reward = [mf2, mb2, self.get("tidy2", Rnd, NoHuman)]
            .iter()
            .all(|o| p_greater(&o.reward(), &ec2.reward()) >= 0.05);
        let cheap = stats::mean(&ec2.cost()) <= 2.0 * stats::mean(&mf2.cost());
        claims.push(Claim {
            id: "T2-b",
            text: "Task 2: EC again has the best reward for a near-MF cost.",
            verdict: verdict(&[best_reward, cheap]),
            evidence: format!(
                "Total reward: MF {}, MB {}, RND {}, EC {}. Cost: EC/MF = {:.1}. Rule: no controller significantly above EC, and EC cost <= 2 x MF.",
                mean_sd(&mf2.reward()),
                mean_sd(&mb2.reward()),
                mean_sd(&self.get("tidy2", Rnd, NoHuman).reward()),
                mean_sd(&ec2.reward()),
                stats::mean(&ec2.cost()) / stats::mean(&mf2.cost())
            ),
        });
        claims
    }

    /// Claim 6 (SPEC 9 rule): the smallest budget b such that no larger budget has a higher
    /// mean total reward with a one-sided Mann-Whitney p < 0.05.
    fn claim_min_budget(&self) -> Claim {
        let mut ev = String::new();
        let mut matches = Vec::new();
        for &(c, interaction, found, monotone) in self.min_budgets {
            let paper = paper_budget(c, interaction);
            matches.push(found == Some(paper));
            let _ = write!(
                ev,
                "{} {}: {} (paper {}){}. ",
                c.name().to_uppercase(),
                interaction.name(),
                found.map_or("none found".to_string(), |b| b.to_string()),
                paper,
                if monotone { "" } else { ", rule not monotone" }
            );
        }
        let budgets = if self.scale.budgets.is_empty() {
            "only the paper's budgets and 0 (quick mode: this is no test)".to_string()
        } else {
            format!("{:?} and 0", self.scale.budgets)
        };
        Claim {
            id: "6",
            text: "Minimal budgets reaching the maximal rate: congratulation MF 300, MB 50, RND 20, EC 30; takeover MF 200, MB/RND/EC 50.",
            verdict: verdict(&matches),
            evidence: format!(
                "{ev}Budgets tried: {budgets}. Rule (SPEC 9): the smallest budget such that no larger budget has a higher mean total reward with one-sided Mann-Whitney p < 0.05, no correction."
            ),
        }
    }

    fn markdown(&self, figures: &[(String, PathBuf)]) -> String {
        let mut s = String::new();
        let scale = self.scale;
        let _ = writeln!(s, "# mbmf reproduction of Dromnelle et al. (RO-MAN 2020)\n");
        let _ = writeln!(
            s,
            "Command: `mbmf reproduce{}` (seed {}), mbmf {}. {} runs per condition; task 1 {} steps, task 2 {} steps, {} babbling steps; simulated in {:.1} s.\n",
            if self.args.quick { " --quick" } else { "" },
            self.args.seed,
            env!("CARGO_PKG_VERSION"),
            scale.runs,
            scale.steps_task1,
            scale.steps_task2,
            scale.babbling,
            self.seconds
        );
        if self.args.quick {
            let _ = writeln!(
                s,
                "**Quick mode: small samples and short runs. The verdicts below check the pipeline, not the paper.**\n"
            );
        }
        let _ = writeln!(
            s,
            "Interactions use the paper's minimal budgets in task 1 (SPEC 9 item 6) and {TASK2_BUDGET} in task 2; forget probability 0.1, zeta 0.1. Costs are in `ops` (SPEC 6). Mean ± sd over runs.\n"
        );
        s.push_str(&self.summary_table());
        let _ = writeln!(s, "\n## The paper's claims\n");
        let _ = writeln!(s, "| claim | verdict |\n|---|---|");
        let claims = self.claims();
        for c in &claims {
            let _ = writeln!(s, "| {} {} | **{}** |", c.id, c.text, c.verdict);
        }
        for c in &claims {
            let _ = writeln!(
                s,
                "\n### Claim {}: {}\n\n**{}.** {}",
                c.id, c.text, c.verdict, c.evidence
            );
        }
        let _ = writeln!(s, "\n## Figures\n");
        for (caption, path) in figures {
            let rel = path.strip_prefix(&self.args.out).unwrap_or(path);
            let _ = writeln!(s, "![{caption}]({})\n\n*{caption}*\n", rel.display());
        }
        let _ = writeln!(
            s,
            "Data: `data/runs.parquet` (one row per run) and `data/series.parquet` (one row per run per {}-step checkpoint).",
            scale.checkpoint
        );
        s
    }

    fn figures(&self) -> Result<Vec<(String, PathBuf)>, PlotError> {
        use Interaction::{Congratulation, None as NoHuman, Takeover};
        let dir = self.args.out.join("figures");
        let mut out = Vec::new();
        let mut add = |(caption, paths): (String, Vec<PathBuf>)| {
            if let Some(png) = paths
                .into_iter()
                .find(|p| p.extension().is_some_and(|e| e == "png"))
            {
                out.push((caption, png));
            }
        };
        for (task, fig) in [("tidy1", "3"), ("tidy2", "5")] {
            let name = if task == "tidy1" { "Task 1" } else { "Task 2" };
            // Reward and cost accumulation without interaction.
            for (what, y_label, f) in [
                (
                    "reward",
                    "cumulative reward",
                    (|c: &Checkpoint| c.cum_reward) as fn(&Checkpoint) -> f64,
                ),
                ("cost", "cumulative cost (ops)", |c: &Checkpoint| {
                    c.cum_cost_mf + c.cum_cost_mb
                }),
            ] {
                let series = CONTROLLERS
                    .iter()
                    .map(|&c| {
                        let (x, y, se) = self.get(task, c, NoHuman).curve(f);
                        plot::Series {
                            label: c.name().to_uppercase(),
                            x,
                            y,
                            band: Some(se),
                        }
                    })
                    .collect();
                let title =
                    format!("{name}: {what} accumulation without interaction (mean ± s.e.)");
                let path = dir.join(format!("fig{fig}_{task}_{what}_curves"));
                let (x, log_y) = ("experiment step", what == "cost");
                add(lines(title, [x, y_label], series, log_y, &path)?);
            }
            // Bars: total reward and cost, none vs each interaction, with significance marks.
            for (what, metric) in [("reward", 0usize), ("cost", 1usize)] {
                for interaction in [Congratulation, Takeover] {
                    let mut bars = Vec::new();
                    let mut annotations = Vec::new();
                    for &c in &CONTROLLERS {
                        let pair = [self.get(task, c, NoHuman), self.get(task, c, interaction)];
                        let values: Vec<Vec<f64>> = pair
                            .iter()
                            .map(|o| if metric == 0 { o.reward() } else { o.cost() })
                            .collect();
                        let i = bars.len();
                        for (o, v) in pair.iter().zip(&values) {
                            bars.push(plot::Bar {
                                label: format!(
                                    "{} {}",
                                    c.name().to_uppercase(),
                                    if o.condition.interaction == NoHuman {
                                        "none".to_string()
                                    } else {
                                        format!(
                                            "{} {}",
                                            o.condition.interaction.name(),
                                            o.condition.budget
                                        )
                                    }
                                ),
                                value: stats::mean(v),
                                error: Some(if v.len() > 1 { stats::sem(v) } else { 0.0 }),
                                group: c.name().to_uppercase(),
                            });
                        }
                        annotations.push((
                            i,
                            i + 1,
                            stars(p_two_sided(&values[0], &values[1])).to_string(),
                        ));
                    }
                    let chart = plot::BarChart {
                        title: format!(
                            "{name}: total {what} after {} steps, none vs {} (mean ± s.e.)",
                            if task == "tidy1" {
                                self.scale.steps_task1
                            } else {
                                self.scale.steps_task2
                            },
                            interaction.name()
                        ),
                        y_label: if metric == 0 {
                            "total reward".into()
                        } else {
                            "total cost (ops)".into()
                        },
                        bars,
                        annotations,
                    };
                    let path = dir.join(format!(
                        "fig{fig}_{task}_{what}_bars_{}",
                        interaction.name()
                    ));
                    add((
                        format!(
                            "{} Wilcoxon-Mann-Whitney two-sided: *** p<0.001, ** p<0.01, * p<0.05.",
                            chart.title
                        ),
                        plot::bar_chart(&chart, &path)?,
                    ));
                }
            }
        }
        // Fig. 4: EC's P(MB) over time, per interaction.
        let series = [NoHuman, Congratulation, Takeover]
            .iter()
            .map(|&i| {
                let (x, y, se) = self.get("tidy1", Controller::Ec, i).curve(|c| c.p_mb_mean);
                let keep: Vec<usize> = (0..y.len()).filter(|&k| y[k].is_finite()).collect();
                plot::Series {
                    // Labels without the controller's name get distinct colours.
                    label: match i {
                        NoHuman => "no interaction".to_string(),
                        _ => i.name().to_string(),
                    },
                    x: keep.iter().map(|&k| x[k]).collect(),
                    y: keep.iter().map(|&k| y[k]).collect(),
                    band: Some(keep.iter().map(|&k| se[k]).collect()),
                }
            })
            .collect();
        let title = format!(
            "Task 1: EC's probability of selecting MB ({}-step window means, mean ± s.e.)",
            self.scale.checkpoint
        );
        let path = dir.join("fig4_tidy1_ec_p_mb");
        add(lines(
            title,
            ["experiment step", "P(MB)"],
            series,
            false,
            &path,
        )?);
        // Claim 6: total reward against budget.
        for interaction in [Congratulation, Takeover] {
            let series = CONTROLLERS
                .iter()
                .map(|&c| {
                    let mut points: Vec<(f64, Vec<f64>)> =
                        vec![(0.0, self.get("tidy1", c, NoHuman).reward())];
                    for o in self.outcomes.iter().filter(|o| {
                        o.condition.task == "tidy1"
                            && o.condition.controller == c
                            && o.condition.interaction == interaction
                            && o.condition.selection == Selection::Softmax
                    }) {
                        points.push((f64::from(o.condition.budget), o.reward()));
                    }
                    points.sort_by(|a, b| a.0.total_cmp(&b.0));
                    plot::Series {
                        label: c.name().to_uppercase(),
                        x: points.iter().map(|p| p.0).collect(),
                        y: points.iter().map(|p| stats::mean(&p.1)).collect(),
                        band: Some(
                            points
                                .iter()
                                .map(|p| if p.1.len() > 1 { stats::sem(&p.1) } else { 0.0 })
                                .collect(),
                        ),
                    }
                })
                .collect();
            let kind = interaction.name();
            let title = format!("Task 1: total reward against the {kind} budget (mean ± s.e.)");
            let labels = ["budget (interactions per run)", "total reward"];
            let path = dir.join(format!("budget_{kind}"));
            add(lines(title, labels, series, false, &path)?);
        }
        Ok(out)
    }
}

/// Draws a line chart of `series` (linear x; axis labels x then y) into `path`; returns its
/// title with the files written.
fn lines(
    title: String,
    [x_label, y_label]: [&str; 2],
    series: Vec<plot::Series>,
    log_y: bool,
    path: &Path,
) -> Result<(String, Vec<PathBuf>), PlotError> {
    let chart = plot::LineChart {
        title,
        x_label: x_label.into(),
        y_label: y_label.into(),
        series,
        log_x: false,
        log_y,
        x_marks: Vec::new(),
    };
    Ok((chart.title.clone(), plot::line_chart(&chart, path)?))
}

fn verdict(checks: &[bool]) -> &'static str {
    if checks.iter().all(|&x| x) {
        "holds"
    } else if checks.iter().any(|&x| x) {
        "partly holds"
    } else {
        "does not hold"
    }
}

/// Path of the report inside an output folder.
pub fn report_path(out: &Path) -> PathBuf {
    out.join("report.md")
}
