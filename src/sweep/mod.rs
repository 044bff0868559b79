//! Sweeps: TOML files expanded into configurations x seeds, run in batches and streamed to a
//! Parquet dataset (issue 4). (Being written.)

use clap::Args;

use crate::cli::{Failure, usage};

/// `mbmf sweep`.
#[derive(Debug, Clone, Args)]
pub struct SweepArgs {
    /// The sweep file (TOML), e.g. sweeps/kappa.toml.
    pub file: std::path::PathBuf,
}

/// Runs `mbmf sweep`.
pub fn command(_args: &SweepArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!("mbmf sweep is not implemented yet")))
}
