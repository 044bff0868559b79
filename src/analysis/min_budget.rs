//! The minimal interaction budget (`mbmf min-budget`): per task, controller and interaction
//! type, the smallest budget whose reward is not significantly below that of a larger budget
//! (the paper's "minimal number of interactions necessary to reach the maximal accumulation
//! rate", SPEC 9 item 6).
//!
//! NOTE: SPEC 9 fixes the rule. Over the budgets present in the data (0 included), the minimal
//! budget is the smallest budget `b` such that no larger budget has a higher mean of the metric
//! with a one-sided Mann–Whitney p < alpha (0.05), without multiple-comparison correction. The
//! largest budget always satisfies it, so there is always an answer. The rule is not monotone
//! in general: a budget above the chosen one can itself be beaten by a still larger budget;
//! such budgets are reported.
//!
//! Budget 0: a run with budget 0, or with interaction `none`, receives no interaction at all,
//! whatever its other human parameters. Such runs are pooled as the budget-0 level of every
//! interaction type (and every forget probability and zeta) present for the same other
//! parameters: `mbmf run --interaction none` runs serve as the baseline of takeover and
//! congratulation alike.

use std::collections::BTreeMap;

use crate::analysis::AnalysisError;
use crate::analysis::dataset::{Column, Table, Value, configuration_columns};
use crate::analysis::stats::{self, Alternative};

/// Columns left out of a group's key: the budget is what varies; the profile only names a
/// preset whose values are in the other columns (and differs between budgets of one preset).
const NOT_KEY: [&str; 2] = ["budget", "profile"];
/// Columns always shown in the table, if present.
const ALWAYS_SHOWN: [&str; 3] = ["task", "controller", "interaction"];

/// The significance level of SPEC 9.
pub const DEFAULT_ALPHA: f64 = 0.05;

/// A larger budget compared with a smaller one.
#[derive(Debug, Clone, PartialEq)]
pub struct Versus {
    /// The larger budget.
    pub budget: u64,
    /// Its mean of the metric is higher than the smaller budget's.
    pub higher_mean: bool,
    /// One-sided Mann–Whitney p-value that the larger budget's values tend to be greater.
    pub p_value: f64,
    /// `higher_mean` and `p_value < alpha`: the smaller budget does not reach this one.
    pub beats: bool,
}

/// One budget of a group.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// The budget.
    pub budget: u64,
    /// Runs with a value of the metric.
    pub n: usize,
    /// Mean of the metric.
    pub mean: f64,
    /// Standard deviation (NaN below two runs).
    pub sd: f64,
    /// The tests against every larger budget, ascending.
    pub vs_larger: Vec<Versus>,
    /// No larger budget beats this one.
    pub qualifies: bool,
}

/// The budgets of one task / controller / interaction type (and other parameters).
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetGroup {
    /// The values of [`MinBudget::keys`].
    pub key: Vec<Value>,
    /// The budgets present, ascending.
    pub levels: Vec<Level>,
    /// Index in `levels` of the minimal budget.
    pub chosen: usize,
    /// Index in `levels` of the highest mean (the smallest budget on a tie).
    pub best: usize,
    /// Budgets above the chosen one that a larger budget beats (empty when the rule is
    /// monotone here).
    pub not_monotone: Vec<u64>,
}

impl BudgetGroup {
    /// The minimal budget.
    pub fn chosen_budget(&self) -> u64 {
        self.levels[self.chosen].budget
    }
}

/// The minimal budget of every group of a dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct MinBudget {
    /// The dataset.
    pub source: String,
    /// The metric compared (`total_reward` by default).
    pub metric: String,
    /// The significance level.
    pub alpha: f64,
    /// The configuration columns that define a group (all but budget, profile, seed, run).
    pub keys: Vec<String>,
    /// The key columns worth showing: task, controller, interaction, and any other that varies.
    pub shown: Vec<String>,
    /// The key columns' types, for output.
    key_types: Vec<Column>,
    /// The groups, in ascending key order.
    pub groups: Vec<BudgetGroup>,
    /// Parameter combinations (human columns empty) that have budget-0 runs but no run with an
    /// interaction, so no group.
    pub baseline_only: usize,
}

