//! Pairwise comparison of a metric between groups of runs (`mbmf stats`): two-sided
//! Wilcoxon–Mann–Whitney tests ([`stats::mann_whitney`]: exact for small samples without ties,
//! normal approximation with tie correction otherwise), Holm's correction over all pairs, and
//! the rank-biserial correlation as effect size.

use crate::analysis::AnalysisError;
use crate::analysis::dataset::{Column, Table, Value, distinct_values, group_rows, mixed_columns};
use crate::analysis::stats::{self, Alternative, MannWhitney};

/// One group of runs: those sharing a value of the `--by` column.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// The value of the `--by` column.
    pub value: Value,
    /// Runs with a value of the metric.
    pub n: usize,
    /// Runs without one (left out of the test).
    pub missing: usize,
    /// Mean of the metric.
    pub mean: f64,
    /// Sample standard deviation (NaN below two runs).
    pub sd: f64,
    /// Median.
    pub median: f64,
    /// The metric's values, in run order.
    pub values: Vec<f64>,
}

/// The test of one pair of groups, `first` against `second` (indices into the groups).
#[derive(Debug, Clone, PartialEq)]
pub struct Pair {
    /// The first group.
    pub first: usize,
    /// The second group.
    pub second: usize,
    /// Two-sided test of the first group's values against the second's: `u` is the first
    /// group's U, `effect_size` is `P(X > Y) - P(X < Y)` (positive: the first tends higher).
    pub test: MannWhitney,
    /// Holm-adjusted p-value over all pairs.
    pub p_holm: f64,
}

/// All pairwise tests of a metric between groups.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The dataset.
    pub source: String,
    /// The grouping column.
    pub by: String,
    /// The metric tested.
    pub metric: String,
    /// Groups in ascending order of their value (groups with no value of the metric are left
    /// out and listed in `empty`).
    pub groups: Vec<Group>,
    /// Every pair `i < j` of groups.
    pub pairs: Vec<Pair>,
    /// Configuration columns other than `by` that vary within some group: the groups then mix
    /// conditions, which the caller should say (or filter with `--where`).
    pub mixed: Vec<String>,
    /// Values of `by` whose runs all lack the metric.
    pub empty: Vec<Value>,
}

/// Tests `metric` between the groups of `table` defined by the values of `by`.
pub fn compare(table: &Table, by: &str, metric: &str) -> Result<Comparison, AnalysisError> {
    let by_column = table.column(by)?;
    let values = table.numeric(metric, "--metric")?;
    let grouped = group_rows(table, &[by.to_owned()])?;
    let mut groups = Vec::new();
    let mut empty = Vec::new();
    for (key, rows) in &grouped {
        let xs: Vec<f64> = rows.iter().filter_map(|&r| values[r]).collect();
        let value = key[0].clone();
        if xs.is_empty() {
            empty.push(value);
            continue;
        }
        groups.push(Group {
            value,
            n: xs.len(),
            missing: rows.len() - xs.len(),
            mean: stats::mean(&xs),
            sd: stats::sd(&xs),
            median: median(&xs),
            values: xs,
        });
    }
    if groups.len() < 2 {
        let found = match groups.first() {
            Some(g) => format!("one group ({}) with values", g.value),
            None => "no group with values".to_owned(),
        };
        let found = format!(
            "{found} (values of {by}: {})",
            distinct_values(by_column, 20)
        );
        return Err(AnalysisError::TooFewGroups {
            dataset: table.source().to_owned(),
            by: by.to_owned(),
            metric: metric.to_owned(),
            found,
        });
    }
    let mut pairs = Vec::new();
    for i in 0..groups.len() {
        for j in (i + 1)..groups.len() {
            // Both samples are non-empty and free of NaN (nulls were dropped; NaN cannot come
            // from Parquet numbers written by mbmf, but is reported rather than assumed away).
            let test =
                stats::mann_whitney(&groups[i].values, &groups[j].values, Alternative::TwoSided)
                    .map_err(|e| AnalysisError::NothingToAnalyse {
                        dataset: table.source().to_owned(),
                        reason: format!(
                            "cannot test {by}={} against {by}={}: {e}",
                            groups[i].value, groups[j].value
                        ),
                    })?;
            pairs.push(Pair {
                first: i,
                second: j,
                test,
                p_holm: f64::NAN,
            });
        }
    }
    let adjusted = stats::holm(&pairs.iter().map(|p| p.test.p_value).collect::<Vec<_>>());
    for (pair, p) in pairs.iter_mut().zip(adjusted) {
        pair.p_holm = p;
    }
    let mixed = mixed_columns(table, by, &grouped);
    Ok(Comparison {
        source: table.source().to_owned(),
        by: by.to_owned(),
        metric: metric.to_owned(),
        groups,
        pairs,
        mixed,
        empty,
    })
}

