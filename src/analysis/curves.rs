//! Mean curves of a dataset's series table (`mbmf plot`): per group of runs and per checkpoint
//! step, the mean of a cumulative metric over runs with its standard error, and the steps at
//! which the runs' schedules change something (SPEC 10).
//!
//! Groups and filters are taken from the runs table, which holds every parameter and the
//! `schedule` column; series rows are matched to their run by the run-identity columns both
//! tables carry (`run_index`, `master_seed`, and for sweeps `config_index`, `seed_index`). A
//! series row whose run was filtered out is left out.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

use crate::analysis::AnalysisError;
use crate::analysis::dataset::{self, Filter, RUN_IDENTITY, ReadOptions, Table, Value};
use crate::analysis::stats;
use crate::plot::{LineChart, LineColours, Series};

/// The series column a curve shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveMetric {
    /// `cum_reward`: reward so far.
    CumReward,
    /// `cum_cost`: inference cost so far (SPEC 6).
    CumCost,
    /// `p_mb_mean`: the MC's mean P(MB) over the checkpoint window.
    PMb,
}

impl CurveMetric {
    /// Names accepted by [`CurveMetric::parse`], for messages.
    pub const ACCEPTED: &'static str = "cum_reward, cum_cost or p_mb (p_mb_mean)";

    /// Parses `cum_reward`, `cum_cost`, `p_mb` or `p_mb_mean`.
    ///
    /// # Errors
    /// A message naming the value and the accepted names.
    pub fn parse(text: &str) -> Result<CurveMetric, String> {
        match text.trim() {
            "cum_reward" => Ok(CurveMetric::CumReward),
            "cum_cost" => Ok(CurveMetric::CumCost),
            "p_mb" | "p_mb_mean" => Ok(CurveMetric::PMb),
            other => Err(format!(
                "unknown metric '{other}'; accepted: {}",
                CurveMetric::ACCEPTED
            )),
        }
    }

    /// The series column holding the metric.
    pub fn column(self) -> &'static str {
        match self {
            CurveMetric::CumReward => "cum_reward",
            CurveMetric::CumCost => "cum_cost",
            CurveMetric::PMb => "p_mb_mean",
        }
    }

    /// Axis text.
    pub fn axis_label(self) -> &'static str {
        match self {
            CurveMetric::CumReward => "cumulative reward",
            CurveMetric::CumCost => "cumulative inference cost (ops)",
            CurveMetric::PMb => "P(MB), mean over the checkpoint window",
        }
    }
}

/// One group's mean curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The group's value of the `--by` column, as text (`(none)` for an empty text).
    pub label: String,
    /// That value as a number, when the `--by` column is numeric.
    pub value: Option<f64>,
    /// Checkpoint steps, ascending.
    pub steps: Vec<u32>,
    /// Mean over runs at each step.
    pub mean: Vec<f64>,
    /// Standard error of that mean (sample sd / sqrt(n); 0 for a single run).
    pub sem: Vec<f64>,
    /// Number of runs with a value at each step (null values, e.g. `p_mb_mean` without a
    /// decision, are left out).
    pub n: Vec<usize>,
}

/// The curves of a dataset, ready to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct Curves {
    /// What was read (for messages and titles).
    pub source: String,
    /// The grouping column.
    pub by: String,
    /// The metric.
    pub metric: CurveMetric,
    /// One curve per group, in ascending order of the group value.
    pub curves: Vec<Curve>,
    /// Every step at which some selected run's schedule has an event, ascending.
    pub change_steps: Vec<u32>,
    /// Configuration columns other than `by` that vary within a curve's runs: a curve then
    /// averages conditions, which `mbmf plot` says (as `mbmf stats` does).
    pub mixed: Vec<String>,
}

/// One observation: a run's value of the metric at a checkpoint, with the run's group.
#[derive(Debug, Clone, PartialEq)]
pub struct Point<'a> {
    /// Group label.
    pub group: &'a str,
    /// Checkpoint step.
    pub step: u32,
    /// The value (`None` when null).
    pub value: Option<f64>,
}

