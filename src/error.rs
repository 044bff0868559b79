//! Which errors are the caller's. Every entry of the library returns a typed error; [`Usage`]
//! says whether it is a usage error (an input that can never work: a bad value, a file in the
//! way, a job too large for the machine) or a failure while running (a write that failed, a
//! full disk, a stop request), so a front end decides once what to do with each kind — the
//! command line exits 2 for the first and 1 for the second.

/// Whether an error is a usage error; see the module documentation.
pub trait Usage {
    /// True for an input that can never work, false for a failure while running.
    fn is_usage(&self) -> bool;
}

/// A file system operation that failed, saying what was being done (with its path): a failure
/// while running, never a usage error.
#[derive(Debug, thiserror::Error)]
#[error("{what}")]
pub struct IoError {
    /// What could not be done ("cannot create output folder out/run").
    pub what: String,
    /// Why.
    #[source]
    pub cause: std::io::Error,
}

impl IoError {
    /// A mapper of [`std::io::Error`]s for `map_err`, saying `what` was being done.
    pub fn doing(what: String) -> impl FnOnce(std::io::Error) -> IoError {
        move |cause| IoError { what, cause }
    }
}

/// `impl Usage` for error types that are always, or never, usage errors.
macro_rules! always {
    ($usage:literal: $($ty:ty),*) => {$(
        impl Usage for $ty {
            fn is_usage(&self) -> bool {
                $usage
            }
        }
    )*};
}

always!(true: crate::params::ConfigError, crate::sweep::SweepError);

impl Usage for crate::pipeline::MemoryError {
    /// A run too large for the limits is an input that can never work here; an allocation that
    /// failed while running is a failure like a full disk.
    fn is_usage(&self) -> bool {
        matches!(self, crate::pipeline::MemoryError::RunTooLarge { .. })
    }
}
always!(false: IoError, crate::output::OutputError, crate::pipeline::Interrupted);

impl Usage for crate::sweep::RunError {
    fn is_usage(&self) -> bool {
        crate::sweep::RunError::is_usage(self)
    }
}