/// Finds the minimal budget of every group of `table` for `metric` at level `alpha`.
pub fn min_budget(table: &Table, metric: &str, alpha: f64) -> Result<MinBudget, AnalysisError> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(AnalysisError::InvalidArgument {
            name: "--alpha",
            value: alpha.to_string(),
            accepted: "a significance level strictly between 0 and 1, e.g. 0.05",
        });
    }
    let values = table.numeric(metric, "--metric")?;
    let budgets = table.numeric("budget", "min-budget")?;
    let interaction = table.column("interaction")?;
    let keys: Vec<String> = configuration_columns(table)
        .into_iter()
        .filter(|k| !NOT_KEY.contains(&k.as_str()))
        .collect();
    let key_columns: Vec<&Column> = keys
        .iter()
        .map(|k| table.column(k))
        .collect::<Result<_, _>>()?;
    // The human's fields are part of a group's key, but irrelevant for budget-0 runs.
    let is_human: Vec<bool> = keys
        .iter()
        .map(|k| crate::params::param(k).is_some_and(|p| p.in_human))
        .collect();
    let base_of = |key: &[Value]| -> Vec<Value> {
        key.iter()
            .zip(&is_human)
            .map(|(v, &h)| if h { Value::Null } else { v.clone() })
            .collect()
    };

    // Budget-0 runs by base key; other runs by full key and budget.
    let mut zero: BTreeMap<Vec<Value>, Vec<f64>> = BTreeMap::new();
    let mut with_budget: BTreeMap<Vec<Value>, BTreeMap<u64, Vec<f64>>> = BTreeMap::new();
    for row in 0..table.len() {
        let budget = match budgets[row] {
            Some(b) if b >= 0.0 && b.fract() == 0.0 => b as u64,
            other => {
                return Err(AnalysisError::NothingToAnalyse {
                    dataset: table.source().to_owned(),
                    reason: format!(
                        "row {row} has budget {}; budgets must be whole numbers >= 0",
                        other.map_or("null".to_owned(), |b| b.to_string())
                    ),
                });
            }
        };
        let key: Vec<Value> = key_columns.iter().map(|c| c.value(row)).collect();
        let none = matches!(interaction.value(row), Value::Str(ref s) if s == "none");
        if budget == 0 || none {
            let pool = zero.entry(base_of(&key)).or_default();
            pool.extend(values[row]);
        } else {
            let pool = with_budget
                .entry(key)
                .or_default()
                .entry(budget)
                .or_default();
            pool.extend(values[row]);
        }
    }
    if with_budget.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: table.source().to_owned(),
            reason: "no run has an interaction type other than none and a budget above 0; \
                     min-budget compares budgets of one interaction type (run e.g. \
                     mbmf run --interaction takeover --budget B for several B)"
                .to_owned(),
        });
    }

    let mut groups = Vec::new();
    let mut bases_with_groups = std::collections::BTreeSet::new();
    for (key, by_budget) in with_budget {
        let base = base_of(&key);
        let mut samples: Vec<(u64, Vec<f64>)> = Vec::new();
        if let Some(z) = zero.get(&base) {
            samples.push((0, z.clone()));
        }
        samples.extend(by_budget);
        bases_with_groups.insert(base);
        samples.retain(|(_, xs)| !xs.is_empty());
        if samples.is_empty() {
            continue;
        }
        groups.push(decide(key, &samples, alpha, table.source())?);
    }
    let baseline_only = zero
        .keys()
        .filter(|b| !bases_with_groups.contains(*b))
        .count();
    if groups.is_empty() {
        return Err(AnalysisError::NothingToAnalyse {
            dataset: table.source().to_owned(),
            reason: format!("no run with an interaction has a value of {metric}"),
        });
    }

    let mut shown: Vec<String> = Vec::new();
    for (i, k) in keys.iter().enumerate() {
        let varies = groups.iter().any(|g| g.key[i] != groups[0].key[i]);
        if ALWAYS_SHOWN.contains(&k.as_str()) || varies {
            shown.push(k.clone());
        }
    }
    let key_types = key_columns.iter().map(|c| c.take(&[])).collect();
    Ok(MinBudget {
        source: table.source().to_owned(),
        metric: metric.to_owned(),
        alpha,
        keys,
        shown,
        key_types,
        groups,
        baseline_only,
    })
}

