//! Analysis of result datasets: statistics, Pareto fronts, minimal budgets, the paper's figures.
