//! Runs aggregated by configuration, and the Pareto front over chosen objectives
//! (`mbmf pareto`).
//!
//! A configuration is one combination of the parameter columns except `run_index` and `seed`
//! (the seeds are the replicates). Each numeric result is averaged over a configuration's runs
//! with a 95% Student-t confidence interval ([`stats::ci95_half_width`]); missing values (e.g.
//! `mean_entropy_chosen` of a run that made no decision) are left out of that result's mean.
//! The front is computed on the means: a configuration whose mean of some objective is
//! missing is left out of the ranking (its rank is empty), never silently placed on the front.

use crate::analysis::AnalysisError;
use crate::analysis::dataset::{
    Column, RUN_IDENTITY, Table, Value, configuration_columns, group_rows, parameter_columns,
    varying_columns,
};
use crate::analysis::pareto::{self, Direction, Objective};
use crate::analysis::stats;

/// The paper's three objectives: maximise total reward, minimise total inference cost,
/// maximise learning quality (minimise the controlling expert's mean normalised entropy).
pub const DEFAULT_OBJECTIVES: &str = "total_reward:max,cost_total:min,mean_entropy_chosen:min";

/// The parameter columns whose values make results incomparable: a reward depends on the task
/// and on how many steps a run had to collect it.
pub const INCOMPARABLE: [&str; 2] = ["task", "steps"];

/// One group of runs whose results can be compared: its values of the [`INCOMPARABLE`] columns
/// that vary in the dataset, and its runs (named after the dataset and those values).
pub type ComparableGroup = (Vec<(String, Value)>, Table);

/// The runs of `table` split by the [`INCOMPARABLE`] columns that vary in it: one group per
/// task and step count present, in ascending order; the whole table, with no values, when
/// neither varies.
pub fn comparable_groups(table: &Table) -> Result<Vec<ComparableGroup>, AnalysisError> {
    groups_by(table, &[])
}

/// The runs of `table` split by the [`INCOMPARABLE`] columns that vary in it and by every
/// column of `by` (`mbmf pareto --by interaction`: one front per human), in ascending order of
/// those values; each group carries its values of them, the `by` columns even when they take
/// one value only. The whole table, with no values, when there is nothing to split by.
///
/// # Errors
/// A `by` column the table lacks (the message lists the columns and the closest name).
pub fn groups_by(table: &Table, by: &[String]) -> Result<Vec<ComparableGroup>, AnalysisError> {
    for column in by {
        table.column(column)?;
    }
    let present: Vec<String> = INCOMPARABLE
        .iter()
        .filter(|c| table.has(c) && !by.iter().any(|b| b == *c))
        .map(|c| (*c).to_owned())
        .collect();
    let all: Vec<usize> = (0..table.len()).collect();
    let mut keys = varying_columns(table, &present, &all);
    keys.extend(by.iter().cloned());
    if keys.is_empty() {
        return Ok(vec![(Vec::new(), table.clone())]);
    }
    Ok(group_rows(table, &keys)?
        .into_iter()
        .map(|(values, rows)| {
            let values: Vec<(String, Value)> = keys.iter().cloned().zip(values).collect();
            let label: Vec<String> = values.iter().map(|(k, v)| format!("{k}={v}")).collect();
            let source = format!("{}, {}", table.source(), label.join(", "));
            (values, table.take(&rows).renamed(source))
        })
        .collect())
}

/// The column of the human's effort, minimised by default when it varies.
pub const HUMAN_EFFORT: &str = "interactions";

/// The objectives used when none are given: [`DEFAULT_OBJECTIVES`], plus `interactions:min`
/// when the runs' `interactions` take more than one value. A human's help is a cost like the
/// computation: without it, a front over a sweep of humans or budgets calls the most helped
/// configuration free. Where it does not vary it could not change the front, so the paper's
/// three objectives stay alone.
pub fn default_objectives(table: &Table) -> Vec<Objective> {
    let mut objectives: Vec<Objective> = DEFAULT_OBJECTIVES
        .split(',')
        .map(|o| Objective::parse(o).expect("the default objectives parse"))
        .collect();
    let varies = table.numeric(HUMAN_EFFORT, "").is_ok_and(|values| {
        let mut finite = values.into_iter().flatten();
        finite
            .next()
            .is_some_and(|first| finite.any(|v| v != first))
    });
    if varies {
        objectives.push(Objective {
            name: HUMAN_EFFORT.to_owned(),
            direction: Direction::Minimize,
        });
    }
    objectives
}