/// Applies the SPEC 9 rule to the samples of one group (budgets ascending, none empty).
fn decide(
    key: Vec<Value>,
    samples: &[(u64, Vec<f64>)],
    alpha: f64,
    source: &str,
) -> Result<BudgetGroup, AnalysisError> {
    let mut levels: Vec<Level> = Vec::new();
    for (i, (budget, xs)) in samples.iter().enumerate() {
        let mean = stats::mean(xs);
        let mut vs_larger = Vec::new();
        for (larger, ys) in &samples[i + 1..] {
            let test = stats::mann_whitney(ys, xs, Alternative::Greater).map_err(|e| {
                AnalysisError::NothingToAnalyse {
                    dataset: source.to_owned(),
                    reason: format!("cannot test budget {larger} against budget {budget}: {e}"),
                }
            })?;
            let higher_mean = stats::mean(ys) > mean;
            vs_larger.push(Versus {
                budget: *larger,
                higher_mean,
                p_value: test.p_value,
                beats: higher_mean && test.p_value < alpha,
            });
        }
        let qualifies = !vs_larger.iter().any(|v| v.beats);
        levels.push(Level {
            budget: *budget,
            n: xs.len(),
            mean,
            sd: stats::sd(xs),
            vs_larger,
            qualifies,
        });
    }
    let chosen = levels
        .iter()
        .position(|l| l.qualifies)
        .expect("the largest budget always qualifies");
    let mut best = 0;
    for (i, l) in levels.iter().enumerate() {
        if l.mean > levels[best].mean {
            best = i;
        }
    }
    let not_monotone = levels[chosen..]
        .iter()
        .filter(|l| !l.qualifies)
        .map(|l| l.budget)
        .collect();
    Ok(BudgetGroup {
        key,
        levels,
        chosen,
        best,
        not_monotone,
    })
}

impl MinBudget {
    /// The value of key column `name` in group `g`.
    pub fn key_value(&self, g: usize, name: &str) -> Option<&Value> {
        self.keys
            .iter()
            .position(|k| k == name)
            .map(|i| &self.groups[g].key[i])
    }

    /// One row per group and budget: the key columns (human columns of pooled budget-0 runs
    /// take the group's values), `budget`, `n`, `mean`, `sd`, `p_vs_larger` (text:
    /// `budget:p` for every larger budget, one-sided), `beaten_by` (text: the larger budgets
    /// with a higher mean and p < alpha), `min_p_vs_higher` (smallest p among larger budgets
    /// with a higher mean), `qualifies`, `chosen`, `monotone` (of the group), `metric`.
    pub fn to_table(&self) -> Table {
        let mut t = Table::new(format!("minimal budgets of {}", self.source));
        let rows: Vec<(usize, usize)> = self
            .groups
            .iter()
            .enumerate()
            .flat_map(|(g, group)| (0..group.levels.len()).map(move |l| (g, l)))
            .collect();
        let level = |&(g, l): &(usize, usize)| &self.groups[g].levels[l];
        for (i, (name, like)) in self.keys.iter().zip(&self.key_types).enumerate() {
            let values: Vec<Value> = rows
                .iter()
                .map(|&(g, _)| self.groups[g].key[i].clone())
                .collect();
            t.push(name.clone(), Column::from_values(like, &values));
        }
        t.push(
            "metric",
            Column::texts(rows.iter().map(|_| Some(self.metric.as_str()))),
        );
        t.push(
            "budget",
            Column::uints(rows.iter().map(|r| Some(level(r).budget))),
        );
        t.push(
            "n",
            Column::uints(rows.iter().map(|r| Some(level(r).n as u64))),
        );
        let finite = |x: f64| x.is_finite().then_some(x);
        t.push(
            "mean",
            Column::floats(rows.iter().map(|r| finite(level(r).mean))),
        );
        t.push(
            "sd",
            Column::floats(rows.iter().map(|r| finite(level(r).sd))),
        );
        t.push(
            "p_vs_larger",
            Column::texts(rows.iter().map(|r| {
                Some(
                    level(r)
                        .vs_larger
                        .iter()
                        .map(|v| format!("{}:{:.4e}", v.budget, v.p_value))
                        .collect::<Vec<_>>()
                        .join(" "),
                )
            })),
        );
        t.push(
            "beaten_by",
            Column::texts(rows.iter().map(|r| {
                Some(
                    level(r)
                        .vs_larger
                        .iter()
                        .filter(|v| v.beats)
                        .map(|v| v.budget.to_string())
                        .collect::<Vec<_>>()
                        .join(","),
                )
            })),
        );
        t.push(
            "min_p_vs_higher",
            Column::floats(rows.iter().map(|r| {
                level(r)
                    .vs_larger
                    .iter()
                    .filter(|v| v.higher_mean)
                    .map(|v| v.p_value)
                    .min_by(f64::total_cmp)
            })),
        );
        t.push(
            "qualifies",
            Column::bools(rows.iter().map(|r| Some(level(r).qualifies))),
        );
        t.push(
            "chosen",
            Column::bools(rows.iter().map(|&(g, l)| Some(self.groups[g].chosen == l))),
        );
        t.push(
            "monotone",
            Column::bools(
                rows.iter()
                    .map(|&(g, _)| Some(self.groups[g].not_monotone.is_empty())),
            ),
        );
        t
    }
}
