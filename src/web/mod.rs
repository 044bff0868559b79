//! The web page of `mbmf teach` (a person teaches a live run, SPEC 15) and `mbmf view` (a traced
//! run replayed), served by axum on a tokio runtime: one page embedded in the binary (it works
//! offline) and one WebSocket per tab.
//!
//! The server trusts nothing its client sends: messages are JSON objects of at most
//! [`MAX_MESSAGE`] bytes with known fields and bounded values; anything else closes that tab's
//! session with a logged reason, never the server; no message names a file. A WebSocket from
//! another origin (a page elsewhere driving the person's browser) is refused. Each tab is its
//! own [`Session`], committed at every step, so a closed tab or a killed server loses at most
//! the step in progress.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use serde_json::{Value, json};

use crate::session::{Session, SessionError, Shown, Teaching};

/// The page, embedded.
const PAGE: &str = include_str!("page.html");

/// Largest message a client may send, in bytes.
pub const MAX_MESSAGE: usize = 512;

/// Slowest and fastest pace a person may choose, in milliseconds per step.
pub const PACE_MS: std::ops::RangeInclusive<u64> = 100..=5000;

/// What the server serves.
pub enum Mode {
    /// Live sessions, one per tab.
    Teach(Box<TeachOptions>),
    /// One traced run, replayed.
    View(Replay),
}

/// How `mbmf teach` runs its sessions.
pub struct TeachOptions {
    /// Where the sessions dataset is.
    pub sessions: PathBuf,
    /// The robot and its task, for every session (the participant is set per session).
    pub teaching: Teaching,
    /// The pseudonym given on the command line (else each session draws one).
    pub participant: Option<String>,
    /// Text the person must agree to before a session starts.
    pub consent: Option<String>,
    /// The pace a session starts at, in milliseconds per step.
    pub pace_ms: u64,
    /// Sessions open at once, at most.
    pub max_sessions: usize,
}

/// A traced run to replay: the `hello` fields and the rows, as the page reads them.
pub struct Replay {
    /// The task's name.
    pub task: String,
    /// The run's participant (a session) or a description of the simulated human.
    pub participant: String,
    /// The steps, as `step` messages.
    pub rows: Vec<Value>,
}

/// Where the server listens and what it serves.
pub struct Server {
    /// Address to bind (loopback unless the front end was told otherwise).
    pub addr: SocketAddr,
    /// Teach or view.
    pub mode: Mode,
}

/// What stops the server from starting or running.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    /// The address cannot be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The runtime or the listener failed.
    #[error("the server stopped: {0}")]
    Io(#[from] std::io::Error),
}

/// The state every request sees.
struct Shared {
    mode: Mode,
    open: AtomicUsize,
    /// Session messages for the operator (start, end, refused clients), printed by `log`.
    log: Box<dyn Fn(&str) + Send + Sync>,
    /// Serialises the claim of run indices by sessions of this server.
    starting: Mutex<()>,
}

/// Serves until interrupted (Ctrl-C or SIGTERM); `ready` is called with the bound address (the
/// port chosen when 0 was asked) before the first request, `log` with each session event.
pub fn serve(
    server: Server,
    ready: impl FnOnce(SocketAddr),
    log: impl Fn(&str) + Send + Sync + 'static,
) -> Result<(), WebError> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(server.addr)
            .await
            .map_err(|source| WebError::Bind {
                addr: server.addr,
                source,
            })?;
        ready(listener.local_addr()?);
        let shared = Arc::new(Shared {
            mode: server.mode,
            open: AtomicUsize::new(0),
            log: Box::new(log),
            starting: Mutex::new(()),
        });
        let app = Router::new()
            .route("/", get(page))
            .route("/ws", get(socket))
            .with_state(shared);
        axum::serve(listener, app)
            .with_graceful_shutdown(stopped())
            .await?;
        Ok(())
    })
}

/// Resolves on Ctrl-C or SIGTERM.
async fn stopped() {
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term => {}
    }
}

/// The page, with headers that keep it from loading anything from elsewhere.
async fn page() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (
                header::CONTENT_SECURITY_POLICY,
                "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
                 img-src data:; connect-src 'self'",
            ),
            (header::CACHE_CONTROL, "no-store"),
        ],
        Html(PAGE),
    )
        .into_response()
}

