//! The per-step trace (SPEC 14): `--trace` on `mbmf run` and `mbmf sweep`, read back through the
//! dataset reader. A traced run's rows are checked by hand on a tiny takeover run and against
//! the runs and series tables (rewards, interactions, P(MB), decisions) for every controller;
//! tracing moves no result; the trace itself does not depend on threads or batch size; a
//! traced sweep survives kills and resumes with its trace committed with its runs.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::*;
use mbmf::analysis::dataset::{Table, Value, read_dataset, read_trace};

/// One trace row, typed.
#[derive(Debug, Clone, PartialEq)]
struct Step {
    run: i64,
    step: i64,
    state: i64,
    action: Option<i64>,
    next_state: i64,
    reward: f64,
    terminal: bool,
    actor: String,
    p_mb: Option<f64>,
    event: String,
}

fn int(t: &Table, name: &str, i: usize) -> Option<i64> {
    match t.column(name).unwrap().value(i) {
        Value::Int(v) => Some(v),
        Value::Null => None,
        other => panic!("{name}: {other:?} is not an integer"),
    }
}

fn text(t: &Table, name: &str, i: usize) -> String {
    match t.column(name).unwrap().value(i) {
        Value::Str(s) => s,
        other => panic!("{name}: {other:?} is not text"),
    }
}

