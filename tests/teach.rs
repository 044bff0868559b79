//! A person in the loop (SPEC 15) without a browser: the engine's person human, sessions as
//! parts of one dataset committed at every step, and the checks of `mbmf teach` and `mbmf
//! view`. The page itself is driven in real Chromium by tests/teach_browser.rs.

mod common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use common::{run, run_ok, serve};
use mbmf::analysis::dataset::{self, Value};
use mbmf::batch::Refusal;
use mbmf::batch::trace::{Actor, HumanEvent};
use mbmf::env;
use mbmf::params::{Controller, Interaction, Params};
use mbmf::session::{NO_LIMIT, Session, SessionJudgeError, Teaching};

fn teaching(budget: u32, steps: u32) -> Teaching {
    let mut params = Params {
        controller: Controller::Ec,
        steps,
        babbling: 200,
        ..Params::default()
    };
    params.human.interaction = Interaction::Person;
    params.human.budget = budget;
    Teaching {
        spec: Arc::new(env::load("tidy1").unwrap()),
        params,
        master_seed: 7,
        participant: "p-test".into(),
        command: "tests/teach.rs".into(),
    }
}

/// Steps until the robot chose the action itself; returns that step.
fn step_to_robot_action(s: &mut Session) -> u32 {
    loop {
        let shown = s.step().unwrap().expect("the run is not over");
        if matches!(shown.actor, Actor::Mf | Actor::Mb | Actor::Mix) {
            return shown.step;
        }
    }
}

fn runs_row(dir: &Path, run_index: u64) -> (dataset::Table, usize) {
    let runs = dataset::read_runs(dir).unwrap();
    let col = runs.column("run_index").unwrap();
    let row = (0..runs.len())
        .find(|&i| col.value(i).as_f64() == Some(run_index as f64))
        .expect("the session's runs row");
    (runs, row)
}

fn value(table: &dataset::Table, name: &str, row: usize) -> Value {
    table.column(name).unwrap().value(row)
}

/// Trace rows of one run: (step, actor, event, clicked_at).
fn trace_of(dir: &Path, run_index: u64) -> Vec<(u64, String, String, Option<f64>)> {
    let t = dataset::read_trace(dir).unwrap();
    let text = |name: &str, i: usize| match value(&t, name, i) {
        Value::Str(s) => s,
        other => panic!("{name}: {other:?}"),
    };
    let mut rows: Vec<_> = (0..t.len())
        .filter(|&i| value(&t, "run_index", i).as_f64() == Some(run_index as f64))
        .map(|i| {
            (
                value(&t, "step", i).as_f64().unwrap() as u64,
                text("actor", i),
                text("human_event", i),
                value(&t, "clicked_at", i).as_f64(),
            )
        })
        .collect();
    rows.sort_by_key(|r| r.0);
    rows
}

