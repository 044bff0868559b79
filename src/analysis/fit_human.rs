//! Fitting the simulated human to traced sessions (SPEC 15 "Fitting"): per session (a run of a
//! dataset written with `--trace`, simulated or taught by a person), or pooled over the runs
//! that share the values of `--by` columns, the maximum-likelihood forget_prob and error_prob
//! with profile-likelihood intervals, the share of each interaction type and the interaction
//! rate over the session.
//!
//! The model: at each opportunity the human is attentive with probability a = 1 - f and, when
//! attentive, judges rightly with probability 1 - e. A robot action that merits feedback (a
//! relevant action for congratulation, an error for punishment) gets it with probability
//! a (1 - e), any other robot action with probability a e; a step that starts with the robot
//! holding a cube is taken over with probability a. Opportunities are recomputed from the
//! task's human tables ([`crate::env::HumanTables`]) at the traced state and action; after the
//! budget is spent there are none. The log likelihood depends on the trace through six counts
//! only ([`Counts`]), so pooling runs is adding their counts.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{Array, ArrayRef, AsArray};
use arrow::compute::{CastOptions, cast_with_options};
use arrow::datatypes::{DataType, Int64Type};

use super::AnalysisError;
use super::dataset::{self, DatasetError, Table, Value};
use crate::env::{self, HumanTables, NO_TAKEOVER, Spec};
use crate::params::{PARAMS, Params, registry::Kind};

/// The trace table's name: `DIR/trace.parquet` or `DIR/trace/part-*.parquet` (SPEC 14).
pub const TRACE: &str = "trace";

/// Half-width of a 95% profile-likelihood interval: the 0.95 quantile of chi-square with one
/// degree of freedom, halved (an interval holds the values whose log likelihood is within it of
/// the maximum).
pub const HALF_CHI2_95: f64 = 3.841_458_820_694_124 / 2.0;

/// Interaction types a session's human may use, as the trace's `human_event` names them.
const EVENTS: [&str; 5] = [
    "congratulation",
    "punishment",
    "takeover",
    "nuisance",
    "reward",
];

/// The sufficient statistics of a session under the model: opportunities and interactions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Robot actions that merit the human's feedback, and how many got it.
    pub merited: (u64, u64),
    /// Other robot actions (feedback opportunities), and how many got feedback all the same.
    pub other: (u64, u64),
    /// Steps starting with the robot holding a cube (takeover opportunities), and takeovers.
    pub holds: (u64, u64),
}

impl Counts {
    /// Both sessions' counts, as one session.
    pub fn add(&mut self, other: &Counts) {
        for (a, b) in [
            (&mut self.merited, other.merited),
            (&mut self.other, other.other),
            (&mut self.holds, other.holds),
        ] {
            a.0 += b.0;
            a.1 += b.1;
        }
    }

    /// The log likelihood of attention `a` = 1 - forget_prob and error probability `e`.
    pub fn log_likelihood(&self, a: f64, e: f64) -> f64 {
        bernoulli(self.merited, a * (1.0 - e))
            + bernoulli(self.other, a * e)
            + bernoulli(self.holds, a)
    }

    /// Whether anything informs the error probability: feedback opportunities.
    fn judged(&self) -> bool {
        self.merited.0 + self.other.0 > 0
    }
}

/// log P of `k` successes in `n` trials of probability `p`, without the binomial coefficient;
/// `0 ln 0` counts as 0.
fn bernoulli((n, k): (u64, u64), p: f64) -> f64 {
    let term = |count: u64, q: f64| {
        if count == 0 {
            0.0
        } else {
            count as f64 * q.ln()
        }
    };
    term(k, p) + term(n - k, 1.0 - p)
}

