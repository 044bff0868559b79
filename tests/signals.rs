//! SIGINT and SIGTERM end `mbmf run` and `mbmf sweep` cleanly: exit 130 or 143, a message
//! saying what was kept, no temporary file, staging folder or lock left; a run leaves the
//! earlier results untouched, a sweep keeps its committed parts and `--resume` completes it to
//! the dataset of an uninterrupted sweep. A staging folder left by a SIGKILL is removed by the
//! next run on that folder, never one of a live process.
//!
//! Every wait polls for a state (a staging folder, a committed part, the exit) with a generous
//! limit; no test depends on how long anything takes.

mod common;

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::*;

/// Far more than any state below takes to appear on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(180);

fn spawn(args: &[&str]) -> Child {
    mbmf()
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mbmf starts")
}

/// Polls until `ready` holds; panics (after killing the child) if it exits first or never does.
fn wait_until(child: &mut Child, what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("mbmf ended ({status}) before {what}");
        }
        if start.elapsed() > PATIENCE {
            let _ = child.kill();
            panic!("{what}: not seen in {PATIENCE:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn send(child: &Child, signal: i32) {
    // SAFETY: kill(2) on our own child's pid; it touches no memory.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    assert_eq!(rc, 0, "kill failed");
}

/// Waits for the child to exit; returns its exit code and stderr.
fn finish(mut child: Child) -> (Option<i32>, String) {
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > PATIENCE {
            let _ = child.kill();
            panic!("mbmf did not stop within {PATIENCE:?} of the signal");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (status.code(), err)
}

/// Names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn staging(out: &Path, child: &Child) -> PathBuf {
    out.join(format!(".mbmf-run-{}", child.id()))
}

/// The committed pair of a run folder.
fn results(out: &Path) -> (Vec<Row>, Vec<Row>) {
    (
        file_rows(&out.join("runs.parquet"), NONDETERMINISTIC),
        file_rows(&out.join("series.parquet"), NONDETERMINISTIC),
    )
}

/// A run that takes minutes, one run per batch so batches are written one after another.
fn long_run(out: &Path) -> Child {
    spawn(&[
        "run",
        "--controller",
        "ec",
        "--runs",
        "1000",
        "--steps",
        "200000",
        "--batch-size",
        "1",
        "--quiet",
        "--force",
        "--out",
        out.to_str().unwrap(),
    ])
}

fn small_run(out: &Path, extra: &[&str]) {
    let mut args = SMALL_RUN.to_vec();
    args.extend(["--quiet", "--out", out.to_str().unwrap()]);
    args.extend(extra);
    run_ok(&args);
}

#[test]
fn sigint_and_sigterm_stop_a_run_with_nothing_written_and_the_earlier_results_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    small_run(&out, &[]);
    let before = results(&out);
    for (signal, code, name) in [
        (libc::SIGINT, 130, "SIGINT"),
        (libc::SIGTERM, 143, "SIGTERM"),
    ] {
        let mut child = long_run(&out);
        let stage = staging(&out, &child);
        if signal == libc::SIGINT {
            // Mid-run: a first batch is in the staging folder.
            wait_until(&mut child, "a first staged batch", || {
                std::fs::read_dir(&stage).is_ok_and(|mut d| d.next().is_some())
            });
        } else {
            // Right at the start: the staging folder exists, simulation may not have begun.
            wait_until(&mut child, "the staging folder", || stage.exists());
        }
        send(&child, signal);
        let (exit, err) = finish(child);
        assert_eq!(exit, Some(code), "{name}: {err}");
        assert!(
            err.contains(&format!("interrupted by {name}"))
                && err.contains("nothing was written")
                && err.contains("untouched"),
            "{name}: {err}"
        );
        assert_eq!(
            listing(&out),
            ["runs.parquet", "series.parquet"],
            "{name}: staging left"
        );
        assert_eq!(results(&out), before, "{name}: earlier results changed");
    }
}