#[test]
fn feedback_applies_to_the_last_robot_action_and_spends_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = Session::start(dir.path(), teaching(3, 400)).unwrap();
    assert_eq!((s.step_count(), s.budget_left()), (0, Some(3)));
    // Nothing to judge before the first step.
    assert!(matches!(
        s.judge(0, true),
        Err(SessionJudgeError::Refused(Refusal::NotLast { .. }))
    ));
    let k = step_to_robot_action(&mut s);
    assert_eq!(s.judge(k, true).unwrap(), HumanEvent::Congratulation);
    assert_eq!(s.budget_left(), Some(2));
    // Once per step; and only the last step.
    assert!(matches!(
        s.judge(k, false),
        Err(SessionJudgeError::Refused(Refusal::AlreadyJudged { .. }))
    ));
    let k2 = step_to_robot_action(&mut s);
    assert!(matches!(
        s.judge(k, false),
        Err(SessionJudgeError::Refused(Refusal::NotLast { .. }))
    ));
    assert_eq!(s.judge(k2, false).unwrap(), HumanEvent::Punishment);
    assert_eq!(s.budget_left(), Some(1));
    // A takeover needs a cube in the hand; with one it is the next step's action.
    while !s.holding() {
        assert_eq!(
            s.take_over(3).unwrap_err(),
            Refusal::NothingHeld,
            "an empty hand"
        );
        s.step().unwrap();
    }
    assert_eq!(
        s.take_over(1).unwrap_err(),
        Refusal::NotAPut { action: 1 },
        "a take is not a put"
    );
    s.take_over(6).unwrap();
    let shown = s.step().unwrap().unwrap();
    assert_eq!(
        (shown.actor, shown.action, shown.event),
        (Actor::Human, Some(6), HumanEvent::Takeover)
    );
    assert_eq!(s.budget_left(), Some(0));
    // The budget is spent: nothing more is accepted, the run goes on.
    let k3 = step_to_robot_action(&mut s);
    assert!(matches!(
        s.judge(k3, true),
        Err(SessionJudgeError::Refused(Refusal::NoBudget))
    ));
    // The person's own takeover is not theirs to judge.
    let trace = trace_of(dir.path(), s.run_index());
    assert_eq!(trace.len(), s.step_count() as usize);
    let events: Vec<(u64, &str)> = trace
        .iter()
        .filter(|r| r.2 != "none")
        .map(|r| (r.0, r.2.as_str()))
        .collect();
    assert_eq!(
        events,
        [
            (u64::from(k), "congratulation"),
            (u64::from(k2), "punishment"),
            (u64::from(shown.step), "takeover")
        ]
    );
    // Every interaction has the time of its click; other steps none.
    for r in &trace {
        assert_eq!(r.3.is_some(), r.2 != "none", "step {}", r.0);
    }
    let (runs, row) = runs_row(dir.path(), s.run_index());
    for (col, want) in [
        ("congratulations", 1.0),
        ("punishments", 1.0),
        ("takeovers", 1.0),
        ("budget", 3.0),
    ] {
        assert_eq!(value(&runs, col, row).as_f64(), Some(want), "{col}");
    }
    assert_eq!(
        value(&runs, "budget_exhausted_step", row).as_f64(),
        Some(f64::from(shown.step))
    );
    assert_eq!(
        value(&runs, "interaction", row),
        Value::Str("person".into())
    );
}

#[test]
fn a_session_is_committed_at_every_step_and_marked_until_it_ends() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = Session::start(dir.path(), teaching(NO_LIMIT, 50)).unwrap();
    // Visible at once, with no step.
    assert!(trace_of(dir.path(), 0).is_empty());
    for n in 1..=5u64 {
        s.step().unwrap();
        // What a kill now would leave: every step taken, the session not finished.
        assert_eq!(trace_of(dir.path(), 0).len() as u64, n);
        let (runs, row) = runs_row(dir.path(), 0);
        assert_eq!(value(&runs, "finished", row), Value::Bool(false));
    }
    assert_eq!(s.budget_left(), None, "no limit");
    let (runs, row) = runs_row(dir.path(), 0);
    assert_eq!(
        value(&runs, "participant", row),
        Value::Str("p-test".into())
    );
    assert_eq!(value(&runs, "session", row), Value::Str(s.id().to_owned()));
    // Run to the end: the last step marks it finished (the front end calls finish).
    while s.step().unwrap().is_some() {}
    s.finish().unwrap();
    assert_eq!(trace_of(dir.path(), 0).len(), 50);
    let (runs, row) = runs_row(dir.path(), 0);
    assert_eq!(value(&runs, "finished", row), Value::Bool(true));
    let series = dataset::read_dataset(dir.path(), "series").unwrap();
    assert!(!series.is_empty(), "the checkpoints reached are written");
    // No temporary file is left among the parts.
    assert!(common::temporaries(dir.path()).is_empty());
}