/// The maximum of a concave function on [0, 1] (golden sections, then the end points, which
/// a boundary maximum may sit on).
fn max_concave(f: impl Fn(f64) -> f64) -> (f64, f64) {
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut x1 = hi - INV_PHI * (hi - lo);
    let mut x2 = lo + INV_PHI * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    while hi - lo > 1e-12 {
        if f1 < f2 {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + INV_PHI * (hi - lo);
            f2 = f(x2);
        } else {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - INV_PHI * (hi - lo);
            f1 = f(x1);
        }
    }
    let mid = 0.5 * (lo + hi);
    [(mid, f(mid)), (0.0, f(0.0)), (1.0, f(1.0))]
        .into_iter()
        .fold((mid, f64::NEG_INFINITY), |best, c| {
            if c.1 > best.1 { c } else { best }
        })
}

/// One parameter's estimate: the maximum-likelihood value (`None` where the data do not
/// identify it) and its 95% profile-likelihood interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The MLE, or `None` when not identified.
    pub value: Option<f64>,
    /// Lower end of the 95% interval.
    pub low: f64,
    /// Upper end of the 95% interval.
    pub high: f64,
}

/// The maximum-likelihood human of a session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// forget_prob.
    pub forget: Estimate,
    /// error_prob.
    pub error: Estimate,
    /// The maximum log likelihood.
    pub log_likelihood: f64,
}

/// The MLE of (forget_prob, error_prob) from `counts`, with 95% profile-likelihood intervals.
///
/// For a fixed e the log likelihood is concave in a (a sum of logs of functions affine in a),
/// and for a fixed a concave in e: each profile is a one-dimensional concave maximisation. The
/// profile of e is scanned on a grid and refined by golden sections; interval ends are found
/// by bisection on each side of the maximum.
pub fn fit(counts: &Counts) -> Fit {
    let profile_e = |e: f64| max_concave(|a| counts.log_likelihood(a, e)).1;
    let profile_a = |a: f64| max_concave(|e| counts.log_likelihood(a, e)).1;
    // The profile of e: best of a grid, then refined within the grid cells around it.
    const GRID: usize = 200;
    let best = (0..=GRID)
        .map(|i| i as f64 / GRID as f64)
        .map(|e| (e, profile_e(e)))
        .fold(
            (0.0, f64::NEG_INFINITY),
            |b, c| if c.1 > b.1 { c } else { b },
        );
    let (lo, hi) = (
        (best.0 - 1.0 / GRID as f64).max(0.0),
        (best.0 + 1.0 / GRID as f64).min(1.0),
    );
    let (t, _) = max_concave(|t| profile_e(lo + t * (hi - lo)));
    let e_hat = lo + t * (hi - lo);
    let (a_hat, max) = max_concave(|a| counts.log_likelihood(a, e_hat));
    let (e_hat, max) = if best.1 > max {
        (best.0, best.1)
    } else {
        (e_hat, max)
    };
    let a_hat = if best.1 > max {
        max_concave(|a| counts.log_likelihood(a, e_hat)).0
    } else {
        a_hat
    };
    let any = counts.judged() || counts.holds.0 > 0;
    let (f_low, f_high) = interval(|f| profile_a(1.0 - f), 1.0 - a_hat, max);
    let forget = Estimate {
        value: any.then_some(1.0 - a_hat),
        low: f_low,
        high: f_high,
    };
    // A human never attentive (a = 0) shows nothing of their judgment.
    let identified = counts.judged() && a_hat > 1e-9;
    let (e_low, e_high) = if identified {
        interval(profile_e, e_hat, max)
    } else {
        (0.0, 1.0)
    };
    Fit {
        forget,
        error: Estimate {
            value: identified.then_some(e_hat),
            low: e_low,
            high: e_high,
        },
        log_likelihood: max,
    }
}