/// Runs grouped by configuration, with every numeric result averaged over each group.
#[derive(Debug, Clone)]
pub struct Configurations {
    /// The dataset the runs came from.
    pub source: String,
    /// The configuration columns, in the order `mbmf` writes them.
    pub keys: Vec<String>,
    /// The configuration columns that take more than one value (the ones worth showing).
    pub varying: Vec<String>,
    /// Each configuration's values of `keys`, in ascending order of those values.
    pub values: Vec<Vec<Value>>,
    /// The key columns with one row per configuration, typed as in the dataset.
    pub key_columns: Vec<Column>,
    /// Each configuration's rows in the runs table.
    pub rows: Vec<Vec<usize>>,
    /// The averaged results: numeric columns other than the keys and the run identity (plus
    /// any key asked for as a metric).
    pub metrics: Vec<String>,
    /// `mean[c][m]`: mean of metric `m` over configuration `c`'s runs (NaN if none has one).
    pub mean: Vec<Vec<f64>>,
    /// `ci95[c][m]`: half-width of the 95% confidence interval of that mean (NaN below 2 runs).
    pub ci95: Vec<Vec<f64>>,
    /// `count[c][m]`: the runs with a value of metric `m`.
    pub count: Vec<Vec<usize>>,
}

impl Configurations {
    /// Groups `table`'s runs by configuration and averages every numeric result; the columns
    /// in `extra` are averaged too even if they are configuration columns (an objective such as
    /// `budget:min`).
    pub fn from_runs(table: &Table, extra: &[&str]) -> Result<Configurations, AnalysisError> {
        let keys = configuration_columns(table);
        if keys.is_empty() {
            return Err(AnalysisError::NotARunsTable {
                dataset: table.source().to_owned(),
                expected: parameter_columns()[2..].join(", "),
            });
        }
        for name in extra {
            table.numeric(name, "an objective")?;
        }
        let mut metrics: Vec<String> = table
            .numeric_names()
            .into_iter()
            .filter(|n| !keys.contains(n) && !RUN_IDENTITY.contains(&n.as_str()))
            .collect();
        for name in extra {
            if !metrics.iter().any(|m| m == name) {
                metrics.push((*name).to_owned());
            }
        }
        let metric_values: Vec<Vec<Option<f64>>> = metrics
            .iter()
            .map(|m| table.numeric(m, "averaging"))
            .collect::<Result<_, _>>()?;
        let groups = group_rows(table, &keys)?;
        let all_rows: Vec<usize> = (0..table.len()).collect();
        let varying = varying_columns(table, &keys, &all_rows);
        let first_rows: Vec<usize> = groups.iter().map(|(_, rows)| rows[0]).collect();
        let key_columns = keys
            .iter()
            .map(|k| table.column(k).map(|c| c.take(&first_rows)))
            .collect::<Result<_, _>>()?;
        let (mut mean, mut ci95, mut count) = (Vec::new(), Vec::new(), Vec::new());
        for (_, rows) in &groups {
            let (mut m, mut c, mut k) = (Vec::new(), Vec::new(), Vec::new());
            for values in &metric_values {
                let xs: Vec<f64> = rows.iter().filter_map(|&r| values[r]).collect();
                m.push(stats::mean(&xs));
                c.push(stats::ci95_half_width(&xs));
                k.push(xs.len());
            }
            mean.push(m);
            ci95.push(c);
            count.push(k);
        }
        let (values, rows) = groups.into_iter().unzip();
        Ok(Configurations {
            source: table.source().to_owned(),
            keys,
            varying,
            values,
            key_columns,
            rows,
            metrics,
            mean,
            ci95,
            count,
        })
    }