/// The trace of the dataset at `dir`, sorted by run then step.
fn trace(dir: &Path) -> Vec<Step> {
    let t = read_trace(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut steps: Vec<Step> = (0..t.len())
        .map(|i| Step {
            run: int(&t, "run_index", i).unwrap(),
            step: int(&t, "step", i).unwrap(),
            state: int(&t, "state", i).unwrap(),
            action: int(&t, "action", i),
            next_state: int(&t, "next_state", i).unwrap(),
            reward: t.column("reward").unwrap().f64_at(i).unwrap(),
            terminal: matches!(t.column("terminal").unwrap().value(i), Value::Bool(true)),
            actor: text(&t, "actor", i),
            p_mb: t.column("p_mb").unwrap().f64_at(i),
            event: text(&t, "human_event", i),
        })
        .collect();
    steps.sort_by_key(|s| (s.run, s.step));
    steps
}

/// A numeric column of the runs (or series) table, by run index (and step).
fn runs_column(dir: &Path, name: &str) -> BTreeMap<i64, f64> {
    let t = read_dataset(dir, "runs").unwrap();
    (0..t.len())
        .map(|i| {
            (
                int(&t, "run_index", i).unwrap(),
                t.column(name).unwrap().f64_at(i).unwrap_or(f64::NAN),
            )
        })
        .collect()
}

/// Series rows: (run, step) -> (p_mb_mean, decisions).
fn series(dir: &Path) -> BTreeMap<(i64, i64), (Option<f64>, i64)> {
    let t = read_dataset(dir, "series").unwrap();
    (0..t.len())
        .map(|i| {
            (
                (
                    int(&t, "run_index", i).unwrap(),
                    int(&t, "step", i).unwrap(),
                ),
                (
                    t.column("p_mb_mean").unwrap().f64_at(i),
                    int(&t, "decisions", i).unwrap(),
                ),
            )
        })
        .collect()
}

fn traced_run(out: &Path, args: &[&str]) {
    let mut all = args.to_vec();
    all.push("--trace");
    run_quiet(out, &all);
}

/// Checks what must hold of every traced run, against the runs and series tables of `dir`
/// (`steps` experiment steps per run).
fn check_invariants(dir: &Path, steps: i64) -> Vec<Step> {
    let rows = trace(dir);
    let total = runs_column(dir, "total_reward");
    assert_eq!(
        rows.len() as i64,
        steps * total.len() as i64,
        "a row per step"
    );
    let by_run = |r: i64| rows.iter().filter(move |s| s.run == r);
    let series = series(dir);
    for (&r, &total_reward) in &total {
        let run: Vec<&Step> = by_run(r).collect();
        let numbers: Vec<i64> = run.iter().map(|s| s.step).collect();
        assert_eq!(
            numbers,
            (1..=steps).collect::<Vec<_>>(),
            "run {r}: steps 1.."
        );
        for w in run.windows(2) {
            assert_eq!(w[0].next_state, w[1].state, "run {r} step {}", w[0].step);
            // A reset step follows a terminal arrival (in the tidy tasks, always).
            if w[1].actor == "reset" {
                assert!(w[0].terminal, "run {r} step {}", w[1].step);
            }
        }
        // Summed in step order as the run adds it up: the same bits.
        let sum = run.iter().fold(0.0, |a, s| a + s.reward);
        assert_eq!(sum.to_bits(), total_reward.to_bits(), "run {r}: rewards");
        for s in &run {
            let decision = matches!(s.actor.as_str(), "mf" | "mb" | "mix");
            assert_eq!(s.p_mb.is_some(), decision, "run {r} step {}: p_mb", s.step);
            assert_eq!(
                s.action.is_none(),
                s.actor == "reset",
                "run {r} step {}",
                s.step
            );
            if s.actor == "reset" {
                assert_eq!((s.reward, s.terminal), (0.0, false));
                assert_eq!(s.event, "none");
            }
            assert_eq!(s.actor == "human", s.event == "takeover", "step {}", s.step);
        }
        // Each checkpoint's decisions and mean P(MB) are the trace's over its window.
        let mut from = 0;
        for (&(_, at), &(p_mb_mean, decisions)) in series.range((r, 0)..(r + 1, 0)) {
            let window: Vec<f64> = run
                .iter()
                .filter(|s| s.step > from && s.step <= at)
                .filter_map(|s| s.p_mb)
                .collect();
            assert_eq!(window.len() as i64, decisions, "run {r} at step {at}");
            let mean = window.iter().fold(0.0, |a, p| a + p) / window.len() as f64;
            match p_mb_mean {
                Some(m) => assert!((m - mean).abs() <= 1e-12 * m.abs().max(1.0), "{m} {mean}"),
                None => assert!(window.is_empty()),
            }
            from = at;
        }
    }
    // Interactions per kind are the runs table's counts.
    for (event, column) in [
        ("takeover", "takeovers"),
        ("congratulation", "congratulations"),
        ("punishment", "punishments"),
        ("nuisance", "nuisances"),
    ] {
        for (&r, &n) in &runs_column(dir, column) {
            let traced = by_run(r).filter(|s| s.event == event).count();
            assert_eq!(traced as f64, n, "run {r}: {column}");
        }
    }
    // MB decisions: drawn from MB (select), weighted above 1/2 (mix) or planned for (vpi).
    let mb = runs_column(dir, "mb_decisions");
    let controllers = read_dataset(dir, "runs").unwrap();
    for i in 0..controllers.len() {
        let r = int(&controllers, "run_index", i).unwrap();
        let controller = text(&controllers, "controller", i);
        let combine = text(&controllers, "combine", i);
        let counted = match (controller.as_str(), combine.as_str()) {
            ("vpi", _) => by_run(r).filter(|s| s.actor == "mix").count(),
            ("mf" | "mb", _) | (_, "select") => by_run(r).filter(|s| s.actor == "mb").count(),
            _ => by_run(r)
                .filter(|s| s.actor == "mix" && s.p_mb > Some(0.5))
                .count(),
        };
        assert_eq!(counted as f64, mb[&r], "run {r} ({controller}, {combine})");
    }
    rows
}

#[test]
fn a_takeover_human_puts_every_cube_and_a_goal_is_followed_by_its_reset_step() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = [
        "--controller",
        "ec",
        "--runs",
        "2",
        "--steps",
        "120",
        "--babbling",
        "0",
        "--interaction",
        "takeover",
        "--budget",
        "1000",
        "--forget",
        "0",
    ];
    traced_run(&out, &args);
    let rows = check_invariants(&out, 120);
    // With an attentive human, every put is the human's: after a robot's pick the human puts
    // (the robot never holds a cube at its own decision), and the puts bring every reward.
    let takeovers: Vec<&Step> = rows.iter().filter(|s| s.actor == "human").collect();
    assert!(takeovers.len() >= 6, "{} takeovers", takeovers.len());
    for s in &takeovers {
        assert_eq!(s.event, "takeover");
        assert_eq!(s.p_mb, None);
        assert!(s.action.is_some());
    }
    let terminal: Vec<&Step> = rows.iter().filter(|s| s.terminal).collect();
    assert!(!terminal.is_empty(), "no goal reached in 120 steps");
    for t in &terminal {
        assert_eq!(t.actor, "human", "the last cube is put by the human");
        assert!(t.reward > 0.0);
        // The next row is the reset step: from the goal, no action, a new start.
        if let Some(next) = rows.iter().find(|s| s.run == t.run && s.step == t.step + 1) {
            assert_eq!(next.actor, "reset");
            assert_eq!(next.action, None);
            assert_eq!(next.state, t.next_state);
            assert_eq!(next.p_mb, None);
        }
    }
    // The robot's own steps are decisions of EC: drawn from MF or MB, with their P(MB).
    for s in rows.iter().filter(|s| s.actor == "mf" || s.actor == "mb") {
        let p = s.p_mb.unwrap();
        assert!((0.0..=1.0).contains(&p), "{p}");
        assert_eq!(s.event, "none");
    }
}