/// The values of [0, 1] around the maximum `x_hat` whose profile log likelihood is within
/// [`HALF_CHI2_95`] of the maximum `max`, assuming the profile falls away on each side.
fn interval(profile: impl Fn(f64) -> f64, x_hat: f64, max: f64) -> (f64, f64) {
    let inside = |x: f64| max - profile(x) <= HALF_CHI2_95;
    let end = |outer: f64| {
        if inside(outer) {
            return outer;
        }
        let (mut i, mut o) = (x_hat, outer);
        for _ in 0..60 {
            let m = 0.5 * (i + o);
            if inside(m) {
                i = m;
            } else {
                o = m;
            }
        }
        i
    };
    (end(0.0), end(1.0))
}

/// A session, or the runs pooled into one by `--by`: what their traces show and the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Session {
    /// The values of the `--by` columns, or `run_index` alone for one run.
    pub key: Vec<(String, Value)>,
    /// Runs pooled.
    pub runs: usize,
    /// Steps traced.
    pub steps: u64,
    /// Interactions by type, in the order of [`EVENT_NAMES`].
    pub events: [u64; 5],
    /// Interaction types fitted (of congratulation, punishment, takeover).
    pub types: Vec<&'static str>,
    /// The opportunities and interactions the fit reads.
    pub counts: Counts,
    /// The fit.
    pub fit: Fit,
    /// Interactions per window of the session's steps (window `w`: steps `w * window + 1` to
    /// `(w + 1) * window`, summed over the pooled runs), and the steps traced in it.
    pub windows: Vec<(u64, u64)>,
    /// The interaction type and budget a simulated human fitted to it would have.
    pub interaction: &'static str,
    /// The budget of that human (the runs' largest; the interactions given where none was set).
    pub budget: u64,
}

/// Names of the interaction types in [`Session::events`].
pub const EVENT_NAMES: [&str; 5] = EVENTS;

impl Session {
    /// The interaction rate per 1,000 steps in each window (`None` for an empty window).
    pub fn rates(&self) -> Vec<Option<f64>> {
        self.windows
            .iter()
            .map(|&(k, n)| (n > 0).then(|| 1000.0 * k as f64 / n as f64))
            .collect()
    }

    /// The share of each interaction type among the interactions (`None` without any).
    pub fn shares(&self) -> [Option<f64>; 5] {
        let total: u64 = self.events.iter().sum();
        self.events
            .map(|k| (total > 0).then(|| k as f64 / total as f64))
    }

    /// The profile name the session gets in a profile file: `run-N`, or the `--by` values
    /// joined by `-`, in letters, digits and `-` only.
    pub fn profile_name(&self) -> String {
        let parts: Vec<String> = self
            .key
            .iter()
            .map(|(k, v)| {
                let v = v.to_string();
                if k == "run_index" {
                    format!("run-{v}")
                } else {
                    v
                }
            })
            .collect();
        let mut name: String = parts
            .join("-")
            .to_ascii_lowercase()
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        while name.contains("--") {
            name = name.replace("--", "-");
        }
        let name = name.trim_matches('-').to_string();
        format!("fitted-{}", if name.is_empty() { "all" } else { &name })
    }
}

/// What [`fit_humans`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct HumanFit {
    /// The dataset.
    pub source: String,
    /// The `--by` columns (empty: one session per run).
    pub by: Vec<String>,
    /// Steps per window of the interaction rate.
    pub window: u32,
    /// Sessions, in key order.
    pub sessions: Vec<Session>,
    /// Runs left out, and why: one sentence each.
    pub notes: Vec<String>,
}

