//! `mbmf fit-human` (SPEC 15 "Fitting") end to end: traces of humans with known forget_prob
//! and error_prob are fitted back, opportunities stop with the budget, runs pool by `--by`,
//! and the profile file it writes is read by `mbmf run --profile-file` and by sweep files.
//!
//! The traces here are written by the test itself: a robot acting at random in tidy1 and a
//! simulated human stepped by the rules of SPEC 5 and 15 (attention, then judgment) with a seeded
//! stream, in the trace table's schema (SPEC 14) with an extra column as a person's sessions
//! have. The runs table comes from `mbmf run` (its run indices, task, interaction and budget).

mod common;

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray, UInt16Array};
use arrow::array::{UInt32Array, UInt64Array};
use mbmf::env::{NO_TAKEOVER, Spec};
use mbmf::rng::uniform;
use parquet::arrow::ArrowWriter;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde_json::Value;

use common::{run_ok, run_quiet};

/// A simulated human for the generator: its type, budget, forget and error probabilities.
#[derive(Clone, Copy)]
struct Human {
    interaction: &'static str,
    budget: u64,
    forget: f64,
    error: f64,
}

/// One trace row.
struct Row {
    run: u64,
    step: u32,
    state: u32,
    action: Option<u16>,
    next: u32,
    terminal: bool,
    actor: &'static str,
    event: &'static str,
}

/// What the generator counted: feedback opportunities (robot actions, while budget lasts).
#[derive(Default, Debug, PartialEq)]
struct Truth {
    robot_actions_with_budget: u64,
    interactions: u64,
}

/// `steps` steps of run `run` in tidy1: a robot acting uniformly at random and `human`, each
/// opportunity drawn as the engine draws it (attention, then judgment when error > 0).
fn session(spec: &Spec, run: u64, steps: u32, human: Human, seed: u64) -> (Vec<Row>, Truth) {
    let tables = spec.human.as_ref().expect("tidy1 has human tables");
    let goal = spec.goal_state().expect("a goal") as usize;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut left = human.budget;
    let mut s = spec.initial_states[0] as usize;
    let mut rows = Vec::new();
    let mut truth = Truth::default();
    let n_a = spec.n_actions;
    for step in 1..=steps {
        if s == goal {
            let start = spec.initial_states[0];
            rows.push(Row {
                run,
                step,
                state: s as u32,
                action: None,
                next: start,
                terminal: false,
                actor: "reset",
                event: "none",
            });
            s = start as usize;
            continue;
        }
        let mut event = "none";
        let mut actor = "mf";
        let mut a = None;
        if left > 0
            && human.interaction == "takeover"
            && tables.takeover_action[s] != NO_TAKEOVER
            && uniform(&mut rng) >= human.forget
        {
            a = Some(tables.takeover_action[s] as usize);
            (event, actor) = ("takeover", "human");
        }
        let a = a.unwrap_or_else(|| ((uniform(&mut rng) * n_a as f64) as usize).min(n_a - 1));
        let sa = s * n_a + a;
        let next = spec.outcome_state[spec.outcomes(sa).start] as usize;
        if actor != "human" && left > 0 {
            truth.robot_actions_with_budget += 1;
            let merits = match human.interaction {
                "congratulation" => Some(tables.relevant[sa]),
                "punishment" => Some(tables.error[sa]),
                _ => None,
            };
            if let Some(merits) = merits
                && (human.error > 0.0 || merits)
                && uniform(&mut rng) >= human.forget
            {
                let wrong = human.error > 0.0 && uniform(&mut rng) < human.error;
                if merits != wrong {
                    event = human.interaction;
                }
            }
        }
        if event != "none" {
            left -= 1;
            truth.interactions += 1;
        }
        rows.push(Row {
            run,
            step,
            state: s as u32,
            action: Some(a as u16),
            next: next as u32,
            terminal: next == goal,
            actor,
            event,
        });
        s = next;
    }
    (rows, truth)
}

