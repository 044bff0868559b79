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
        /// tidy1, tidy2 or json:PATH.
        task: String,
        /// The json: task's files, if not beside the model.
        #[command(flatten)]
        files: TaskFiles,
    },
    /// Write a built-in task in the authors' transition-model format.
    ///
    /// Example: mbmf env export tidy1 --json out/tidy1
    Export {
        /// tidy1, tidy2 or json:PATH.
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
    let goal_name = spec
        .state_names
        .get(spec.goal as usize)
        .map_or("?", String::as_str);
    let _ = writeln!(
        out,
        "goal      {} ({goal_name}), reward {}",
        spec.goal, spec.goal_reward
    );
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