/// Reads a trace table given by its own path, as written (a person's session log, or a trace
/// kept apart from its runs): `path` itself if it is a file, else `trace.parquet` in it, else the
/// `*.parquet` files of its `trace/` folder or of `path` (in name order). Unlike
/// [`dataset::read_trace`], which reads only the trace committed with a dataset's runs, it
/// trusts the caller that the files belong to the runs analysed.
pub fn read_trace_at(path: &Path) -> Result<Table, DatasetError> {
    let not_found = |detail: String| DatasetError::NotFound {
        path: path.to_path_buf(),
        table: TRACE.to_owned(),
        detail,
    };
    if path.is_file() {
        return dataset::read_parquet_file(path);
    }
    let file = path.join(format!("{TRACE}.parquet"));
    if file.is_file() {
        return dataset::read_parquet_file(&file);
    }
    let folder = if path.join(TRACE).is_dir() {
        path.join(TRACE)
    } else {
        path.to_path_buf()
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
        .map_err(|_| {
            not_found(
                "no trace.parquet, no trace/ folder and no folder of .parquet files there"
                    .to_owned(),
            )
        })?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension().is_some_and(|x| x == "parquet")
                && !p
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(not_found(format!(
            "{} holds no .parquet file",
            folder.display()
        )));
    }
    let tables = files
        .iter()
        .map(|f| dataset::read_parquet_file(f))
        .collect::<Result<Vec<_>, _>>()?;
    Table::stack(folder.display().to_string(), &tables)
}

/// One column of the trace as integers (`None` for null).
fn ints(trace: &Table, name: &str) -> Result<Vec<Option<i64>>, AnalysisError> {
    let array = cast_column(trace, name, DataType::Int64, "whole numbers")?;
    let array = array.as_primitive::<Int64Type>();
    Ok((0..array.len())
        .map(|i| (!array.is_null(i)).then(|| array.value(i)))
        .collect())
}

/// One column of the trace as text.
fn texts(trace: &Table, name: &str) -> Result<Vec<Option<String>>, AnalysisError> {
    let array = cast_column(trace, name, DataType::Utf8, "text")?;
    let array = array.as_string::<i32>();
    Ok((0..array.len())
        .map(|i| (!array.is_null(i)).then(|| array.value(i).to_owned()))
        .collect())
}

/// Column `name` of the trace cast to `to`, or an error saying it holds something else than
/// `expected`: a value that does not convert (text in a column of numbers) is refused, not
/// read as null as arrow's default cast would.
fn cast_column(
    trace: &Table,
    name: &str,
    to: DataType,
    expected: &str,
) -> Result<ArrayRef, AnalysisError> {
    let column = trace.column(name)?;
    let strict = CastOptions {
        safe: false,
        ..CastOptions::default()
    };
    cast_with_options(column.array(), &to, &strict).map_err(|_| AnalysisError::NothingToAnalyse {
        dataset: trace.source().to_owned(),
        reason: format!(
            "trace column '{name}' holds {}, not {expected}",
            column.type_name()
        ),
    })
}

/// The task's world a run starts in, from its `task` and task-parameter columns.
fn world(runs: &Table, row: usize) -> Result<Spec, String> {
    let task = match runs.column("task").map(|c| c.value(row)) {
        Ok(Value::Str(t)) => t,
        _ => return Err("it has no task".to_owned()),
    };
    let spec = env::load(&task).map_err(|e| e.to_string())?;
    let mut params = Params::default();
    for p in PARAMS.iter().filter(|p| p.task) {
        let Ok(column) = runs.column(p.name) else {
            continue;
        };
        let value = match (p.kind, column.value(row)) {
            (Kind::Choice(names), Value::Str(s)) => names
                .iter()
                .find(|n| **n == s)
                .map(|n| crate::params::Value::Choice(n)),
            (Kind::Real, v) => v.as_f64().map(crate::params::Value::Real),
            (Kind::Count, v) => v.as_f64().map(|x| crate::params::Value::Count(x as u32)),
            _ => None,
        };
        if let Some(value) = value {
            (p.set)(&mut params, &value);
        }
    }
    match env::registry::configure(&spec, &params) {
        Ok(Some(configured)) => Ok(configured),
        Ok(None) => Ok(spec),
        Err((what, reason)) => Err(format!("{what}: {reason}")),
    }
}

/// The runs of one `--by` group: its key (column and value) and each run's session.
type Group = (Vec<(String, Value)>, Vec<Session>);