#[test]
fn every_controller_and_human_traces_what_its_runs_and_series_report() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [&[&str]; 6] = [
        &["--controller", "mf,mb,rnd,ec,entropy,fixed,reliability,vpi"],
        &["--controller", "fixed,reliability,ec", "--combine", "mix"],
        &[
            "--controller",
            "ec,vpi",
            "--interaction",
            "congratulation",
            "--budget",
            "40",
        ],
        &[
            "--controller",
            "ec",
            "--interaction",
            "punishment",
            "--budget",
            "40",
        ],
        &[
            "--controller",
            "mf,ec",
            "--interaction",
            "nuisance",
            "--budget",
            "30",
        ],
        &[
            "--controller",
            "ec,mb",
            "--reward-source",
            "human",
            "--budget",
            "5",
        ],
    ];
    for (k, case) in cases.iter().enumerate() {
        let out = dir.path().join(format!("case-{k}"));
        let mut args = case.to_vec();
        args.extend(["--runs", "2", "--steps", "400", "--checkpoint", "50"]);
        traced_run(&out, &args);
        let rows = check_invariants(&out, 400);
        if case.contains(&"human") {
            let given = runs_column(&out, "rewards_given");
            for (&r, &n) in &given {
                let events = rows
                    .iter()
                    .filter(|s| s.run == r && s.event == "reward")
                    .count();
                assert_eq!(events as f64, n, "case {k} run {r}: rewards given");
            }
            assert!(
                given.values().sum::<f64>() > 0.0,
                "case {k}: no reward given"
            );
        }
        if case.contains(&"mix") {
            assert!(rows.iter().all(|s| s.actor != "mf" && s.actor != "mb"));
        }
    }
}

#[test]
fn the_two_step_task_traces_trials_of_two_steps() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    traced_run(
        &out,
        &[
            "--task",
            "twostep",
            "--controller",
            "mf,mb,vpi",
            "--runs",
            "2",
        ],
    );
    let rows = check_invariants(&out, 402);
    for s in &rows {
        // No reset step: every second step ends a trial back in the first stage.
        assert_ne!(s.actor, "reset");
        assert_eq!(s.terminal, s.step % 2 == 0, "step {}", s.step);
        assert_eq!(s.state == 0, s.step % 2 == 1, "step {}", s.step);
    }
}

