//! The two-step task's stay analysis (`mbmf stay`, SPEC 13): per group of runs, the four stay
//! probabilities (after a rewarded or unrewarded previous trial whose transition was common or
//! rare) and the reward and interaction effects, each as a mean over runs with a 95%
//! confidence interval and a standard error, and between every two groups a two-sided
//! Wilcoxon–Mann–Whitney test per column, Holm-corrected over the pairs of that column (as
//! `mbmf stats` does for one metric).

use crate::analysis::AnalysisError;
use crate::analysis::dataset::{Table, Value, group_rows, mixed_columns};
use crate::analysis::stats::{self, Alternative, MannWhitney};

/// The stay columns a `twostep` run writes, in the order they are reported: the four
/// probabilities, then the two effects.
pub const COLUMNS: [&str; 6] = [
    "stay_rc",
    "stay_rr",
    "stay_uc",
    "stay_ur",
    "stay_reward_effect",
    "stay_interaction",
];

/// One column's summary over a group's runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Runs with a value (a run whose previous trials never had this kind has none).
    pub n: usize,
    /// Mean over those runs (NaN when none).
    pub mean: f64,
    /// Half-width of the 95% confidence interval of the mean (Student's t; NaN below 2 runs).
    pub ci95: f64,
    /// Standard error of the mean (NaN below 2 runs): the figure's error bars.
    pub sem: f64,
    /// The values, in run order.
    pub values: Vec<f64>,
}

/// The runs sharing a value of the `--by` column.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// The value of the `--by` column.
    pub value: Value,
    /// Runs in the group.
    pub runs: usize,
    /// One summary per column of [`COLUMNS`].
    pub columns: Vec<Summary>,
}

/// The test of one column between two groups.
#[derive(Debug, Clone, PartialEq)]
pub struct Pair {
    /// The column, an index into [`COLUMNS`].
    pub column: usize,
    /// The first group (index into the groups).
    pub first: usize,
    /// The second group.
    pub second: usize,
    /// Two-sided test of the first group's values against the second's.
    pub test: MannWhitney,
    /// Holm-adjusted p-value over the pairs of this column.
    pub p_holm: f64,
}

/// The stay analysis of a dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct Stay {
    /// The dataset.
    pub source: String,
    /// The grouping column.
    pub by: String,
    /// Groups in ascending order of their value.
    pub groups: Vec<Group>,
    /// Per column, every pair of groups that both have values of it.
    pub pairs: Vec<Pair>,
    /// Configuration columns other than `by` that vary within some group.
    pub mixed: Vec<String>,
}

/// Summarises `values`.
fn summary(values: Vec<f64>) -> Summary {
    Summary {
        n: values.len(),
        mean: stats::mean(&values),
        ci95: stats::ci95_half_width(&values),
        sem: stats::sem(&values),
        values,
    }
}