/// One run's trace rows, in step order: (state, action, actor, event).
type Rows = Vec<(u64, Option<i64>, Option<i64>, String, String)>;

/// Fits the simulated human to each run of `runs` that has a trace in `trace` (one session a
/// run), or to the runs pooled by the values of `by`, with the interaction rate in windows of
/// `window` steps.
pub fn fit_humans(
    runs: &Table,
    trace: &Table,
    by: &[String],
    window: u32,
) -> Result<HumanFit, AnalysisError> {
    if window == 0 {
        return Err(AnalysisError::InvalidArgument {
            name: "--window",
            value: "0".to_owned(),
            accepted: "a window of at least 1 step",
        });
    }
    for name in by {
        runs.column(name)?;
    }
    let run_col = ints(trace, "run_index")?;
    let step_col = ints(trace, "step")?;
    let state_col = ints(trace, "state")?;
    let action_col = ints(trace, "action")?;
    let actor_col = texts(trace, "actor")?;
    let event_col = texts(trace, "human_event")?;
    let mut by_run: HashMap<i64, Rows> = HashMap::new();
    for i in 0..trace.len() {
        let (Some(run), Some(step)) = (run_col[i], step_col[i]) else {
            continue;
        };
        by_run.entry(run).or_default().push((
            step as u64,
            state_col[i],
            action_col[i],
            actor_col[i].clone().unwrap_or_default(),
            event_col[i].clone().unwrap_or_else(|| "none".to_owned()),
        ));
    }
    let run_index = runs.column("run_index")?;
    let mut notes = Vec::new();
    let mut worlds: HashMap<String, Arc<Spec>> = HashMap::new();
    let mut pooled: BTreeMap<Vec<Value>, Group> = BTreeMap::new();
    for row in 0..runs.len() {
        let Some(index) = run_index.f64_at(row).map(|x| x as i64) else {
            continue;
        };
        let Some(rows) = by_run.get_mut(&index) else {
            notes.push(format!("run {index} has no trace rows: left out"));
            continue;
        };
        if let Ok(Value::Str(s)) = runs.column("schedule").map(|c| c.value(row))
            && !s.is_empty()
        {
            notes.push(format!(
                "run {index} has a schedule of changes ({s}): left out, the fit assumes one \
                 world and one human for the whole session"
            ));
            continue;
        }
        let key_of = |name: &str| {
            runs.column(name)
                .map(|c| c.value(row))
                .unwrap_or(Value::Null)
        };
        let world_key: String = std::iter::once("task")
            .chain(PARAMS.iter().filter(|p| p.task).map(|p| p.name))
            .map(|n| key_of(n).to_string())
            .collect::<Vec<_>>()
            .join("|");
        let spec = match worlds.get(&world_key) {
            Some(s) => Arc::clone(s),
            None => match world(runs, row) {
                Ok(s) => {
                    let s = Arc::new(s);
                    worlds.insert(world_key, Arc::clone(&s));
                    s
                }
                Err(reason) => {
                    notes.push(format!(
                        "run {index}: cannot build its task ({reason}): left out"
                    ));
                    continue;
                }
            },
        };
        let Some(tables) = spec.human.as_ref() else {
            notes.push(format!(
                "run {index}: task {} defines no relevant actions, errors or takeovers: left out",
                spec.name
            ));
            continue;
        };
        rows.sort_by_key(|r| r.0);
        let interaction = match key_of("interaction") {
            Value::Str(s) => s,
            _ => String::new(),
        };
        let budget = key_of("budget").as_f64().map(|b| b as u64);
        let session = session(tables, spec.n_actions, rows, &interaction, budget, window);
        let key: Vec<(String, Value)> = if by.is_empty() {
            vec![("run_index".to_owned(), Value::Int(index))]
        } else {
            by.iter().map(|n| (n.clone(), key_of(n))).collect()
        };
        let sort_key: Vec<Value> = key.iter().map(|(_, v)| v.clone()).collect();
        pooled
            .entry(sort_key)
            .or_insert_with(|| (key, Vec::new()))
            .1
            .push(session);
    }
    if pooled.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: runs.source().to_owned(),
            reason: format!(
                "no run with a trace to fit ({}); write the runs with --trace",
                if notes.is_empty() {
                    "the runs table is empty".to_owned()
                } else {
                    notes.join("; ")
                }
            ),
        });
    }
    let sessions = pooled
        .into_values()
        .map(|(key, parts)| pool(key, parts))
        .collect();
    Ok(HumanFit {
        source: runs.source().to_owned(),
        by: by.to_vec(),
        window,
        sessions,
        notes,
    })
}