    /// Number of configurations.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// `true` when there are no configurations.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Index of metric `name` in [`Configurations::metrics`].
    pub fn metric_index(&self, name: &str) -> Option<usize> {
        self.metrics.iter().position(|m| m == name)
    }

    /// Configuration `c`'s value of the key column `name`.
    pub fn key_value(&self, c: usize, name: &str) -> Option<&Value> {
        self.keys
            .iter()
            .position(|k| k == name)
            .map(|i| &self.values[c][i])
    }

    /// The numeric configuration column that varies most (most distinct values; the first in
    /// `keys` on a tie), the swept number a figure colours its points by; `None` when no
    /// numeric column varies.
    pub fn swept_number(&self) -> Option<&str> {
        self.varying
            .iter()
            .filter_map(|name| {
                let k = self.keys.iter().position(|k| k == name)?;
                let mut values: Vec<f64> = self
                    .values
                    .iter()
                    .map(|row| row[k].as_f64())
                    .collect::<Option<_>>()?;
                values.sort_by(f64::total_cmp);
                values.dedup();
                Some((values.len(), std::cmp::Reverse(k), name.as_str()))
            })
            .max()
            .map(|(_, _, name)| name)
    }

    /// Configuration `c`'s value of `name`: a configuration column's value, or the mean of an
    /// averaged result; `None` if it is neither or not a number.
    pub fn number(&self, c: usize, name: &str) -> Option<f64> {
        match self.key_value(c, name) {
            Some(v) => v.as_f64(),
            None => self.metric_index(name).map(|m| self.mean[c][m]),
        }
    }

    /// A short label of configuration `c` from the varying columns: text values bare, others
    /// as `name=value` (e.g. `ec, kappa_coeff=9`); `all runs` when nothing varies.
    pub fn label(&self, c: usize) -> String {
        let parts: Vec<String> = self
            .varying
            .iter()
            .filter_map(|name| {
                self.key_value(c, name).map(|v| match v {
                    Value::Str(s) => s.clone(),
                    other => format!("{name}={other}"),
                })
            })
            .collect();
        if parts.is_empty() {
            "all runs".to_owned()
        } else {
            parts.join(", ")
        }
    }
}

/// Configurations ranked by non-domination over some objectives, with a knee point.
#[derive(Debug, Clone)]
pub struct Front {
    /// The aggregated configurations.
    pub configs: Configurations,
    /// The objectives, in the order given.
    pub objectives: Vec<Objective>,
    /// Index in `configs.metrics` of each objective.
    pub objective_metric: Vec<usize>,
    /// Non-domination rank of each configuration on the objective means (0 = the front), or
    /// `None` when a mean is missing.
    pub rank: Vec<Option<usize>>,
    /// The knee of the front ([`pareto::knee_point`] on the front's means): the front point
    /// nearest the ideal point once each objective is rescaled to [0, 1] over the front.
    pub knee: Option<usize>,
}