/// Writes `rows` as `file` in the trace table's schema, with a person's `shown_ms` column too.
fn write_trace(file: &Path, rows: &[Row]) {
    let columns: Vec<(&str, ArrayRef)> = vec![
        (
            "run_index",
            Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.run))),
        ),
        (
            "step",
            Arc::new(UInt32Array::from_iter_values(rows.iter().map(|r| r.step))),
        ),
        (
            "state",
            Arc::new(UInt32Array::from_iter_values(rows.iter().map(|r| r.state))),
        ),
        (
            "action",
            Arc::new(UInt16Array::from_iter(rows.iter().map(|r| r.action))),
        ),
        (
            "next_state",
            Arc::new(UInt32Array::from_iter_values(rows.iter().map(|r| r.next))),
        ),
        (
            "reward",
            Arc::new(Float64Array::from_iter_values(
                rows.iter().map(|r| f64::from(u8::from(r.terminal))),
            )),
        ),
        (
            "terminal",
            Arc::new(BooleanArray::from_iter(
                rows.iter().map(|r| Some(r.terminal)),
            )),
        ),
        (
            "actor",
            Arc::new(StringArray::from_iter_values(rows.iter().map(|r| r.actor))),
        ),
        (
            "p_mb",
            Arc::new(Float64Array::from_iter_values(rows.iter().map(|_| 0.5))),
        ),
        (
            "human_event",
            Arc::new(StringArray::from_iter_values(rows.iter().map(|r| r.event))),
        ),
        (
            "shown_ms",
            Arc::new(UInt64Array::from_iter_values(
                rows.iter().map(|r| u64::from(r.step) * 700),
            )),
        ),
    ];
    let batch = RecordBatch::try_from_iter(columns).expect("a batch");
    let mut writer =
        ArrowWriter::try_new(File::create(file).expect("create"), batch.schema(), None)
            .expect("a writer");
    writer.write(&batch).expect("write");
    writer.close().expect("close");
}