/// The counts of one run's trace `rows` (in step order) in a world whose human tables are
/// `tables`, for a human of type `interaction` with `budget` (`None` or 0 with interactions in
/// the trace: a person without a budget).
fn session(
    tables: &HumanTables,
    n_actions: usize,
    rows: &Rows,
    interaction: &str,
    budget: Option<u64>,
    window: u32,
) -> Session {
    let mut events = [0u64; 5];
    for r in rows {
        if let Some(k) = EVENTS.iter().position(|e| *e == r.4) {
            events[k] += 1;
        }
    }
    let given: u64 = events.iter().sum();
    // The types fitted: the run's, and any other a person used.
    let types: Vec<&'static str> = EVENTS[..3]
        .iter()
        .enumerate()
        .filter(|&(k, name)| *name == interaction || events[k] > 0)
        .map(|(_, name)| *name)
        .collect();
    let (congratulates, punishes, takes_over) = (
        types.contains(&"congratulation"),
        types.contains(&"punishment"),
        types.contains(&"takeover"),
    );
    let mut left = match budget {
        Some(b) if b > 0 || given == 0 => b,
        _ => u64::MAX,
    };
    let mut counts = Counts::default();
    let mut windows: Vec<(u64, u64)> = Vec::new();
    for &(step, state, action, ref actor, ref event) in rows {
        let w = (step.saturating_sub(1) / u64::from(window)) as usize;
        if windows.len() <= w {
            windows.resize(w + 1, (0, 0));
        }
        windows[w].1 += 1;
        let interacted = event != "none" && !event.is_empty();
        if interacted {
            windows[w].0 += 1;
        }
        let (Some(s), Some(a)) = (state, action) else {
            continue;
        };
        if left == 0 || actor == "reset" {
            continue;
        }
        let s = s as usize;
        if takes_over
            && tables
                .takeover_action
                .get(s)
                .is_some_and(|&p| p != NO_TAKEOVER)
        {
            counts.holds.0 += 1;
            counts.holds.1 += u64::from(event == "takeover");
        }
        if actor != "human" {
            let sa = s * n_actions + a as usize;
            for (fits, merits, name) in [
                (congratulates, tables.relevant.get(sa), "congratulation"),
                (punishes, tables.error.get(sa), "punishment"),
            ] {
                let Some(&merits) = merits.filter(|_| fits) else {
                    continue;
                };
                let slot = if merits {
                    &mut counts.merited
                } else {
                    &mut counts.other
                };
                slot.0 += 1;
                slot.1 += u64::from(event == name);
            }
        }
        if interacted {
            left -= 1;
        }
    }
    let dominant = (0..3)
        .filter(|&k| types.contains(&EVENTS[k]))
        .max_by_key(|&k| (events[k], std::cmp::Reverse(k)))
        .map_or("none", |k| EVENTS[k]);
    Session {
        key: Vec::new(),
        runs: 1,
        steps: rows.len() as u64,
        events,
        types,
        counts,
        fit: fit(&counts),
        windows,
        interaction: dominant,
        budget: match budget {
            Some(b) if b > 0 => b,
            _ => given,
        },
    }
}

