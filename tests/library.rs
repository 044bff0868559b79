//! The library entry of `mbmf run` ([`mbmf::run`]) as a second front end calls it: the same
//! job gives the same rows as the command line, warnings come back as data, a raised stop flag
//! writes nothing, and refusals say they are usage errors. The job is the one of
//! `examples/run_library.rs`.

mod common;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use common::*;
use mbmf::error::Usage as _;
use mbmf::params::{Controller, Interaction};
use mbmf::run::{Job, Run, RunError, execute};

/// The example front end's job, with the command it records.
#[path = "../examples/run_library.rs"]
mod example;

fn job(out: &Path) -> Job {
    Job {
        command: "a library test".into(),
        ..example::job(out).expect("tidy1 loads")
    }
}

/// The columns of a file whose values depend on when and how it was written, not on the runs.
const ABOUT_THE_WRITING: &[&str] = &["wall_time_s"];

#[test]
fn the_library_entry_writes_the_rows_the_command_line_writes() {
    let dir = tempfile::tempdir().unwrap();
    let lib_out = dir.path().join("lib");
    let stop = AtomicBool::new(false);
    let mut advanced = 0u64;
    let done = execute(job(&lib_out), &stop, |n| advanced += n).expect("the job runs");
    // 8 runs of 1,100 agent-steps each, every one reported.
    assert_eq!(advanced, 8 * 1_100);
    assert_eq!(done.runs, 8);
    assert_eq!(
        done.files,
        [lib_out.join("runs.parquet"), lib_out.join("series.parquet")]
    );
    assert!(done.warnings.is_empty(), "{:?}", done.warnings);
    let controllers: Vec<(Controller, usize)> =
        done.rows.iter().map(|r| (r.controller, r.runs)).collect();
    assert_eq!(controllers, [(Controller::Ec, 4), (Controller::Mf, 4)]);
    // Nothing but the pair is left in the folder: no staging folder, no temporary file.
    let mut names: Vec<String> = std::fs::read_dir(&lib_out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["runs.parquet", "series.parquet"]);

    let cli_out = dir.path().join("cli");
    run_quiet(
        &cli_out,
        &[
            "--controller",
            "ec,mf",
            "--interaction",
            "takeover",
            "--budget",
            "20",
            "--steps",
            "1000",
            "--babbling",
            "100",
            "--runs",
            "4",
            "--seed",
            "7",
        ],
    );
    for file in ["runs.parquet", "series.parquet"] {
        let lib = file_rows(&lib_out.join(file), ABOUT_THE_WRITING);
        let cli = file_rows(&cli_out.join(file), ABOUT_THE_WRITING);
        assert_eq!(lib.len(), if file == "runs.parquet" { 8 } else { 8 * 10 });
        assert_same_rows(file, &lib, &cli);
    }
    // The summary is the runs file's: EC's mean total reward over its 4 runs.
    let runs = file_rows(&lib_out.join("runs.parquet"), ABOUT_THE_WRITING);
    let ec: Vec<f64> = runs
        .iter()
        .filter(|r| r["controller"] == "ec")
        .map(|r| r["total_reward"].parse().unwrap())
        .collect();
    let mean = ec.iter().sum::<f64>() / ec.len() as f64;
    assert!((done.rows[0].reward.0 - mean).abs() < 1e-9 * mean.abs().max(1.0));
    // The provenance records the command the front end gave, and both files share a run id.
    let kv = key_values(&done.files[0]);
    let get = |kv: &[(String, String)], k: &str| {
        kv.iter().find(|(key, _)| key == k).map(|(_, v)| v.clone())
    };
    assert_eq!(get(&kv, "mbmf_command").as_deref(), Some("a library test"));
    let series_kv = key_values(&done.files[1]);
    assert!(get(&kv, "mbmf_run_id").is_some());
    assert_eq!(get(&kv, "mbmf_run_id"), get(&series_kv, "mbmf_run_id"));
}

#[test]
fn a_raised_stop_flag_writes_nothing_and_is_not_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("stopped");
    let stop = AtomicBool::new(true);
    let error = execute(job(&out), &stop, |_| {}).expect_err("stopped");
    assert!(matches!(error, RunError::Interrupted(_)), "{error:?}");
    assert!(!error.is_usage());
    let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn warnings_come_back_as_data_and_refusals_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("twice");
    let mut twice = job(&out);
    twice.configs.push(twice.configs[0]);
    twice
        .configs
        .iter_mut()
        .for_each(|p| p.human.interaction = Interaction::None);
    twice.set = vec!["budget"];
    let run = Run::new(twice).expect("legal");
    assert_eq!(
        run.warnings(),
        [
            "--controller lists ec twice: each listing adds --runs 4 runs (with other run \
             indices), and the summary merges them into one row",
            "--budget 20 has no effect: no interaction uses it (give --interaction, a --profile \
             with one, or a --change STEP:interaction=...)",
        ]
    );

    // Earlier results without `force`: refused before anything is simulated.
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("runs.parquet"), "old").unwrap();
    let mut run = Run::new(job(&out)).unwrap();
    run.size().expect("small enough");
    let error = run.open().expect_err("earlier results");
    assert!(error.is_usage(), "{error:?}");
    assert!(error.to_string().contains("--force"), "{error}");
    assert_eq!(std::fs::read(out.join("runs.parquet")).unwrap(), b"old");

    // A parameter out of range.
    let mut bad = job(&out);
    bad.configs[0].alpha_mf = 2.0;
    let error = Run::new(bad).expect_err("alpha > 1");
    assert!(
        matches!(error, RunError::Invalid(_)) && error.is_usage(),
        "{error:?}"
    );
}

#[test]
fn the_stream_hands_over_the_rows_the_files_hold_batch_by_batch() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lib");
    let done = execute(job(&out), &AtomicBool::new(false), |_| {}).expect("the job runs");
    // 8 runs in batches of 3: 3, 3, 2, in run order.
    let streamed = Run::new(Job {
        batch_size: 3,
        ..job(&dir.path().join("unused"))
    })
    .unwrap();
    let (mut runs, mut series) = (Vec::new(), Vec::new());
    let n = streamed
        .stream(
            &AtomicBool::new(false),
            |_| {},
            |[r, s]| {
                runs.push(r);
                series.push(s);
                std::ops::ControlFlow::Continue(())
            },
        )
        .expect("the job runs");
    assert_eq!(n, 8);
    assert!(
        !dir.path().join("unused").exists(),
        "a stream writes nothing"
    );
    let sizes: Vec<usize> = runs.iter().map(|b| b.num_rows()).collect();
    assert_eq!(sizes, [3, 3, 2]);
    assert_same_rows(
        "runs",
        &batch_rows(&runs, ABOUT_THE_WRITING),
        &file_rows(&done.files[0], ABOUT_THE_WRITING),
    );
    assert_same_rows(
        "series",
        &batch_rows(&series, ABOUT_THE_WRITING),
        &file_rows(&done.files[1], ABOUT_THE_WRITING),
    );
    // A callback that breaks stops the job after that batch.
    let mut seen = 0;
    let stopped = Run::new(Job {
        batch_size: 3,
        ..job(&dir.path().join("unused"))
    })
    .unwrap()
    .stream(
        &AtomicBool::new(false),
        |_| {},
        |_| {
            seen += 1;
            std::ops::ControlFlow::Break(())
        },
    );
    assert!(
        matches!(stopped, Err(RunError::Interrupted(_))),
        "{stopped:?}"
    );
    assert_eq!(seen, 1);
}