/// Mean and standard error per group and step. Groups come out in the order of `order` (labels
/// not in `order` are left out); a step with no value in a group is left out of its curve.
pub fn mean_curves(points: &[Point<'_>], order: &[String]) -> Vec<Curve> {
    let mut acc: HashMap<&str, BTreeMap<u32, Vec<f64>>> = HashMap::new();
    for p in points {
        if let Some(v) = p.value {
            acc.entry(p.group)
                .or_default()
                .entry(p.step)
                .or_default()
                .push(v);
        }
    }
    order
        .iter()
        .filter_map(|label| {
            let steps = acc.get(label.as_str())?;
            let mut curve = Curve {
                label: label.clone(),
                value: None,
                steps: Vec::with_capacity(steps.len()),
                mean: Vec::with_capacity(steps.len()),
                sem: Vec::with_capacity(steps.len()),
                n: Vec::with_capacity(steps.len()),
            };
            for (&step, values) in steps {
                let mean = stats::mean(values);
                // A single run has no spread to estimate: its band is drawn with zero width.
                let sem = if values.len() < 2 {
                    0.0
                } else {
                    stats::sem(values)
                };
                curve.steps.push(step);
                curve.mean.push(mean);
                curve.sem.push(sem);
                curve.n.push(values.len());
            }
            Some(curve)
        })
        .collect()
}

/// The steps of every event of a canonical schedule (`1601:goal=34;1601:world=json:P`), in
/// order; parts that do not start with a step are ignored (the schedule was validated when
/// the run was made).
pub fn schedule_steps(schedule: &str) -> Vec<u32> {
    schedule
        .split(';')
        .filter_map(|event| event.split_once(':')?.0.trim().parse().ok())
        .collect()
}

/// Reads the dataset at `path` (as `options` says) and computes the curves of `metric` grouped
/// by `by`, over the runs that pass `filters`; also returns the reader's warnings, each once.
///
/// # Errors
/// A dataset that cannot be read, a missing or non-numeric column, a filter that matches
/// nothing, or series rows that match no selected run.
pub fn read_curves(
    path: &Path,
    by: &str,
    metric: CurveMetric,
    filters: &[Filter],
    options: &ReadOptions,
) -> Result<(Curves, Vec<String>), AnalysisError> {
    let runs = dataset::read_table(path, "runs", options)?;
    let mut warnings = runs.warnings;
    let selected = Filter::apply_all(&runs.table, filters)?;
    let series = dataset::read_table(path, "series", options)?;
    for w in series.warnings {
        if !warnings.contains(&w) {
            warnings.push(w);
        }
    }
    Ok((curves_of(&selected, &series.table, by, metric)?, warnings))
}

/// [`read_curves`] on tables already read (and `runs` already filtered).
///
/// # Errors
/// As [`read_curves`].
pub fn curves_of(
    runs: &Table,
    series: &Table,
    by: &str,
    metric: CurveMetric,
) -> Result<Curves, AnalysisError> {
    let by_column = runs.column(by)?;
    let identity: Vec<String> = RUN_IDENTITY
        .iter()
        .filter(|c| runs.has(c) && series.has(c))
        .map(|c| (*c).to_owned())
        .collect();
    if identity.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: series.source().to_owned(),
            reason: format!(
                "the runs and series tables share none of the run-identity columns ({}); give \
                 a dataset written by mbmf run or mbmf sweep",
                RUN_IDENTITY.join(", ")
            ),
        });
    }
    let label_of = |v: Value| match v {
        Value::Str(s) if s.is_empty() => "(none)".to_owned(),
        v => v.to_string(),
    };
    let mut groups: BTreeMap<Value, String> = BTreeMap::new();
    let mut run_group: BTreeMap<Vec<Value>, String> = BTreeMap::new();
    for row in 0..runs.len() {
        let value = by_column.value(row);
        let label = groups
            .entry(value.clone())
            .or_insert_with(|| label_of(value))
            .clone();
        run_group.insert(key(runs, &identity, row)?, label);
    }
    let mut change_steps = BTreeSet::new();
    if runs.has("schedule") {
        let schedule = runs.column("schedule")?;
        for row in 0..runs.len() {
            if let Value::Str(s) = schedule.value(row) {
                change_steps.extend(schedule_steps(&s));
            }
        }
    } else if runs.has("first_change_step") {
        let first = runs.numeric("first_change_step", "change marks")?;
        change_steps.extend(first.into_iter().flatten().map(|t| t as u32));
    }

    let steps = series.numeric("step", "the x axis")?;
    let values = series.numeric(metric.column(), "--metric")?;
    let mut points = Vec::with_capacity(series.len());
    for row in 0..series.len() {
        let Some(group) = run_group.get(&key(series, &identity, row)?) else {
            continue;
        };
        let Some(step) = steps[row] else { continue };
        points.push(Point {
            group,
            step: step as u32,
            value: values[row],
        });
    }
    let order: Vec<String> = groups.values().cloned().collect();
    let mut curves = mean_curves(&points, &order);
    for curve in &mut curves {
        curve.value = groups
            .iter()
            .find(|(_, label)| **label == curve.label)
            .and_then(|(value, _)| value.as_f64());
    }
    if curves.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: series.source().to_owned(),
            reason: format!(
                "no series row with a value of {} belongs to the selected runs",
                metric.column()
            ),
        });
    }
    let mixed = dataset::mixed_columns(runs, by, &dataset::group_rows(runs, &[by.to_owned()])?);
    Ok(Curves {
        source: series.source().to_owned(),
        by: by.to_owned(),
        metric,
        curves,
        change_steps: change_steps.into_iter().collect(),
        mixed,
    })
}

