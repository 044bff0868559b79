//! `mbmf teach` (a person teaches a live run in a web page, SPEC 15) and `mbmf view` (a traced
//! run replayed in the same page): flags, messages and exit codes over [`crate::web`] and
//! [`crate::session`].

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::anyhow;
use clap::Args;

use super::args::{ParamArgs, explain, load_task, seed};
use super::{Failure, runtime, usage};
use crate::analysis::dataset::{self, Value};
use crate::env::registry;
use crate::params::{Controller, Interaction, Params, Profile};
use crate::session::{self, NO_LIMIT, Teaching};
use crate::web::{self, Mode, ReplayRow, Server, TeachOptions};

/// `mbmf teach`.
#[derive(Debug, Clone, Args)]
pub struct TeachArgs {
    /// The task (a tidy task: a person judges and moves cubes).
    #[arg(long, default_value = "tidy1")]
    pub task: String,
    /// The robot's controller.
    #[arg(long, value_enum, default_value = "ec")]
    pub controller: Controller,
    /// Master seed; with each session's run index it fixes the session's random stream.
    #[arg(long, default_value_t = 1, value_parser = seed)]
    pub seed: u64,
    /// Folder of the sessions dataset (created if needed; sessions are added, never replaced).
    #[arg(long, default_value = "sessions")]
    pub sessions: PathBuf,
    /// A text file shown first; a session starts only when the person agrees to it.
    #[arg(long, value_name = "FILE")]
    pub consent: Option<PathBuf>,
    /// The participant's pseudonym for every session of this server (letters, digits, - and
    /// _; at most 40). Default: a random one per session.
    #[arg(long)]
    pub participant: Option<String>,
    /// Address to listen on. Default 127.0.0.1: only this machine. Any other address lets other
    /// machines teach (a warning says so).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Port to listen on (0: any free port; the URL printed says which).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Milliseconds per step when a session starts (the person changes it): 100 to 5000.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(100..=5000))]
    pub pace_ms: u64,
    /// Sessions open at once, at most (a further tab is told to come back later).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..=64))]
    pub max_sessions: u64,
    /// The robot's other parameters and the person's budget (--budget: interactions a session
    /// allows; none given: no limit) and zeta.
    #[command(flatten)]
    pub params: ParamArgs,
}

/// `mbmf view`.
#[derive(Debug, Clone, Args)]
pub struct ViewArgs {
    /// A traced dataset (mbmf run --trace, a sweep with trace = true, or a sessions folder).
    pub dir: PathBuf,
    /// The run to replay (its run_index).
    #[arg(long)]
    pub run: u64,
    /// Address to listen on (default: only this machine).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Port to listen on (0: any free port).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
}

/// The robot's parameters for every session, checked.
fn teaching_params(args: &TeachArgs) -> anyhow::Result<Params> {
    if let Some((p, _)) = args.params.given.iter().find(|(p, _)| {
        matches!(
            p.name,
            "interaction" | "reward_source" | "forget_prob" | "error_prob"
        )
    }) {
        return Err(anyhow!(
            "{} describes a simulated human; in mbmf teach the human is the person (--budget and \
             --zeta still apply)",
            p.flag()
        ));
    }
    let mut params = Params {
        controller: args.controller,
        profile: Profile::Custom,
        steps: registry::default_steps(&args.task),
        babbling: registry::default_babbling(&args.task),
        ..Params::default()
    };
    params.human.budget = NO_LIMIT;
    args.params.apply(&mut params);
    params.human.interaction = Interaction::Person;
    params.validate().map_err(explain)?;
    Ok(params)
}

/// The address to bind, with a warning when it is not this machine only.
fn address(host: IpAddr, port: u16) -> SocketAddr {
    if !host.is_loopback() {
        eprintln!(
            "warning: listening on {host}: anyone who can reach this machine can open a session \
             (the default, 127.0.0.1, keeps it to this machine)"
        );
    }
    SocketAddr::new(host, port)
}

/// The URL to print for a bound address.
fn url(addr: SocketAddr) -> String {
    let host = match addr.ip() {
        ip if ip.is_unspecified() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        ip => ip,
    };
    format!("http://{}/", SocketAddr::new(host, addr.port()))
}

