//! Analysis of result datasets: statistics, Pareto fronts, minimal budgets, the paper's figures.

pub mod pareto;
pub mod stats;

pub mod cli;