fn key(table: &Table, identity: &[String], row: usize) -> Result<Vec<Value>, AnalysisError> {
    identity
        .iter()
        .map(|c| Ok(table.column(c)?.value(row)))
        .collect()
}

impl Curves {
    /// How to colour the curves: by value on a colour scale when the groups are numbers (a
    /// swept parameter), by label otherwise.
    pub fn colours(&self) -> LineColours {
        let values: Option<Vec<f64>> = self.curves.iter().map(|c| c.value).collect();
        match values {
            Some(values) => LineColours::Scale {
                title: self.by.clone(),
                values,
            },
            None => LineColours::Labels,
        }
    }

    /// A line chart of the curves: mean with a standard-error band per group, a vertical mark
    /// at each change step. `title` goes above the plot.
    pub fn chart(&self, title: &str) -> LineChart {
        LineChart {
            title: title.to_owned(),
            x_label: "experiment step".to_owned(),
            y_label: self.metric.axis_label().to_owned(),
            series: self
                .curves
                .iter()
                .map(|c| Series {
                    label: format!("{}={}", self.by, c.label),
                    x: c.steps.iter().map(|&s| f64::from(s)).collect(),
                    y: c.mean.clone(),
                    band: Some(c.sem.clone()),
                })
                .map(|mut s| {
                    // A controller's name alone keeps its fixed colour.
                    if self.by == "controller" {
                        s.label = s.label.trim_start_matches("controller=").to_owned();
                    }
                    s
                })
                .collect(),
            log_x: false,
            log_y: false,
            x_marks: self.change_steps.iter().map(|&s| f64::from(s)).collect(),
        }
    }
}

/// The figure's file name (no extension): `METRIC-by-BY`, then each filter as
/// `-COLUMN-VALUE` with characters other than letters, digits, `.`, `_` and `-` replaced by
/// `_` and then a short hash of the whole added; a name longer than 96 characters is cut and
/// ends with a hash of the whole, so distinct filters never share a file.
pub fn figure_name(metric: CurveMetric, by: &str, filters: &[Filter]) -> String {
    safe_name(&format!("{}-by-{by}", metric.column()), filters)
}

/// The file name (no extension) of what an analysis writes: `stem`, then `-by-COLUMNS` when it
/// groups by columns, then the filters as in [`figure_name`]. Analyses of other groups or other
/// runs never share a file, so one never silently replaces another's results.
pub fn output_name(stem: &str, by: &[String], filters: &[Filter]) -> String {
    if by.is_empty() {
        safe_name(stem, filters)
    } else {
        safe_name(&format!("{stem}-by-{}", by.join("-")), filters)
    }
}

