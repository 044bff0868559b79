//! `mbmf reproduce --study arbitration`: which arbitration rule (SPEC 12) wins? Runs the shipped
//! sweeps `sweeps/arbitration-*.toml` (each into its own dataset folder, resumably, as `mbmf
//! sweep --resume`), reads the datasets back, compares every rule with EC (Mann-Whitney,
//! Holm-corrected), ranks the rules on the front of reward, cost and (with a human) interactions, follows P(MB) around every change,
//! draws the figures and writes `report.md` with every number and the command behind it.
//!
//! The sweep texts are compiled in, so the study is the one this binary was built with; the
//! `json:` paths of the navigation-world sweep start at [`Options::sweeps_dir`], and without the
//! authors' files that sweep is skipped with a note.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::{ReproduceError, write_atomic};
use crate::analysis::dataset::{Table, Value, read_dataset};
use crate::analysis::pareto::{self, Direction};
use crate::analysis::stats::{self, Alternative};
use crate::error::IoError;
use crate::pipeline::run_steps as pipeline_steps;
use crate::plot::{self, FrontChart, FrontPanel, LineChart, LineColours, Series};
use crate::sweep::Shard;
use crate::sweep::file::Sweep;
use crate::sweep::runner::{self, Event};

/// One sweep of the study.
struct StudySweep {
    /// Folder of its dataset inside the output folder, and its name in the report.
    name: &'static str,
    /// The shipped file it comes from.
    file: &'static str,
    /// Its text.
    text: &'static str,
    /// A file it reads, relative to the sweeps folder, without which it is skipped.
    needs: Option<&'static str>,
    /// The replacements that make its `--quick` version (each must occur in the text).
    quick: &'static [(&'static str, &'static str)],
}

/// The study's sweeps, in run order (the cheap ones first, so a quick look comes early).
const SWEEPS: [StudySweep; 4] = [
    StudySweep {
        name: "twostep",
        file: "sweeps/arbitration-twostep.toml",
        text: include_str!("../../sweeps/arbitration-twostep.toml"),
        needs: None,
        quick: &[("steps = 2000", "steps = 400")],
    },
    StudySweep {
        name: "tidy",
        file: "sweeps/arbitration-tidy.toml",
        text: include_str!("../../sweeps/arbitration-tidy.toml"),
        needs: None,
        quick: &[
            ("steps = 10000", "steps = 1500"),
            ("babbling = 1000", "babbling = 200"),
        ],
    },
    StudySweep {
        name: "objective",
        file: "sweeps/arbitration-objective.toml",
        text: include_str!("../../sweeps/arbitration-objective.toml"),
        needs: None,
        quick: &[
            ("steps = 10000", "steps = 1500"),
            ("babbling = 1000", "babbling = 200"),
            ("\"5000:boxes=brg\"", "\"750:boxes=brg\""),
        ],
    },
    StudySweep {
        name: "navworld",
        file: "sweeps/arbitration-navworld.toml",
        text: include_str!("../../sweeps/arbitration-navworld.toml"),
        needs: Some("../../shared/data/navworld/realisticNavWorld.json"),
        quick: &[
            ("steps = 3200", "steps = 600"),
            ("\"1601:", "\"301:"),
            (";1601:", ";301:"),
        ],
    },
];

/// Runs per cell in the full study and in `--quick`.
const RUNS_FULL: u32 = 50;
const RUNS_QUICK: u32 = 3;
/// The rule every other is compared with: the paper's EC at its default kappa_coeff.
const REFERENCE: &str = "EC k=9";
/// The rules drawn in the curve figures: every controller at its default parameters (a figure
/// of 22 curves cannot be read; the tables hold the others).
const MAIN_RULES: [&str; 10] = [
    "MF",
    "MB",
    "RND",
    "entropy",
    "EC k=9",
    "fixed select w=0.5",
    "fixed mix w=0.5",
    "reliability select b=10",
    "reliability mix b=10",
    "VPI tau=0.08",
];

/// What to run, and where.
#[derive(Debug, Clone)]
pub struct Options {
    /// Output folder: a dataset folder per sweep, `figures/` and `report.md`.
    pub out: PathBuf,
    /// The small version (3 runs per cell, short experiments): for checking the pipeline.
    pub quick: bool,
    /// Runs per cell (default 50, or 3 with `quick`).
    pub runs: Option<u32>,
    /// Where the sweeps' `json:` paths start (the repository's `sweeps/` folder).
    pub sweeps_dir: PathBuf,
    /// The command recorded in the data files' provenance and in the report.
    pub command: String,
}

/// The repository's `sweeps/` folder as it was when this binary was built: where the
/// navigation-world sweep finds `../../shared/data`.
pub fn default_sweeps_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps")
}

/// What a study did.
#[derive(Debug, Clone)]
pub struct Summary {
    /// One line per condition: the best rule on reward and the fastest to recover.
    pub table: String,
    /// Runs in the datasets.
    pub runs: u64,
    /// Runs simulated by this call (0 when everything was already on disk).
    pub ran: u64,
    /// Seconds spent simulating by this call.
    pub seconds: f64,
    /// Things the user should know (a skipped sweep, a resumed one, a stale lock).
    pub notes: Vec<String>,
    /// The report written.
    pub report: PathBuf,
    /// The folder of the figures.
    pub figures: PathBuf,
}