/// `mbmf fit-human DIR --trace DIR ARGS --json`, parsed: the trace the test wrote in DIR, read
/// as it is (it has no commit of its own).
fn fit(args: &[&str]) -> Value {
    let mut all = vec!["fit-human", args[0], "--trace", args[0]];
    all.extend_from_slice(&args[1..]);
    all.push("--json");
    let out = run_ok(&all);
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

/// `mbmf run` of `runs` runs of tidy1 with `human_flags`: the runs table the traces belong to.
fn runs_table(dir: &Path, runs: u32, flags: &[&str]) {
    let runs = runs.to_string();
    let mut args = vec![
        "--controller",
        "mf",
        "--runs",
        runs.as_str(),
        "--steps",
        "10",
    ];
    args.extend_from_slice(flags);
    run_quiet(dir, &args);
}

fn tidy1() -> Arc<Spec> {
    Arc::new(mbmf::env::load("tidy1").expect("tidy1"))
}

fn estimate(session: &Value, name: &str) -> (Option<f64>, f64, f64) {
    let e = &session[name];
    (
        e["value"].as_f64(),
        e["low"].as_f64().expect("low"),
        e["high"].as_f64().expect("high"),
    )
}

#[test]
fn known_forget_and_error_probabilities_are_recovered_within_their_intervals() {
    // Nine congratulating humans, f in {0, 0.2, 0.5} x e in {0, 0.1, 0.3}, 20,000 steps each:
    // about 1,200 relevant actions of a robot acting at random, so a standard error of at most
    // 0.015 on forget_prob and the tolerance of 0.05 is more than three of them.
    let spec = tidy1();
    let dir = tempfile::tempdir().expect("temp dir");
    let grid: Vec<(f64, f64)> = [0.0, 0.2, 0.5]
        .iter()
        .flat_map(|&f| [0.0, 0.1, 0.3].map(|e| (f, e)))
        .collect();
    runs_table(
        dir.path(),
        grid.len() as u32,
        &["--interaction", "congratulation", "--budget", "1000000"],
    );
    let mut rows = Vec::new();
    for (i, &(forget, error)) in grid.iter().enumerate() {
        let human = Human {
            interaction: "congratulation",
            budget: 1_000_000,
            forget,
            error,
        };
        rows.extend(session(&spec, i as u64, 20_000, human, 100 + i as u64).0);
    }
    write_trace(&dir.path().join("trace.parquet"), &rows);
    let report = fit(&[dir.path().to_str().unwrap()]);
    let sessions = report["sessions"].as_array().expect("sessions");
    assert_eq!(sessions.len(), grid.len());
    let mut misses = 0;
    for (s, &(f, e)) in sessions.iter().zip(&grid) {
        for (name, truth) in [("forget_prob", f), ("error_prob", e)] {
            let (value, low, high) = estimate(s, name);
            let value = value.unwrap_or_else(|| panic!("{name} not identified: {s}"));
            assert!(
                (value - truth).abs() < 0.05,
                "{name} {value} for {truth}: {s}"
            );
            assert!(
                high - low < 0.15,
                "{name} interval [{low}, {high}] too wide: {s}"
            );
            if !(low..=high).contains(&truth) {
                misses += 1;
            }
        }
    }
    // 18 intervals at 95%: four misses or more has a probability of about 1%.
    assert!(
        misses <= 3,
        "{misses} of 18 intervals miss their true value"
    );
}

#[test]
fn punishment_and_takeover_humans_are_recovered_and_takeovers_leave_the_error_open() {
    let spec = tidy1();
    let punishing = tempfile::tempdir().expect("temp dir");
    runs_table(
        punishing.path(),
        1,
        &["--interaction", "punishment", "--budget", "1000000"],
    );
    let punisher = Human {
        interaction: "punishment",
        budget: 1_000_000,
        forget: 0.3,
        error: 0.2,
    };
    let rows = session(&spec, 0, 20_000, punisher, 7).0;
    write_trace(&punishing.path().join("trace.parquet"), &rows);
    let s = &fit(&[punishing.path().to_str().unwrap()])["sessions"][0];
    assert_eq!(s["types"], serde_json::json!(["punishment"]));
    let (f, low, high) = estimate(s, "forget_prob");
    assert!((f.unwrap() - 0.3).abs() < 0.05 && low < high, "{s}");
    let (e, low, high) = estimate(s, "error_prob");
    assert!((e.unwrap() - 0.2).abs() < 0.05 && low < high, "{s}");

    let taking = tempfile::tempdir().expect("temp dir");
    runs_table(
        taking.path(),
        1,
        &["--interaction", "takeover", "--budget", "1000000"],
    );
    let taker = Human {
        interaction: "takeover",
        forget: 0.4,
        error: 0.0,
        ..punisher
    };
    let rows = session(&spec, 0, 20_000, taker, 8).0;
    write_trace(&taking.path().join("trace.parquet"), &rows);
    let s = &fit(&[taking.path().to_str().unwrap()])["sessions"][0];
    assert_eq!(s["types"], serde_json::json!(["takeover"]));
    let (f, low, high) = estimate(s, "forget_prob");
    assert!((f.unwrap() - 0.4).abs() < 0.05 && low < high, "{s}");
    // A takeover shows nothing of the human's judgment.
    assert_eq!(estimate(s, "error_prob"), (None, 0.0, 1.0));
    assert_eq!(s["shares"]["takeover"], 1.0);
    assert_eq!(s["other"]["opportunities"], 0);
}

#[test]
fn opportunities_after_the_budget_is_spent_are_not_counted() {
    let spec = tidy1();
    let dir = tempfile::tempdir().expect("temp dir");
    runs_table(
        dir.path(),
        1,
        &["--interaction", "congratulation", "--budget", "40"],
    );
    let human = Human {
        interaction: "congratulation",
        budget: 40,
        forget: 0.1,
        error: 0.2,
    };
    let (rows, truth) = session(&spec, 0, 3000, human, 3);
    assert_eq!(truth.interactions, 40, "the budget runs out in the session");
    write_trace(&dir.path().join("trace.parquet"), &rows);
    let s = &fit(&[dir.path().to_str().unwrap()])["sessions"][0];
    let counted = s["merited"]["opportunities"].as_u64().unwrap()
        + s["other"]["opportunities"].as_u64().unwrap();
    assert_eq!(counted, truth.robot_actions_with_budget);
    assert!(counted < 3000 / 2, "{counted}");
    assert_eq!(s["budget"], 40);
}

#[test]
fn runs_pool_by_a_column_by_adding_their_counts_and_rates_come_per_window() {
    let spec = tidy1();
    let dir = tempfile::tempdir().expect("temp dir");
    let flags = ["--controller", "mf,ec", "--runs", "2", "--steps", "10"];
    let mut args = flags.to_vec();
    args.extend(["--interaction", "congratulation", "--budget", "1000000"]);
    run_quiet(dir.path(), &args);
    let human = Human {
        interaction: "congratulation",
        budget: 1_000_000,
        forget: 0.2,
        error: 0.1,
    };
    let mut rows = Vec::new();
    for run in 0..4 {
        rows.extend(session(&spec, run, 2500, human, 40 + run).0);
    }
    // As a sweep writes it: the trace in parts.
    let folder = dir.path().join("trace");
    std::fs::create_dir(&folder).unwrap();
    let (first, second) = rows.split_at(5000);
    write_trace(&folder.join("part-000000.parquet"), first);
    write_trace(&folder.join("part-000001.parquet"), second);
    let path = dir.path().to_str().unwrap();
    let each = fit(&[path]);
    let pooled = fit(&[path, "--by", "controller", "--window", "500"]);
    let groups = pooled["sessions"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    for (g, controller) in groups.iter().zip(["ec", "mf"]) {
        assert_eq!(g["session"]["controller"], controller);
        assert_eq!(g["runs"], 2);
        // mbmf run numbers mf's runs 0 and 1, ec's 2 and 3.
        let runs: Vec<&Value> = match controller {
            "mf" => vec![&each["sessions"][0], &each["sessions"][1]],
            _ => vec![&each["sessions"][2], &each["sessions"][3]],
        };
        for part in ["merited", "other"] {
            for field in ["opportunities", "interactions"] {
                let sum: u64 = runs.iter().map(|r| r[part][field].as_u64().unwrap()).sum();
                assert_eq!(g[part][field], sum, "{controller} {part} {field}");
            }
        }
        let rates = g["rate_per_1000"].as_array().unwrap();
        assert_eq!(rates.len(), 5, "2,500 steps in windows of 500");
        let given: u64 = runs
            .iter()
            .map(|r| r["interactions"]["congratulation"].as_u64().unwrap())
            .sum();
        // Each window has 2 x 500 steps: its rate per 1,000 steps is its interaction count.
        let from_rates: f64 = rates.iter().map(|r| r.as_f64().unwrap()).sum();
        assert!(
            (from_rates - given as f64).abs() < 1e-9,
            "{from_rates} vs {given}"
        );
    }
}

#[test]
fn the_profile_file_is_read_by_run_and_by_sweep_files() {
    let spec = tidy1();
    let dir = tempfile::tempdir().expect("temp dir");
    runs_table(
        dir.path(),
        1,
        &["--interaction", "congratulation", "--budget", "500"],
    );
    let human = Human {
        interaction: "congratulation",
        budget: 500,
        forget: 0.25,
        error: 0.15,
    };
    write_trace(
        &dir.path().join("trace.parquet"),
        &session(&spec, 0, 4000, human, 9).0,
    );
    let report = fit(&[dir.path().to_str().unwrap()]);
    let file = report["files"][0].as_str().unwrap().to_owned();
    assert!(file.ends_with("analysis/fitted_humans.toml"), "{file}");
    let s = &report["sessions"][0];
    assert_eq!(s["profile"], "fitted-run-0");
    let round = |x: f64| (x * 1e6).round() / 1e6;
    let f = round(s["forget_prob"]["value"].as_f64().unwrap());
    let e = round(s["error_prob"]["value"].as_f64().unwrap());

    // mbmf run takes the human from the file; an explicit flag overrides one of its fields.
    let out = dir.path().join("again");
    let o = out.to_str().unwrap();
    run_ok(&[
        "run",
        "--controller",
        "ec",
        "--runs",
        "2",
        "--steps",
        "300",
        "--profile-file",
        &file,
        "--zeta",
        "0.3",
        "--out",
        o,
        "-q",
    ]);
    let runs = mbmf::analysis::dataset::read_runs(&out).expect("runs");
    let value = |c: &str| runs.column(c).unwrap().value(0).to_string();
    assert_eq!(value("interaction"), "congratulation");
    assert_eq!(value("budget"), "500");
    assert_eq!(value("forget_prob").parse::<f64>().unwrap(), f);
    assert_eq!(value("error_prob").parse::<f64>().unwrap(), e);
    assert_eq!(value("zeta"), "0.3");
    assert_eq!(value("profile"), "custom");

    // A sweep file names the profile file (relative to itself) and uses its profile.
    let sweep = dir.path().join("fitted.toml");
    std::fs::write(
        &sweep,
        "profile_file = \"analysis/fitted_humans.toml\"\nseeds = 2\n[fixed]\nsteps = 300\nprofile = \"fitted-run-0\"\n[grid]\ncontroller = [\"mf\", \"ec\"]\n",
    )
    .unwrap();
    let swept = dir.path().join("swept");
    run_ok(&[
        "sweep",
        sweep.to_str().unwrap(),
        "--out",
        swept.to_str().unwrap(),
        "-q",
    ]);
    let runs = mbmf::analysis::dataset::read_runs(&swept).expect("sweep runs");
    assert_eq!(runs.len(), 4);
    for row in 0..runs.len() {
        let value = |c: &str| runs.column(c).unwrap().value(row).to_string();
        assert_eq!(value("profile"), "fitted-run-0");
        assert_eq!(value("error_prob").parse::<f64>().unwrap(), e);
        assert_eq!(value("forget_prob").parse::<f64>().unwrap(), f);
    }
}

#[test]
fn a_profile_file_with_several_profiles_needs_a_name_and_bad_files_are_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("two.toml");
    std::fs::write(
        &file,
        "[profiles.alice]\ninteraction = \"congratulation\"\nbudget = 100\nerror_prob = 0.2\n\
         [profiles.bob]\ninteraction = \"takeover\"\nbudget = 50\nforget_prob = 0.3\n",
    )
    .unwrap();
    let f = file.to_str().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let failed = common::run(&[
        "run",
        "--profile-file",
        f,
        "--out",
        o,
        "--steps",
        "10",
        "--runs",
        "1",
    ]);
    assert_eq!(failed.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(
        stderr.contains("--profile-name") && stderr.contains("alice, bob"),
        "{stderr}"
    );
    let failed = common::run(&[
        "run",
        "--profile-file",
        f,
        "--profile-name",
        "carol",
        "--out",
        o,
    ]);
    assert_eq!(failed.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&failed.stderr).contains("alice, bob"));
    run_ok(&[
        "run",
        "--controller",
        "mf",
        "--profile-file",
        f,
        "--profile-name",
        "bob",
        "--out",
        o,
        "--steps",
        "50",
        "--runs",
        "1",
        "-q",
    ]);
    let runs = mbmf::analysis::dataset::read_runs(&out).expect("runs");
    assert_eq!(
        runs.column("interaction").unwrap().value(0).to_string(),
        "takeover"
    );
    assert_eq!(
        runs.column("forget_prob").unwrap().value(0).to_string(),
        "0.3"
    );
    // A file that sets more than humans is not a profile file.
    std::fs::write(&file, "[fixed]\nsteps = 10\n[profiles.x]\nbudget = 3\n").unwrap();
    let failed = common::run(&["run", "--profile-file", f, "--out", o]);
    assert_eq!(failed.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&failed.stderr).contains("[profiles.NAME] tables only"));
}