/// `stem`, then each filter as `-COLUMN-VALUE`, made safe for a file name (see
/// [`figure_name`]).
fn safe_name(stem: &str, filters: &[Filter]) -> String {
    let mut name = stem.to_owned();
    for f in filters {
        name.push_str(&format!("-{}-{}", f.column, f.value));
    }
    let mut clean: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    if clean.len() > 96 {
        clean.truncate(80);
        clean.push_str(&format!("-{hash:016x}"));
    } else if clean != name {
        // Replaced characters could make two names one (`my grid` and `my_grid`): a hash of
        // the whole keeps them apart.
        clean.push_str(&format!("-{:08x}", hash >> 32));
    }
    clean
}

/// The figure's title: the metric by the grouping column, and the filters.
pub fn title(metric: CurveMetric, by: &str, filters: &[Filter]) -> String {
    let mut title = format!("{} by {by}", metric.axis_label());
    if let Some((first, _)) = title.split_once(',') {
        title = format!("{first} by {by}");
    }
    with_filters(title, filters)
}

/// `title`, then the filters in parentheses (long schedule paths shortened to their file).
fn with_filters(mut title: String, filters: &[Filter]) -> String {
    if !filters.is_empty() {
        let texts: Vec<String> = filters
            .iter()
            .map(|f| {
                // Paths in schedules are long; their last component says enough.
                let value = f
                    .value
                    .split(';')
                    .map(|e| match e.rsplit_once('/') {
                        Some((head, file)) => match head.split_once("json:") {
                            Some((pre, _)) => format!("{pre}json:{file}"),
                            None => file.to_owned(),
                        },
                        None => e.to_owned(),
                    })
                    .collect::<Vec<_>>()
                    .join(";");
                format!("{}={value}", f.column)
            })
            .collect();
        title.push_str(&format!(" ({})", texts.join(", ")));
    }
    title
}

// ---------------------------------------------------------------------------------------------
// Response curves: a runs-table metric against a swept parameter (`mbmf plot --x`)

/// One group's response curve: at each value of the swept parameter, the mean of the metric
/// over the group's runs with the half-width of its 95% Student-t confidence interval.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// The group's value of the `--by` column as text (`all runs` without `--by`).
    pub label: String,
    /// That value as a number, when the `--by` column is numeric.
    pub value: Option<f64>,
    /// The swept parameter's values, ascending.
    pub x: Vec<f64>,
    /// Mean of the metric over the runs at each `x`.
    pub mean: Vec<f64>,
    /// Half-width of the 95% Student-t confidence interval of that mean (NaN below two runs).
    pub ci95: Vec<f64>,
    /// Runs with a value of the metric at each `x`.
    pub n: Vec<usize>,
}

/// The response curves of a dataset, ready to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct Responses {
    /// What was read.
    pub source: String,
    /// The swept parameter (x axis).
    pub x: String,
    /// The runs-table metric (y axis).
    pub metric: String,
    /// The grouping column, if any.
    pub by: Option<String>,
    /// One curve per group, in ascending order of the group value.
    pub curves: Vec<Response>,
}

/// The numeric column `name` of the runs, for `flag`; a column holding something else is
/// refused with the numeric columns and the closest of them.
fn numeric_for(table: &Table, name: &str, flag: &str) -> Result<Vec<Option<f64>>, AnalysisError> {
    let column = table.column(name)?;
    if column.is_numeric() {
        return Ok(table.numeric(name, flag)?);
    }
    let numeric = table.numeric_names();
    Err(AnalysisError::NothingToAnalyse {
        dataset: table.source().to_owned(),
        reason: format!(
            "column '{name}' holds {}, but {flag} needs a numeric column of the runs table;              {}numeric columns: {}",
            column.type_name(),
            crate::suggest::hint(name, numeric.iter().map(String::as_str)),
            numeric.join(", ")
        ),
    })
}

