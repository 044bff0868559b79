//! Analysis of result datasets: statistics, Pareto fronts, minimal budgets, the paper's figures.
//!
//! - [`dataset`] reads what `mbmf run` and `mbmf sweep` write into a columnar [`dataset::Table`].
//! - [`front`] aggregates runs by configuration and finds the Pareto front (`mbmf pareto`).
//! - [`compare`] tests a metric between groups of runs (`mbmf stats`).
//! - [`curves`] computes mean curves with standard errors from the series table (`mbmf plot`).
//! - [`min_budget`] finds the smallest sufficient interaction budget (`mbmf min-budget`).
//! - [`stay`] summarises and tests the two-step task's stay probabilities (`mbmf stay`).
//! - [`pareto`] and [`stats`] hold the algorithms they use; the verbs that print
//!   them are the command line's.

pub mod compare;
pub mod curves;
pub mod dataset;
pub mod front;
pub mod min_budget;
pub mod pareto;
pub mod stats;
pub mod stay;

use dataset::DatasetError;

/// Failure of an analysis. Messages name the dataset, the offending input and what would be
/// accepted.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// Reading the dataset, or a column or filter it lacks.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A malformed `--objectives` entry.
    #[error(transparent)]
    Objective(#[from] pareto::ObjectiveParseError),
    /// The dataset has none of the parameter columns `mbmf` writes.
    #[error(
        "{dataset} has none of the parameter columns mbmf writes ({expected}); give the runs \
         table of a dataset written by mbmf run or mbmf sweep"
    )]
    NotARunsTable {
        /// The dataset.
        dataset: String,
        /// The parameter columns looked for.
        expected: String,
    },
    /// Too few groups to compare.
    #[error(
        "{dataset}: --by {by} gives {found}; a comparison needs at least two groups with values \
         of {metric}"
    )]
    TooFewGroups {
        /// The dataset.
        dataset: String,
        /// The grouping column.
        by: String,
        /// The metric.
        metric: String,
        /// What was found (e.g. `one group (ec)`).
        found: String,
    },
    /// Nothing to analyse (e.g. no run with an interaction budget).
    #[error("{dataset}: {reason}")]
    NothingToAnalyse {
        /// The dataset.
        dataset: String,
        /// What is missing and what would be accepted.
        reason: String,
    },
    /// A command-line value out of range.
    #[error("invalid {name} {value}: {accepted}")]
    InvalidArgument {
        /// The flag.
        name: &'static str,
        /// The value given.
        value: String,
        /// What would be accepted.
        accepted: &'static str,
    },
}
