//! The `mbmf` binary: parse, run, and turn any error into a message and an exit code.

fn main() {
    if let Err(failure) = mbmf::cli::main_with_args(std::env::args_os()) {
        eprintln!("error: {:#}", failure.error);
        std::process::exit(failure.code);
    }
}