/// Mean and 95% interval of `metric` at each value of `x`, per group of `by`, over the runs of
/// `runs` (already filtered). Runs without a value of `x` or of the metric are left out.
///
/// # Errors
/// A missing column, an `x` or metric column that is not numeric, or no run with both values.
pub fn response_curves(
    runs: &Table,
    x: &str,
    metric: &str,
    by: Option<&str>,
) -> Result<Responses, AnalysisError> {
    let xs = numeric_for(runs, x, "--x")?;
    let ys = numeric_for(runs, metric, "--metric")?;
    let by_column = by.map(|b| runs.column(b)).transpose()?;
    let mut groups: BTreeMap<Value, BTreeMap<u64, Vec<f64>>> = BTreeMap::new();
    for row in 0..runs.len() {
        let (Some(xv), Some(yv)) = (xs[row], ys[row]) else {
            continue;
        };
        let group = by_column.map_or(Value::Null, |c| c.value(row));
        // Keyed by the bits of a total-order-preserving map of x, so equal x values meet.
        groups
            .entry(group)
            .or_default()
            .entry(order_key(xv))
            .or_default()
            .push(yv);
    }
    let curves: Vec<Response> = groups
        .into_iter()
        .map(|(group, points)| {
            let mut curve = Response {
                label: match (&group, by) {
                    (_, None) => "all runs".to_owned(),
                    (Value::Str(s), _) if s.is_empty() => "(none)".to_owned(),
                    (v, _) => v.to_string(),
                },
                value: group.as_f64(),
                x: Vec::with_capacity(points.len()),
                mean: Vec::with_capacity(points.len()),
                ci95: Vec::with_capacity(points.len()),
                n: Vec::with_capacity(points.len()),
            };
            for (key, values) in points {
                curve.x.push(from_order_key(key));
                curve.mean.push(stats::mean(&values));
                curve.ci95.push(stats::ci95_half_width(&values));
                curve.n.push(values.len());
            }
            curve
        })
        .collect();
    if curves.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: runs.source().to_owned(),
            reason: format!("no run has a value of both {x} and {metric}"),
        });
    }
    Ok(Responses {
        source: runs.source().to_owned(),
        x: x.to_owned(),
        metric: metric.to_owned(),
        by: by.map(str::to_owned),
        curves,
    })
}

