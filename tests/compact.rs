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
    // A live writer is no usage error (exit 1, as for sweep).
    assert_eq!(e.status.code(), Some(1));
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(err.contains("being written by"), "{err}");
    common::release_lock(lock, &out.join(".lock-1-of-2"));
    run_ok(&["compact", out.to_str().unwrap()]);

    let e = run(&["compact", dir.path().to_str().unwrap()]);
    assert_eq!(e.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&e.stderr).contains("not a sweep dataset"));
}

/// Parts written by two shards (two commands) merged into one file keep what told them apart:
/// the keys on which they disagree say so at the top, and `mbmf_merged_parts` records each
/// part's values of them. A dataset with nothing left to merge is not rewritten.
#[test]
fn compact_keeps_every_merged_parts_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    // One kind of run (one controller and human), so every part merges into one file.
    let file = write_sweep(
        dir.path(),
        "kappa.toml",
        "seeds = 2\n[fixed]\ntask = \"tidy1\"\ncontroller = \"ec\"\nsteps = 200\nbabbling = 50\n\
         [grid]\nkappa_coeff = [0, 1, 2, 3]\n",
    );
    for shard in ["0/2", "1/2"] {
        let o = out.to_str().unwrap();
        run_ok(&[
            "sweep",
            &file,
            "--out",
            o,
            "--quiet",
            "--batch-size",
            "2",
            "--shard",
            shard,
        ]);
    }
    let before = parts(&out.join("runs"));
    assert_eq!(before.len(), 4, "{before:?}");
    let get = |kv: &[(String, String)], key: &str| {
        kv.iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .unwrap_or_else(|| panic!("no {key}"))
    };
    let originals: Vec<Vec<(String, String)>> = before
        .iter()
        .map(|p| key_values(&out.join("runs").join(p)))
        .collect();
    let commands: Vec<String> = originals.iter().map(|kv| get(kv, "mbmf_command")).collect();
    assert!(commands.iter().any(|c| c.contains("--shard 0/2")));
    assert!(commands.iter().any(|c| c.contains("--shard 1/2")));

    run_ok(&["compact", out.to_str().unwrap(), "--runs-per-file", "100"]);
    assert_eq!(parts(&out.join("runs")).len(), 1);
    for table in ["runs", "series"] {
        let name = &parts(&out.join(table))[0];
        let kv = key_values(&out.join(table).join(name));
        // What the shards disagree on is flagged, what they share is kept.
        assert!(get(&kv, "mbmf_command").starts_with("(differs"), "{kv:?}");
        assert!(get(&kv, "mbmf_shard").starts_with("(differs"), "{kv:?}");
        assert_eq!(get(&kv, "mbmf_sweep_runs"), "8");
        let starts: Vec<String> = originals
            .iter()
            .map(|kv| get(kv, "mbmf_started_utc"))
            .collect();
        assert_eq!(get(&kv, "mbmf_started_utc"), *starts.iter().min().unwrap());
        assert!(get(&kv, "mbmf_compacted_by").contains("compact"));
        let merged: serde_json::Value =
            serde_json::from_str(&get(&kv, "mbmf_merged_parts")).unwrap();
        let mut recorded: Vec<(String, String)> = merged
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                assert!(r["mbmf_ended_utc"].is_string(), "{r}");
                let part = r["part"].as_str().unwrap().to_owned();
                (part, r["mbmf_command"].as_str().unwrap().to_owned())
            })
            .collect();
        recorded.sort();
        let mut expected: Vec<(String, String)> = before
            .iter()
            .cloned()
            .zip(commands.iter().cloned())
            .collect();
        expected.sort();
        assert_eq!(recorded, expected, "{table}");
    }

    // Nothing left to merge: the file is left as it is.
    let merged_file = out.join("runs").join(&parts(&out.join("runs"))[0]);
    let bytes = std::fs::read(&merged_file).unwrap();
    let again = run_ok(&["compact", out.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&again.stdout).contains("1 part"),
        "{again:?}"
    );
    assert_eq!(std::fs::read(&merged_file).unwrap(), bytes);
}
