//! Typed errors of the library. Each message names the bad input, the bad value and what would be
//! accepted, and suggests the closest known name when a name is misspelt.

use thiserror::Error;

/// Failure to build an environment.
#[derive(Debug, Error)]
pub enum EnvError {
    /// The task name is none of the known ones.
    #[error(
        "unknown task '{0}': {hint}expected tidy1, tidy2 or json:PATH (the authors' \
         transition-model file, with keyStates.txt and spaces.txt beside it)",
        hint = task_hint(.0)
    )]
    UnknownTask(String),
    /// A task of a known family with a bad argument (e.g. a generated world's size).
    #[error("invalid task '{task}': {reason}")]
    InvalidTask {
        /// The task as given.
        task: String,
        /// What is wrong and what is accepted.
        reason: String,
    },
    /// A `json:` environment's files are malformed.
    #[error(transparent)]
    File(#[from] crate::env::json::EnvFileError),
}

/// The built-in task names.
const TASKS: [&str; 2] = ["tidy1", "tidy2"];

/// "did you mean ...? " for a task name that is not known, or nothing when no guess is close.
fn task_hint(task: &str) -> String {
    let lower = task.to_lowercase();
    // A mistyped prefix ("JSON:x", "json=x"), or a path given without its prefix.
    let path = ["json:", "json="].iter().find_map(|p| {
        task.get(..p.len())
            .filter(|head| head.eq_ignore_ascii_case(p))
            .map(|_| &task[p.len()..])
    });
    let guess = match path {
        Some(rest) if !rest.is_empty() => Some(format!("json:{rest}")),
        Some(_) => None,
        None if task.contains('/') || lower.ends_with(".json") => Some(format!("json:{task}")),
        None => closest_name(&lower, &TASKS).map(str::to_string),
    };
    guess.map_or_else(String::new, |g| format!("did you mean '{g}'? "))
}

/// Edit distance (insertions, deletions, substitutions) between two short words.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// The name of `known` closest to `word`, if it is close enough to be a plausible typo (at most
/// a third of the name's letters wrong, and at least one letter right).
pub fn closest_name<'a>(word: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|&k| (edit_distance(word, k), k))
        .min_by_key(|&(d, _)| d)
        .filter(|&(d, k)| d < k.chars().count() && d <= 1 + k.chars().count() / 3)
        .map(|(_, k)| k)
}

/// A parameter value outside what the model accepts.
#[derive(Debug, Error, PartialEq)]
pub enum ConfigError {
    /// A scalar out of range.
    #[error("invalid {name} = {value}: expected {accepted}")]
    InvalidParam {
        /// The parameter's name: the field of [`crate::params::Params`] (or of its `human`),
        /// which is also its output column; [`crate::params::cli_flag`] gives the flag.
        name: &'static str,
        /// The bad value, as [`crate::params::show`] writes it.
        value: String,
        /// What would be accepted.
        accepted: &'static str,
    },
    /// Values the simulation would compute could exceed the range of a float (SPEC 3.3: no
    /// overflow), so the combination is refused before anything runs.
    #[error(
        "{what} could reach {reached} with {because}, beyond the supported magnitude {limit:e} \
         (sums of such values would overflow to infinity); {fix}",
        limit = crate::params::VALUE_LIMIT
    )]
    ValueOverflow {
        /// The quantity at risk, e.g. "action values".
        what: &'static str,
        /// Its bound, to three significant digits.
        reached: String,
        /// The inputs that make it large, with their values.
        because: String,
        /// How to bring it back in range.
        fix: &'static str,
    },
    /// Human interactions on a task that does not define them (SPEC 5).
    #[error(
        "interaction '{interaction}' is not defined for task '{task}': only tidy1 and tidy2 say which \
         actions are relevant or errors and where a held cube belongs; use --interaction none (or budget 0)"
    )]
    InteractionUnsupported {
        /// The task.
        task: String,
        /// The interaction type asked for.
        interaction: String,
    },
    /// A schedule of changes that cannot be read or does not fit the task (SPEC 10).
    #[error(transparent)]
    Schedule(#[from] crate::schedule::ScheduleError),
    /// More distinct schedules in one batch than the engine indexes.
    #[error("too many distinct schedules in one batch (at most 65534): split the runs")]
    TooManySchedules,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_misspelt_task_suggests_the_closest_built_in_one() {
        let message = EnvError::UnknownTask("tidy3".into()).to_string();
        assert!(message.contains("did you mean 'tidy1'?"), "{message}");
        let message = EnvError::UnknownTask("Tidy2".into()).to_string();
        assert!(message.contains("did you mean 'tidy2'?"), "{message}");
    }

    #[test]
    fn a_path_without_its_json_prefix_suggests_adding_it() {
        let message = EnvError::UnknownTask("data/world.json".into()).to_string();
        assert!(message.contains("did you mean 'json:data/world.json'?"));
        let message = EnvError::UnknownTask("JSON=data/w.json".into()).to_string();
        assert!(
            message.contains("did you mean 'json:data/w.json'?"),
            "{message}"
        );
    }

    #[test]
    fn a_name_far_from_every_task_gets_no_guess() {
        let message = EnvError::UnknownTask("gridworld".into()).to_string();
        assert!(!message.contains("did you mean"), "{message}");
        assert!(message.contains("expected tidy1, tidy2 or json:PATH"));
    }

    #[test]
    fn closest_name_accepts_one_typo_in_a_short_name_and_rejects_unrelated_words() {
        assert_eq!(closest_name("taw", &["tau", "task"]), Some("tau"));
        assert_eq!(closest_name("xyz", &["tau", "task"]), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
