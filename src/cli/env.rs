//! `mbmf env`: what an environment holds, and its export in the authors' format.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::Subcommand;

use super::args::{TaskFiles, load_task};
use super::{Failure, runtime, usage};
use crate::env::Spec;

/// `mbmf env ...`
#[derive(Debug, Subcommand)]
pub enum EnvCommand {
    /// Print the state and action counts, the goal and a few state names.
    Info {
        /// The task (the list is the task registry's).
        #[arg(help = crate::env::registry::short_help(), long_help = crate::env::registry::help())]
        task: String,
        /// The json: task's files, if not beside the model.
        #[command(flatten)]
        files: TaskFiles,
    },
    /// Write a built-in task in the authors' transition-model format.
    ///
    /// Example: mbmf env export tidy1 --json out/tidy1
    Export {
        /// The task (the list is the task registry's).
        #[arg(help = crate::env::registry::short_help(), long_help = crate::env::registry::help())]
        task: String,
        /// Folder to write TASK.json, keyStates.txt and spaces.txt into.
        #[arg(long)]
        json: PathBuf,
        /// The json: task's files, if not beside the model.
        #[command(flatten)]
        files: TaskFiles,
    },
}

/// `mbmf env ...`.
pub fn command(cmd: &EnvCommand) -> Result<(), Failure> {
    match cmd {
        EnvCommand::Info { task, files } => {
            let spec = load_task(task, files.key_states.as_deref(), files.spaces.as_deref())
                .map_err(usage)?;
            if !spec.can_move() {
                eprintln!("warning: {}", super::args::no_transition(task));
            }
            out!("{}", env_info(&spec));
            Ok(())
        }
        EnvCommand::Export { task, json, files } => {
            if json.exists() && !json.is_dir() {
                return Err(usage(anyhow!(
                    "--json {} is a file, not a folder; give a folder to write the model, \
                     keyStates.txt and spaces.txt into",
                    json.display()
                )));
            }
            let spec = load_task(task, files.key_states.as_deref(), files.spaces.as_deref())
                .map_err(usage)?;
            refuse_overwriting_sources(task, files, &spec, json)?;
            let paths = crate::env::json::export(&spec, json).map_err(runtime)?;
            outln!(
                "wrote {}, {} and {}",
                paths.model.display(),
                paths.key_states.display(),
                paths.spaces.display()
            );
            Ok(())
        }
    }
}

/// Refuses an export that would replace the files its task was loaded from: the export is
/// written file by file, so a failure half-way (or a model that does not round-trip exactly)
/// would lose the original. Paths are compared canonically, so `./x` and `x` are one file.
fn refuse_overwriting_sources(
    task: &str,
    files: &TaskFiles,
    spec: &Spec,
    dir: &std::path::Path,
) -> Result<(), Failure> {
    let Some(model) = task.strip_prefix("json:") else {
        return Ok(());
    };
    let mut sources = crate::env::JsonPaths::beside(model);
    if let Some(k) = &files.key_states {
        sources.key_states = k.clone();
    }
    if let Some(s) = &files.spaces {
        sources.spaces = s.clone();
    }
    let targets = crate::env::json::export_paths(spec, dir);
    let sources = [sources.model, sources.key_states, sources.spaces];
    for target in [targets.model, targets.key_states, targets.spaces] {
        let Ok(target_real) = std::fs::canonicalize(&target) else {
            continue;
        };
        if let Some(source) = sources
            .iter()
            .find(|s| std::fs::canonicalize(s).is_ok_and(|s| s == target_real))
        {
            return Err(usage(anyhow!(
                "--json {}: exporting there would overwrite {}, which '{task}' was loaded \
                 from; choose another folder",
                dir.display(),
                source.display()
            )));
        }
    }
    Ok(())
}

/// A number as a person reads it: plain, or in scientific notation when plain would spell out
/// dozens of digits (`1e306`, `2.5e-9`).
fn readable(x: f64) -> String {
    let magnitude = x.abs();
    if magnitude != 0.0 && !(1e-4..1e9).contains(&magnitude) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Initial states shown by `mbmf env info` before "...".
const SHOWN_INITIAL: usize = 10;

/// What `mbmf env info` prints.
fn env_info(spec: &Spec) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(out, "task      {}", spec.name);
    let _ = writeln!(out, "states    {}", spec.n_states);
    let _ = writeln!(out, "actions   {}", spec.n_actions);
    let _ = writeln!(
        out,
        "outcomes  {} (max {} per state-action pair)",
        spec.outcome_state.len(),
        spec.max_branching()
    );
    let initial = &spec.initial_states;
    let _ = if initial.len() > SHOWN_INITIAL {
        writeln!(
            out,
            "initial   {:?} ... ({} states)",
            &initial[..SHOWN_INITIAL],
            initial.len()
        )
    } else {
        writeln!(out, "initial   {initial:?}")
    };
    let _ = match spec.goal {
        Some(goal) => {
            let goal_name = spec
                .state_names
                .get(goal.state as usize)
                .map_or("?", String::as_str);
            writeln!(
                out,
                "goal      {} ({goal_name}), reward {}",
                goal.state,
                readable(goal.reward)
            )
        }
        None => writeln!(out, "goal      none (each outcome carries its own reward)"),
    };
    let _ = writeln!(
        out,
        "human     {}",
        if spec.human.is_some() {
            "defined"
        } else {
            "not defined (no interactions)"
        }
    );
    for (i, name) in spec.state_names.iter().enumerate().take(5) {
        let _ = writeln!(out, "  state {i:>4}: {name}");
    }
    out
}
