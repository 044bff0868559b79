//! The analysis verbs: `mbmf pareto`, `mbmf stats`, `mbmf min-budget`. (Being written.)

use clap::Args;

use crate::cli::{Failure, usage};

/// `mbmf pareto`.
#[derive(Debug, Clone, Args)]
pub struct ParetoArgs {
    /// A dataset folder written by mbmf run or mbmf sweep.
    pub dir: std::path::PathBuf,
}

/// `mbmf stats`.
#[derive(Debug, Clone, Args)]
pub struct StatsArgs {
    /// A dataset folder written by mbmf run or mbmf sweep.
    pub dir: std::path::PathBuf,
}

/// `mbmf min-budget`.
#[derive(Debug, Clone, Args)]
pub struct MinBudgetArgs {
    /// A dataset folder written by mbmf run or mbmf sweep.
    pub dir: std::path::PathBuf,
}

/// Runs `mbmf pareto`.
pub fn pareto(_args: &ParetoArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!("mbmf pareto is not implemented yet")))
}

/// Runs `mbmf stats`.
pub fn stats(_args: &StatsArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!("mbmf stats is not implemented yet")))
}

/// Runs `mbmf min-budget`.
pub fn min_budget(_args: &MinBudgetArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!(
        "mbmf min-budget is not implemented yet"
    )))
}
