//! `mbmf compact DIR`: a finished sweep's parts merged into large files, swapped in at once.
//! The rows are unchanged, `--resume` finds the dataset complete, the analysis verbs read it
//! as before, parts never mix controllers (so filters skip files), and an incomplete or locked
//! dataset is refused.

mod common;

use std::path::Path;

use common::*;

fn parts(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".parquet"))
        .collect();
    names.sort();
    names
}

fn sweep_into(dir: &Path, out: &Path, extra: &[&str]) {
    let file = write_sweep(dir, "small.toml", SMALL);
    let mut args = vec!["sweep", &file, "--out", out.to_str().unwrap(), "--quiet"];
    args.extend(extra);
    run_ok(&args);
}

#[test]
fn compact_merges_parts_without_changing_a_row_and_resume_finds_it_complete() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    sweep_into(dir.path(), &out, &["--batch-size", "2"]);
    let reference = dir.path().join("ref");
    sweep_into(dir.path(), &reference, &[]);
    let before = parts(&out.join("runs"));
    assert!(before.len() >= 6, "{before:?}");
    // Every part holds one controller, so a filter on it skips the others.
    for name in &before {
        let rows = file_rows(&out.join("runs").join(name), &[]);
        assert!(
            rows.iter()
                .all(|r| r["controller"] == rows[0]["controller"]),
            "{name}"
        );
    }
    let pareto_before = run_ok(&["pareto", out.to_str().unwrap(), "--no-plot"]).stdout;

    let done = run_ok(&["compact", out.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&done.stdout);
    assert!(text.contains("12 runs"), "{text}");
    let after = parts(&out.join("runs"));
    assert_eq!(after, parts(&out.join("series")));
    // SMALL has two controllers x two (interaction, budget) pairs: four groups, one file each.
    assert_eq!(after.len(), 4, "{after:?}");
    for name in &after {
        let rows = file_rows(&out.join("runs").join(name), &[]);
        assert!(
            rows.iter()
                .all(|r| r["controller"] == rows[0]["controller"]),
            "{name}"
        );
    }
    assert_same_dataset("compacted", &out, &reference);
    let pareto_after = run_ok(&["pareto", out.to_str().unwrap(), "--no-plot"]).stdout;
    // The same front; only the number of files read, on the first line, differs.
    let (before, after_text) = (
        String::from_utf8_lossy(&pareto_before).into_owned(),
        String::from_utf8_lossy(&pareto_after).into_owned(),
    );
    assert!(
        after_text
            .lines()
            .next()
            .unwrap()
            .contains("(4 runs files): 12 runs"),
        "{after_text}"
    );
    assert!(
        before.lines().skip(1).eq(after_text.lines().skip(1)),
        "{before}\n{after_text}"
    );
    // A resume has nothing left to run, and no staging folder is left beside the dataset.
    let file = dir.path().join("small.toml");
    let resumed = run_ok(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
    ]);
    assert_same_dataset("resumed after compact", &out, &reference);
    assert!(
        parts(&out.join("runs")) == after,
        "{:?}",
        String::from_utf8_lossy(&resumed.stdout)
    );
    let siblings: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(siblings.is_empty(), "{siblings:?}");
}

#[test]
fn compact_refuses_an_incomplete_a_locked_and_a_foreign_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    sweep_into(dir.path(), &out, &["--batch-size", "2", "--shard", "0/2"]);
    let before = parts(&out.join("runs"));
    let e = run(&["compact", out.to_str().unwrap()]);
    assert_eq!(e.status.code(), Some(2));
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(
        err.contains("incomplete") && err.contains("of 12 runs") && err.contains("--resume"),
        "{err}"
    );
    assert_eq!(parts(&out.join("runs")), before);
    // The command it suggests names the dataset's own copy of the sweep file, and works.
    let copy = out.join("sweep.toml");
    let suggested = format!(
        "mbmf sweep {} --out {} --resume",
        copy.display(),
        out.display()
    );
    assert!(err.contains(&suggested), "{err}");
    run_ok(&[
        "sweep",
        copy.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
        "--quiet",
    ]);
    let (lock, _) =
        mbmf::sweep::store::Lock::acquire(&out, mbmf::sweep::Shard { index: 1, count: 2 }).unwrap();
    let e = run(&["compact", out.to_str().unwrap()]);
    assert_ne!(e.status.code(), Some(0));
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(err.contains("being written by"), "{err}");
    common::release_lock(lock, &out.join(".lock-1-of-2"));
    run_ok(&["compact", out.to_str().unwrap()]);

    let e = run(&["compact", dir.path().to_str().unwrap()]);
    assert_eq!(e.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&e.stderr).contains("not a sweep dataset"));
}
