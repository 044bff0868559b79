//! `mbmf bench`: the headline speed figures in about a minute, for users checking their machine.
//! (Being written.)

use clap::Args;

use crate::cli::{Failure, usage};

/// `mbmf bench`.
#[derive(Debug, Clone, Args)]
pub struct BenchArgs {}

/// Runs `mbmf bench`.
pub fn command(_args: &BenchArgs) -> Result<(), Failure> {
    Err(usage(anyhow::anyhow!("mbmf bench is not implemented yet")))
}
