//! `mbmf reproduce --study arbitration --quick` end to end: the datasets, the report (read back
//! from the Parquet files it wrote), the figures, and a resume after an interruption that
//! reruns no finished cell and gives the same report.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::SystemTime;

use mbmf::analysis::dataset::read_dataset;
use mbmf::reproduce::ReproduceError;
use mbmf::reproduce::arbitration::{Options, arbitration, default_sweeps_dir};
use mbmf::sweep::RunError;

mod common;

/// Rules per condition in `sweeps/arbitration-*.toml`.
const RULES: usize = 22;

fn options(out: &Path) -> Options {
    Options {
        out: out.to_path_buf(),
        quick: true,
        runs: Some(2),
        sweeps_dir: default_sweeps_dir(),
        command: "mbmf reproduce --study arbitration --quick --runs 2".to_string(),
    }
}

/// Every data file of `dir` with its modification time.
fn parts(dir: &Path) -> BTreeMap<String, SystemTime> {
    let mut out = BTreeMap::new();
    for table in ["runs", "series"] {
        let Ok(entries) = std::fs::read_dir(dir.join(table)) else {
            continue;
        };
        for e in entries {
            let e = e.unwrap();
            let name = format!("{table}/{}", e.file_name().to_string_lossy());
            out.insert(name, e.metadata().unwrap().modified().unwrap());
        }
    }
    out
}

/// The report without what legitimately differs between two calls: the output folder and the
/// line saying what this call simulated and in how long.
fn normalised(report: &str, out: &Path) -> String {
    report
        .replace(&out.display().to_string(), "OUT")
        .lines()
        .filter(|l| !l.contains("simulated by this call"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_quick_study_writes_its_datasets_report_and_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("arb");
    let output = common::run_ok(&[
        "reproduce",
        "--study",
        "arbitration",
        "--quick",
        "--runs",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("most reward:"), "{stdout}");
    assert!(stdout.contains("fastest recovery:"), "{stdout}");

    // Every cell is in the data, read back from the Parquet parts.
    let tidy = read_dataset(&out.join("tidy"), "runs").unwrap();
    assert_eq!(tidy.len(), 3 * RULES * 2);
    let objective = read_dataset(&out.join("objective"), "runs").unwrap();
    assert_eq!(objective.len(), RULES * 2);
    let twostep = read_dataset(&out.join("twostep"), "runs").unwrap();
    assert_eq!(twostep.len(), RULES * 2);
    let navworld = common::navworld_task().is_some();
    if navworld {
        let nav = read_dataset(&out.join("navworld"), "runs").unwrap();
        assert_eq!(nav.len(), 2 * RULES * 2);
    }

    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("**Quick version**"));
    for heading in [
        "### tidy1, none",
        "### tidy1, paper-congratulation",
        "### tidy1, paper-takeover",
        "### tidy1, boxes change",
        "### Two-step signatures",
    ] {
        assert!(report.contains(heading), "no {heading} in the report");
    }
    // One table row per rule in each condition, with Holm-corrected p-values beside EC's.
    let rows = report
        .lines()
        .filter(|l| l.starts_with("| reliability mix b=2 |"))
        .count();
    // tidy x3, objective (table and P(MB) window table), twostep (+ navworld x2 with P(MB)).
    let expected = 3 + 2 + 1 + if navworld { 4 } else { 0 };
    assert!(
        rows >= expected,
        "{rows} rows of reliability mix b=2\n{report}"
    );
    assert!(report.contains("Holm-corrected"));
    for figure in [
        "front_tidy",
        "front_objective",
        "p_mb_tidy1_boxes_change",
        "cum_reward_tidy1_boxes_change",
    ] {
        let png = out.join("figures").join(format!("{figure}.png"));
        assert!(png.is_file(), "{} is missing", png.display());
    }
    if navworld {
        assert!(out.join("figures/p_mb_navworld_goal_moves.png").is_file());
        assert!(out.join("figures/front_navworld.png").is_file());
    } else {
        assert!(report.contains("skipped the navworld sweep"));
    }
}

#[test]
fn an_interrupted_study_resumes_without_rerunning_finished_cells_and_gives_the_same_report() {
    let dir = tempfile::tempdir().unwrap();

    // An uninterrupted study.
    let whole = dir.path().join("whole");
    let stop_never = AtomicBool::new(false);
    let first = arbitration(&options(&whole), &stop_never, |_| {}, |_| {}).unwrap();
    assert_eq!(first.ran, first.runs);

    // The same study, stopped a third of the way through (inside the tidy sweep: the twostep
    // sweep, run first, is much shorter than a third).
    let cut = dir.path().join("cut");
    let stop = AtomicBool::new(false);
    let total = AtomicU64::new(0);
    let mut done = 0;
    let err = arbitration(
        &options(&cut),
        &stop,
        |n| total.store(n, Ordering::Relaxed),
        |n| {
            done += n;
            if done * 3 > total.load(Ordering::Relaxed) {
                stop.store(true, Ordering::Relaxed);
            }
        },
    )
    .expect_err("the study was stopped");
    assert!(
        matches!(err, ReproduceError::Run(RunError::Interrupted(_))),
        "{err}"
    );
    assert!(!cut.join("report.md").exists());
    let twostep_before = parts(&cut.join("twostep"));
    let tidy_before = parts(&cut.join("tidy"));
    assert!(!twostep_before.is_empty() && !tidy_before.is_empty());

    // Resumed: the finished cells are not run again (their files untouched), the rest is.
    stop.store(false, Ordering::Relaxed);
    let resumed = arbitration(&options(&cut), &stop, |_| {}, |_| {}).unwrap();
    assert_eq!(resumed.runs, first.runs);
    assert!(resumed.ran > 0 && resumed.ran < resumed.runs, "{resumed:?}");
    assert_eq!(parts(&cut.join("twostep")), twostep_before);
    let tidy_after = parts(&cut.join("tidy"));
    for (name, modified) in &tidy_before {
        if name.starts_with("runs/") {
            assert_eq!(tidy_after.get(name), Some(modified), "{name} was rewritten");
        }
    }
    assert!(resumed.notes.iter().any(|n| n.contains("already done")));

    // And the report is the uninterrupted study's.
    let a = std::fs::read_to_string(whole.join("report.md")).unwrap();
    let b = std::fs::read_to_string(cut.join("report.md")).unwrap();
    assert_eq!(normalised(&a, &whole), normalised(&b, &cut));

    // A third call finds everything done and simulates nothing.
    let again = arbitration(&options(&cut), &stop, |_| {}, |_| {}).unwrap();
    assert_eq!(again.ran, 0);
    let c = std::fs::read_to_string(cut.join("report.md")).unwrap();
    assert_eq!(normalised(&b, &cut), normalised(&c, &cut));
}