/// `mbmf teach`.
pub fn teach(args: &TeachArgs) -> Result<(), Failure> {
    let spec = load_task(&args.task, None, None).map_err(usage)?;
    let params = teaching_params(args).map_err(usage)?;
    registry::check_person(&spec, &params).map_err(|e| usage(explain(e)))?;
    if let Some(p) = &args.participant
        && !session::valid_pseudonym(p)
    {
        return Err(usage(anyhow!(
            "--participant {p:?}: a pseudonym is 1 to 40 letters, digits, '-' or '_' (never a \
             person's name)"
        )));
    }
    session::check_folder(&args.sessions).map_err(usage)?;
    let consent = match &args.consent {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| usage(anyhow!("--consent {}: {e}", path.display())))?;
            if text.trim().is_empty() {
                return Err(usage(anyhow!(
                    "--consent {}: the file is empty",
                    path.display()
                )));
            }
            Some(text)
        }
        None => None,
    };
    let options = TeachOptions {
        sessions: args.sessions.clone(),
        teaching: Teaching {
            spec: Arc::new(spec),
            params,
            master_seed: args.seed,
            participant: String::new(),
            command: super::command_line(),
        },
        participant: args.participant.clone(),
        consent,
        pace_ms: args.pace_ms,
        max_sessions: args.max_sessions as usize,
    };
    let sessions = args.sessions.display().to_string();
    let server = Server {
        addr: address(args.host, args.port),
        mode: Mode::Teach(Box::new(options)),
    };
    web::serve(
        server,
        |addr| {
            outln!(
                "mbmf teach: open {} (sessions go to {sessions}/; Ctrl-C stops)",
                url(addr)
            );
        },
        |line| eprintln!("{line}"),
    )
    .map_err(|e| match e {
        web::WebError::Bind { .. } => usage(e),
        other => runtime(other),
    })
}

/// `mbmf view`.
pub fn view(args: &ViewArgs) -> Result<(), Failure> {
    let data = |e: dataset::DatasetError| usage(anyhow!(e));
    let runs = dataset::read_runs(&args.dir).map_err(data)?;
    let index = runs.column("run_index").map_err(data)?;
    let row = (0..runs.len())
        .find(|&i| index.value(i).as_f64() == Some(args.run as f64))
        .ok_or_else(|| {
            usage(anyhow!(
                "--run {}: {} has no run with that run_index ({} runs)",
                args.run,
                args.dir.display(),
                runs.len()
            ))
        })?;
    let text = |name: &str| match runs.column(name).map(|c| c.value(row)) {
        Ok(Value::Str(s)) => Some(s),
        _ => None,
    };
    let task = text("task").ok_or_else(|| usage(anyhow!("the runs table names no task")))?;
    let spec = load_task(&task, None, None).map_err(usage)?;
    let trace = dataset::read_trace(&args.dir).map_err(data)?;
    let col = |name: &str| trace.column(name).map_err(data);
    let (run_index, step, state, action, next_state) = (
        col("run_index")?,
        col("step")?,
        col("state")?,
        col("action")?,
        col("next_state")?,
    );
    let (reward, terminal, actor, event) = (
        col("reward")?,
        col("terminal")?,
        col("actor")?,
        col("human_event")?,
    );
    let uint = |v: Value| v.as_f64().map(|x| x as u64);
    let str_of = |v: Value| match v {
        Value::Str(s) => s,
        _ => String::new(),
    };
    let mut rows: Vec<ReplayRow> = (0..trace.len())
        .filter(|&i| uint(run_index.value(i)) == Some(args.run))
        .map(|i| ReplayRow {
            step: uint(step.value(i)).unwrap_or(0),
            state: uint(state.value(i)).unwrap_or(0) as usize,
            action: uint(action.value(i)),
            next_state: uint(next_state.value(i)).unwrap_or(0) as usize,
            reward: reward.value(i).as_f64().unwrap_or(0.0),
            terminal: matches!(terminal.value(i), Value::Bool(true)),
            actor: str_of(actor.value(i)),
            event: str_of(event.value(i)),
        })
        .collect();
    if rows.is_empty() {
        return Err(usage(anyhow!(
            "--run {}: the trace of {} has no row of that run",
            args.run,
            args.dir.display()
        )));
    }
    rows.sort_by_key(|r| r.step);
    let rows = web::replay_rows(&spec.state_names, rows.into_iter())
        .map_err(|e| usage(anyhow!("{}: {e}", args.dir.display())))?;
    let participant = text("participant").unwrap_or_else(|| {
        format!(
            "simulated human: {}",
            text("interaction").unwrap_or_else(|| "none".into())
        )
    });
    let n = rows.len();
    let server = Server {
        addr: address(args.host, args.port),
        mode: Mode::View(web::Replay {
            task,
            participant,
            rows,
        }),
    };
    web::serve(
        server,
        |addr| {
            outln!(
                "mbmf view: open {} (run {}, {n} steps; Ctrl-C stops)",
                url(addr),
                args.run
            )
        },
        |line| eprintln!("{line}"),
    )
    .map_err(|e| match e {
        web::WebError::Bind { .. } => usage(e),
        other => runtime(other),
    })
}