#[test]
fn sessions_of_one_folder_take_their_own_run_index_stream_and_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Session::start(dir.path(), teaching(NO_LIMIT, 100)).unwrap();
    let mut b = Session::start(dir.path(), teaching(NO_LIMIT, 100)).unwrap();
    assert_eq!((a.run_index(), b.run_index()), (0, 1));
    assert_ne!(a.id(), b.id());
    for _ in 0..30 {
        a.step().unwrap();
    }
    for _ in 0..10 {
        b.step().unwrap();
    }
    assert_eq!(trace_of(dir.path(), 0).len(), 30);
    assert_eq!(trace_of(dir.path(), 1).len(), 10);
    assert_eq!(common::parts(dir.path(), "runs").len(), 2);
    // A third session after both: the next index, never one reused.
    drop(a);
    let c = Session::start(dir.path(), teaching(NO_LIMIT, 100)).unwrap();
    assert_eq!(c.run_index(), 2);
    // Each run its own stream: the two traces differ.
    let states = |r: u64| {
        let t = dataset::read_trace(dir.path()).unwrap();
        (0..t.len())
            .filter(|&i| value(&t, "run_index", i).as_f64() == Some(r as f64))
            .map(|i| value(&t, "action", i).as_f64())
            .take(10)
            .collect::<Vec<_>>()
    };
    assert_ne!(states(0), states(1));
}

#[test]
fn the_same_seed_and_inputs_give_the_same_session() {
    let trace = || {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::start(dir.path(), teaching(NO_LIMIT, 300)).unwrap();
        let mut judged = 0;
        while let Some(shown) = s.step().unwrap() {
            if matches!(shown.actor, Actor::Mf | Actor::Mb) && shown.step % 7 == 0 {
                s.judge(shown.step, shown.step % 2 == 0).unwrap();
                judged += 1;
            }
            if s.holding() && !s.is_over() && shown.step % 5 == 0 {
                s.take_over(4).unwrap();
            }
        }
        assert!(judged > 5);
        let rows: Vec<_> = trace_of(dir.path(), 0)
            .into_iter()
            .map(|r| (r.0, r.1, r.2))
            .collect();
        rows
    };
    let (first, second) = (trace(), trace());
    assert_eq!(first.len(), 300);
    assert_eq!(first, second);
    // The person's feedback changed what the robot did: not the run without a person.
    assert!(first.iter().any(|r| r.2 == "takeover"));
}

#[test]
fn a_person_is_refused_outside_teach_and_teach_refuses_a_simulated_human() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    // `run` does not know the person.
    let r = run(&["run", "--interaction", "person", "--out", o]);
    assert_eq!(r.status.code(), Some(2));
    // Nor does a sweep file.
    let sweep = common::write_sweep(
        dir.path(),
        "p.toml",
        "seeds = 1\n[fixed]\ntask = \"tidy1\"\ncontroller = \"ec\"\ninteraction = \"person\"\nbudget = 5\nsteps = 10\n",
    );
    let r = run(&["sweep", &sweep, "--out", o, "--quiet"]);
    assert_eq!(r.status.code(), Some(2));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("mbmf teach"), "{err}");
    for (flags, names) in [
        (&["--interaction", "takeover"][..], "--interaction"),
        (&["--forget", "0.2"][..], "--forget"),
        (&["--congratulation-effect", "reward"][..], "bias"),
        (&["--task", "twostep"][..], "tidy1 or tidy2"),
        (&["--participant", "Jane Doe"][..], "pseudonym"),
    ] {
        let mut args = vec!["teach", "--port", "0", "--sessions", o];
        args.extend_from_slice(flags);
        let r = run(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{flags:?}: {err}");
        assert!(err.contains(names), "{flags:?}: {err}");
    }
    assert!(!out.exists(), "a refused teach leaves no folder");
    // Sessions never go into another kind of dataset.
    run_ok(&[
        "run",
        "--controller",
        "ec",
        "--runs",
        "1",
        "--steps",
        "10",
        "--out",
        o,
        "--quiet",
    ]);
    let r = run(&["teach", "--port", "0", "--sessions", o]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("not sessions"));
}

