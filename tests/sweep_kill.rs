//! Crash safety of `mbmf sweep`: SIGKILL the process at many moments, check that no visible
//! file is truncated, resume (sometimes killing the resume too), and check that the dataset
//! equals an uninterrupted run's, no lost and no duplicated row, with nothing else left.

mod common;

use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::*;

const TRIALS: u64 = 24;

fn start(file: &str, out: &Path, resume: bool) -> Child {
    let mut cmd = mbmf();
    cmd.args(["sweep", file, "--quiet", "--batch-size", "3", "--out"])
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if resume {
        cmd.arg("--resume");
    }
    cmd.spawn().expect("mbmf starts")
}

/// Kills `child` with SIGKILL after `delay`; true if it was still running.
fn kill_after(mut child: Child, delay: Duration) -> bool {
    std::thread::sleep(delay);
    let running = child.try_wait().unwrap().is_none();
    child.kill().unwrap();
    child.wait().unwrap();
    running
}

/// What a killed process may leave: hidden temporaries and uncommitted series parts, never a
/// truncated file under a final name, and never a runs part without its series part.
fn check_after_kill(out: &Path, trial: u64) {
    let runs = parts(out, "runs");
    let series = parts(out, "series");
    for name in &runs {
        assert!(
            series.contains(name),
            "trial {trial}: runs/{name} committed before its series part"
        );
    }
    for (sub, names) in [("runs", &runs), ("series", &series)] {
        for name in names {
            // Panics with the file name if the file is not complete Parquet.
            file_rows(&out.join(sub).join(name), &[]);
        }
    }
}

/// A deterministic pseudo-random number in [0, 1) (SplitMix64), so failures reproduce.
fn unit(i: u64) -> f64 {
    let mut z = i.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn sigkill_at_random_moments_then_resume_gives_the_uninterrupted_dataset() {
    let dir = tempfile::tempdir().unwrap();
    // 6 configurations x 6 seeds = 36 runs in 12 parts of 3: about 0.3 s, much of it in fsync.
    let file = write_sweep(dir.path(), "kill.toml", &six_configurations(6, 1500, 100));
    let reference = dir.path().join("reference");
    let started = Instant::now();
    let status = start(&file, &reference, false).wait().unwrap();
    assert!(status.success());
    // Kill points cover the whole of a run on this machine, start-up included.
    let span = started.elapsed().mul_f64(1.1);
    let (ref_runs, _) = dataset(&reference);
    assert_eq!(ref_runs.len(), 36);

    let mut killed_running = 0;
    for trial in 0..TRIALS {
        let out = dir.path().join(format!("trial-{trial}"));
        if kill_after(start(&file, &out, false), span.mul_f64(unit(trial))) {
            killed_running += 1;
        }
        check_after_kill(&out, trial);
        // One trial in three kills the resume as well.
        if trial % 3 == 0 {
            if kill_after(start(&file, &out, true), span.mul_f64(unit(1000 + trial))) {
                killed_running += 1;
            }
            check_after_kill(&out, trial);
        }
        let resumed = start(&file, &out, true).wait_with_output().unwrap();
        assert!(resumed.status.success(), "trial {trial}: resume failed");
        assert_same_dataset(&format!("trial {trial}"), &out, &reference);
        assert!(
            temporaries(&out).is_empty(),
            "trial {trial}: temporaries left: {:?}",
            temporaries(&out)
        );
        assert!(
            !out.join(".lock-0-of-1").exists(),
            "trial {trial}: lock file left"
        );
        // Nothing else either: no copy of the sweep text a kill during start-up left.
        let mut top: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        top.sort();
        assert_eq!(top, ["runs", "series", "sweep.toml"], "trial {trial}");
        assert_eq!(parts(&out, "series"), parts(&out, "runs"), "trial {trial}");
        std::fs::remove_dir_all(&out).unwrap();
    }
    eprintln!(
        "{TRIALS} trials: {killed_running} SIGKILLs hit a running process (kill points spread over {span:?})"
    );
    assert!(killed_running >= 1, "no kill hit a running process");
}
