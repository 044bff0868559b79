//! `mbmf run --out DIR` over earlier results: refused without `--force`, and with it the two
//! files are replaced as one commit. A process aborted between the two moves
//! (`MBMF_FAULT=after-first-rename`) leaves the old pair readable, never a mix; `mbmf --version`
//! names the commit the binary was built from.

mod common;

use std::path::Path;

use common::*;

fn run_into(out: &Path, seed: &str, extra: &[&str]) -> std::process::Output {
    let mut args = SMALL_RUN.to_vec();
    args.extend([
        "--babbling",
        "50",
        "--checkpoint",
        "100",
        "--seed",
        seed,
        "--quiet",
        "--out",
    ]);
    args.push(out.to_str().unwrap());
    args.extend(extra);
    run(&args)
}

/// The rows of the committed pair of `dir`, as a reader that follows the run id sees them.
fn committed(dir: &Path) -> (Vec<Row>, Vec<Row>) {
    let runs = file_rows(
        &mbmf::output::atomic::committed_file(dir, "runs"),
        NONDETERMINISTIC,
    );
    let series = file_rows(
        &mbmf::output::atomic::committed_file(dir, "series"),
        NONDETERMINISTIC,
    );
    (runs, series)
}

#[test]
fn a_second_run_into_the_same_folder_is_refused_naming_the_files_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    assert!(run_into(&out, "1", &[]).status.success());
    let before = committed(&out);
    let again = run_into(&out, "2", &[]);
    assert_eq!(again.status.code(), Some(2));
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(
        err.contains("runs.parquet") && err.contains("series.parquet") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(committed(&out), before, "a refused run changes nothing");
    // The analyses of the earlier results stay (they are the user's), named in a warning.
    run_ok(&["stats", out.to_str().unwrap(), "--by", "controller"]);
    run_ok(&["pareto", out.to_str().unwrap()]);
    let forced = run_into(&out, "2", &["--force"]);
    assert!(forced.status.success());
    let err = String::from_utf8_lossy(&forced.stderr);
    let analysis = out.join("analysis");
    assert!(
        err.contains("keeps 3 file(s) made from them (pareto.parquet, pareto.png, pareto.svg)")
            && err.contains(&analysis.display().to_string()),
        "{err}"
    );
    assert!(analysis.join("pareto.parquet").is_file());
    // Without analyses, no warning.
    std::fs::remove_dir_all(&analysis).unwrap();
    let quiet = run_into(&out, "2", &["--force"]);
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains("warning"));
    let fresh = dir.path().join("fresh");
    assert!(run_into(&fresh, "2", &[]).status.success());
    assert_eq!(committed(&out), committed(&fresh));
    assert_ne!(committed(&out), before);
}

#[test]
fn a_run_killed_between_the_two_moves_leaves_the_old_pair_for_readers() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    assert!(run_into(&out, "1", &[]).status.success());
    let old = committed(&out);
    let old_id = mbmf::output::atomic::run_id(&out.join("runs.parquet")).unwrap();
    assert_eq!(
        mbmf::output::atomic::run_id(&out.join("series.parquet")).as_deref(),
        Some(old_id.as_str()),
        "both files of a run share its id"
    );

    let killed = mbmf()
        .args(SMALL_RUN)
        .args([
            "--babbling",
            "50",
            "--checkpoint",
            "100",
            "--seed",
            "2",
            "--quiet",
        ])
        .args(["--force", "--out", out.to_str().unwrap()])
        .env("MBMF_FAULT", "after-first-rename")
        .output()
        .unwrap();
    assert!(!killed.status.success(), "the fault aborts the process");
    // The new series file is in place, the runs file is still the old one: the pair a reader
    // that follows the run id gets is the old one, whole.
    let visible_series = file_rows(&out.join("series.parquet"), NONDETERMINISTIC);
    assert_ne!(
        visible_series, old.1,
        "the fault struck after the first move"
    );
    assert_eq!(committed(&out), old);
    assert_eq!(
        mbmf::output::atomic::run_id(&mbmf::output::atomic::committed_file(&out, "series")),
        Some(old_id)
    );

    // The next run commits a whole new pair and removes the interrupted one's copy.
    assert!(run_into(&out, "2", &["--force"]).status.success());
    let fresh = dir.path().join("fresh");
    assert!(run_into(&fresh, "2", &[]).status.success());
    assert_eq!(committed(&out), committed(&fresh));
    let left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut left = left;
    left.sort();
    assert_eq!(left, ["runs.parquet", "series.parquet"]);
}

#[test]
fn version_names_the_commit() {
    let out = run_ok(&["--version"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("commit "), "{text}");
    assert!(
        text.contains(mbmf::output::provenance::GIT_COMMIT),
        "{text}"
    );
}
