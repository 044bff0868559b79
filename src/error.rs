//! Typed errors of the library. Each message names the bad input and what would be accepted.

use thiserror::Error;

/// Failure to build an environment.
#[derive(Debug, Error)]
pub enum EnvError {
    /// The task name is none of the known ones.
    #[error(
        "unknown task '{0}': expected tidy1, tidy2 or json:PATH (the authors' transition-model file)"
    )]
    UnknownTask(String),
    /// A `json:` environment's files are malformed.
    #[error(transparent)]
    File(#[from] crate::env::json::EnvFileError),
}

/// A parameter value outside what the model accepts.
#[derive(Debug, Error, PartialEq)]
pub enum ConfigError {
    /// A scalar out of range.
    #[error("invalid {name} = {value}: {accepted}")]
    InvalidParam {
        /// The parameter's name, as on the command line.
        name: &'static str,
        /// The bad value.
        value: String,
        /// What would be accepted.
        accepted: &'static str,
    },
    /// Human interactions on a task that does not define them (SPEC 5).
    #[error(
        "interaction '{interaction}' is not defined for task '{task}': only tidy1 and tidy2 say which \
         actions are relevant or errors and where a held cube belongs; use --interaction none (or budget 0)"
    )]
    InteractionUnsupported {
        /// The task.
        task: String,
        /// The interaction type asked for.
        interaction: String,
    },
}