/// A key that sorts as `v` does (`f64::total_cmp`), and its inverse.
fn order_key(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

fn from_order_key(key: u64) -> f64 {
    f64::from_bits(if key >> 63 == 1 {
        key & !(1 << 63)
    } else {
        !key
    })
}

impl Responses {
    /// Whether the groups are values of a number (drawn on a colour scale).
    pub fn numeric_groups(&self) -> bool {
        self.by.is_some() && self.curves.iter().all(|c| c.value.is_some())
    }

    /// A line chart: per group, the mean against the swept parameter with its 95% band (no
    /// band where a point has a single run), and how to colour the groups: by their value on a
    /// colour scale when the groups are numbers, by label otherwise.
    pub fn chart(&self, title: &str) -> (LineChart, LineColours) {
        let by = self.by.as_deref().unwrap_or_default();
        let series = self
            .curves
            .iter()
            .map(|c| Series {
                // A controller's name alone keeps its fixed colour.
                label: match self.by.as_deref() {
                    None | Some("controller") => c.label.clone(),
                    Some(by) => format!("{by}={}", c.label),
                },
                x: c.x.clone(),
                y: c.mean.clone(),
                band: Some(
                    c.ci95
                        .iter()
                        .map(|h| if h.is_finite() { *h } else { 0.0 })
                        .collect(),
                ),
            })
            .collect();
        let colours = if self.numeric_groups() {
            LineColours::Scale {
                title: by.to_owned(),
                values: self.curves.iter().filter_map(|c| c.value).collect(),
            }
        } else {
            LineColours::Labels
        };
        let chart = LineChart {
            title: title.to_owned(),
            x_label: self.x.clone(),
            y_label: format!("{} (mean, 95% CI)", self.metric),
            series,
            log_x: false,
            log_y: false,
            x_marks: Vec::new(),
        };
        (chart, colours)
    }
}

/// The response figure's file name (no extension): `METRIC-vs-X[-by-BY]`, then the filters as
/// in [`figure_name`].
pub fn response_name(metric: &str, x: &str, by: Option<&str>, filters: &[Filter]) -> String {
    let by = by.map(|b| format!("-by-{b}")).unwrap_or_default();
    safe_name(&format!("{metric}-vs-{x}{by}"), filters)
}

/// The response figure's title: `METRIC against X[, by BY]`, then the filters as in [`title`].
pub fn response_title(metric: &str, x: &str, by: Option<&str>, filters: &[Filter]) -> String {
    let by = by.map(|b| format!(", by {b}")).unwrap_or_default();
    with_filters(format!("{metric} against {x}{by}"), filters)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(group: &str, step: u32, value: Option<f64>) -> Point<'_> {
        Point { group, step, value }
    }

    #[test]
    fn means_and_standard_errors_match_hand_values() {
        // Group a, step 10: 1, 2, 3 -> mean 2, sd 1, se 1/sqrt(3); step 20: 4, 8 -> mean 6,
        // sd sqrt(8), se 2. Group b has a single run: se 0; a null is left out.
        let points = [
            p("a", 10, Some(1.0)),
            p("a", 20, Some(4.0)),
            p("b", 10, Some(5.0)),
            p("a", 10, Some(2.0)),
            p("a", 20, Some(8.0)),
            p("a", 10, Some(3.0)),
            p("b", 20, None),
        ];
        let curves = mean_curves(&points, &["b".to_owned(), "a".to_owned()]);
        assert_eq!(curves.len(), 2);
        let (b, a) = (&curves[0], &curves[1]);
        assert_eq!(b.label, "b");
        assert_eq!(b.steps, [10]);
        assert_eq!(b.mean, [5.0]);
        assert_eq!(b.sem, [0.0]);
        assert_eq!(a.steps, [10, 20]);
        assert_eq!(a.mean, [2.0, 6.0]);
        assert_eq!(a.n, [3, 2]);
        assert!((a.sem[0] - 1.0 / 3f64.sqrt()).abs() < 1e-15, "{}", a.sem[0]);
        assert!((a.sem[1] - 2.0).abs() < 1e-15, "{}", a.sem[1]);
    }

    #[test]
    fn series_rows_join_their_runs_groups_and_change_steps() {
        use crate::analysis::dataset::Column;
        let text = |v: &[&str]| Column::texts(v.iter().map(|s| Some(*s)));
        let mut runs = Table::new("runs");
        runs.push("run_index", Column::uints([Some(0), Some(1), Some(2)]));
        runs.push("master_seed", Column::uints([Some(7), Some(7), Some(7)]));
        runs.push("controller", text(&["mb", "mf", "mb"]));
        runs.push(
            "schedule",
            text(&["", "1601:goal=34", "800:boxes=brg;1601:goal=3"]),
        );
        let mut series = Table::new("series");
        // Run 1 (mf) at steps 100, 200; runs 0 and 2 (mb) at step 100 only; a row of run 9,
        // which is not among the runs, is left out.
        series.push(
            "run_index",
            Column::uints([Some(1), Some(0), Some(1), Some(2), Some(9)]),
        );
        series.push("master_seed", Column::uints([Some(7); 5]));
        series.push(
            "step",
            Column::uints([Some(100), Some(100), Some(200), Some(100), Some(100)]),
        );
        series.push(
            "cum_reward",
            Column::floats([Some(1.0), Some(2.0), Some(3.0), Some(6.0), Some(100.0)]),
        );
        let curves = curves_of(&runs, &series, "controller", CurveMetric::CumReward).unwrap();
        assert_eq!(curves.change_steps, [800, 1601]);
        assert_eq!(curves.curves.len(), 2);
        let (mb, mf) = (&curves.curves[0], &curves.curves[1]);
        assert_eq!(
            (mb.label.as_str(), &mb.steps[..], &mb.mean[..]),
            ("mb", &[100][..], &[4.0][..])
        );
        // 2 and 6: sd sqrt(8), se sqrt(8) / sqrt(2) = 2.
        assert!((mb.sem[0] - 2.0).abs() < 1e-12, "{}", mb.sem[0]);
        assert_eq!(
            (&mf.steps[..], &mf.mean[..]),
            (&[100, 200][..], &[1.0, 3.0][..])
        );
        let chart = curves.chart("t");
        assert_eq!(
            chart.series[0].label, "mb",
            "a controller keeps its bare name"
        );
        assert_eq!(chart.x_marks, [800.0, 1601.0]);
        let err = curves_of(&runs, &series, "controller", CurveMetric::PMb).unwrap_err();
        assert!(err.to_string().contains("p_mb_mean"), "{err}");
    }

    #[test]
    fn groups_outside_the_order_are_left_out() {
        let points = [p("a", 1, Some(1.0)), p("z", 1, Some(9.0))];
        let curves = mean_curves(&points, &["a".to_owned(), "missing".to_owned()]);
        assert_eq!(curves.len(), 1);
        assert_eq!(curves[0].label, "a");
    }

    #[test]
    fn schedule_steps_are_read_from_every_event() {
        assert_eq!(
            schedule_steps("1601:goal=34;1601:world=json:a:b.json;2400:delete=20-21"),
            [1601, 1601, 2400]
        );
        assert!(schedule_steps("").is_empty());
    }

    #[test]
    fn figure_names_are_safe_and_distinct_and_titles_shorten_paths() {
        let f = |t: &str| Filter::parse(t).unwrap();
        assert_eq!(
            figure_name(CurveMetric::CumReward, "controller", &[f("budget=300")]),
            "cum_reward-by-controller-budget-300"
        );
        let long = |goal: &str| {
            figure_name(
                CurveMetric::CumCost,
                "controller",
                &[f(&format!(
                    "schedule=1601:goal={goal};1601:world=json:../../shared/data/navworld/realisticNavWorld_newGoal.json"
                ))],
            )
        };
        // Values that clean to the same text keep distinct names.
        let task = |t: &str| output_name("pareto", &[], &[f(&format!("task=json:w/{t}/g.json"))]);
        assert_ne!(task("my grid"), task("my_grid"));
        assert!(task("my grid").starts_with("pareto-task-json_w_my_grid_g.json-"));
        assert_eq!(
            output_name("pareto", &["a".into(), "b".into()], &[]),
            "pareto-by-a-b"
        );
        assert!(long("34").len() <= 97, "{}", long("34"));
        assert!(!long("34").contains('/') && !long("34").contains(':'));
        assert_ne!(long("34"), long("35"));
        assert_eq!(
            title(
                CurveMetric::CumReward,
                "controller",
                &[f("schedule=1601:goal=34;1601:world=json:../a/b/new.json")]
            ),
            "cumulative reward by controller (schedule=1601:goal=34;1601:world=json:new.json)"
        );
    }

    #[test]
    fn metrics_parse_their_column_names_and_refuse_others() {
        assert_eq!(CurveMetric::parse("p_mb"), Ok(CurveMetric::PMb));
        assert_eq!(
            CurveMetric::parse("p_mb_mean").unwrap().column(),
            "p_mb_mean"
        );
        assert_eq!(CurveMetric::parse("cum_cost"), Ok(CurveMetric::CumCost));
        let e = CurveMetric::parse("reward").unwrap_err();
        assert!(e.contains("'reward'") && e.contains("cum_reward"), "{e}");
    }

    /// Runs of a tiny sweep: kappa (x), a reward (metric) and the human (group).
    fn sweep_runs() -> Table {
        use crate::analysis::dataset::Column;
        // Group "none": x=1 -> 1, 2, 3; x=2 -> 4, 8; x=3 -> 5 (one run). Group "takeover":
        // x=1 -> 10, 10 (no spread). A run without a reward is left out.
        let rows: [(&str, f64, Option<f64>); 9] = [
            ("none", 1.0, Some(1.0)),
            ("none", 2.0, Some(4.0)),
            ("takeover", 1.0, Some(10.0)),
            ("none", 1.0, Some(2.0)),
            ("none", 3.0, Some(5.0)),
            ("none", 2.0, Some(8.0)),
            ("none", 1.0, Some(3.0)),
            ("takeover", 1.0, Some(10.0)),
            ("none", 3.0, None),
        ];
        let mut runs = Table::new("sweep");
        runs.push("interaction", Column::texts(rows.iter().map(|r| Some(r.0))));
        runs.push(
            "kappa_coeff",
            Column::floats(rows.iter().map(|r| Some(r.1))),
        );
        runs.push("total_reward", Column::floats(rows.iter().map(|r| r.2)));
        runs
    }

    #[test]
    fn response_curves_give_the_mean_and_t_interval_at_each_swept_value() {
        let r = response_curves(
            &sweep_runs(),
            "kappa_coeff",
            "total_reward",
            Some("interaction"),
        )
        .unwrap();
        assert_eq!(r.curves.len(), 2);
        let (none, takeover) = (&r.curves[0], &r.curves[1]);
        assert_eq!(none.label, "none");
        assert_eq!(none.x, [1.0, 2.0, 3.0]);
        assert_eq!(none.mean, [2.0, 6.0, 5.0]);
        assert_eq!(none.n, [3, 2, 1]);
        // x=1: sd 1, t(0.975, 2) = 0.95 / sqrt(2 * 0.975 * 0.025) (Student's t with two
        // degrees of freedom in closed form), half-width t / sqrt(3).
        let t2 = 0.95 / (2.0f64 * 0.975 * 0.025).sqrt();
        let want = t2 / 3f64.sqrt();
        assert!(
            (none.ci95[0] - want).abs() < 1e-9 * want,
            "{} vs {want}",
            none.ci95[0]
        );
        // x=2: sd sqrt(8), sem 2, t(0.975, 1) = tan(0.475 pi) (the Cauchy quantile).
        let want = 2.0 * (0.475 * std::f64::consts::PI).tan();
        assert!(
            (none.ci95[1] - want).abs() < 1e-9 * want,
            "{} vs {want}",
            none.ci95[1]
        );
        assert!(none.ci95[2].is_nan(), "no interval from one run");
        assert_eq!(
            (takeover.x.as_slice(), takeover.mean.as_slice()),
            (&[1.0][..], &[10.0][..])
        );
        assert_eq!(takeover.ci95, [0.0]);

        // The chart draws the band (0 where undefined) and colours text groups by label.
        let (chart, colours) = r.chart("t");
        assert_eq!(chart.series[0].label, "interaction=none");
        assert_eq!(chart.series[0].band.as_ref().unwrap()[2], 0.0);
        assert_eq!(chart.x_label, "kappa_coeff");
        assert_eq!(colours, LineColours::Labels);

        // Without --by: one curve of all runs; grouped by a number: a colour scale.
        let all = response_curves(&sweep_runs(), "kappa_coeff", "total_reward", None).unwrap();
        assert_eq!(all.curves.len(), 1);
        assert_eq!(all.curves[0].mean[0], 26.0 / 5.0, "1, 2, 3, 10, 10");
        let by_number = response_curves(
            &sweep_runs(),
            "total_reward",
            "kappa_coeff",
            Some("kappa_coeff"),
        )
        .unwrap();
        assert!(matches!(by_number.chart("t").1, LineColours::Scale { .. }));
    }

    #[test]
    fn response_curves_refuse_a_column_that_is_not_numeric_naming_the_numeric_ones() {
        let e = response_curves(&sweep_runs(), "interaction", "total_reward", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("column 'interaction' holds text, but --x needs a numeric column")
                && e.contains("numeric columns: kappa_coeff, total_reward"),
            "{e}"
        );
        let e = response_curves(&sweep_runs(), "kappa_coeff", "interaction", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--metric"), "{e}");
        let e = response_curves(&sweep_runs(), "kappa", "total_reward", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no column 'kappa' (did you mean 'kappa_coeff'?)"),
            "{e}"
        );
    }

    #[test]
    fn order_keys_sort_as_the_numbers_and_read_back() {
        let values = [-2.5, -0.0, 0.0, 1e-300, 3.0, f64::INFINITY];
        let keys: Vec<u64> = values.iter().map(|&v| order_key(v)).collect();
        assert!(keys.windows(2).all(|w| w[0] < w[1]), "{keys:?}");
        for v in values {
            assert_eq!(from_order_key(order_key(v)).to_bits(), v.to_bits());
        }
    }
}
