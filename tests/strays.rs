//! Copies are not runs: a stray file in a sweep dataset (`part-… (1).parquet`, anything not
//! named as a part) is warned about and ignored by `sweep --resume`, `compact` and the analysis
//! verbs alike, and a part copied under another part name (so that two parts hold the same
//! runs) is refused by all three, naming both files.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{SMALL, parts, run, run_ok, write_sweep};
use tempfile::TempDir;

/// A finished sweep of `SMALL` in `dir/out`; returns (sweep file, dataset folder).
fn finished(dir: &Path) -> (String, PathBuf) {
    let file = write_sweep(dir, "small.toml", SMALL);
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    run_ok(&["sweep", &file, "--out", o, "--quiet", "--batch-size", "3"]);
    (file, out)
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_copied_part_is_warned_about_and_ignored_by_resume_compact_and_analysis() {
    let dir = TempDir::new().unwrap();
    let (file, out) = finished(dir.path());
    let first = parts(&out, "runs")[0].clone();
    let copy = out
        .join("runs")
        .join(first.replace(".parquet", " (1).parquet"));
    std::fs::copy(out.join("runs").join(&first), &copy).unwrap();
    let o = out.to_str().unwrap();
    let warning = format!(
        "ignoring {}: not a part the sweep committed",
        copy.display()
    );

    let resume = run(&["sweep", &file, "--out", o, "--resume", "--json"]);
    assert!(resume.status.success(), "{}", text(&resume));
    assert!(text(&resume).contains(&warning), "{}", text(&resume));
    let report: serde_json::Value = serde_json::from_slice(&resume.stdout).unwrap();
    assert_eq!(
        (report["ran"].as_u64(), report["done_before"].as_u64()),
        (Some(0), Some(12))
    );

    let stats = run(&["stats", o, "--metric", "total_reward", "--by", "controller"]);
    assert!(stats.status.success(), "{}", text(&stats));
    assert!(text(&stats).contains(&warning), "{}", text(&stats));

    let compact = run(&["compact", o]);
    assert!(compact.status.success(), "{}", text(&compact));
    assert!(text(&compact).contains(&warning), "{}", text(&compact));
    assert!(
        String::from_utf8_lossy(&compact.stdout).contains("12 runs"),
        "{}",
        String::from_utf8_lossy(&compact.stdout)
    );
    // Kept, not deleted by the swap, and still not counted.
    assert!(copy.is_file(), "the copy was deleted");
    let again = run(&["stats", o, "--metric", "total_reward", "--by", "controller"]);
    assert!(again.status.success(), "{}", text(&again));
    assert_eq!(again.stdout, stats.stdout);
}

#[test]
fn a_part_copied_under_another_part_name_is_refused_naming_both_files() {
    let dir = TempDir::new().unwrap();
    let (file, out) = finished(dir.path());
    let first = parts(&out, "runs")[0].clone();
    let copy_name = "part-999998-999999.parquet";
    for sub in ["runs", "series"] {
        std::fs::copy(out.join(sub).join(&first), out.join(sub).join(copy_name)).unwrap();
    }
    let o = out.to_str().unwrap();
    let original = out.join("runs").join(&first).display().to_string();
    let copy = out.join("runs").join(copy_name).display().to_string();
    let names_both = |o: &Output| {
        let e = text(o);
        assert!(
            e.contains(&original) && e.contains(&copy) && e.contains("holds run"),
            "{e}"
        );
        assert!(
            !e.contains("panicked") && !e.contains("internal error"),
            "{e}"
        );
    };

    // A part that is not what it should be is the input's fault in every verb (exit 2).
    let resume = run(&["sweep", &file, "--out", o, "--resume"]);
    assert_eq!(resume.status.code(), Some(2), "{}", text(&resume));
    names_both(&resume);

    let compact = run(&["compact", o]);
    assert_eq!(compact.status.code(), Some(2), "{}", text(&compact));
    names_both(&compact);
    assert!(out.join("runs").join(copy_name).is_file());

    let stats = run(&["stats", o, "--metric", "total_reward", "--by", "controller"]);
    assert_eq!(stats.status.code(), Some(2), "{}", text(&stats));
    names_both(&stats);
}
