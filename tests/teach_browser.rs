//! `mbmf teach` and `mbmf view` as a person uses them: the page driven in real headless
//! Chromium (Debian's chromium and chromium-driver, with Selenium in the project's venv, all
//! installed by scripts/browser-env.sh) by tests/browser/teach_browser.py, then the sessions
//! read back from Parquet. Without the browser the tests say they skip; under `CI=true` they
//! fail.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use mbmf::analysis::dataset::{self, Value};
use serde_json::Value as Json;

/// One browser scenario at a time: on a 2-core machine four Chromiums at once starve the
/// servers they drive.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The venv python with Selenium, if the browser and its driver are installed.
fn browser_python() -> Option<PathBuf> {
    let missing: Vec<&str> = ["/usr/bin/chromium", "/usr/bin/chromedriver"]
        .into_iter()
        .filter(|p| !Path::new(p).exists())
        .collect();
    if !missing.is_empty() {
        let why = format!("{} not installed", missing.join(" and "));
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("CI=true but {why}; .ci/run runs scripts/browser-env.sh first");
        }
        eprintln!("SKIP browser test: {why} (run scripts/browser-env.sh)");
        return None;
    }
    common::venv_python("MBMF_BROWSER_PYTHON", ".venv", "selenium")
}

/// A browser test's set-up: the browser's lock (or `None`: skip), a `mbmf teach` server on a
/// fresh sessions folder with `args`, and its URL.
struct Teaching {
    _one: std::sync::MutexGuard<'static, ()>,
    py: PathBuf,
    _dir: tempfile::TempDir,
    sessions: PathBuf,
    served: common::Served,
    url: String,
}

fn teaching(args: &[&str]) -> Option<Teaching> {
    let one = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let py = browser_python()?;
    let dir = tempfile::tempdir().unwrap();
    let sessions = dir.path().join("sessions");
    let mut all = vec!["teach", "--sessions", sessions.to_str().unwrap()];
    all.extend_from_slice(args);
    let served = common::serve(&all);
    let url = format!("http://{}/", served.addr);
    Some(Teaching {
        _one: one,
        py,
        _dir: dir,
        sessions,
        served,
        url,
    })
}