#[test]
fn tracing_moves_no_result_and_the_trace_does_not_depend_on_threads_or_batches() {
    let dir = tempfile::tempdir().unwrap();
    let base = [
        "--controller",
        "mf,ec,vpi,reliability",
        "--runs",
        "5",
        "--steps",
        "300",
        "--interaction",
        "takeover",
        "--budget",
        "20",
    ];
    let plain = dir.path().join("plain");
    run_quiet(&plain, &base);
    let traced = dir.path().join("traced");
    let mut args = base.to_vec();
    args.extend(["--trace", "--batch-size", "3"]);
    run_quiet(&traced, &args);
    assert_same_rows(
        "runs",
        &rows_of(&plain, "runs.parquet"),
        &rows_of(&traced, "runs.parquet"),
    );
    assert_same_rows(
        "series",
        &rows_of(&plain, "series.parquet"),
        &rows_of(&traced, "series.parquet"),
    );
    assert!(!plain.join("trace.parquet").exists());
    // One thread, one run per batch: the same trace.
    let serial = dir.path().join("serial");
    let mut all = vec!["--threads", "1", "run"];
    all.extend_from_slice(&base);
    all.extend(["--trace", "--batch-size", "1", "--quiet", "--out"]);
    all.push(serial.to_str().unwrap());
    run_ok(&all);
    assert_eq!(trace(&serial), trace(&traced));
    assert_same_rows(
        "trace",
        &rows_of(&serial, "trace.parquet"),
        &rows_of(&traced, "trace.parquet"),
    );
}

/// Rows of `dir/file`, without the columns that legitimately differ.
fn rows_of(dir: &Path, file: &str) -> Vec<Row> {
    let mut rows = file_rows(&dir.join(file), NONDETERMINISTIC);
    sort_rows(&mut rows);
    rows
}

#[test]
fn a_trace_is_committed_with_its_runs_and_an_untraced_rerun_removes_the_old_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    traced_run(
        &out,
        &["--controller", "ec", "--runs", "2", "--steps", "50"],
    );
    let runs_id = mbmf::output::atomic::run_id(&out.join("runs.parquet"));
    assert!(runs_id.is_some());
    assert_eq!(
        mbmf::output::atomic::run_id(&out.join("trace.parquet")),
        runs_id
    );
    assert_eq!(trace(&out).len(), 100);
    // Replaced by a run without the trace: the old trace is no longer the dataset's.
    run_quiet(
        &out,
        &[
            "--controller",
            "ec",
            "--runs",
            "3",
            "--steps",
            "50",
            "--force",
        ],
    );
    // It was part of the results --force replaced: removed, so that no reader opening
    // trace.parquet by name joins the old run's steps to the new run's runs.
    assert!(!out.join("trace.parquet").exists());
    let e = read_trace(&out).unwrap_err().to_string();
    assert!(e.contains("trace"), "{e}");
    assert_eq!(read_dataset(&out, "runs").unwrap().len(), 3);
    // Replaced by a traced run again: the new trace.
    traced_run(
        &out,
        &[
            "--controller",
            "ec",
            "--runs",
            "3",
            "--steps",
            "50",
            "--force",
        ],
    );
    assert_eq!(trace(&out).len(), 150);
}

#[test]
fn the_json_report_and_the_schema_name_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = run_ok(&[
        "run",
        "--controller",
        "mb",
        "--runs",
        "1",
        "--steps",
        "20",
        "--trace",
        "--json",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        report["files"]["trace"].as_str(),
        Some(out.join("trace.parquet").to_str().unwrap())
    );
    let file = std::fs::File::open(out.join("trace.parquet")).unwrap();
    let reader =
        parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
    let kv = reader
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .unwrap();
    assert!(
        kv.iter()
            .any(|k| k.key == "mbmf_schema" && k.value.as_deref() == Some("trace/1"))
    );
    let names: Vec<String> = reader
        .schema()
        .fields()
        .iter()
        .map(|f| format!("{}:{}", f.name(), f.data_type()))
        .collect();
    assert_eq!(
        names,
        [
            "run_index:Int64",
            "step:Int32",
            "state:Int32",
            "action:Int16",
            "next_state:Int32",
            "reward:Float64",
            "terminal:Boolean",
            "actor:Dictionary(Int8, Utf8)",
            "p_mb:Float64",
            "human_event:Dictionary(Int8, Utf8)",
        ]
    );
    // An `mb` run: every decision drawn from MB, with P(MB) 1.
    assert!(
        trace(&out)
            .iter()
            .all(|s| s.actor == "reset" || (s.actor == "mb" && s.p_mb == Some(1.0)))
    );
}