#[test]
fn a_second_signal_ends_a_run_at_once_and_still_removes_its_staging() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    // One batch of many runs: a stride is long, so the second signal usually comes during it.
    let mut child = spawn(&[
        "run",
        "--controller",
        "ec",
        "--runs",
        "3000",
        "--steps",
        "100000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stage = staging(&out, &child);
    wait_until(&mut child, "the staging folder", || stage.exists());
    send(&child, libc::SIGINT);
    send(&child, libc::SIGINT);
    let (exit, err) = finish(child);
    assert_eq!(exit, Some(130), "{err}");
    assert!(
        err.contains("stopped at once") || err.contains("interrupted by SIGINT"),
        "{err}"
    );
    assert!(listing(&out).is_empty(), "left: {:?}", listing(&out));
}

#[test]
fn a_staging_folder_left_by_sigkill_is_removed_by_the_next_run_but_a_live_one_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let mut child = long_run(&out);
    let stage = staging(&out, &child);
    wait_until(&mut child, "a first staged batch", || {
        std::fs::read_dir(&stage).is_ok_and(|mut d| d.next().is_some())
    });
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(stage.exists(), "SIGKILL leaves the staging folder");
    // This test process is alive: its (pretend) staging folder must survive.
    let live = out.join(format!(".mbmf-run-{}", std::process::id()));
    std::fs::create_dir(&live).unwrap();
    small_run(&out, &[]);
    assert!(!stage.exists(), "the dead run's staging folder is removed");
    assert!(live.exists(), "a live process's staging folder is kept");
    std::fs::remove_dir(&live).unwrap();
    assert_eq!(listing(&out), ["runs.parquet", "series.parquet"]);
}

fn sweep(file: &str, out: &Path, resume: bool) -> Child {
    let mut args = vec![
        "sweep",
        file,
        "--batch-size",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    if resume {
        args.push("--resume");
    }
    spawn(&args)
}

#[test]
fn sigint_and_sigterm_stop_a_sweep_keeping_its_parts_and_resume_gives_the_whole_dataset() {
    let dir = tempfile::tempdir().unwrap();
    // 6 configurations x 8 seeds = 48 runs, one part each: a few seconds in all.
    let sweep_text = six_configurations(8, 20000, 1000);
    let file = write_sweep(dir.path(), "sig.toml", &sweep_text);
    let reference = dir.path().join("reference");
    let (exit, err) = finish(sweep(&file, &reference, false));
    assert_eq!(exit, Some(0), "{err}");
    for (signal, code, name) in [
        (libc::SIGINT, 130, "SIGINT"),
        (libc::SIGTERM, 143, "SIGTERM"),
    ] {
        let out = dir.path().join(name);
        let mut child = sweep(&file, &out, false);
        wait_until(&mut child, "a first committed part", || {
            !parts(&out, "runs").is_empty()
        });
        send(&child, signal);
        let (exit, err) = finish(child);
        assert_eq!(exit, Some(code), "{name}: {err}");
        let resume = format!("mbmf sweep {file} --out {} --resume", out.display());
        assert!(
            err.contains(&format!("interrupted by {name}")) && err.contains(&resume),
            "{name}: {err}"
        );
        let committed = parts(&out, "runs");
        assert!(
            !committed.is_empty() && committed.len() < 48,
            "{name}: {} parts",
            committed.len()
        );
        assert!(
            err.contains(&format!("holds {} of 48 runs", committed.len())),
            "{name}: {err}"
        );
        assert_eq!(
            parts(&out, "series"),
            committed,
            "{name}: a series part without its runs part"
        );
        assert!(
            temporaries(&out).is_empty(),
            "{name}: {:?}",
            temporaries(&out)
        );
        assert_eq!(
            listing(&out),
            ["runs", "series", "sweep.toml"],
            "{name}: lock or temporary left"
        );
        let (exit, err) = finish(sweep(&file, &out, true));
        assert_eq!(exit, Some(0), "{name}: resume: {err}");
        assert_same_dataset(name, &out, &reference);
    }
}