/// The sweep text of `s` at the study's scale.
fn scaled_text(s: &StudySweep, quick: bool, runs: u32) -> String {
    let mut text = s.text.to_string();
    if quick {
        for (from, to) in s.quick {
            text = text.replace(from, to);
        }
        text.insert_str(
            0,
            "# The --quick version of this sweep (mbmf reproduce --study arbitration --quick).\n",
        );
    }
    text.replace(
        &format!("seeds = {RUNS_FULL}\n"),
        &format!("seeds = {runs}\n"),
    )
}

/// Runs the study into `options.out` and writes its report. `total` is told the agent-steps of
/// the whole study (those already on disk included) before the first step, `progress` the
/// agent-steps done since (those found on disk first). Once `stop` is set the study ends within
/// one simulation stride with [`crate::sweep::RunError::Interrupted`]; rerunning continues.
pub fn arbitration(
    options: &Options,
    stop: &AtomicBool,
    total: impl FnOnce(u64),
    mut progress: impl FnMut(u64) + Send,
) -> Result<Summary, ReproduceError> {
    let runs = options
        .runs
        .unwrap_or(if options.quick { RUNS_QUICK } else { RUNS_FULL });
    let mut notes = Vec::new();
    let mut active = Vec::new();
    for s in &SWEEPS {
        if let Some(needed) = s.needs {
            let path = options.sweeps_dir.join(needed);
            if !path.is_file() {
                notes.push(format!(
                    "skipped the {} sweep: it reads {}, which is absent (the authors' data, \
                     not part of the repository)",
                    s.name,
                    path.display()
                ));
                continue;
            }
        }
        let text = scaled_text(s, options.quick, runs);
        let sweep = Sweep::parse(s.file, &options.sweeps_dir, &text)?;
        let specs = sweep.load_specs()?;
        sweep.check(&specs)?;
        active.push((s, sweep, specs));
    }
    std::fs::create_dir_all(&options.out).map_err(IoError::doing(format!(
        "cannot create output folder {}",
        options.out.display()
    )))?;
    let full = |sweep: &Sweep| -> u64 {
        (0..sweep.configurations())
            .map(|c| u64::from(sweep.seeds) * pipeline_steps(&sweep.resolve(c).params))
            .sum()
    };
    total(active.iter().map(|(_, sweep, _)| full(sweep)).sum());
    let started = Instant::now();
    let mut ran = 0;
    for (s, sweep, specs) in &active {
        let run_options = runner::Options {
            out: options.out.join(s.name),
            resume: true,
            shard: Shard::ALL,
            batch_size: 256,
            command: options.command.clone(),
        };
        let whole = full(sweep);
        let mut on_event = |event: Event<'_>| match event {
            Event::Warning(w) => notes.push(w.to_string()),
            Event::Resuming { done, of, .. } => {
                notes.push(format!("{}: {done} of {of} runs already done", s.name));
            }
            Event::Started { agent_steps } => progress(whole - agent_steps),
            Event::Advanced(n) => progress(n),
            Event::Ran { .. } => {}
        };
        ran += runner::execute(sweep, specs, &run_options, stop, &mut on_event)?.ran;
    }
    let seconds = started.elapsed().as_secs_f64();

    let figures = options.out.join("figures");
    std::fs::create_dir_all(&figures).map_err(IoError::doing(format!(
        "cannot create output folder {}",
        figures.display()
    )))?;
    let mut study = Study {
        options,
        runs_per_cell: runs,
        sections: Vec::new(),
        headline: String::new(),
        skipped: notes
            .iter()
            .filter(|n| n.starts_with("skipped"))
            .cloned()
            .collect(),
        total_runs: 0,
    };
    for (s, sweep, _) in &active {
        study.analyse(s, sweep, &figures)?;
    }
    let text = study.markdown(seconds, ran);
    let report = options.out.join("report.md");
    write_atomic(&report, &text)?;
    Ok(Summary {
        table: study.headline.clone(),
        runs: study.total_runs,
        ran,
        seconds,
        notes,
        report,
        figures,
    })
}

// ---------------------------------------------------------------------------------------------
// Reading the datasets
// ---------------------------------------------------------------------------------------------

/// One run's results, as the report uses them.
#[derive(Debug, Clone, Copy)]
struct Run {
    reward: f64,
    last10: f64,
    cost: f64,
    p_mb: f64,
    interactions: f64,
    /// Steps from the change to the first reward after it; runs that got none count as the
    /// steps left after the change plus one (censored, so no run is dropped).
    recovery: f64,
    reward_after: f64,
    /// Two-step stay probabilities (NaN until the task reports them).
    stay_reward_effect: f64,
    stay_interaction: f64,
}

/// The runs of one cell (condition x rule), and their series.
#[derive(Default)]
struct Cell {
    runs: Vec<Run>,
    /// Per run: (step, cum_reward, p_mb_mean) at every checkpoint.
    series: Vec<Vec<(u32, f64, f64)>>,
}