/// The runs of one `--by` group as one session: counts, events and windows added, fitted again.
fn pool(key: Vec<(String, Value)>, parts: Vec<Session>) -> Session {
    let mut counts = Counts::default();
    let mut events = [0u64; 5];
    let mut windows: Vec<(u64, u64)> = Vec::new();
    let mut types: Vec<&'static str> = Vec::new();
    for p in &parts {
        counts.add(&p.counts);
        for (e, k) in events.iter_mut().zip(p.events) {
            *e += k;
        }
        if windows.len() < p.windows.len() {
            windows.resize(p.windows.len(), (0, 0));
        }
        for (w, x) in windows.iter_mut().zip(&p.windows) {
            w.0 += x.0;
            w.1 += x.1;
        }
        for t in &p.types {
            if !types.contains(t) {
                types.push(t);
            }
        }
    }
    types.sort_by_key(|t| EVENTS.iter().position(|e| e == t));
    let dominant = (0..3)
        .filter(|&k| types.contains(&EVENTS[k]))
        .max_by_key(|&k| (events[k], std::cmp::Reverse(k)))
        .map_or("none", |k| EVENTS[k]);
    Session {
        key,
        runs: parts.len(),
        steps: parts.iter().map(|p| p.steps).sum(),
        events,
        types,
        counts,
        fit: fit(&counts),
        windows,
        interaction: dominant,
        budget: parts.iter().map(|p| p.budget).max().unwrap_or(0),
    }
}

impl HumanFit {
    /// The profile file of the fitted humans: one `[profiles.NAME]` table per session, in the
    /// syntax of a sweep file's profiles, which `mbmf run --profile-file` and a sweep file's
    /// `profile_file` read. `command` is recorded in its header.
    pub fn profile_file(&self, command: &str) -> String {
        let mut text = format!(
            "# Simulated humans fitted by mbmf fit-human (SPEC 15) to {}.\n\
             # Written by: {command}\n\
             # forget_prob and error_prob are maximum-likelihood estimates; the comments give\n\
             # their 95% profile-likelihood intervals. Use: mbmf run --profile-file FILE\n\
             # --profile-name NAME, or profile_file = \"FILE\" in a sweep file.\n",
            self.source
        );
        for s in &self.sessions {
            let f = &s.fit;
            text.push_str(&format!(
                "\n[profiles.{}]\n# {} run(s), {} steps traced, {} interactions\n",
                s.profile_name(),
                s.runs,
                s.steps,
                s.events.iter().sum::<u64>()
            ));
            text.push_str(&format!("interaction = \"{}\"\n", s.interaction));
            text.push_str(&format!("budget = {}\n", s.budget.min(u64::from(u32::MAX))));
            match f.forget.value {
                Some(v) => text.push_str(&format!(
                    "forget_prob = {}  # 95% interval [{}, {}]\n",
                    round(v),
                    round(f.forget.low),
                    round(f.forget.high)
                )),
                None => text.push_str("# forget_prob: no opportunity to estimate it from\n"),
            }
            match f.error.value {
                Some(v) => text.push_str(&format!(
                    "error_prob = {}  # 95% interval [{}, {}]\n",
                    round(v),
                    round(f.error.low),
                    round(f.error.high)
                )),
                None => text.push_str(
                    "# error_prob: not identified (no feedback opportunity, or no attention)\n",
                ),
            }
        }
        text
    }
}

