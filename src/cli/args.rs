//! Flags shared by the verbs that take a run's parameters, and their value parsers. Ranges are
//! checked by [`Params::validate`], so flags and sweep files share one set of rules.

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Arg, ArgAction, Args};

use crate::env::{self, Spec};
use crate::params::{ConfigError, Kind, PARAMS, Param, Params, Value, cli_flag};

/// Where a `json:` task's keyStates.txt and spaces.txt are, when not beside the model file.
#[derive(Debug, Clone, Args, Default)]
pub struct TaskFiles {
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
}

/// Every parameter of the registry with a flag (all but the controller list and the profile,
/// which `mbmf run` declares itself), as the flags given: unset flags keep the default. Built
/// from [`PARAMS`] at run time, so a row there is a flag here.
#[derive(Debug, Clone, Default)]
pub struct ParamArgs {
    /// The parameters set on the command line, in the registry's order.
    pub given: Vec<(&'static Param, Value)>,
}

impl ParamArgs {
    /// The parameters with a flag.
    fn flags() -> impl Iterator<Item = &'static Param> {
        PARAMS.iter().filter(|p| p.flag)
    }

    /// Applies the flags that were given to `p`.
    pub fn apply(&self, p: &mut Params) {
        for (param, value) in &self.given {
            (param.set)(p, value);
        }
    }
}

impl clap::FromArgMatches for ParamArgs {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let given = ParamArgs::flags()
            .filter_map(|p| Some((p, matches.get_one::<Value>(p.key)?.clone())))
            .collect();
        Ok(ParamArgs { given })
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl clap::Args for ParamArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        ParamArgs::flags().fold(cmd, |cmd, p| cmd.arg(flag(p)))
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// The flag of `param`: its help says what it is, what it accepts and its default; numbers are
/// parsed here and range-checked by [`Params::validate`], so flags and sweep files share one set
/// of rules.
fn flag(param: &'static Param) -> Arg {
    let mut doc = param.doc.to_string();
    if let Some(first) = doc.get_mut(..1) {
        first.make_ascii_uppercase();
    }
    let accepted = param.accepted.map(|a| format!(": {a}")).unwrap_or_default();
    let default = match param.default_value() {
        Value::Switch(b) => if b { "on" } else { "off" }.to_string(),
        other => other.to_string(),
    };
    let arg = Arg::new(param.key)
        .long(param.key.replace('_', "-"))
        .value_name(param.key.to_uppercase())
        .action(ArgAction::Set)
        .help(format!("{doc}{accepted}. Default {default}{}", param.help));
    match param.kind {
        Kind::Real => arg
            .allow_hyphen_values(true)
            .value_parser(|s: &str| number(s).map(Value::Real)),
        Kind::Count => {
            // What the parameter accepts, where it says (`1 to 10000 transitions`), rather than
            // the whole range of the type.
            let range = param.accepted.map_or_else(
                || "a whole number from 0 to 4294967295".to_string(),
                str::to_string,
            );
            arg.allow_negative_numbers(true)
                .value_parser(move |s: &str| count(s, &range).map(Value::Count))
        }
        Kind::Switch => arg.value_parser(
            PossibleValuesParser::new([
                PossibleValue::new("on").help("Enabled"),
                PossibleValue::new("off").help("Disabled"),
            ])
            .map(|s| Value::Switch(s == "on")),
        ),
        Kind::Choice(names) => {
            let mut values = (param.possible_values)();
            if values.is_empty() {
                values = names.iter().map(|n| PossibleValue::new(*n)).collect();
            }
            // Case is ignored, as in sweep files.
            let parser = PossibleValuesParser::new(values).map(move |s: String| {
                let name = names.iter().find(|n| n.eq_ignore_ascii_case(&s));
                Value::Choice(name.copied().unwrap_or_default())
            });
            arg.ignore_case(true).value_parser(parser)
        }
        Kind::Task | Kind::Profile | Kind::Schedule => arg,
    }
}

/// Most runs per controller of one `mbmf run`.
pub const MAX_RUNS: u64 = 1_000_000;

/// Most worker threads `--threads` accepts.
pub const MAX_THREADS: u64 = 4096;

/// Parses a number flag. Ranges are checked by [`Params::validate`], so flags and sweep files
/// share one set of rules; NaN and infinities parse here and are refused there.
pub fn number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| "expected a number, such as 0.5 or 1e-3".to_string())
}

/// Parses a whole number in `min..=max`, saying which rule a bad value breaks (the maximum
/// included, even the largest 64-bit one).
pub fn whole(text: &str, min: u64, max: u64) -> Result<u64, String> {
    whole_described(
        text,
        min,
        max,
        &format!("a whole number from {min} to {max}"),
    )
}

/// [`whole`], saying that `range` is expected.
fn whole_described(text: &str, min: u64, max: u64, range: &str) -> Result<u64, String> {
    match text.trim().parse::<i128>() {
        Ok(n) if n < i128::from(min) => Err(format!("{n} is too small: expected {range}")),
        Ok(n) if n > i128::from(max) => Err(format!("{n} is too large: expected {range}")),
        Ok(n) => Ok(n as u64),
        Err(_) if text.trim().parse::<f64>().is_ok() => {
            Err(format!("not a whole number: expected {range}"))
        }
        Err(_) => Err(format!("expected {range}")),
    }
}