/// Runs a scenario of the Selenium driver; its JSON result.
fn scenario(py: &Path, args: &[&str]) -> Json {
    let out = Command::new(py)
        .arg(common::repo().join("tests/browser/teach_browser.py"))
        .args(args)
        .output()
        .expect("python starts");
    assert!(
        out.status.success(),
        "teach_browser.py {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.lines().last().unwrap_or("")).expect("one JSON line")
}

/// Trace rows of run `r` of `dir`: step -> (actor, event).
fn trace(dir: &Path, r: u64) -> Vec<(u64, String, String)> {
    let t = dataset::read_trace(dir).unwrap();
    let v = |name: &str, i: usize| t.column(name).unwrap().value(i);
    let text = |x: Value| match x {
        Value::Str(s) => s,
        other => panic!("{other:?}"),
    };
    let mut rows: Vec<_> = (0..t.len())
        .filter(|&i| v("run_index", i).as_f64() == Some(r as f64))
        .map(|i| {
            (
                v("step", i).as_f64().unwrap() as u64,
                text(v("actor", i)),
                text(v("human_event", i)),
            )
        })
        .collect();
    rows.sort();
    rows
}

fn steps(v: &Json) -> Vec<u64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

#[test]
fn a_person_congratulates_punishes_takes_over_and_closes_the_tab() {
    let consent_dir = tempfile::tempdir().unwrap();
    let consent = consent_dir.path().join("consent.txt");
    let text = "You will teach a robot to tidy cubes. Nothing about you is kept.";
    std::fs::write(&consent, text).unwrap();
    let consent = consent.to_str().unwrap();
    let args = ["--consent", consent, "--budget", "50", "--pace-ms", "200"];
    let Some(t) = teaching(&args) else { return };
    let (sessions, got) = (&t.sessions, scenario(&t.py, &["teach", &t.url]));
    // The tab is closed: the session is kept, unfinished, with every step it showed.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let rows = trace(sessions, 0);
    let seen = got["last_step_seen"].as_u64().unwrap();
    assert!(
        rows.len() as u64 >= seen,
        "{} rows, {seen} shown",
        rows.len()
    );
    assert_eq!(
        rows.iter().map(|r| r.0).collect::<Vec<_>>(),
        (1..=rows.len() as u64).collect::<Vec<_>>()
    );
    let event_at = |step: u64| &rows[step as usize - 1];
    for (key, event) in [
        ("congratulated", "congratulation"),
        ("punished", "punishment"),
    ] {
        let at = steps(&got[key]);
        assert_eq!(at.len(), 1, "{key}: {got}");
        assert_eq!(event_at(at[0]).2, event, "step {}", at[0]);
    }
    let takeover = got["takeover_step"].as_u64().unwrap();
    assert_eq!(
        (event_at(takeover).1.as_str(), event_at(takeover).2.as_str()),
        ("human", "takeover")
    );
    assert_eq!(
        rows.iter().filter(|r| r.2 != "none").count(),
        3,
        "nothing else was given"
    );
    let runs = dataset::read_runs(sessions).unwrap();
    let v = |name: &str| runs.column(name).unwrap().value(0);
    assert_eq!(v("finished"), Value::Bool(false));
    assert_eq!(v("interactions").as_f64(), Some(3.0));
    // The analysis verbs read the session as they read simulated runs.
    let fit = common::run_ok(&["fit-human", sessions.to_str().unwrap(), "--json"]);
    let fit: Json = serde_json::from_slice(&fit.stdout).unwrap();
    assert_eq!(fit["sessions"].as_array().unwrap().len(), 1, "{fit}");
}

#[test]
fn two_people_teach_at_once_in_sessions_of_their_own() {
    let Some(t) = teaching(&[]) else { return };
    let (py, sessions, url) = (&t.py, &t.sessions, &t.url);
    let got = scenario(py, &["two", url, url]);
    let (a, b) = (&got["first"], &got["second"]);
    assert_ne!(a["participant"], b["participant"], "{got}");
    std::thread::sleep(std::time::Duration::from_millis(500));
    let runs = dataset::read_runs(sessions).unwrap();
    assert_eq!(runs.len(), 2);
    let participants: Vec<Value> = (0..2)
        .map(|i| runs.column("participant").unwrap().value(i))
        .collect();
    assert_ne!(participants[0], participants[1]);
    for r in [0, 1] {
        let rows = trace(sessions, r);
        assert!(!rows.is_empty());
        assert_eq!(rows.iter().filter(|x| x.2 == "congratulation").count(), 1);
    }
}

#[test]
fn hostile_messages_close_their_own_socket_and_leave_a_session_running() {
    let Some(t) = teaching(&[]) else { return };
    let got = scenario(&t.py, &["hostile", &t.url]);
    assert!(
        got["step_after"].as_u64() > got["step_before"].as_u64(),
        "{got}"
    );
    // The person's session (run 0) has their congratulation; the server still serves.
    let rows = trace(&t.sessions, 0);
    let at = steps(&got["congratulated"]);
    assert_eq!(rows[at[0] as usize - 1].2, "congratulation");
    let page = std::net::TcpStream::connect(&t.served.addr);
    assert!(page.is_ok(), "the server is still up");
}

#[test]
fn view_replays_a_simulated_traced_run_step_by_step() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let Some(py) = browser_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    common::run_ok(&[
        "run",
        "--controller",
        "ec",
        "--interaction",
        "takeover",
        "--budget",
        "5",
        "--runs",
        "2",
        "--steps",
        "60",
        "--trace",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    let served = common::serve(&["view", out.to_str().unwrap(), "--run", "1"]);
    let got = scenario(&py, &["view", &format!("http://{}/", served.addr)]);
    assert_eq!(got["rows"].as_u64(), Some(60), "{got}");
    assert_eq!(got["step_after_scrub"].as_u64(), Some(60));
}
