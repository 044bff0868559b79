//! The `mbmf` binary: parse, run, and turn any error into a message and an exit code (2 for
//! usage errors, 1 for runtime failures).

use std::alloc::{GlobalAlloc, Layout};
use std::io::Write as _;

use mbmf::huge_pages::HugePageSystem;

mod cli;

// The command line is a front end of the library like any other; its modules name the
// library's as `crate::...`, as they did when they lived inside it.
#[allow(unused_imports)]
use mbmf::{
    analysis, batch, bench, env, error, expert, human, meta, output, params, pipeline, plot,
    reproduce, rng, run, run_stats, schedule, session, sizing, suggest, sweep, web, whole_file,
};

/// The system allocator with large allocations on huge pages ([`HugePageSystem`]), except that
/// running out of memory ends the process with a message, exit code 1 and its temporary files
/// removed, instead of Rust's abort (exit 134) that leaves them. A failed probe of
/// [`mbmf::limits::can_reserve`] is returned to it as usual.
struct ExitOnOutOfMemory;

/// `pointer`, unless it is null for an allocation that cannot be done without.
fn checked(pointer: *mut u8, bytes: usize) -> *mut u8 {
    if pointer.is_null() && !mbmf::limits::probing() {
        cli::signal::out_of_memory(bytes);
    }
    pointer
}

// SAFETY: every call is forwarded to `HugePageSystem` with its arguments unchanged.
unsafe impl GlobalAlloc for ExitOnOutOfMemory {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        checked(unsafe { HugePageSystem.alloc(layout) }, layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        checked(
            unsafe { HugePageSystem.alloc_zeroed(layout) },
            layout.size(),
        )
    }

    unsafe fn realloc(&self, pointer: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        checked(
            unsafe { HugePageSystem.realloc(pointer, layout, new_size) },
            new_size,
        )
    }

    unsafe fn dealloc(&self, pointer: *mut u8, layout: Layout) {
        unsafe { HugePageSystem.dealloc(pointer, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: ExitOnOutOfMemory = ExitOnOutOfMemory;

fn main() {
    mbmf::limits::fit_malloc_to_limits();
    install_panic_hook();
    use clap::Parser as _;
    // Help and version requests print and exit 0; argument errors print clap's message (with
    // its suggestion for a typo) and exit 2.
    let parsed = match cli::Cli::try_parse_from(std::env::args_os()) {
        Ok(parsed) => parsed,
        Err(mut e) => {
            let code = if e.use_stderr() { cli::EXIT_USAGE } else { 0 };
            cli::suggest_verb(&mut e);
            let _ = e.print();
            std::process::exit(code);
        }
    };
    if let Err(failure) = cli::execute(&parsed) {
        // writeln, not the panicking macro: a closed stderr must not turn an error into a panic.
        let message = cli::error_line(&failure.error);
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