/// A count of steps, sweeps or interactions: 0 to 2^32 - 1, the parameter's own range
/// (`range`, as its message says it) checked later with every other rule.
pub fn count(text: &str, range: &str) -> Result<u32, String> {
    whole_described(text, 0, u64::from(u32::MAX), range).map(|n| n as u32)
}

/// `--runs`: 1 to [`MAX_RUNS`].
pub fn runs_count(text: &str) -> Result<u32, String> {
    whole(text, 1, MAX_RUNS).map(|n| n as u32)
}

/// `--seed`: any 64-bit unsigned integer.
pub fn seed(text: &str) -> Result<u64, String> {
    whole(text, 0, u64::MAX)
}

/// A column name of `--by` or `--metric`: an empty one is refused here, with the flag, rather
/// than looked up (and matched to some unrelated column) in the dataset.
pub fn column(text: &str) -> Result<String, String> {
    if text.trim().is_empty() {
        return Err(
            "the column name is empty: give a column of the dataset, such as \
                    controller, budget or total_reward"
                .to_string(),
        );
    }
    Ok(text.to_string())
}

pub use crate::run::no_transition;

/// `--batch-size`: at least 1.
pub fn batch_size(text: &str) -> Result<usize, String> {
    whole(text, 1, usize::MAX as u64).map(|n| n as usize)
}

/// `--threads`: 1 to [`MAX_THREADS`].
pub fn threads_count(text: &str) -> Result<usize, String> {
    whole(text, 1, MAX_THREADS).map(|n| n as usize)
}

/// Checks, before any work, that `path` can be an output folder: its nearest existing ancestor
/// (the folder itself included) is a folder that can be written into. A file, a device such as
/// `/dev/null` or a read-only folder is a usage error naming `flag`, so no verb computes for
/// minutes and then fails on its first write.
pub fn check_out_dir(path: &Path, flag: &str) -> Result<(), super::Failure> {
    let refuse = |why: String| super::usage(anyhow!("{flag} {}: {why}", path.display()));
    let Some(existing) = crate::sizing::nearest_existing(path) else {
        return Err(refuse("no part of this path exists".into()));
    };
    let metadata = std::fs::metadata(existing).map_err(|e| refuse(e.to_string()))?;
    if !metadata.is_dir() {
        let what = if metadata.is_file() {
            "a file"
        } else {
            "a device, pipe or socket"
        };
        let whose = if existing == path {
            "it is".to_string()
        } else {
            format!("{} is", existing.display())
        };
        return Err(refuse(format!(
            "{whose} {what}, not a folder; give a folder to write into"
        )));
    }
    // Creating (and at once removing) a file is the only reliable test of write access.
    tempfile::Builder::new()
        .prefix(".mbmf-write-check")
        .tempfile_in(existing)
        .map_err(|e| refuse(format!("cannot write into {}: {e}", existing.display())))?;
    Ok(())
}

/// Loads the environment named by `task`, with explicit keyStates / spaces paths if given.
pub fn load_task(task: &str, key_states: Option<&Path>, spaces: Option<&Path>) -> Result<Spec> {
    if let Some(path) = task.strip_prefix("json:") {
        if path.is_empty() {
            return Err(anyhow!(
                "task 'json:' names no file: expected json:PATH, the transition-model file \
                 (e.g. json:data/navworld/realisticNavWorld.json)"
            ));
        }
        let mut paths = env::JsonPaths::beside(path);
        if let Some(k) = key_states {
            paths.key_states = k.to_path_buf();
        }
        if let Some(s) = spaces {
            paths.spaces = s.to_path_buf();
        }
        return Ok(env::json::load(&paths, task)?);
    }
    if key_states.is_some() || spaces.is_some() {
        let flag = if key_states.is_some() {
            "--key-states"
        } else {
            "--spaces"
        };
        return Err(anyhow!(
            "{flag} only applies to json:PATH tasks, not '{task}': the built-in tasks have no files"
        ));
    }
    Ok(env::load(task)?)
}

/// A library configuration error in command-line terms: parameters are named by their flags.
pub fn explain(error: ConfigError) -> anyhow::Error {
    match error {
        ConfigError::InvalidParam {
            name,
            value,
            accepted,
        } => anyhow!(
            "invalid value '{value}' for '{}': expected {accepted}",
            cli_flag(name)
        ),
        ConfigError::Incompatible {
            name,
            value,
            with,
            with_value,
            why,
        } => anyhow!(
            "{} {value} cannot be used with {} {with_value}: {why}",
            cli_flag(name),
            cli_flag(with)
        ),
        other => other.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_number_flags_say_which_rule_a_bad_value_breaks() {
        let any = "a whole number from 0 to 4294967295";
        assert_eq!(count("12", any), Ok(12));
        assert!(count("-1", any).unwrap_err().contains("-1 is too small"));
        assert!(count("4294967296", any).unwrap_err().contains("too large"));
        assert!(
            count("2.5", any)
                .unwrap_err()
                .contains("not a whole number")
        );
        // A parameter's own range is what the message names.
        let memory = "1 to 10000 transitions";
        assert_eq!(
            count("-1", memory).unwrap_err(),
            "-1 is too small: expected 1 to 10000 transitions"
        );
        assert_eq!(
            count("1.5", memory).unwrap_err(),
            "not a whole number: expected 1 to 10000 transitions"
        );
        assert!(runs_count("0").unwrap_err().contains("from 1 to 1000000"));
        assert_eq!(seed("18446744073709551615"), Ok(u64::MAX));
        assert!(number("x").is_err());
        assert!(number("nan").is_ok_and(f64::is_nan));
    }
}