#[test]
fn view_refuses_a_run_without_a_trace_or_that_is_not_there() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("r");
    let o = o.to_str().unwrap();
    let small = [
        "run",
        "--controller",
        "ec",
        "--runs",
        "2",
        "--steps",
        "30",
        "--quiet",
    ];
    run_ok(&[&small[..], &["--out", o]].concat());
    let r = run(&["view", o, "--run", "0", "--port", "0"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("trace"));
    run_ok(&[&small[..], &["--out", o, "--trace", "--force"]].concat());
    let r = run(&["view", o, "--run", "9", "--port", "0"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--run 9"));
}

fn http(addr: &str, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    String::from_utf8_lossy(&out).into_owned()
}

#[test]
fn the_server_listens_on_loopback_serves_its_page_and_refuses_other_origins() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = dir.path().join("s");
    let served = serve(&["teach", "--sessions", sessions.to_str().unwrap()]);
    assert!(served.addr.starts_with("127.0.0.1:"), "{}", served.addr);
    let page = http(
        &served.addr,
        &format!(
            "GET / HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
            served.addr
        ),
    );
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(page.contains("content-security-policy"), "{page}");
    assert!(page.contains("<svg") && page.contains("/ws"));
    let upgrade = |origin: &str| {
        http(
            &served.addr,
            &format!(
                "GET /ws HTTP/1.1\r\nHost: {}\r\nOrigin: {origin}\r\nConnection: Upgrade\r\n\
                 Upgrade: websocket\r\nSec-WebSocket-Version: 13\r\n\
                 Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
                served.addr
            ),
        )
    };
    assert!(upgrade("http://evil.example").starts_with("HTTP/1.1 403"));
    // No session was started by the refused socket.
    assert!(!sessions.join("runs").exists() || common::parts(&sessions, "runs").is_empty());
}

/// Reads one server frame (unmasked, as servers send) from a WebSocket: its text.
fn read_frame(s: &mut TcpStream) -> String {
    let mut head = [0u8; 2];
    s.read_exact(&mut head).unwrap();
    let mut len = u64::from(head[1] & 0x7f);
    if len == 126 {
        let mut ext = [0u8; 2];
        s.read_exact(&mut ext).unwrap();
        len = u64::from(u16::from_be_bytes(ext));
    } else if len == 127 {
        let mut ext = [0u8; 8];
        s.read_exact(&mut ext).unwrap();
        len = u64::from_be_bytes(ext);
    }
    let mut body = vec![0u8; len as usize];
    s.read_exact(&mut body).unwrap();
    String::from_utf8_lossy(&body).into_owned()
}

#[test]
fn a_killed_server_loses_at_most_the_step_in_progress() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = dir.path().join("s");
    let mut served = serve(&[
        "teach",
        "--sessions",
        sessions.to_str().unwrap(),
        "--pace-ms",
        "100",
    ]);
    // A client that shakes hands, then only listens: the session steps at its pace.
    let mut ws = TcpStream::connect(&served.addr).unwrap();
    ws.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(
        ws,
        "GET /ws HTTP/1.1\r\nHost: {}\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n\
         Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
        served.addr
    )
    .unwrap();
    let mut response = Vec::new();
    while !response.ends_with(b"\r\n\r\n") {
        let mut b = [0u8; 1];
        ws.read_exact(&mut b).unwrap();
        response.push(b[0]);
    }
    assert!(String::from_utf8_lossy(&response).starts_with("HTTP/1.1 101"));
    let mut last_seen = 0;
    while last_seen < 15 {
        let message: serde_json::Value = serde_json::from_str(&read_frame(&mut ws)).unwrap();
        if message["type"] == "step" {
            last_seen = message["step"].as_u64().unwrap();
        }
    }
    // SIGKILL: no handler runs, nothing is flushed on the way out.
    served.kill();
    let rows = trace_of(&sessions, 0);
    assert!(
        rows.len() as u64 >= last_seen && rows.len() as u64 <= last_seen + 1,
        "{} steps kept, {last_seen} shown",
        rows.len()
    );
    let (runs, row) = runs_row(&sessions, 0);
    assert_eq!(value(&runs, "finished", row), Value::Bool(false));
}