/// Whether the request comes from this server's own page: no `Origin` (not a browser), or one
/// whose host is the `Host` asked for.
fn same_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return true;
    };
    let (Ok(origin), Some(Ok(host))) = (
        origin.to_str(),
        headers.get(header::HOST).map(|h| h.to_str()),
    ) else {
        return false;
    };
    origin
        .split_once("://")
        .is_some_and(|(_, rest)| rest.trim_end_matches('/') == host)
}

async fn socket(
    State(shared): State<Arc<Shared>>,
    headers: HeaderMap,
    upgrade: WebSocketUpgrade,
) -> Response {
    if !same_origin(&headers) {
        (shared.log)("refused a WebSocket from another origin");
        return (StatusCode::FORBIDDEN, "another origin").into_response();
    }
    upgrade
        .max_message_size(MAX_MESSAGE)
        .max_frame_size(MAX_MESSAGE)
        .on_upgrade(move |ws| async move {
            match &shared.mode {
                Mode::View(replay) => view(ws, replay).await,
                Mode::Teach(_) => teach(ws, Arc::clone(&shared)).await,
            }
        })
}

async fn send(ws: &mut WebSocket, message: &Value) -> bool {
    ws.send(Message::Text(message.to_string().into()))
        .await
        .is_ok()
}

async fn close(ws: &mut WebSocket, reason: &str) {
    let reason: String = reason.chars().take(100).collect();
    let _ = ws
        .send(Message::Close(Some(CloseFrame {
            code: 1008,
            reason: reason.into(),
        })))
        .await;
}

/// Replays a run: hello, then every row; the page plays them.
async fn view(mut ws: WebSocket, replay: &Replay) {
    let hello = json!({
        "type": "hello", "mode": "view", "task": replay.task,
        "participant": replay.participant, "session": null, "consent": null,
        "budget": null, "budget_left": null, "steps": replay.rows.len(),
        "pace_ms": 300, "actions": action_names(),
    });
    if send(&mut ws, &hello).await {
        let rows =
            json!({"type": "replay", "rows": replay.rows, "participant": replay.participant});
        let _ = send(&mut ws, &rows).await;
    }
    // Nothing is expected from a viewer; wait for it to leave.
    while let Some(Ok(m)) = ws.recv().await {
        if matches!(m, Message::Close(_)) {
            break;
        }
    }
}

/// The tidy tasks' action names, for the page's text.
fn action_names() -> Vec<&'static str> {
    vec![
        "take red",
        "take green",
        "take blue",
        "put in red box",
        "put in green box",
        "put in blue box",
        "put on table",
    ]
}

/// A message from the page, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Request {
    Consent,
    Pace(u64),
    Pause,
    Resume,
    Feedback { step: u32, positive: bool },
    Takeover(usize),
    Stop,
}

/// Parses one client message; the error says what was wrong (and closes the session).
fn parse(text: &str) -> Result<Request, String> {
    let value: Value = serde_json::from_str(text).map_err(|_| "not JSON".to_string())?;
    let Value::Object(map) = value else {
        return Err("not a JSON object".into());
    };
    let kind = map
        .get("type")
        .and_then(Value::as_str)
        .ok_or("no \"type\"")?;
    let fields: &[&str] = match kind {
        "consent" | "pause" | "resume" | "stop" => &[],
        "pace" => &["ms"],
        "feedback" => &["step", "sign"],
        "takeover" => &["to"],
        _ => return Err(format!("unknown type {:?}", truncate(kind))),
    };
    if let Some(k) = map
        .keys()
        .find(|k| k.as_str() != "type" && !fields.contains(&k.as_str()))
    {
        return Err(format!("unexpected field {:?}", truncate(k)));
    }
    let int = |name: &str| map.get(name).and_then(Value::as_i64);
    Ok(match kind {
        "consent" => Request::Consent,
        "pause" => Request::Pause,
        "resume" => Request::Resume,
        "stop" => Request::Stop,
        "pace" => match int("ms") {
            Some(ms) if PACE_MS.contains(&(ms as u64)) && ms > 0 => Request::Pace(ms as u64),
            _ => return Err("pace: ms must be a whole number from 100 to 5000".into()),
        },
        "feedback" => {
            let step = int("step")
                .and_then(|s| u32::try_from(s).ok())
                .ok_or("feedback: step must be a step number")?;
            let positive = match int("sign") {
                Some(1) => true,
                Some(-1) => false,
                _ => return Err("feedback: sign must be 1 or -1".into()),
            };
            Request::Feedback { step, positive }
        }
        _ => {
            let to = map.get("to").and_then(Value::as_str).unwrap_or("");
            let action = match to {
                "red" => 3,
                "green" => 4,
                "blue" => 5,
                "table" => 6,
                _ => return Err("takeover: to must be red, green, blue or table".into()),
            };
            Request::Takeover(action)
        }
    })
}