impl Comparison {
    /// One row per group, as `mbmf stats` prints them: the `by` column (its values, of its
    /// type), `n`, `missing`, `mean`, `sd`, `median` (null where undefined).
    pub fn groups_table(&self) -> Table {
        let mut t = Table::new(format!("groups of {} by {}", self.metric, self.by));
        let values: Vec<Value> = self.groups.iter().map(|g| g.value.clone()).collect();
        t.push(self.by.clone(), column_of(&values));
        let finite = |x: f64| x.is_finite().then_some(x);
        t.push(
            "n",
            Column::uints(self.groups.iter().map(|g| Some(g.n as u64))),
        );
        t.push(
            "missing",
            Column::uints(self.groups.iter().map(|g| Some(g.missing as u64))),
        );
        t.push(
            "mean",
            Column::floats(self.groups.iter().map(|g| finite(g.mean))),
        );
        t.push(
            "sd",
            Column::floats(self.groups.iter().map(|g| finite(g.sd))),
        );
        t.push(
            "median",
            Column::floats(self.groups.iter().map(|g| finite(g.median))),
        );
        t
    }

    /// One row per pair, as `mbmf stats` prints them: `a`, `b` (the groups' values, of the `by`
    /// column's type), `u`, `p`, `p_holm`, `effect` (rank-biserial correlation), `method`.
    pub fn pairs_table(&self) -> Table {
        let mut t = Table::new(format!("pairs of {} by {}", self.metric, self.by));
        let side = |f: fn(&Pair) -> usize| -> Vec<Value> {
            self.pairs
                .iter()
                .map(|p| self.groups[f(p)].value.clone())
                .collect()
        };
        t.push("a", column_of(&side(|p| p.first)));
        t.push("b", column_of(&side(|p| p.second)));
        t.push(
            "u",
            Column::floats(self.pairs.iter().map(|p| Some(p.test.u))),
        );
        t.push(
            "p",
            Column::floats(self.pairs.iter().map(|p| Some(p.test.p_value))),
        );
        t.push(
            "p_holm",
            Column::floats(self.pairs.iter().map(|p| Some(p.p_holm))),
        );
        t.push(
            "effect",
            Column::floats(self.pairs.iter().map(|p| Some(p.test.effect_size))),
        );
        t.push(
            "method",
            Column::texts(self.pairs.iter().map(|p| Some(p.test.method.name()))),
        );
        t
    }
}

/// Values of one column (a group key) as a column of their type: the type of the first value
/// that is not null (text when all are).
fn column_of(values: &[Value]) -> Column {
    let like = match values.iter().find(|v| !matches!(v, Value::Null)) {
        Some(Value::Bool(_)) => Column::bools([]),
        Some(Value::Int(_)) => Column::ints([]),
        Some(Value::UInt(_)) => Column::uints([]),
        Some(Value::Float(_)) => Column::floats([]),
        _ => Column::texts::<&str>([]),
    };
    Column::from_values(&like, values)
}

/// Median (mean of the two middle values for an even count); NaN when empty.
fn median(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}