/// A probability to six decimals, as a TOML float.
fn round(x: f64) -> String {
    let r = (x * 1e6).round() / 1e6;
    let text = format!("{r}");
    if text.contains('.') || text.contains('e') {
        text
    } else {
        format!("{text}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn trace_columns_are_read_as_numbers_or_text_and_refused_naming_what_they_hold() {
        use dataset::Column;
        let mut t = Table::new("session.parquet");
        t.push("step", Column::floats([Some(1.0), None, Some(3.0)]));
        t.push("actor", Column::texts([Some("human"), None, Some("mf")]));
        assert_eq!(ints(&t, "step").unwrap(), [Some(1), None, Some(3)]);
        let actors = texts(&t, "actor").unwrap();
        assert_eq!(
            actors,
            [Some("human".to_owned()), None, Some("mf".to_owned())]
        );
        // Text that is no number: refused, naming the file, the column and what it holds.
        let AnalysisError::NothingToAnalyse { dataset, reason } = ints(&t, "actor").unwrap_err()
        else {
            panic!("not a refusal of the dataset");
        };
        assert_eq!(dataset, "session.parquet");
        assert!(
            reason.starts_with("trace column 'actor' holds "),
            "{reason}"
        );
        assert!(reason.ends_with(", not whole numbers"), "{reason}");
    }

    #[test]
    fn the_mle_of_an_inner_point_is_the_closed_form() {
        // p1 = a (1 - e) = 0.6, p0 = a e = 0.1: a = 0.7, e = 1/7.
        let counts = Counts {
            merited: (1000, 600),
            other: (2000, 200),
            holds: (0, 0),
        };
        let fit = fit(&counts);
        assert!(close(fit.forget.value.unwrap(), 0.3, 1e-6), "{fit:?}");
        assert!(close(fit.error.value.unwrap(), 1.0 / 7.0, 1e-6), "{fit:?}");
        assert!(fit.forget.low < 0.3 && 0.3 < fit.forget.high);
        assert!(fit.error.low < 1.0 / 7.0 && 1.0 / 7.0 < fit.error.high);
        // The interval's ends are where the profile has fallen by 1.92.
        let profile = |e: f64| max_concave(|a| counts.log_likelihood(a, e)).1;
        for end in [fit.error.low, fit.error.high] {
            assert!(close(fit.log_likelihood - profile(end), HALF_CHI2_95, 1e-6));
        }
    }

    #[test]
    fn a_human_who_never_errs_is_fitted_at_zero_with_a_one_sided_interval() {
        let counts = Counts {
            merited: (500, 450),
            other: (3000, 0),
            holds: (0, 0),
        };
        let fit = fit(&counts);
        assert!(close(fit.forget.value.unwrap(), 0.1, 1e-6), "{fit:?}");
        assert_eq!(fit.error.value.map(|e| e < 1e-9), Some(true), "{fit:?}");
        assert_eq!(fit.error.low, 0.0);
        // With 3000 clean opportunities, e above about 1.92 / (0.9 * 3000) is excluded.
        assert!(
            fit.error.high > 0.0005 && fit.error.high < 0.0015,
            "{fit:?}"
        );
    }

    #[test]
    fn takeovers_alone_give_the_forget_rate_and_leave_the_error_unidentified() {
        let counts = Counts {
            holds: (400, 300),
            ..Counts::default()
        };
        let fit = fit(&counts);
        assert!(close(fit.forget.value.unwrap(), 0.25, 1e-6), "{fit:?}");
        assert_eq!(fit.error.value, None);
        assert_eq!((fit.error.low, fit.error.high), (0.0, 1.0));
    }

    #[test]
    fn rates_above_one_in_sum_put_the_mle_on_the_boundary_of_full_attention() {
        // p1 = 0.9 and p0 = 0.3 cannot both be had with a <= 1: a = 1, e pooled.
        let counts = Counts {
            merited: (100, 90),
            other: (100, 30),
            holds: (0, 0),
        };
        let fit = fit(&counts);
        assert!(fit.forget.value.unwrap() < 1e-6, "{fit:?}");
        assert!(
            close(fit.error.value.unwrap(), 40.0 / 200.0, 1e-6),
            "{fit:?}"
        );
    }

    #[test]
    fn no_opportunity_identifies_nothing() {
        let fit = fit(&Counts::default());
        assert_eq!((fit.forget.value, fit.error.value), (None, None));
    }
}