fn truncate(s: &str) -> String {
    s.chars().take(24).collect()
}

/// A step as the page reads it.
fn step_message(session: &Session, shown: &Shown) -> Value {
    let names = &session.spec().state_names;
    json!({
        "type": "step",
        "step": shown.step,
        "state": names[shown.state],
        "action": shown.action,
        "actor": shown.actor.name(),
        "next_state": names[shown.next_state],
        "reward": shown.reward,
        "total_reward": shown.total_reward,
        "terminal": shown.terminal,
        "event": shown.event.name(),
        "budget_left": shown.budget_left,
        "holding": shown.holding,
    })
}

/// What ends a session's loop.
enum Ending {
    /// Every step taken, or the person pressed stop: committed as finished.
    Finished(&'static str),
    /// The tab closed or the connection dropped: kept as unfinished.
    Left,
    /// The client broke the protocol: kept as unfinished, closed with the reason.
    Broken(String),
    /// The session could not be written.
    Failed(SessionError),
}

/// Runs one tab's session.
async fn teach(mut ws: WebSocket, shared: Arc<Shared>) {
    let Mode::Teach(options) = &shared.mode else {
        return;
    };
    if shared.open.fetch_add(1, Ordering::SeqCst) >= options.max_sessions {
        shared.open.fetch_sub(1, Ordering::SeqCst);
        (shared.log)("refused a session: the server is full (--max-sessions)");
        close(&mut ws, "the server is full: try again later").await;
        return;
    }
    let ending = run_session(&mut ws, &shared, options).await;
    shared.open.fetch_sub(1, Ordering::SeqCst);
    match ending {
        Ok((session, ending)) => {
            let (id, steps) = (session.id().to_owned(), session.step_count());
            let who = format!("session {id} (run {}, {steps} steps)", session.run_index());
            let mut session = session;
            match ending {
                Ending::Finished(reason) => {
                    let written = tokio::task::spawn_blocking(move || session.finish()).await;
                    match written {
                        Ok(Ok(())) => (shared.log)(&format!("{who} finished ({reason})")),
                        Ok(Err(e)) => (shared.log)(&format!("{who}: {e}")),
                        Err(e) => (shared.log)(&format!("{who}: {e}")),
                    }
                    let _ = send(&mut ws, &json!({"type": "end", "reason": reason})).await;
                    close(&mut ws, reason).await;
                }
                Ending::Left => (shared.log)(&format!("{who} left unfinished (tab closed)")),
                Ending::Broken(why) => {
                    (shared.log)(&format!("{who} closed: {why}"));
                    close(&mut ws, &why).await;
                }
                Ending::Failed(e) => {
                    (shared.log)(&format!("{who} stopped: {e}"));
                    close(&mut ws, "the session could not be written").await;
                }
            }
        }
        Err(why) => {
            (shared.log)(&format!("a session did not start: {why}"));
            close(&mut ws, &why).await;
        }
    }
}

/// Greets, waits for consent, starts the session and steps it until it ends.
async fn run_session(
    ws: &mut WebSocket,
    shared: &Shared,
    options: &TeachOptions,
) -> Result<(Session, Ending), String> {
    let participant = options
        .participant
        .clone()
        .unwrap_or_else(crate::session::pseudonym);
    let params = &options.teaching.params;
    let budget = (params.human.budget != crate::session::NO_LIMIT).then_some(params.human.budget);
    let hello = |session: Option<&str>| {
        json!({
            "type": "hello", "mode": "teach", "task": options.teaching.spec.name,
            "participant": participant, "session": session,
            "consent": options.consent, "budget": budget, "budget_left": budget,
            "steps": params.steps, "pace_ms": options.pace_ms, "actions": action_names(),
        })
    };
    if options.consent.is_some() {
        if !send(ws, &hello(None)).await {
            return Err("the tab closed before consenting".into());
        }
        loop {
            match ws.recv().await {
                Some(Ok(Message::Text(t))) => match parse(&t) {
                    Ok(Request::Consent) => break,
                    Ok(_) => {
                        let _ =
                            send(ws, &json!({"type": "refused", "reason": "consent first"})).await;
                    }
                    Err(why) => return Err(format!("malformed message before consent: {why}")),
                },
                Some(Ok(Message::Ping(_) | Message::Pong(_))) => {}
                Some(Ok(Message::Binary(_))) => return Err("binary message".into()),
                _ => return Err("the tab closed before consenting".into()),
            }
        }
    }
    let teaching = Teaching {
        participant: participant.clone(),
        ..options.teaching.clone()
    };
    let dir = options.sessions.clone();
    let guard = shared
        .starting
        .lock()
        .map_err(|_| "server state poisoned")?;
    let started = Session::start(&dir, teaching);
    drop(guard);
    let session = started.map_err(|e| e.to_string())?;
    (shared.log)(&format!(
        "session {} started: participant {participant}, run {}",
        session.id(),
        session.run_index()
    ));
    // The page learns its session's id: in the greeting, or after the consent.
    let greeting = if options.consent.is_some() {
        json!({"type": "started", "session": session.id(), "participant": participant})
    } else {
        hello(Some(session.id()))
    };
    if !send(ws, &greeting).await {
        return Ok((session, Ending::Left));
    }
    let session = Arc::new(Mutex::new(session));
    let ending = drive(ws, &session, options.pace_ms).await;
    let session = Arc::try_unwrap(session)
        .map_err(|_| "session still shared")?
        .into_inner()
        .map_err(|_| "session poisoned")?;
    Ok((session, ending))
}

/// Locks the session for one engine call off the async threads.
async fn with_session<T: Send + 'static>(
    session: &Arc<Mutex<Session>>,
    f: impl FnOnce(&mut Session) -> T + Send + 'static,
) -> T {
    let session = Arc::clone(session);
    tokio::task::spawn_blocking(move || {
        let mut s = session.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut s)
    })
    .await
    .expect("a session call does not panic")
}

