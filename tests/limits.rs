//! Memory limits a job runs under (a cgroup's, `ulimit -v`), through the built binary: batches
//! are planned for the tightest limit, a run that cannot fit is refused before the first step
//! naming the limit and the flag, and running out of memory is an error that cleans up, never
//! an abort.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::mbmf;
use mbmf::limits::ROOT_VAR;
use mbmf::params::{Controller, Params};
use tempfile::TempDir;

fn write(root: &Path, path: &str, text: &str) {
    let file = root.join(path);
    std::fs::create_dir_all(file.parent().expect("a parent")).expect("mkdir");
    std::fs::write(file, text).expect("write");
}

/// What `mbmf run` left in `out` besides its two tables (staging folders, temporaries).
fn leftovers(out: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Vec::new();
    };
    entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != "runs.parquet" && n != "series.parquet")
        .collect()
}

/// `mbmf ARGS` under `ulimit -v KIB`.
fn under_ulimit(kib: u64, args: &[&str]) -> Output {
    let exe = env!("CARGO_BIN_EXE_mbmf");
    Command::new("bash")
        .arg("-c")
        .arg(format!("ulimit -v {kib}; exec \"$0\" \"$@\""))
        .arg(exe)
        .args(args)
        .output()
        .expect("bash starts")
}

/// The batch size for 150 MiB of headroom (a cgroup's 200 MiB limit, 50 MiB in use), by hand:
/// half of it for batches, over the bytes of one tidy1 mf run of 2000 steps checkpointed at
/// every step.
fn batch_in_150_mib() -> usize {
    let spec = mbmf::env::load("tidy1").expect("tidy1");
    let params = Params {
        controller: Controller::Mf,
        steps: 2000,
        checkpoint: 1,
        ..Params::default()
    };
    let per_run = mbmf::pipeline::bytes_per_run(&spec, &params, false);
    ((150u64 << 20) / 2 / per_run) as usize
}

#[test]
fn a_cgroup_limit_sizes_the_batches() {
    let root = TempDir::new().expect("tempdir");
    let out = TempDir::new().expect("tempdir");
    // 200 MiB limit, 50 MiB in use: 150 MiB left, half of it for batches.
    write(root.path(), "proc/self/cgroup", "0::/job\n");
    write(root.path(), "sys/fs/cgroup/job/memory.max", "209715200\n");
    write(
        root.path(),
        "sys/fs/cgroup/job/memory.current",
        "52428800\n",
    );
    let run = mbmf()
        .env(ROOT_VAR, root.path())
        .args([
            "run",
            "--controller",
            "mf",
            "--runs",
            "200",
            "--steps",
            "2000",
        ])
        .args(["--checkpoint", "1", "--json", "--out"])
        .arg(out.path())
        .output()
        .expect("mbmf starts");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let expected = batch_in_150_mib();
    assert!(expected < 200, "the limit must bind: {expected}");
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
    assert_eq!(report["batch_size"], expected, "{report}");
    assert!(
        String::from_utf8_lossy(&run.stderr).contains(&format!("simulating {expected} runs")),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn a_run_larger_than_the_cgroup_leaves_is_refused_naming_the_limit() {
    let root = TempDir::new().expect("tempdir");
    let out = TempDir::new().expect("tempdir");
    write(
        root.path(),
        "proc/self/cgroup",
        "4:memory:/slurm/job1\n0::/\n",
    );
    write(
        root.path(),
        "sys/fs/cgroup/memory/slurm/job1/memory.limit_in_bytes",
        "10485760\n",
    );
    write(
        root.path(),
        "sys/fs/cgroup/memory/slurm/job1/memory.usage_in_bytes",
        "9437184\n",
    );
    // 20000 checkpoint rows: about 11 MiB for one run, 1 MiB left.
    let run = mbmf()
        .env(ROOT_VAR, root.path())
        .args([
            "run",
            "--controller",
            "mf",
            "--runs",
            "2",
            "--steps",
            "20000",
        ])
        .args(["--checkpoint", "1", "--out"])
        .arg(out.path())
        .output()
        .expect("mbmf starts");
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(
        err.contains("memory.limit_in_bytes")
            && err.contains("cgroup")
            && err.contains("raise --checkpoint"),
        "{err}"
    );
    assert!(
        leftovers(out.path()).is_empty(),
        "{:?}",
        leftovers(out.path())
    );
}

#[test]
fn under_ulimit_v_batches_shrink_and_nothing_aborts() {
    let out = TempDir::new().expect("tempdir");
    let args = |out: &Path| -> Vec<String> {
        [
            "run",
            "--controller",
            "mf",
            "--runs",
            "2000",
            "--steps",
            "2000",
            "--checkpoint",
            "1",
            "--json",
            "--force",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.display().to_string()])
        .collect()
    };
    let args = args(out.path());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    // 2 GB of address space: 4096 runs of about 1 MiB do not fit, a smaller batch does.
    let run = under_ulimit(2_000_000, &args);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
    let size = report["batch_size"].as_u64().expect("a batch size");
    assert!((1..2000).contains(&size), "{report}");
    // Tighter limits either run, or fail with a message and exit 1 or 2: never an abort, and
    // never a staging folder left behind.
    for kib in [600_000, 400_000, 250_000] {
        let run = under_ulimit(kib, &args);
        let err = String::from_utf8_lossy(&run.stderr);
        let code = run.status.code();
        assert!(
            matches!(code, Some(0..=2)),
            "ulimit -v {kib}: {code:?} {err}"
        );
        assert!(!err.contains("memory allocation of"), "{err}");
        if code != Some(0) {
            assert!(
                err.contains("ulimit -v") && err.contains("--batch-size"),
                "{err}"
            );
        }
        assert!(
            leftovers(out.path()).is_empty(),
            "{:?}",
            leftovers(out.path())
        );
    }
    // Too little for even one run: refused before the first step, naming the limit.
    let run = under_ulimit(60_000, &args);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{err}");
    assert!(
        err.contains("ulimit -v") && err.contains("one run needs"),
        "{err}"
    );
    assert!(
        leftovers(out.path()).is_empty(),
        "{:?}",
        leftovers(out.path())
    );
}

#[test]
fn a_sweep_plans_its_batches_for_the_cgroup_limit_too() {
    let root = TempDir::new().expect("tempdir");
    let dir = TempDir::new().expect("tempdir");
    write(root.path(), "proc/self/cgroup", "0::/\n");
    // At the mount itself (a cgroup namespace): 200 MiB limit, 50 MiB in use.
    write(root.path(), "sys/fs/cgroup/memory.max", "209715200\n");
    write(root.path(), "sys/fs/cgroup/memory.current", "52428800\n");
    let file = common::write_sweep(
        dir.path(),
        "big.toml",
        "seeds = 100\n[fixed]\ntask = \"tidy1\"\ncontroller = \"mf\"\nsteps = 2000\n\
         checkpoint = 1\n",
    );
    let out = dir.path().join("out");
    let run = mbmf()
        .env(ROOT_VAR, root.path())
        .args(["sweep", &file, "--quiet", "--json", "--out"])
        .arg(&out)
        .output()
        .expect("mbmf starts");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let expected = batch_in_150_mib();
    assert!(expected < 100, "the limit must bind: {expected}");
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
    assert_eq!(report["batch_size"], expected, "{report}");
    // Parts of at most that many runs hold every run once.
    assert_eq!(
        report["parts_written"],
        100usize.div_ceil(expected),
        "{report}"
    );
    assert_eq!(report["ran"], 100, "{report}");
}