impl Cell {
    fn values(&self, f: impl Fn(&Run) -> f64) -> Vec<f64> {
        self.runs.iter().map(f).filter(|v| v.is_finite()).collect()
    }
    fn mean(&self, f: impl Fn(&Run) -> f64) -> f64 {
        let v = self.values(f);
        if v.is_empty() {
            f64::NAN
        } else {
            stats::mean(&v)
        }
    }
    fn median(&self, f: impl Fn(&Run) -> f64) -> f64 {
        let mut v = self.values(f);
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        }
    }
    fn ci95(&self, f: impl Fn(&Run) -> f64) -> f64 {
        let v = self.values(f);
        if v.len() < 2 {
            f64::NAN
        } else {
            stats::ci95_half_width(&v)
        }
    }
    /// Mean over runs of the mean series P(MB) over checkpoints in `[from, to)` (checkpoint
    /// rows cover the steps since the previous one, so a row at step s covers (s - K, s]).
    fn p_mb_window(&self, from: u32, to: u32) -> f64 {
        let per_run: Vec<f64> = self
            .series
            .iter()
            .filter_map(|s| {
                let v: Vec<f64> = s
                    .iter()
                    .filter(|(step, _, p)| *step > from && *step <= to && p.is_finite())
                    .map(|&(_, _, p)| p)
                    .collect();
                (!v.is_empty()).then(|| stats::mean(&v))
            })
            .collect();
        if per_run.is_empty() {
            f64::NAN
        } else {
            stats::mean(&per_run)
        }
    }
    /// Mean and standard error over runs at each checkpoint of a series value.
    fn curve(&self, f: impl Fn(&(u32, f64, f64)) -> f64) -> Series {
        let n = self.series.iter().map(Vec::len).min().unwrap_or(0);
        let (mut x, mut y, mut band) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let v: Vec<f64> = self
                .series
                .iter()
                .map(|s| f(&s[i]))
                .filter(|v| v.is_finite())
                .collect();
            if v.is_empty() {
                continue;
            }
            x.push(f64::from(self.series[0][i].0));
            y.push(stats::mean(&v));
            band.push(if v.len() < 2 { 0.0 } else { stats::sem(&v) });
        }
        Series {
            label: String::new(),
            x,
            y,
            band: Some(band),
        }
    }
}

/// A condition's cells in rule order, and where its change (if any) happens.
struct Condition {
    name: String,
    /// The `--where` filter that selects it in `mbmf` commands (empty for the only condition).
    filter: String,
    cells: Vec<(String, Cell)>,
    change: Option<u32>,
    steps: u32,
}

impl Condition {
    fn cell(&self, rule: &str) -> Option<&Cell> {
        self.cells.iter().find(|(r, _)| r == rule).map(|(_, c)| c)
    }
}

fn text_at(table: &Table, name: &str, i: usize) -> String {
    match table.column(name).map(|c| c.value(i)) {
        Ok(Value::Str(s)) => s,
        Ok(Value::Null) | Err(_) => String::new(),
        Ok(v) => v.to_string(),
    }
}

fn number_at(column: &[Option<f64>], i: usize) -> f64 {
    column.get(i).copied().flatten().unwrap_or(f64::NAN)
}

/// The rule a run ran: its controller with the parameter the study sweeps for it.
fn rule_label(table: &Table, i: usize, numbers: &BTreeMap<&str, Vec<Option<f64>>>) -> String {
    let controller = text_at(table, "controller", i);
    let combine = text_at(table, "combine", i);
    let num = |name: &str| number_at(&numbers[name], i);
    match controller.as_str() {
        "ec" => format!("EC k={}", num("kappa_coeff")),
        "fixed" => format!("fixed {combine} w={}", num("w_mb")),
        "reliability" => format!("reliability {combine} b={}", num("rel_b_mf_mb")),
        "vpi" => format!("VPI tau={}", num("vpi_tau")),
        "entropy" => "entropy".to_string(),
        other => other.to_uppercase(),
    }
}

/// Columns read as numbers; the stay columns may be absent (null for tasks without them).
const NUMBERS: [&str; 15] = [
    "run_index",
    "config_index",
    "total_reward",
    "reward_last10",
    "cost_total",
    "p_mb_mean",
    "interactions",
    "recovery_steps",
    "reward_after_change",
    "first_change_step",
    "steps",
    "kappa_coeff",
    "w_mb",
    "vpi_tau",
    "rel_b_mf_mb",
];

