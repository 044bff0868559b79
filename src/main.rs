//! The `mbmf` binary: parse, run, and turn any error into a message and an exit code (2 for
//! usage errors, 1 for runtime failures).

use std::io::Write as _;

fn main() {
    install_panic_hook();
    if let Err(failure) = mbmf::cli::main_with_args(std::env::args_os()) {
        // writeln, not the panicking macro: a closed stderr must not turn an error into a panic.
        let message = mbmf::cli::error_line(&failure.error);
        let _ = writeln!(std::io::stderr(), "error: {message}");
        std::process::exit(failure.code);
    }
}

/// Replaces Rust's panic message. No user input should reach a panic (every input is validated
/// and reported as an error); if one does, it is a bug, and the message says so.
fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown cause".to_string());
        let location = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let mut stderr = std::io::stderr();
        let _ = writeln!(
            stderr,
            "error: internal error in mbmf{location}: {message}\n\
             This is a bug; please report it with the command line that caused it."
        );
        // Only when asked for with RUST_BACKTRACE, as Rust's own hook does.
        let backtrace = std::backtrace::Backtrace::capture();
        if backtrace.status() == std::backtrace::BacktraceStatus::Captured {
            let _ = writeln!(stderr, "{backtrace}");
        }
    }));
}