/// The session's loop: a step at each tick of the pace (unless paused), and the person's
/// messages in between.
async fn drive(ws: &mut WebSocket, session: &Arc<Mutex<Session>>, pace_ms: u64) -> Ending {
    let mut pace = Duration::from_millis(pace_ms);
    let mut paused = false;
    let mut next = tokio::time::Instant::now() + pace;
    loop {
        let tick = tokio::time::sleep_until(next);
        tokio::select! {
            _ = tick, if !paused => {
                let stepped = with_session(session, |s| {
                    s.step().map(|shown| shown.map(|shown| step_message(s, &shown)))
                })
                .await;
                match stepped {
                    Ok(Some(message)) => {
                        if !send(ws, &message).await {
                            return Ending::Left;
                        }
                    }
                    Ok(None) => return Ending::Finished("finished"),
                    Err(e) => return Ending::Failed(e),
                }
                next = tokio::time::Instant::now() + pace;
            }
            incoming = ws.recv() => {
                let text = match incoming {
                    Some(Ok(Message::Text(t))) => t,
                    Some(Ok(Message::Ping(_) | Message::Pong(_))) => continue,
                    Some(Ok(Message::Binary(_))) => return Ending::Broken("binary message".into()),
                    Some(Ok(Message::Close(_))) | None => return Ending::Left,
                    Some(Err(e)) => return Ending::Broken(format!("connection error: {e}")),
                };
                let request = match parse(&text) {
                    Ok(r) => r,
                    Err(why) => return Ending::Broken(format!("malformed message: {why}")),
                };
                let reply = match request {
                    Request::Consent => None,
                    Request::Pace(ms) => {
                        pace = Duration::from_millis(ms);
                        next = next.min(tokio::time::Instant::now() + pace);
                        None
                    }
                    Request::Pause => {
                        paused = true;
                        None
                    }
                    Request::Resume => {
                        paused = false;
                        next = tokio::time::Instant::now() + pace;
                        None
                    }
                    Request::Stop => return Ending::Finished("stopped"),
                    Request::Takeover(action) => {
                        match with_session(session, move |s| s.take_over(action)).await {
                            Ok(()) => None,
                            Err(e) => Some(json!({"type": "refused", "reason": e.to_string()})),
                        }
                    }
                    Request::Feedback { step, positive } => {
                        let judged = with_session(session, move |s| {
                            s.judge(step, positive).map(|event| (event, s.budget_left()))
                        })
                        .await;
                        match judged {
                            Ok((event, left)) => Some(json!({
                                "type": "feedback", "step": step, "event": event.name(),
                                "budget_left": left,
                            })),
                            Err(crate::session::SessionJudgeError::Refused(e)) => {
                                Some(json!({"type": "refused", "reason": e.to_string()}))
                            }
                            Err(crate::session::SessionJudgeError::Session(e)) => {
                                return Ending::Failed(e);
                            }
                        }
                    }
                };
                if let Some(reply) = reply
                    && !send(ws, &reply).await
                {
                    return Ending::Left;
                }
            }
        }
    }
}

