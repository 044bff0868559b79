//! Which errors are the caller's. Every entry of the library returns a typed error; this trait
//! says whether it is a usage error (an input that can never work: a bad value, a file in the
//! way, a job too large for the machine) or a failure while running (a write that failed, a
//! full disk, a stop request), so a front end decides once what to do with each kind — the
//! command line exits 2 for the first and 1 for the second.

/// Whether an error is a usage error; see the module documentation.
pub trait Usage {
    /// True for an input that can never work, false for a failure while running.
    fn is_usage(&self) -> bool;
}

impl Usage for crate::params::ConfigError {
    fn is_usage(&self) -> bool {
        true
    }
}

impl Usage for crate::sweep::SweepError {
    fn is_usage(&self) -> bool {
        true
    }
}

impl Usage for crate::output::OutputError {
    fn is_usage(&self) -> bool {
        false
    }
}

impl Usage for crate::pipeline::Interrupted {
    fn is_usage(&self) -> bool {
        false
    }
}

impl Usage for crate::pipeline::TooLarge {
    fn is_usage(&self) -> bool {
        true
    }
}

impl Usage for crate::sweep::RunError {
    fn is_usage(&self) -> bool {
        crate::sweep::RunError::is_usage(self)
    }
}