/// The conditions of one dataset: its runs grouped by `condition_of` and rule, in the sweep's
/// order, with their series.
fn read_conditions(
    dir: &Path,
    condition_of: impl Fn(&Table, usize) -> (String, String),
) -> Result<Vec<Condition>, ReproduceError> {
    let runs = read_dataset(dir, "runs")?;
    let series = read_dataset(dir, "series")?;
    let mut numbers: BTreeMap<&str, Vec<Option<f64>>> = BTreeMap::new();
    for name in NUMBERS {
        numbers.insert(name, runs.numeric(name, "the arbitration study")?);
    }
    let stay = |name: &str| -> Vec<Option<f64>> {
        runs.numeric(name, "the arbitration study")
            .unwrap_or_else(|_| vec![None; runs.len()])
    };
    let (stay_reward, stay_interaction) = (stay("stay_reward_effect"), stay("stay_interaction"));
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by(|&a, &b| {
        number_at(&numbers["run_index"], a).total_cmp(&number_at(&numbers["run_index"], b))
    });
    let mut conditions: Vec<Condition> = Vec::new();
    let mut where_of_run: BTreeMap<u64, (usize, usize)> = BTreeMap::new();
    for i in order {
        let (name, filter) = condition_of(&runs, i);
        let rule = rule_label(&runs, i, &numbers);
        let c = match conditions.iter().position(|c| c.name == name) {
            Some(c) => c,
            None => {
                let change = number_at(&numbers["first_change_step"], i);
                conditions.push(Condition {
                    name,
                    filter,
                    cells: Vec::new(),
                    change: change.is_finite().then_some(change as u32),
                    steps: number_at(&numbers["steps"], i) as u32,
                });
                conditions.len() - 1
            }
        };
        let cells = &mut conditions[c].cells;
        let r = match cells.iter().position(|(r, _)| *r == rule) {
            Some(r) => r,
            None => {
                cells.push((rule, Cell::default()));
                cells.len() - 1
            }
        };
        let num = |name: &str| number_at(&numbers[name], i);
        let change = num("first_change_step");
        let recovery = match num("recovery_steps") {
            r if r.is_finite() => r,
            _ if change.is_finite() => num("steps") - change + 2.0,
            _ => f64::NAN,
        };
        cells[r].1.runs.push(Run {
            reward: num("total_reward"),
            last10: num("reward_last10"),
            cost: num("cost_total"),
            p_mb: num("p_mb_mean"),
            interactions: num("interactions"),
            recovery,
            reward_after: num("reward_after_change"),
            stay_reward_effect: number_at(&stay_reward, i),
            stay_interaction: number_at(&stay_interaction, i),
        });
        cells[r].1.series.push(Vec::new());
        let run_index = num("run_index") as u64;
        where_of_run.insert(run_index, (c, r));
    }
    let s_run = series.numeric("run_index", "the arbitration study")?;
    let s_step = series.numeric("step", "the arbitration study")?;
    let s_reward = series.numeric("cum_reward", "the arbitration study")?;
    let s_p = series.numeric("p_mb_mean", "the arbitration study")?;
    // Series rows of one run, in step order, go to that run's slot (the last pushed for it).
    let mut slot: BTreeMap<u64, usize> = BTreeMap::new();
    let mut next: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for (&run, &(c, r)) in &where_of_run {
        let k = next.entry((c, r)).or_insert(0);
        slot.insert(run, *k);
        *k += 1;
    }
    let mut rows: Vec<usize> = (0..series.len()).collect();
    rows.sort_by(|&a, &b| {
        number_at(&s_run, a)
            .total_cmp(&number_at(&s_run, b))
            .then(number_at(&s_step, a).total_cmp(&number_at(&s_step, b)))
    });
    for j in rows {
        let run = number_at(&s_run, j) as u64;
        if let (Some(&(c, r)), Some(&k)) = (where_of_run.get(&run), slot.get(&run)) {
            conditions[c].cells[r].1.series[k].push((
                number_at(&s_step, j) as u32,
                number_at(&s_reward, j),
                number_at(&s_p, j),
            ));
        }
    }
    Ok(conditions)
}

// ---------------------------------------------------------------------------------------------
// Analyses
// ---------------------------------------------------------------------------------------------

/// Two-sided Mann-Whitney p-values of every rule against [`REFERENCE`] on `f`, Holm-corrected
/// over the family of those comparisons; NaN for the reference itself or an empty sample.
fn holm_vs_reference(condition: &Condition, f: impl Fn(&Run) -> f64) -> Vec<f64> {
    let Some(reference) = condition.cell(REFERENCE) else {
        return vec![f64::NAN; condition.cells.len()];
    };
    let y = reference.values(&f);
    let raw: Vec<f64> = condition
        .cells
        .iter()
        .filter(|(rule, _)| rule != REFERENCE)
        .map(|(_, cell)| {
            stats::mann_whitney(&cell.values(&f), &y, Alternative::TwoSided)
                .map_or(f64::NAN, |m| m.p_value)
        })
        .collect();
    let mut adjusted = stats::holm(&raw).into_iter();
    condition
        .cells
        .iter()
        .map(|(rule, _)| {
            if rule == REFERENCE {
                f64::NAN
            } else {
                adjusted.next().unwrap_or(f64::NAN)
            }
        })
        .collect()
}

/// Whether a human interacts in the condition: then the human's effort is an objective too.
fn has_human(condition: &Condition) -> bool {
    condition
        .cells
        .iter()
        .any(|(_, cell)| cell.mean(|r| r.interactions) > 0.0)
}

/// The objectives of a condition's front: mean reward (max) and mean cost (min) and, where a
/// human interacts, mean interactions (min).
fn objectives(condition: &Condition) -> &'static [Direction] {
    if has_human(condition) {
        &[
            Direction::Maximize,
            Direction::Minimize,
            Direction::Minimize,
        ]
    } else {
        &[Direction::Maximize, Direction::Minimize]
    }
}

/// The `--objectives` of `mbmf pareto` that draws the same front.
fn objectives_flag(condition: &Condition) -> &'static str {
    if has_human(condition) {
        "total_reward:max,cost_total:min,interactions:min"
    } else {
        "total_reward:max,cost_total:min"
    }
}

/// A rule's point on the condition's front ([`objectives`]).
fn front_point(condition: &Condition, cell: &Cell) -> Vec<f64> {
    let mut point = vec![cell.mean(|r| r.reward), cell.mean(|r| r.cost)];
    if has_human(condition) {
        point.push(cell.mean(|r| r.interactions));
    }
    point
}

/// Non-domination rank of every rule on the condition's [`objectives`].
fn front_ranks(condition: &Condition) -> Vec<usize> {
    let points: Vec<Vec<f64>> = condition
        .cells
        .iter()
        .map(|(_, c)| front_point(condition, c))
        .collect();
    pareto::non_dominated_ranks(&points, objectives(condition))
}

fn fmt(x: f64, decimals: usize) -> String {
    if x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        "–".to_string()
    }
}

/// A cost in thousands of Q values read.
fn fmt_k(x: f64) -> String {
    if x.is_finite() {
        format!("{:.0}k", x / 1000.0)
    } else {
        "–".to_string()
    }
}

