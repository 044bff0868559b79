//! `mbmf reproduce`: the paper's experiments, figures and claim-by-claim report. (Being written.)

use clap::Args;

use crate::cli::{Failure, usage};

/// `mbmf reproduce`.
#[derive(Debug, Clone, Args)]
pub struct ReproduceArgs {
    /// Output folder for the data, figures and report.md.
    #[arg(long, default_value = "out/reproduce")]
    pub out: std::path::PathBuf,
    /// A small version that runs in seconds (CI runs it).
    #[arg(long)]
    pub quick: bool,
}

/// Runs `mbmf reproduce`.
pub fn command(_args: &ReproduceArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!(
        "mbmf reproduce is not implemented yet"
    )))
}