/// The rows of a traced run as the page replays them: one `step` message per trace row.
/// `rows` are (step, state, action, next_state, reward, terminal, actor, event) with state
/// names from `names`.
pub fn replay_rows(
    names: &[String],
    rows: impl Iterator<Item = ReplayRow>,
) -> Result<Vec<Value>, String> {
    let name = |s: usize| {
        names
            .get(s)
            .cloned()
            .ok_or_else(|| format!("state {s} is not a state of the task"))
    };
    let mut total = 0.0;
    let mut out = Vec::new();
    for r in rows {
        total += r.reward;
        out.push(json!({
            "type": "step", "step": r.step, "state": name(r.state)?,
            "action": r.action, "actor": r.actor, "next_state": name(r.next_state)?,
            "reward": r.reward, "total_reward": total, "terminal": r.terminal,
            "event": r.event, "budget_left": null, "holding": false,
        }));
    }
    Ok(out)
}

/// One trace row for [`replay_rows`].
#[derive(Debug, Clone)]
pub struct ReplayRow {
    /// Experiment step.
    pub step: u64,
    /// State before.
    pub state: usize,
    /// Action (none on a reset step).
    pub action: Option<u64>,
    /// State after.
    pub next_state: usize,
    /// Reward of the step.
    pub reward: f64,
    /// Terminal arrival.
    pub terminal: bool,
    /// Who chose.
    pub actor: String,
    /// The human's event.
    pub event: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_client_message_is_checked_field_by_field() {
        assert_eq!(parse(r#"{"type":"pause"}"#), Ok(Request::Pause));
        assert_eq!(parse(r#"{"type":"pace","ms":800}"#), Ok(Request::Pace(800)));
        assert_eq!(
            parse(r#"{"type":"feedback","step":12,"sign":-1}"#),
            Ok(Request::Feedback {
                step: 12,
                positive: false
            })
        );
        assert_eq!(
            parse(r#"{"type":"takeover","to":"table"}"#),
            Ok(Request::Takeover(6))
        );
        for bad in [
            "",
            "[]",
            "null",
            r#"{"type":"pace","ms":50}"#,
            r#"{"type":"pace","ms":"800"}"#,
            r#"{"type":"pace","ms":800,"path":"/etc/passwd"}"#,
            r#"{"type":"feedback","step":-3,"sign":1}"#,
            r#"{"type":"feedback","step":3,"sign":2}"#,
            r#"{"type":"takeover","to":"../runs"}"#,
            r#"{"type":"load","file":"x"}"#,
            r#"{"ms":800}"#,
        ] {
            assert!(parse(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn a_socket_from_another_origin_is_refused() {
        let mut h = HeaderMap::new();
        assert!(same_origin(&h));
        h.insert(header::HOST, "127.0.0.1:8080".parse().unwrap());
        h.insert(header::ORIGIN, "http://127.0.0.1:8080".parse().unwrap());
        assert!(same_origin(&h));
        h.insert(header::ORIGIN, "http://evil.example".parse().unwrap());
        assert!(!same_origin(&h));
    }
}
