//! The Slurm job array of `sweeps/slurm/sweep-array.sbatch` on a real single-node Slurm cluster
//! (`scripts/slurm-setup.sh` starts one): the union of the array's shards equals a
//! single-process run. Without Slurm the test is skipped with a message, except under CI
//! (`CI=true`), where a missing Slurm fails it.

mod common;

use std::path::Path;
use std::process::Command;

use common::*;

/// Why Slurm cannot be used here, if it cannot.
fn slurm_missing() -> Option<String> {
    let out = match Command::new("sinfo").args(["-h", "-o", "%t"]).output() {
        Ok(out) => out,
        Err(e) => return Some(format!("sinfo cannot run ({e})")),
    };
    let states = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        return Some(format!(
            "sinfo fails: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let usable = states
        .lines()
        .any(|s| ["idle", "mix", "alloc", "comp"].contains(&s.trim()));
    (!usable).then(|| format!("no usable Slurm node (sinfo states: {:?})", states.trim()))
}

/// Submits the sweep as a job array and waits for it; panics with the jobs' logs on failure.
fn submit(array: &str, sweep: &str, out: &Path, logs: &Path) {
    std::fs::create_dir_all(logs).unwrap();
    let script = repo().join("sweeps/slurm/sweep-array.sbatch");
    let result = Command::new("timeout")
        .arg("300")
        .arg("sbatch")
        .args(["--parsable", "--wait", "--cpus-per-task=1", "--time=5"])
        .arg(format!("--array={array}"))
        .arg(format!("--chdir={}", logs.display()))
        .arg(format!("--output={}/slurm-%A_%a.out", logs.display()))
        .arg(format!(
            "--export=ALL,SWEEP={sweep},OUT={},MBMF={}",
            out.display(),
            env!("CARGO_BIN_EXE_mbmf")
        ))
        .arg(&script)
        .output()
        .expect("sbatch runs");
    if !result.status.success() {
        let mut logs_text = String::new();
        for entry in std::fs::read_dir(logs).unwrap().flatten() {
            logs_text += &format!(
                "----- {} -----\n{}\n",
                entry.path().display(),
                std::fs::read_to_string(entry.path()).unwrap_or_default()
            );
        }
        panic!(
            "sbatch --array={array} failed ({:?}): {}{}\n{logs_text}",
            result.status,
            String::from_utf8_lossy(&result.stdout),
            String::from_utf8_lossy(&result.stderr)
        );
    }
}

#[test]
fn a_slurm_job_array_writes_shards_whose_union_equals_one_process() {
    if let Some(why) = slurm_missing() {
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!(
                "CI=true but Slurm is not available: {why}; .ci/run runs scripts/slurm-setup.sh first"
            );
        }
        eprintln!(
            "SKIP Slurm job-array test: {why} (start a local cluster with scripts/slurm-setup.sh, as root)"
        );
        return;
    }
    // Slurm jobs run as another process tree: give them a world-readable folder.
    let dir = tempfile::Builder::new()
        .prefix("mbmf-slurm-test")
        .tempdir_in("/tmp")
        .unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let single = dir.path().join("single");
    run_ok(&["sweep", &file, "--out", single.to_str().unwrap(), "--quiet"]);

    // Three shards, run side by side on the node's CPUs, into one folder.
    let zero_based = dir.path().join("array-0-2");
    submit("0-2", &file, &zero_based, &dir.path().join("logs-a"));
    assert_same_dataset("sbatch --array=0-2 vs one process", &zero_based, &single);
    let parts_written = parts(&zero_based, "runs").len();
    assert!(
        parts_written >= 3,
        "one part per shard at least, got {parts_written}"
    );

    // An array numbered from 1: mbmf subtracts SLURM_ARRAY_TASK_MIN.
    let one_based = dir.path().join("array-1-3");
    submit("1-3", &file, &one_based, &dir.path().join("logs-b"));
    assert_same_dataset("sbatch --array=1-3 vs one process", &one_based, &single);
}