fn fmt_p(p: f64) -> String {
    if !p.is_finite() {
        "–".to_string()
    } else if p < 1e-3 {
        format!("{p:.0e}{}", stats::significance_stars(p))
    } else {
        format!("{p:.3}{}", stats::significance_stars(p))
    }
}

/// The text of the report, built section by section.
struct Study<'a> {
    options: &'a Options,
    runs_per_cell: u32,
    sections: Vec<String>,
    headline: String,
    skipped: Vec<String>,
    total_runs: u64,
}

impl Study<'_> {
    fn out_dir(&self, name: &str) -> String {
        self.options.out.join(name).display().to_string()
    }

    fn analyse(
        &mut self,
        s: &StudySweep,
        sweep: &Sweep,
        figures: &Path,
    ) -> Result<(), ReproduceError> {
        let dir = self.options.out.join(s.name);
        let conditions = match s.name {
            "tidy" => read_conditions(&dir, |t, i| {
                let p = text_at(t, "profile", i);
                (format!("tidy1, {p}"), format!("profile={p}"))
            })?,
            "navworld" => read_conditions(&dir, |t, i| {
                let schedule = text_at(t, "schedule", i);
                let name = if schedule.contains("goal") {
                    "navworld, goal moves"
                } else {
                    "navworld, corridor deleted"
                };
                (name.to_string(), format!("'schedule={schedule}'"))
            })?,
            "objective" => read_conditions(&dir, |_, _| {
                ("tidy1, boxes change".to_string(), String::new())
            })?,
            _ => read_conditions(&dir, |_, _| ("twostep".to_string(), String::new()))?,
        };
        self.total_runs += sweep.runs();
        let mut text = String::new();
        let data = self.out_dir(s.name);
        let _ = writeln!(
            text,
            "## {} (`{}`, {} runs)\n\nData: `{data}` (`mbmf sweep {} --out {data} --resume` \
             runs it again).\n",
            section_title(s.name),
            s.file,
            sweep.runs(),
            s.file
        );
        for condition in &conditions {
            text.push_str(&self.condition_section(s.name, condition, &data, figures)?);
        }
        if s.name == "twostep" {
            text.push_str(&twostep_section(&conditions, &data));
        } else {
            text.push_str(&self.front_figure(s.name, &conditions, figures)?);
        }
        self.sections.push(text);
        Ok(())
    }

    /// The table of one condition, and its curves around the change.
    fn condition_section(
        &mut self,
        sweep: &str,
        c: &Condition,
        data: &str,
        figures: &Path,
    ) -> Result<String, ReproduceError> {
        let mut t = String::new();
        let filter = if c.filter.is_empty() {
            String::new()
        } else {
            format!(" --where {}", c.filter)
        };
        let _ = writeln!(t, "### {}\n", c.name);
        let p_reward = holm_vs_reference(c, |r| r.reward);
        let p_cost = holm_vs_reference(c, |r| r.cost);
        let p_recovery = holm_vs_reference(c, |r| r.recovery);
        let ranks = front_ranks(c);
        let changed = c.change.is_some();
        let human = has_human(c);
        let _ = write!(
            t,
            "| rule | total reward (mean ± 95% CI) | p vs {REFERENCE} | reward, last 10% | \
             cost (Q values read) | p vs {REFERENCE} | P(MB) |"
        );
        if human {
            t.push_str(" interactions |");
        }
        if changed {
            let _ = write!(
                t,
                " recovery steps (median / mean) | p vs {REFERENCE} | reward after change |"
            );
        }
        t.push_str(" front rank |\n|---|---|---|---|---|---|---|");
        if human {
            t.push_str("---|");
        }
        if changed {
            t.push_str("---|---|---|");
        }
        t.push_str("---|\n");
        for (i, (rule, cell)) in c.cells.iter().enumerate() {
            let _ = write!(
                t,
                "| {rule} | {} ± {} | {} | {} | {} | {} | {} |",
                fmt(cell.mean(|r| r.reward), 1),
                fmt(cell.ci95(|r| r.reward), 1),
                fmt_p(p_reward[i]),
                fmt(cell.mean(|r| r.last10), 1),
                fmt_k(cell.mean(|r| r.cost)),
                fmt_p(p_cost[i]),
                fmt(cell.mean(|r| r.p_mb), 3),
            );
            if human {
                let _ = write!(t, " {} |", fmt(cell.mean(|r| r.interactions), 1));
            }
            if changed {
                let _ = write!(
                    t,
                    " {} / {} | {} | {} |",
                    fmt(cell.median(|r| r.recovery), 0),
                    fmt(cell.mean(|r| r.recovery), 0),
                    fmt_p(p_recovery[i]),
                    fmt(cell.mean(|r| r.reward_after), 1),
                );
            }
            let _ = writeln!(t, " {} |", ranks[i]);
        }
        let _ = writeln!(
            t,
            "\n{} runs per rule. p: two-sided Mann-Whitney against {REFERENCE}, Holm-corrected \
             over the {} comparisons of the column (* < 0.05, ** < 0.01, *** < 0.001). Front \
             rank: non-domination rank on mean reward (max), mean cost (min){}, 0 = on the \
             front.{}\nCommands: `mbmf pareto {data}{filter} --objectives {}` (the front), \
             `mbmf stats {data}{filter} \
             --metric total_reward --by config_index` (every pair of rules; a rule is a \
             configuration of the sweep).\n",
            self.runs_per_cell,
            c.cells.len().saturating_sub(1),
            if human {
                " and mean interactions (min)"
            } else {
                ""
            },
            if changed {
                " Recovery: steps from the change to the first reward after it (a run with \
                 none counts as the steps left plus one)."
            } else if human {
                " Interactions: the paper's minimal budget for the controller (EC's for the \
                 rules absent from the paper), the human's effort, an objective of the front."
            } else {
                ""
            },
            objectives_flag(c),
        );
        t.push_str(&verdict(c, &p_reward, &p_recovery, &ranks));
        self.headline_line(c);
        if sweep == "twostep" {
            return Ok(t);
        }
        if let Some(change) = c.change {
            t.push_str(&self.change_figures(c, change, data, &filter, figures)?);
        }
        Ok(t)
    }

    fn headline_line(&mut self, c: &Condition) {
        let best = c
            .cells
            .iter()
            .max_by(|a, b| a.1.mean(|r| r.reward).total_cmp(&b.1.mean(|r| r.reward)));
        let mut line = format!("{:<28}", c.name);
        if let Some((rule, cell)) = best {
            let _ = write!(
                line,
                " most reward: {rule} ({})",
                fmt(cell.mean(|r| r.reward), 1)
            );
        }
        if c.change.is_some() {
            let fastest = c.cells.iter().min_by(|a, b| {
                a.1.mean(|r| r.recovery)
                    .total_cmp(&b.1.mean(|r| r.recovery))
            });
            if let Some((rule, cell)) = fastest {
                let _ = write!(
                    line,
                    "; fastest recovery: {rule} ({} steps)",
                    fmt(cell.mean(|r| r.recovery), 0)
                );
            }
        }
        self.headline.push_str(&line);
        self.headline.push('\n');
    }

    /// P(MB) around the change (table and figure) and the reward curves.
    fn change_figures(
        &self,
        c: &Condition,
        change: u32,
        data: &str,
        filter: &str,
        figures: &Path,
    ) -> Result<String, ReproduceError> {
        let window = (c.steps / 10).max(100);
        let mut t = String::new();
        let _ = writeln!(
            t,
            "P(MB) around the change at step {change} (series `p_mb_mean`, mean over runs of \
             the checkpoint means in each window):\n\n| rule | steps {}-{} | {}-{} | {}-{} | \
             last {} |\n|---|---|---|---|---|",
            change.saturating_sub(window),
            change,
            change,
            change + window,
            change + window,
            change + 3 * window,
            window
        );
        for (rule, cell) in &c.cells {
            let _ = writeln!(
                t,
                "| {rule} | {} | {} | {} | {} |",
                fmt(cell.p_mb_window(change.saturating_sub(window), change), 3),
                fmt(cell.p_mb_window(change, change + window), 3),
                fmt(cell.p_mb_window(change + window, change + 3 * window), 3),
                fmt(cell.p_mb_window(c.steps.saturating_sub(window), c.steps), 3),
            );
        }
        let slug = slug(&c.name);
        let mut drawn = Vec::new();
        for (what, y_label, pick) in [
            (
                "p_mb",
                "P(MB), mean over the checkpoint window",
                (|p: &(u32, f64, f64)| p.2) as fn(&(u32, f64, f64)) -> f64,
            ),
            ("cum_reward", "cumulative reward", |p: &(u32, f64, f64)| p.1),
        ] {
            let series: Vec<Series> = MAIN_RULES
                .iter()
                .filter_map(|rule| {
                    let mut s = c.cell(rule)?.curve(pick);
                    s.label = (*rule).to_string();
                    (!s.x.is_empty()).then_some(s)
                })
                .collect();
            if series.is_empty() {
                continue;
            }
            let chart = LineChart {
                title: format!("{}: {what} by rule (default parameters)", c.name),
                x_label: "experiment step".to_string(),
                y_label: y_label.to_string(),
                series,
                log_x: false,
                log_y: false,
                x_marks: vec![f64::from(change)],
            };
            let name = format!("{what}_{slug}");
            plot::line_chart_coloured(&chart, &LineColours::Labels, &figures.join(&name))?;
            drawn.push(name);
        }
        let _ = writeln!(
            t,
            "\nFigures: {} (every controller at its default parameters; the vertical mark is \
             the change). Command: `mbmf plot {data}{filter} --where kappa_coeff=9 --where \
             w_mb=0.5 --where rel_b_mf_mb=10 --where vpi_tau=0.08 --by controller --metric p_mb` \
             (the same curves, select and mix pooled per controller).\n",
            drawn
                .iter()
                .map(|n| format!("`figures/{n}.png`"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        Ok(t)
    }

    /// The fronts of one sweep's conditions, a panel each.
    fn front_figure(
        &self,
        sweep: &str,
        conditions: &[Condition],
        figures: &Path,
    ) -> Result<String, ReproduceError> {
        let human = conditions.iter().any(has_human);
        let mut panels = Vec::new();
        for c in conditions {
            let ranks = front_ranks(c);
            let shown: Vec<usize> = (0..c.cells.len())
                .filter(|&i| {
                    let cell = &c.cells[i].1;
                    cell.mean(|r| r.reward).is_finite() && cell.mean(|r| r.cost).is_finite()
                })
                .collect();
            if shown.is_empty() {
                continue;
            }
            let points: Vec<(f64, f64)> = shown
                .iter()
                .map(|&i| {
                    (
                        c.cells[i].1.mean(|r| r.cost),
                        c.cells[i].1.mean(|r| r.reward),
                    )
                })
                .collect();
            let front: Vec<usize> = (0..shown.len()).filter(|&k| ranks[shown[k]] == 0).collect();
            let front_points: Vec<Vec<f64>> = front
                .iter()
                .map(|&k| front_point(c, &c.cells[shown[k]].1))
                .collect();
            let knee = pareto::knee_point(&front_points, objectives(c)).map(|k| front[k]);
            panels.push(FrontPanel {
                title: c.name.clone(),
                points,
                colour_values: shown
                    .iter()
                    .map(|&i| c.cells[i].1.mean(|r| r.interactions))
                    .collect(),
                front,
                knee,
                labels: shown.iter().map(|&i| c.cells[i].0.clone()).collect(),
            });
        }
        if panels.is_empty() {
            return Ok(String::new());
        }
        let chart = FrontChart {
            title: format!(
                "{}: reward against cost, one point per rule",
                section_title(sweep)
            ),
            x_label: "cost_total (mean Q values read; lower is better)".to_string(),
            y_label: "total_reward (mean; higher is better)".to_string(),
            // Where a human interacts, the front is over three objectives: the third is the
            // colour, and a line in the plane of the other two would zigzag.
            colour: human.then(|| "interactions (mean)".to_string()),
            panels,
            join_front: !human,
            log_x: true,
            log_y: false,
        };
        let name = format!("front_{sweep}");
        plot::front_chart(&chart, &figures.join(&name))?;
        let (drawn, objectives) = if human {
            (
                "the front over reward, cost and interactions ringed, the interactions in colour",
                "total_reward:max,cost_total:min,interactions:min",
            )
        } else {
            ("the front joined", "total_reward:max,cost_total:min")
        };
        Ok(format!(
            "Figure: `figures/{name}.png` (each rule's mean cost across, mean reward up; \
             {drawn}, its knee ringed). Command: `mbmf pareto {} --by {} --objectives \
             {objectives}`.\n\n",
            self.out_dir(sweep),
            match sweep {
                "tidy" => "profile",
                "navworld" => "schedule",
                _ => "task",
            }
        ))
    }

    fn markdown(&self, seconds: f64, ran: u64) -> String {
        let mut t = String::new();
        let quick = if self.options.quick { " --quick" } else { "" };
        let _ = writeln!(
            t,
            "# Which arbitration rule wins?\n\nWritten by `{}`; `mbmf reproduce --study \
             arbitration{quick} --out {}` rebuilds it (it resumes: only missing runs are \
             simulated).{}\n",
            self.options.command,
            self.options.out.display(),
            if self.options.quick {
                " **Quick version**: 3 runs per cell and short experiments, for checking the \
                 pipeline; its numbers support no conclusion."
            } else {
                ""
            }
        );
        let _ = writeln!(
            t,
            "{} runs, {} per cell; {ran} simulated by this call in {seconds:.1} s.\n",
            self.total_runs, self.runs_per_cell
        );
        for note in &self.skipped {
            let _ = writeln!(t, "Note: {note}.\n");
        }
        t.push_str(RULES_TEXT);
        let _ = writeln!(t, "## Headline\n\n```text\n{}```\n", self.headline);
        for s in &self.sections {
            t.push_str(s);
        }
        t
    }
}

/// What the table of a condition says, in sentences generated from its numbers.
fn verdict(c: &Condition, p_reward: &[f64], p_recovery: &[f64], ranks: &[usize]) -> String {
    let Some(ec) = c.cell(REFERENCE) else {
        return String::new();
    };
    let (ec_reward, ec_cost) = (ec.mean(|r| r.reward), ec.mean(|r| r.cost));
    let ec_help = ec.mean(|r| r.interactions);
    // A rule helped more (or less) by the human than EC says so beside its name.
    let named = |rule: &str, cell: &Cell, extra: Option<String>| {
        let help = cell.mean(|r| r.interactions);
        let mut notes: Vec<String> = extra.into_iter().collect();
        if help.is_finite() && ec_help.is_finite() && (help - ec_help).abs() > 0.5 {
            notes.push(format!("{help:.0} interactions against {ec_help:.0}"));
        }
        if notes.is_empty() {
            rule.to_string()
        } else {
            format!("{rule} ({})", notes.join(", "))
        }
    };
    let p_after = holm_vs_reference(c, |r| r.reward_after);
    let mut better_cheaper = Vec::new();
    let mut better_dearer = Vec::new();
    let mut worse = Vec::new();
    let mut faster = Vec::new();
    let mut more_after = Vec::new();
    for (i, (rule, cell)) in c.cells.iter().enumerate() {
        let reward = cell.mean(|r| r.reward);
        let cost = cell.mean(|r| r.cost);
        let dearer = Some(format!("cost x{:.1}", cost / ec_cost));
        if p_reward[i] < 0.05 && reward > ec_reward {
            if cost <= ec_cost {
                better_cheaper.push(named(rule, cell, None));
            } else {
                better_dearer.push(named(rule, cell, dearer.clone()));
            }
        } else if p_reward[i] < 0.05 && reward < ec_reward {
            worse.push(rule.clone());
        }
        if c.change.is_some()
            && p_recovery[i] < 0.05
            && cell.mean(|r| r.recovery) < ec.mean(|r| r.recovery)
        {
            faster.push(named(rule, cell, dearer.clone()));
        }
        if c.change.is_some()
            && p_after[i] < 0.05
            && cell.mean(|r| r.reward_after) > ec.mean(|r| r.reward_after)
        {
            more_after.push(named(rule, cell, dearer));
        }
    }
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    let on_front: Vec<&str> = c
        .cells
        .iter()
        .zip(ranks)
        .filter(|(_, r)| **r == 0)
        .map(|((rule, _), _)| rule.as_str())
        .collect();
    let mut t = format!(
        "Against {REFERENCE} (Holm p < 0.05): more reward at no more cost: {}; more reward at \
         a higher cost: {}; less reward: {}.",
        list(&better_cheaper),
        list(&better_dearer),
        list(&worse),
    );
    if c.change.is_some() {
        let _ = write!(
            t,
            " First reward after the change sooner: {}. More reward after the change: {}.",
            list(&faster),
            list(&more_after)
        );
    }
    let _ = writeln!(
        t,
        " On the front: {}; {REFERENCE} {}.\n",
        on_front.join(", "),
        if on_front.contains(&REFERENCE) {
            "is on it"
        } else {
            "is not"
        }
    );
    t
}

/// The two-step signatures, once the task reports its stay probabilities.
fn twostep_section(conditions: &[Condition], data: &str) -> String {
    let mut t = String::from("### Two-step signatures\n\n");
    let Some(c) = conditions.first() else {
        return t;
    };
    let reported = c
        .cells
        .iter()
        .any(|(_, cell)| cell.runs.iter().any(|r| r.stay_interaction.is_finite()));
    if !reported {
        t.push_str(
            "**Placeholder**: this build's runs table has no stay columns (`stay_rc` ... \
             `stay_interaction`, SPEC 13), so the signatures cannot be reported yet.\n\n",
        );
        return t;
    }
    let p_reward = holm_vs_zero(c, |r| r.stay_reward_effect);
    let p_inter = holm_vs_zero(c, |r| r.stay_interaction);
    t.push_str(
        "| rule | reward effect (mean ± 95% CI) | p (≠ 0) | interaction (mean ± 95% CI) | p (≠ 0) |\n\
         |---|---|---|---|---|\n",
    );
    for (i, (rule, cell)) in c.cells.iter().enumerate() {
        let _ = writeln!(
            t,
            "| {rule} | {} ± {} | {} | {} ± {} | {} |",
            fmt(cell.mean(|r| r.stay_reward_effect), 3),
            fmt(cell.ci95(|r| r.stay_reward_effect), 3),
            fmt_p(p_reward[i]),
            fmt(cell.mean(|r| r.stay_interaction), 3),
            fmt(cell.ci95(|r| r.stay_interaction), 3),
            fmt_p(p_inter[i]),
        );
    }
    let _ = writeln!(
        t,
        "\nReward effect = (stay_rc + stay_rr - stay_uc - stay_ur) / 2 (the MF signature), \
         interaction = (stay_rc - stay_rr - stay_uc + stay_ur) / 2 (the MB signature), per run; \
         p: two-sided one-sample t-test of a zero mean, Holm-corrected over the rules. Command: `mbmf stats {data} \
         --metric stay_interaction --by controller`.\n"
    );
    t
}

/// Whether each rule's mean differs from 0: one-sample Student t-test (two-sided) per rule,
/// Holm-corrected over the rules; NaN below 2 runs or with no spread.
fn holm_vs_zero(c: &Condition, f: impl Fn(&Run) -> f64) -> Vec<f64> {
    let raw: Vec<f64> = c
        .cells
        .iter()
        .map(|(_, cell)| {
            let x = cell.values(&f);
            if x.len() < 2 {
                return f64::NAN;
            }
            let (m, se) = (stats::mean(&x), stats::sem(&x));
            if se > 0.0 {
                (2.0 * stats::student_t_sf((m / se).abs(), (x.len() - 1) as f64)).min(1.0)
            } else {
                f64::NAN
            }
        })
        .collect();
    stats::holm(&raw)
}

fn section_title(sweep: &str) -> &'static str {
    match sweep {
        "tidy" => "Task 1 with and without a human",
        "objective" => "Task 1 whose box assignment changes",
        "navworld" => "The navigation world that changes",
        _ => "The two-step task",
    }
}

fn slug(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .split('_')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

const RULES_TEXT: &str = "## The rules\n\nEvery controller of SPEC 12 over its main parameter \
(one `[[zip]]` row each in `sweeps/arbitration-*.toml`): MF, MB, RND and entropy at their \
defaults; EC at kappa_coeff (k) 4.5, 9 (default), 18; fixed at w_mb (w) 0.25, 0.5, 0.75 with \
`combine = select` and `mix` (mix w=0.5 is Daw 2011's hybrid); reliability (Lee 2014) at \
rel_b_mf_mb (b) 2, 5, 10 (default) with select and mix (mix is Lee's own output); VPI (Keramati \
2011) at vpi_tau 0.02, 0.08 (default), 0.32. The reference of every comparison is the paper's \
EC at k=9. No default was tuned for this study.\n\n";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_quick_replacement_changes_its_sweep() {
        for s in &SWEEPS {
            assert!(
                s.text.contains(&format!("seeds = {RUNS_FULL}\n")),
                "{}",
                s.name
            );
            for (from, _) in s.quick {
                assert!(s.text.contains(from), "{}: {from}", s.name);
            }
        }
    }

    #[test]
    fn slugs_keep_words_only() {
        assert_eq!(slug("navworld, goal moves"), "navworld_goal_moves");
        assert_eq!(slug("tidy1, paper-takeover"), "tidy1_paper_takeover");
    }
}
