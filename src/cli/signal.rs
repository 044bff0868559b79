//! SIGINT and SIGTERM during `mbmf run` and `mbmf sweep`. The first signal only sets a flag:
//! the verb's progress callback reads it between strides of the simulation, the library returns
//! [`crate::pipeline::Interrupted`], and the verb removes its temporary files, releases its lock
//! and says what was kept. A second signal does not wait: it removes the paths registered with
//! [`remove_on_forced_exit`] and exits at once, as a kill would (what a kill leaves is cleaned
//! by the next command on that folder). Either way the exit code is 128 + the signal's number:
//! 130 for SIGINT, 143 for SIGTERM. Other verbs keep the default action (the process ends).

use std::io::{IsTerminal as _, Write as _};
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// Set by the first signal; read by the work between strides.
static STOP: AtomicBool = AtomicBool::new(false);
/// The first signal received, 0 before.
static RECEIVED: AtomicI32 = AtomicI32::new(0);
/// Files and folders a forced exit removes.
static CLEANUP: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Starts catching SIGINT and SIGTERM (once per process; later calls do nothing). Returns the
/// flag the first one sets. Where signals cannot be caught the flag is never set and a signal
/// ends the process as before.
pub fn install() -> &'static AtomicBool {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        // The handlers are registered inside the thread that serves them, so a thread that
        // cannot start leaves the default actions in place.
        let (ready, registered) = std::sync::mpsc::channel();
        let spawned = std::thread::Builder::new()
            .name("mbmf-signals".into())
            .spawn(move || {
                let Ok(mut signals) = Signals::new([SIGINT, SIGTERM]) else {
                    let _ = ready.send(());
                    return;
                };
                let _ = ready.send(());
                for signal in signals.forever() {
                    on_signal(signal);
                }
            });
        if spawned.is_ok() {
            let _ = registered.recv();
        }
    });
    &STOP
}

fn on_signal(signal: i32) {
    let mut stderr = std::io::stderr();
    if RECEIVED
        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok()
    {
        STOP.store(true, Ordering::SeqCst);
        // On a terminal the progress bar holds the line: start a new one.
        let newline = if stderr.is_terminal() { "\n" } else { "" };
        let _ = writeln!(
            stderr,
            "{newline}{}: stopping after the current simulation stride (send it again to stop \
             at once)",
            name(signal)
        );
        return;
    }
    remove_registered();
    let first = RECEIVED.load(Ordering::SeqCst);
    let _ = writeln!(
        stderr,
        "{}: stopped at once; anything left behind is cleaned by the next command on the \
         same folder",
        name(signal)
    );
    std::process::exit(128 + first);
}

/// The exit code after a signal stopped the work: 128 + its number (130 before any signal).
pub fn exit_code() -> i32 {
    128 + match RECEIVED.load(Ordering::SeqCst) {
        0 => SIGINT,
        s => s,
    }
}

/// The name of the signal that stopped the work ("SIGINT" before any signal).
pub fn received() -> &'static str {
    name(RECEIVED.load(Ordering::SeqCst))
}

fn name(signal: i32) -> &'static str {
    if signal == SIGTERM {
        "SIGTERM"
    } else {
        "SIGINT"
    }
}

/// Removes the paths registered with [`remove_on_forced_exit`]. Never waits: a lock held
/// elsewhere (by the thread that failed, in [`out_of_memory`]) skips the cleanup, which the
/// next command on the folder does instead.
fn remove_registered() {
    // A poisoned lock still holds the paths.
    let paths = match CLEANUP.try_lock() {
        Ok(paths) => paths.clone(),
        Err(std::sync::TryLockError::Poisoned(poisoned)) => poisoned.into_inner().clone(),
        Err(std::sync::TryLockError::WouldBlock) => return,
    };
    for path in &paths {
        let _ = std::fs::remove_dir_all(path).or_else(|_| std::fs::remove_file(path));
    }
}

/// Ends the process after an allocation of `bytes` failed (the binary's allocator calls it
/// instead of Rust's abort): says so, removes the registered temporary paths as a second
/// signal does, and exits with code 1. The message is formatted on the stack; should the
/// cleanup itself run out of memory, the nested call exits at once.
pub fn out_of_memory(bytes: usize) -> ! {
    static ENDING: AtomicBool = AtomicBool::new(false);
    if !ENDING.swap(true, Ordering::SeqCst) {
        let mut buffer = [0u8; 400];
        let len = {
            let mut cursor = std::io::Cursor::new(&mut buffer[..]);
            let _ = writeln!(
                cursor,
                "error: out of memory: an allocation of {bytes} bytes failed (a memory limit such \
                 as ulimit -v or the job's); the results in progress were removed (a sweep keeps \
                 its committed parts for --resume); lower --batch-size, or raise --checkpoint or \
                 lower --steps"
            );
            cursor.position() as usize
        };
        // SAFETY: writes `len` initialised bytes of `buffer` to standard error.
        let _ = unsafe { libc::write(2, buffer.as_ptr().cast(), len) };
        remove_registered();
    }
    // SAFETY: ends the process without running anything more that could allocate.
    unsafe { libc::_exit(super::EXIT_RUNTIME) }
}

/// Has a second signal remove `path` (a file or a folder) before it exits.
pub fn remove_on_forced_exit(path: PathBuf) {
    if let Ok(mut paths) = CLEANUP.lock() {
        paths.push(path);
    }
}

/// Stops removing `path` on a forced exit (it was committed or removed).
pub fn keep_on_forced_exit(path: &std::path::Path) {
    if let Ok(mut paths) = CLEANUP.lock() {
        paths.retain(|p| p != path);
    }
}
