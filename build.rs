//! Records the git commit and dirty flag of the build, and rustc's version and target, for
//! `mbmf --version` and the provenance of every file written. Outside a git checkout (a
//! source tarball) the commit is "unknown".

use std::process::Command;

fn run(cmd: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(cmd).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let commit = run("git", &["rev-parse", "HEAD"]).filter(|c| !c.is_empty());
    let dirty = match &commit {
        // Untracked files count: they may be sources the build used.
        Some(_) => match run("git", &["status", "--porcelain"]) {
            Some(s) if s.is_empty() => "false",
            Some(_) => "true",
            None => "unknown",
        },
        None => "unknown",
    };
    println!(
        "cargo:rustc-env=MBMF_GIT_COMMIT={}",
        commit.as_deref().unwrap_or("unknown")
    );
    println!("cargo:rustc-env=MBMF_GIT_DIRTY={dirty}");
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = run(&rustc, &["--version"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=MBMF_RUSTC={version}");
    println!(
        "cargo:rustc-env=MBMF_TARGET={}",
        std::env::var("TARGET").unwrap_or_else(|_| "unknown".into())
    );
    // A new commit or an edited source reruns this (the git paths may not exist: no git).
    if let Some(dir) = run("git", &["rev-parse", "--git-dir"]) {
        println!("cargo:rerun-if-changed={dir}/HEAD");
        println!("cargo:rerun-if-changed={dir}/index");
    }
    if let (Some(common), Some(head)) = (
        run("git", &["rev-parse", "--git-common-dir"]),
        run("git", &["symbolic-ref", "-q", "HEAD"]),
    ) {
        println!("cargo:rerun-if-changed={common}/{head}");
    }
    for path in ["build.rs", "Cargo.toml", "src"] {
        println!("cargo:rerun-if-changed={path}");
    }
}