#[test]
fn a_dataset_without_a_trace_is_refused_with_what_to_do() {
    let dir = tempfile::tempdir().expect("temp dir");
    runs_table(dir.path(), 1, &[]);
    let out = common::run(&["fit-human", dir.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--trace"), "{stderr}");
}

#[test]
fn humans_simulated_by_the_engine_and_traced_are_fitted_back_within_their_intervals() {
    // The engine's own human (SPEC 5 and 15) with f in {0, 0.2, 0.5} x e in {0, 0.1, 0.3}, two
    // traced runs each, pooled per (f, e).
    let dir = tempfile::tempdir().expect("temp dir");
    let sweep = dir.path().join("humans.toml");
    std::fs::write(
        &sweep,
        "seeds = 2\ntrace = true\n[fixed]\ncontroller = \"mf\"\nsteps = 4000\n\
         interaction = \"congratulation\"\nbudget = 1000000\n\
         [grid]\nforget_prob = [0.0, 0.2, 0.5]\nerror_prob = [0.0, 0.1, 0.3]\n",
    )
    .unwrap();
    let data = dir.path().join("humans");
    let data = data.to_str().unwrap();
    run_ok(&["sweep", sweep.to_str().unwrap(), "--out", data, "-q"]);
    let out = run_ok(&[
        "fit-human",
        data,
        "--by",
        "forget_prob,error_prob",
        "--json",
    ]);
    let report: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let sessions = report["sessions"].as_array().expect("sessions");
    assert_eq!(sessions.len(), 9);
    let mut misses = 0;
    for s in sessions {
        assert_eq!(s["runs"], 2);
        for name in ["forget_prob", "error_prob"] {
            let truth: f64 = s["session"][name].as_str().unwrap().parse().unwrap();
            let (value, low, high) = estimate(s, name);
            let value = value.unwrap_or_else(|| panic!("{name} not identified: {s}"));
            assert!(
                (value - truth).abs() < 0.06,
                "{name} {value} for {truth}: {s}"
            );
            if !(low..=high).contains(&truth) {
                misses += 1;
            }
        }
    }
    // 18 intervals at 95%: four misses or more has a probability of about 1%.
    assert!(
        misses <= 3,
        "{misses} of 18 intervals miss their true value"
    );

    // A takeover human of the engine: its forget rate, and no error to estimate.
    let taken = dir.path().join("taken");
    let t = taken.to_str().unwrap();
    run_ok(&[
        "run",
        "--controller",
        "mf",
        "--runs",
        "2",
        "--steps",
        "4000",
        "--interaction",
        "takeover",
        "--budget",
        "1000000",
        "--forget",
        "0.3",
        "--trace",
        "--out",
        t,
        "-q",
    ]);
    let out = run_ok(&["fit-human", t, "--json"]);
    let report: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    for s in report["sessions"].as_array().unwrap() {
        let (f, low, high) = estimate(s, "forget_prob");
        assert!((f.unwrap() - 0.3).abs() < 0.06 && low < high, "{s}");
        assert_eq!(estimate(s, "error_prob"), (None, 0.0, 1.0));
    }
}