impl Front {
    /// Aggregates `table`'s runs by configuration and ranks them on `objectives`.
    pub fn compute(table: &Table, objectives: &[Objective]) -> Result<Front, AnalysisError> {
        if objectives.is_empty() {
            return Err(AnalysisError::InvalidArgument {
                name: "--objectives",
                value: String::new(),
                accepted: "give at least one NAME:max or NAME:min",
            });
        }
        for (i, a) in objectives.iter().enumerate() {
            if let Some(b) = objectives[i + 1..].iter().find(|b| b.name == a.name) {
                return Err(AnalysisError::InvalidArgument {
                    name: "--objectives",
                    value: format!("{a},{b}"),
                    accepted: if a.direction == b.direction {
                        "an objective listed twice; give each column once"
                    } else {
                        "opposite objectives on one column put every configuration on the \
                         front; give each column once, with the direction that is better"
                    },
                });
            }
        }
        let names: Vec<&str> = objectives.iter().map(|o| o.name.as_str()).collect();
        let configs = Configurations::from_runs(table, &names)?;
        let objective_metric: Vec<usize> = names
            .iter()
            .map(|n| configs.metric_index(n).expect("objectives are averaged"))
            .collect();
        let point = |c: usize| -> Vec<f64> {
            objective_metric
                .iter()
                .map(|&m| configs.mean[c][m])
                .collect()
        };
        let eligible: Vec<usize> = (0..configs.len())
            .filter(|&c| point(c).iter().all(|v| v.is_finite()))
            .collect();
        let points: Vec<Vec<f64>> = eligible.iter().map(|&c| point(c)).collect();
        let dirs: Vec<Direction> = objectives.iter().map(|o| o.direction).collect();
        let ranks = pareto::non_dominated_ranks(&points, &dirs);
        let mut rank = vec![None; configs.len()];
        for (&c, &r) in eligible.iter().zip(&ranks) {
            rank[c] = Some(r);
        }
        let front: Vec<usize> = (0..configs.len()).filter(|&c| rank[c] == Some(0)).collect();
        let front_points: Vec<Vec<f64>> = front.iter().map(|&c| point(c)).collect();
        let knee = pareto::knee_point(&front_points, &dirs).map(|i| front[i]);
        Ok(Front {
            configs,
            objectives: objectives.to_vec(),
            objective_metric,
            rank,
            knee,
        })
    }

    /// The front's configurations, best first in the first objective.
    pub fn members(&self) -> Vec<usize> {
        let mut front: Vec<usize> = (0..self.configs.len())
            .filter(|&c| self.rank[c] == Some(0))
            .collect();
        let m = self.objective_metric[0];
        let sign = match self.objectives[0].direction {
            Direction::Maximize => -1.0,
            Direction::Minimize => 1.0,
        };
        front.sort_by(|&a, &b| {
            (sign * self.configs.mean[a][m]).total_cmp(&(sign * self.configs.mean[b][m]))
        });
        front
    }

    /// Mean of objective `o` for configuration `c`.
    pub fn objective_mean(&self, c: usize, o: usize) -> f64 {
        self.configs.mean[c][self.objective_metric[o]]
    }

    /// CI half-width of objective `o` for configuration `c`.
    pub fn objective_ci95(&self, c: usize, o: usize) -> f64 {
        self.configs.ci95[c][self.objective_metric[o]]
    }

    /// One row per configuration: its parameters, `n` (runs), `METRIC_mean` and `METRIC_ci95`
    /// for every averaged result (null when undefined), `rank` (null when an objective mean is
    /// missing), `front` and `knee`.
    pub fn to_table(&self) -> Table {
        let c = &self.configs;
        let mut t = Table::new(format!("Pareto analysis of {}", c.source));
        for (name, column) in c.keys.iter().zip(&c.key_columns) {
            t.push(name.clone(), column.clone());
        }
        t.push(
            "n",
            Column::uints(c.rows.iter().map(|r| Some(r.len() as u64))),
        );
        let finite = |x: f64| x.is_finite().then_some(x);
        for (m, name) in c.metrics.iter().enumerate() {
            t.push(
                format!("{name}_mean"),
                Column::floats(c.mean.iter().map(|row| finite(row[m]))),
            );
            t.push(
                format!("{name}_ci95"),
                Column::floats(c.ci95.iter().map(|row| finite(row[m]))),
            );
        }
        t.push(
            "rank",
            Column::uints(self.rank.iter().map(|r| r.map(|r| r as u64))),
        );
        t.push(
            "front",
            Column::bools(self.rank.iter().map(|r| Some(*r == Some(0)))),
        );
        t.push(
            "knee",
            Column::bools((0..c.len()).map(|i| Some(self.knee == Some(i)))),
        );
        t
    }
}