/// The stay analysis of the runs of `table`, grouped by the values of `by`. Refused, with a
/// message saying so, when the runs carry no stay column or no stay value (not `twostep`
/// runs, or runs too short for two trials).
pub fn stay(table: &Table, by: &str) -> Result<Stay, AnalysisError> {
    let dataset = table.source().to_owned();
    let tasks = table
        .column("task")
        .map(|c| crate::analysis::dataset::distinct_values(c, 5))
        .unwrap_or_else(|_| "unknown".to_owned());
    let not_twostep = |why: &str| AnalysisError::NothingToAnalyse {
        dataset: dataset.clone(),
        reason: format!(
            "{why} (task: {tasks}); the stay analysis needs runs of the two-step task: \
             mbmf run --task twostep"
        ),
    };
    if !table.has(COLUMNS[0]) {
        return Err(not_twostep("the runs have no stay columns"));
    }
    table.column(by)?;
    let columns: Vec<Vec<Option<f64>>> = COLUMNS
        .iter()
        .map(|c| table.numeric(c, "the stay analysis"))
        .collect::<Result<_, _>>()?;
    if columns
        .iter()
        .take(4)
        .all(|c| c.iter().all(Option::is_none))
    {
        return Err(not_twostep("no run has a stay probability"));
    }
    let grouped = group_rows(table, &[by.to_owned()])?;
    let groups: Vec<Group> = grouped
        .iter()
        .map(|(key, rows)| Group {
            value: key[0].clone(),
            runs: rows.len(),
            columns: columns
                .iter()
                .map(|c| summary(rows.iter().filter_map(|&r| c[r]).collect()))
                .collect(),
        })
        .collect();
    let mut pairs = Vec::new();
    for (column, name) in COLUMNS.iter().enumerate() {
        let mut these = Vec::new();
        for i in 0..groups.len() {
            for j in (i + 1)..groups.len() {
                let (x, y) = (
                    &groups[i].columns[column].values,
                    &groups[j].columns[column].values,
                );
                if x.is_empty() || y.is_empty() {
                    continue;
                }
                let test = stats::mann_whitney(x, y, Alternative::TwoSided).map_err(|e| {
                    AnalysisError::NothingToAnalyse {
                        dataset: dataset.clone(),
                        reason: format!("cannot test {name}: {e}"),
                    }
                })?;
                these.push(Pair {
                    column,
                    first: i,
                    second: j,
                    test,
                    p_holm: f64::NAN,
                });
            }
        }
        let adjusted = stats::holm(&these.iter().map(|p| p.test.p_value).collect::<Vec<_>>());
        for (pair, p) in these.iter_mut().zip(adjusted) {
            pair.p_holm = p;
        }
        pairs.extend(these);
    }
    let mixed = mixed_columns(table, by, &grouped);
    Ok(Stay {
        source: dataset,
        by: by.to_owned(),
        groups,
        pairs,
        mixed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::dataset::Column;

    fn table(with_stays: bool) -> Table {
        let mut t = Table::new("t");
        t.push(
            "controller",
            Column::texts(["mf", "mf", "mf", "mb", "mb", "mb"].map(Some)),
        );
        t.push("task", Column::texts(["twostep"; 6].map(Some)));
        if with_stays {
            let values = [
                [0.9, 0.8, 0.5, 0.6, 0.3, -0.05],
                [0.8, 0.9, 0.6, 0.5, 0.3, 0.05],
                [1.0, 0.7, 0.4, 0.4, 0.45, 0.06],
                [0.9, 0.3, 0.5, 0.8, 0.0, 0.45],
                [0.8, 0.2, 0.4, 0.9, -0.05, 0.55],
                [0.7, 0.4, 0.6, 0.7, -0.1, 0.3],
            ];
            for (c, name) in COLUMNS.iter().enumerate() {
                let mut column: Vec<Option<f64>> = values.iter().map(|v| Some(v[c])).collect();
                if c == 1 {
                    column[0] = None;
                }
                t.push(*name, Column::floats(column));
            }
        }
        t
    }

    #[test]
    fn groups_get_means_intervals_and_tests_per_column() {
        let s = stay(&table(true), "controller").unwrap();
        let names: Vec<String> = s.groups.iter().map(|g| g.value.to_string()).collect();
        assert_eq!(names, ["mb", "mf"]);
        let (mb, mf) = (&s.groups[0], &s.groups[1]);
        // mf's stay_rc: 0.9, 0.8, 1.0: mean 0.9, sd 0.1, sem 0.1 / sqrt 3, t(0.975, 2) 4.303.
        let rc = &mf.columns[0];
        assert_eq!(rc.n, 3);
        assert!((rc.mean - 0.9).abs() < 1e-12);
        assert!((rc.sem - 0.1 / 3f64.sqrt()).abs() < 1e-12);
        assert!((rc.ci95 - 4.302_652_7 * 0.1 / 3f64.sqrt()).abs() < 1e-6);
        // A null is left out of its column only: stay_rr of mf has 2 values.
        assert_eq!(mf.columns[1].n, 2);
        assert_eq!(mf.runs, 3);
        // mb's interaction 0.45, 0.55, 0.3: mean 0.4333.
        assert!((mb.columns[5].mean - 1.3 / 3.0).abs() < 1e-12);
        // One pair per column; the interaction separates the groups completely: U = 9 of 9
        // for mb, exact p = 2 / 20 = 0.1.
        assert_eq!(s.pairs.len(), 6);
        let interaction = &s.pairs[5];
        assert_eq!((interaction.first, interaction.second), (0, 1));
        assert_eq!(interaction.test.u, 9.0);
        assert!((interaction.test.p_value - 0.1).abs() < 1e-12);
        assert_eq!(interaction.p_holm, interaction.test.p_value);
    }

    #[test]
    fn runs_without_stay_columns_are_refused_with_a_reason() {
        let e = stay(&table(false), "controller").unwrap_err().to_string();
        assert!(e.contains("no stay columns"), "{e}");
        assert!(e.contains("mbmf run --task twostep"), "{e}");
        let mut t = Table::new("u");
        t.push("controller", Column::texts([Some("mf")]));
        t.push("task", Column::texts([Some("tidy1")]));
        for name in COLUMNS {
            t.push(name, Column::floats([None]));
        }
        let e = stay(&t, "controller").unwrap_err().to_string();
        assert!(
            e.contains("no run has a stay probability") && e.contains("tidy1"),
            "{e}"
        );
    }
}