const TRACED_SWEEP: &str = r#"
seeds = 3
trace = true

[fixed]
task = "tidy1"
steps = 600
checkpoint = 100

[grid]
controller = ["mf", "ec", "vpi"]
interaction = ["none", "takeover"]
budget = [20]
"#;

#[test]
fn a_traced_sweep_writes_a_trace_part_per_part_and_equals_the_runs_it_traces() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "traced.toml", TRACED_SWEEP);
    let out = dir.path().join("out");
    run_ok(&[
        "sweep",
        &file,
        "--quiet",
        "--batch-size",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(parts(&out, "trace"), parts(&out, "runs"));
    let rows = check_invariants(&out, 600);
    assert_eq!(rows.len(), 18 * 600);
    // The same sweep without `trace = true` and with --trace: the same dataset.
    let untraced = write_sweep(
        dir.path(),
        "plain.toml",
        &TRACED_SWEEP.replace("trace = true\n", ""),
    );
    let flagged = dir.path().join("flagged");
    run_ok(&[
        "sweep",
        &untraced,
        "--quiet",
        "--trace",
        "--out",
        flagged.to_str().unwrap(),
    ]);
    assert_eq!(trace(&flagged), rows);
    assert_same_dataset("--trace", &flagged, &out);
    // A sweep started without the trace is not resumed with one.
    let plain = dir.path().join("plain");
    run_ok(&[
        "sweep",
        &untraced,
        "--quiet",
        "--out",
        plain.to_str().unwrap(),
    ]);
    let e = read_trace(&plain).unwrap_err().to_string();
    assert!(e.contains("without the trace"), "{e}");
    let refused = run(&[
        "sweep",
        &untraced,
        "--quiet",
        "--trace",
        "--resume",
        "--out",
        plain.to_str().unwrap(),
    ]);
    assert_eq!(refused.status.code(), Some(2));
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(message.contains("written without the trace"), "{message}");
}

fn start(file: &str, out: &Path, resume: bool) -> Child {
    let mut cmd = mbmf();
    cmd.args(["sweep", file, "--quiet", "--batch-size", "2", "--out"])
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if resume {
        cmd.arg("--resume");
    }
    cmd.spawn().expect("mbmf starts")
}

/// A deterministic pseudo-random number in [0, 1) (SplitMix64), so failures reproduce.
fn unit(i: u64) -> f64 {
    let mut z = i.wrapping_add(7).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn a_traced_sweep_killed_at_random_moments_resumes_to_the_uninterrupted_trace() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "kill.toml", TRACED_SWEEP);
    let reference = dir.path().join("reference");
    let started = Instant::now();
    assert!(start(&file, &reference, false).wait().unwrap().success());
    let span = started.elapsed().mul_f64(1.1);
    let expected = trace(&reference);
    let mut hit = 0;
    for trial in 0..10u64 {
        let out = dir.path().join(format!("trial-{trial}"));
        let mut child = start(&file, &out, false);
        std::thread::sleep(span.mul_f64(unit(trial)).max(Duration::from_millis(1)));
        if child.try_wait().unwrap().is_none() {
            hit += 1;
        }
        child.kill().unwrap();
        child.wait().unwrap();
        // A trace part is never visible without its runs part's commit pending: what a kill
        // leaves is either committed whole or removed by the resume.
        for name in parts(&out, "runs") {
            assert!(
                parts(&out, "trace").contains(&name),
                "trial {trial}: {name}"
            );
        }
        let resumed = start(&file, &out, true).wait().unwrap();
        assert!(resumed.success(), "trial {trial}: resume failed");
        assert_eq!(parts(&out, "trace"), parts(&out, "runs"), "trial {trial}");
        assert_eq!(trace(&out), expected, "trial {trial}");
        assert_same_dataset(&format!("trial {trial}"), &out, &reference);
        let hidden: Vec<String> = std::fs::read_dir(out.join("trace"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(hidden.is_empty(), "trial {trial}: {hidden:?}");
    }
    eprintln!("{hit} of 10 kills hit a running sweep");
    assert!(hit >= 1, "no kill hit a running process");
}