/// One front of [`Pareto`]: the group's values of the [`INCOMPARABLE`] and `by` columns, its
/// runs, and its front.
#[derive(Debug, Clone)]
pub struct ParetoGroup {
    /// The group's values (empty for a dataset with nothing to split by).
    pub values: Vec<(String, Value)>,
    /// Runs in the group.
    pub runs: usize,
    /// The group's front.
    pub front: Front,
}

/// What `mbmf pareto` computes: one front per group of comparable runs ([`groups_by`]), shared
/// by the command line (its table, `--json` and pareto.parquet) and the Python package.
#[derive(Debug, Clone)]
pub struct Pareto {
    /// The dataset.
    pub source: String,
    /// Runs analysed.
    pub runs: usize,
    /// One front per group, in ascending order of the groups' values.
    pub groups: Vec<ParetoGroup>,
}

/// The fronts of `table`'s runs over `objectives` (default: [`default_objectives`]), one per
/// group of [`groups_by`] with `by`.
///
/// # Errors
/// A `by` column or an objective the table lacks, or objectives that cannot be ranked.
pub fn pareto(
    table: &Table,
    objectives: Option<&[Objective]>,
    by: &[String],
) -> Result<Pareto, AnalysisError> {
    let objectives = match objectives {
        Some(o) => o.to_vec(),
        None => default_objectives(table),
    };
    let groups = groups_by(table, by)?
        .into_iter()
        .map(|(values, runs)| {
            Ok(ParetoGroup {
                runs: runs.len(),
                front: Front::compute(&runs, &objectives)?,
                values,
            })
        })
        .collect::<Result<_, AnalysisError>>()?;
    Ok(Pareto {
        source: table.source().to_owned(),
        runs: table.len(),
        groups,
    })
}

impl Pareto {
    /// pareto.parquet: every group's [`Front::to_table`], one after the other.
    ///
    /// # Errors
    /// Groups whose columns of one name have different types (not from one dataset).
    pub fn to_table(&self) -> Result<Table, crate::analysis::dataset::DatasetError> {
        if let [group] = self.groups.as_slice() {
            return Ok(group.front.to_table());
        }
        let tables: Vec<Table> = self.groups.iter().map(|g| g.front.to_table()).collect();
        Table::stack(format!("Pareto analysis of {}", self.source), &tables)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(interactions: &[u64]) -> Table {
        let mut t = Table::new("runs");
        t.push(
            "interactions",
            Column::uints(interactions.iter().map(|&i| Some(i))),
        );
        t
    }

    #[test]
    fn default_objectives_add_the_human_effort_only_when_it_varies() {
        let names = |t: &Table| -> Vec<String> {
            default_objectives(t)
                .iter()
                .map(ToString::to_string)
                .collect()
        };
        let paper = [
            "total_reward:max",
            "cost_total:min",
            "mean_entropy_chosen:min",
        ];
        assert_eq!(names(&runs(&[0, 0, 0])), paper);
        assert_eq!(names(&Table::new("no such column")), paper);
        assert_eq!(
            names(&runs(&[0, 30, 50])),
            [&paper[..], &["interactions:min"]].concat()
        );
    }

    #[test]
    fn groups_by_splits_on_every_by_column_and_names_a_missing_one() {
        let mut t = runs(&[0, 30, 0, 30]);
        t.push(
            "interaction",
            Column::texts(["none", "takeover", "none", "takeover"].map(Some)),
        );
        let groups = groups_by(&t, &["interaction".to_owned()]).unwrap();
        assert_eq!(groups.len(), 2);
        assert_eq!(
            groups[1].0,
            [("interaction".to_owned(), Value::Str("takeover".to_owned()))]
        );
        assert_eq!(groups[1].1.len(), 2);
        // A by column with one value still names the group.
        let one = groups_by(&t.take(&[0, 2]), &["interaction".to_owned()]).unwrap();
        assert_eq!(one.len(), 1);
        assert_eq!(one[0].0.len(), 1);
        let e = groups_by(&t, &["interacton".to_owned()]).unwrap_err();
        assert!(e.to_string().contains("did you mean 'interaction'"), "{e}");
    }
}
