//! Loader and exporter for the paper authors' transition-model format (SPEC 2.3).
//!
//! An environment is three files: a JSON model listing, per state, the outcome counts of each
//! action (`{"transitionActions": [{"state": S, "transitions": [{"action": A, "state": NEXT,
//! "prob": COUNT}]}]}`), `keyStates.txt` (`init S...` and `goal S R` lines) and `spaces.txt`
//! (`state N` and `action M` lines). Everything read is validated: each problem is an
//! [`EnvFileError`] that names the file, the line (text files) or the state and action (JSON),
//! the bad value and what would be accepted. No input makes the loader panic.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use super::registry::{DEFAULTS, Task};
use super::{Goal, JsonPaths, Spec, StateId};

/// The authors' file worlds in the task registry.
pub const JSON: Task = Task {
    name: "json:PATH",
    help: "a world in the authors' transition-model format (keyStates.txt and spaces.txt \
           beside it)",
    build: |task| {
        let path = task.strip_prefix("json:").unwrap_or(task);
        Ok(load(&JsonPaths::beside(path), task)?)
    },
    events: &["world", "goal", "delete"],
    ..DEFAULTS
};

/// Most distinct next states one state-action pair may have (outcome indices fit in a `u16`).
pub const MAX_OUTCOMES_PER_PAIR: usize = u16::MAX as usize;

/// Most state-action pairs (states x actions) an environment may have. Every run of a batch holds
/// tables of this size, so larger worlds are out of reach anyway; the limit also keeps a typo in
/// `spaces.txt` from asking for terabytes.
pub const MAX_PAIRS: usize = 1 << 24;

/// Largest file the loader reads (each file is read whole, and the model is parsed into memory).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The keywords of `keyStates.txt`.
const KEY_STATES_KEYWORDS: &str = "init, goal, new_goal, del_trans";
/// The keywords of `spaces.txt`.
const SPACES_KEYWORDS: &str = "state, action";
/// The JSON layout, quoted in structure errors.
const MODEL_LAYOUT: &str = r#"{"transitionActions": [{"state": S, "transitions": [{"action": A, "state": NEXT, "prob": COUNT}, ...]}, ...]}"#;

/// A malformed or unreadable environment file, or an export that failed.
#[derive(Debug, thiserror::Error)]
pub enum EnvFileError {
    /// A file could not be read (missing, unreadable, not UTF-8).
    #[error("cannot read {path}: {error}", path = .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: io::Error,
    },
    /// A path names a folder, a device or a pipe instead of a regular file.
    #[error("{path} is {found}, not a file; {expected}", path = .path.display())]
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What it is (`a folder`, `not a regular file`).
        found: &'static str,
        /// What the path should name.
        expected: &'static str,
    },
    /// A file is larger than [`MAX_FILE_BYTES`].
    #[error("{path} is {size} bytes, more than the {max} bytes mbmf reads (environment files are read whole)", path = .path.display(), max = MAX_FILE_BYTES)]
    FileTooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        size: u64,
    },
    /// A file or folder could not be written by [`export`].
    #[error("cannot write {path}: {error}", path = .path.display())]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// What the system said.
        error: io::Error,
    },
    /// The model is not valid JSON; serde_json's message gives the line and column. Counts too
    /// large for a float (`1e400`) land here as "number out of range".
    #[error("{path}: invalid JSON: {error}; expected the authors' layout {layout}", path = .path.display(), layout = MODEL_LAYOUT)]
    JsonSyntax {
        /// The model file.
        path: PathBuf,
        /// serde_json's error, with line and column.
        error: serde_json::Error,
    },
    /// A JSON object lacks a key the format requires.
    #[error("{path}: {at}: missing key \"{key}\"; expected the authors' layout {layout}", path = .path.display(), layout = MODEL_LAYOUT)]
    MissingKey {
        /// The model file.
        path: PathBuf,
        /// Where in the document (`transitionActions[3]`, `state 5, transitions[2]`).
        at: String,
        /// The missing key.
        key: &'static str,
    },
    /// A JSON value has the wrong type.
    #[error("{path}: {at}: {what} is {found}, expected {expected}", path = .path.display())]
    WrongType {
        /// The model file.
        path: PathBuf,
        /// Where in the document.
        at: String,
        /// Which value (`"transitions"`, `the entry`).
        what: String,
        /// The value found, described.
        found: String,
        /// What is accepted there.
        expected: &'static str,
    },
    /// A listed state is not in the state space of `spaces.txt`.
    #[error("{path}: transitionActions[{entry}]: state {state} is outside the state space: spaces.txt declares {n_states} states, ids 0 to {last}", path = .path.display(), last = .n_states.saturating_sub(1))]
    StateOutOfRange {
        /// The model file.
        path: PathBuf,
        /// Index of the entry in `transitionActions`.
        entry: usize,
        /// The id as written.
        state: String,
        /// Number of states.
        n_states: usize,
    },
    /// A state has two entries in `transitionActions`.
    #[error("{path}: state {state} is listed twice (transitionActions[{first}] and transitionActions[{second}]); give each state one entry holding all its transitions", path = .path.display())]
    DuplicateState {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// Index of its first entry.
        first: usize,
        /// Index of its second entry.
        second: usize,
    },
    /// An action is not in the action space of `spaces.txt`.
    #[error("{path}: state {state}, transitions[{index}]: action {action} is outside the action space: spaces.txt declares {n_actions} actions, ids 0 to {last}", path = .path.display(), last = .n_actions.saturating_sub(1))]
    ActionOutOfRange {
        /// The model file.
        path: PathBuf,
        /// The state whose transition it is.
        state: usize,
        /// Index of the transition in the state's list.
        index: usize,
        /// The action as written.
        action: String,
        /// Number of actions.
        n_actions: usize,
    },
    /// An outcome's next state is not in the state space.
    #[error("{path}: state {state}, action {action}: next state {next} is outside the state space: spaces.txt declares {n_states} states, ids 0 to {last}", path = .path.display(), last = .n_states.saturating_sub(1))]
    NextStateOutOfRange {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// The action.
        action: usize,
        /// The next state as written.
        next: String,
        /// Number of states.
        n_states: usize,
    },
    /// A count (`prob`) is not a number.
    #[error("{path}: state {state}, action {action}, next state {next}: \"prob\" is {found}, expected a count (a positive number such as 3 or 0.5)", path = .path.display())]
    NonNumericCount {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// The action.
        action: usize,
        /// The next state.
        next: usize,
        /// The value found, described.
        found: String,
    },
    /// A count is zero, negative or not finite.
    #[error("{path}: state {state}, action {action}, next state {next}: count {count} is not a positive finite number; leave an impossible outcome out instead", path = .path.display())]
    NonPositiveCount {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// The action.
        action: usize,
        /// The next state.
        next: usize,
        /// The count.
        count: f64,
    },
    /// The counts of one pair add up to more than the largest float.
    #[error("{path}: state {state}, action {action}: the counts add up to more than {max:e}; scale them down (only their ratios matter)", path = .path.display(), max = f64::MAX)]
    CountTotalOverflow {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// The action.
        action: usize,
    },
    /// A state-action pair has more distinct next states than mbmf supports.
    #[error("{path}: state {state}, action {action}: {count} distinct next states, at most {max} are supported", path = .path.display(), max = MAX_OUTCOMES_PER_PAIR)]
    TooManyOutcomes {
        /// The model file.
        path: PathBuf,
        /// The state.
        state: usize,
        /// The action.
        action: usize,
        /// Its number of distinct next states.
        count: usize,
    },
    /// A text line starts with a keyword the file does not know.
    #[error("{path}, line {line}: unknown keyword '{word}' ({suggestion}accepted: {accepted}; '#' starts a comment)", path = .path.display())]
    UnknownKeyword {
        /// The text file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The word found.
        word: String,
        /// `did you mean 'k'? ` for the closest accepted keyword, or nothing when none is close.
        suggestion: String,
        /// All accepted keywords.
        accepted: &'static str,
    },
    /// A number in a text file cannot be parsed.
    #[error("{path}, line {line}: '{text}' is not a number; expected {expected}", path = .path.display())]
    BadNumber {
        /// The text file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The word found.
        text: String,
        /// What is accepted there.
        expected: String,
    },
    /// A text line has too few or too many values.
    #[error("{path}, line {line}: '{keyword}' has {found} value(s), expected {usage}", path = .path.display())]
    WrongArgCount {
        /// The text file.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The line's keyword.
        keyword: &'static str,
        /// Number of values after the keyword.
        found: usize,
        /// The accepted form.
        usage: &'static str,
    },
    /// A line that may appear once appears again.
    #[error("{path}, line {line}: second '{keyword}' line (the first is line {first_line}); give it once", path = .path.display())]
    RepeatedLine {
        /// The text file.
        path: PathBuf,
        /// Line number of the repetition, from 1.
        line: usize,
        /// The line's keyword.
        keyword: &'static str,
        /// Line number of the first one.
        first_line: usize,
    },
    /// A required line is absent.
    #[error("{path}: no '{keyword}' line; add one such as '{example}'", path = .path.display())]
    MissingLine {
        /// The text file.
        path: PathBuf,
        /// The missing keyword.
        keyword: &'static str,
        /// An example line.
        example: &'static str,
    },
    /// `spaces.txt` declares zero states or zero actions.
    #[error("{path}, line {line}: '{keyword} 0': an environment needs at least one {keyword}", path = .path.display())]
    ZeroSize {
        /// `spaces.txt`.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// `state` or `action`.
        keyword: &'static str,
    },
    /// `spaces.txt` declares more states or actions than [`MAX_PAIRS`] allows.
    #[error("{path}, line {line}: '{keyword} {value}' is too large: at most {max} state-action pairs are supported", path = .path.display(), max = MAX_PAIRS)]
    SpaceTooLarge {
        /// `spaces.txt`.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// `state` or `action`.
        keyword: &'static str,
        /// The value as written.
        value: String,
    },
    /// States x actions exceeds [`MAX_PAIRS`].
    #[error("{path}: {n_states} states x {n_actions} actions is more than the {max} state-action pairs supported", path = .path.display(), max = MAX_PAIRS)]
    TooManyPairs {
        /// `spaces.txt`.
        path: PathBuf,
        /// Number of states.
        n_states: usize,
        /// Number of actions.
        n_actions: usize,
    },
    /// An initial or goal state of `keyStates.txt` is not in the state space.
    #[error("{path}, line {line}: {role} state {state} does not exist: spaces.txt declares {n_states} states, ids 0 to {last}", path = .path.display(), last = .n_states.saturating_sub(1))]
    KeyStateOutOfRange {
        /// `keyStates.txt`.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// `initial` or `goal`.
        role: &'static str,
        /// The id as written.
        state: String,
        /// Number of states.
        n_states: usize,
    },
    /// An initial state is listed twice (it would be drawn twice as often).
    #[error("{path}, line {line}: initial state {state} is listed twice; list each initial state once", path = .path.display())]
    DuplicateInitial {
        /// `keyStates.txt`.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The state.
        state: StateId,
    },
    /// The goal is also an initial state.
    #[error("{path}, line {goal_line}: goal state {state} is also an initial state (line {init_line}); the goal must differ from every initial state", path = .path.display())]
    GoalIsInitial {
        /// `keyStates.txt`.
        path: PathBuf,
        /// Line of the goal.
        goal_line: usize,
        /// Line of the initial states.
        init_line: usize,
        /// The state.
        state: StateId,
    },
    /// The goal reward is infinite or NaN.
    #[error("{path}, line {line}: goal reward '{text}' is not finite; expected a number such as 1 or 0.5", path = .path.display())]
    NonFiniteReward {
        /// `keyStates.txt`.
        path: PathBuf,
        /// Line number, from 1.
        line: usize,
        /// The reward as written.
        text: String,
    },
    /// [`export`] was given a spec that would not load back identically.
    #[error("cannot export environment '{name}': {reason}")]
    InvalidSpec {
        /// The spec's name.
        name: String,
        /// What is wrong with it.
        reason: String,
    },
}

/// Loads a `json:` environment from its three files; `name` becomes [`Spec::name`].
///
/// State names are `s{id}`; `human` is `None` (interactions are not defined for these worlds).
pub fn load(paths: &JsonPaths, name: &str) -> Result<Spec, EnvFileError> {
    // The model first: a mistyped model path is then reported as such, not as a missing
    // spaces.txt in whatever folder it names.
    check_file(&paths.model, MODEL_EXPECTED)?;
    let (n_states, n_actions) = read_spaces(&paths.spaces)?;
    let keys = read_key_states(&paths.key_states, n_states)?;
    let outcomes = read_model(&paths.model, n_states, n_actions)?;
    let state_names = (0..n_states).map(|s| format!("s{s}")).collect();
    let unapplied = keys
        .scheduled
        .iter()
        .map(|(line, text)| format!("line {line}: '{text}'"))
        .collect::<Vec<_>>();
    let unapplied = if unapplied.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "{} ({})",
            paths.key_states.display(),
            unapplied.join(", ")
        )]
    };
    let spec = Spec::from_outcomes(
        name.to_string(),
        n_states,
        n_actions,
        outcomes,
        keys.initial,
        Goal {
            state: keys.goal,
            reward: keys.reward,
        },
        state_names,
        None,
    );
    Ok(Spec { unapplied, ..spec })
}

/// What a `json:` model path should name.
const MODEL_EXPECTED: &str = "json:PATH names the transition-model file itself (e.g. \
     json:data/navworld/realisticNavWorld.json), with keyStates.txt and spaces.txt beside it";

/// What a `keyStates.txt` or `spaces.txt` path should name.
const TEXT_EXPECTED: &str = "expected a text file";

/// Checks that `path` is a regular file of at most [`MAX_FILE_BYTES`], so reading it can neither
/// block (a pipe), run forever (`/dev/zero`) nor exhaust memory.
fn check_file(path: &Path, expected: &'static str) -> Result<(), EnvFileError> {
    let metadata = fs::metadata(path).map_err(|error| EnvFileError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let not_a_file = |found| EnvFileError::NotAFile {
        path: path.to_path_buf(),
        found,
        expected,
    };
    if metadata.is_dir() {
        return Err(not_a_file("a folder"));
    }
    if !metadata.is_file() {
        return Err(not_a_file("a device, pipe or socket"));
    }
    if metadata.len() > MAX_FILE_BYTES {
        return Err(EnvFileError::FileTooLarge {
            path: path.to_path_buf(),
            size: metadata.len(),
        });
    }
    Ok(())
}

/// Reads a whole text file, without a leading byte-order mark.
fn read_text(path: &Path, expected: &'static str) -> Result<String, EnvFileError> {
    check_file(path, expected)?;
    let text = fs::read_to_string(path).map_err(|error| EnvFileError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// The lines of a text file that hold something: `(line number from 1, words)`. A `#` starts a
/// comment that runs to the end of the line.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let content = line.split('#').next().unwrap_or_default();
        let words: Vec<&str> = content.split_whitespace().collect();
        (!words.is_empty()).then_some((i + 1, words))
    })
}

/// `did you mean 'k'? ` for the keyword of `known` a typo meant, if any.
fn closest(word: &str, known: &[&'static str]) -> String {
    crate::suggest::hint(word, known.iter().copied())
}

/// Reads `spaces.txt`: `(number of states, number of actions)`.
fn read_spaces(path: &Path) -> Result<(usize, usize), EnvFileError> {
    let text = read_text(path, TEXT_EXPECTED)?;
    let mut states: Option<(usize, usize)> = None;
    let mut actions: Option<(usize, usize)> = None;
    for (line, words) in content_lines(&text) {
        let (keyword, slot) = match words[0] {
            "state" => ("state", &mut states),
            "action" => ("action", &mut actions),
            word => {
                return Err(EnvFileError::UnknownKeyword {
                    path: path.to_path_buf(),
                    line,
                    word: word.to_string(),
                    suggestion: closest(word, &["state", "action"]),
                    accepted: SPACES_KEYWORDS,
                });
            }
        };
        if let Some((_, first_line)) = *slot {
            return Err(EnvFileError::RepeatedLine {
                path: path.to_path_buf(),
                line,
                keyword,
                first_line,
            });
        }
        let [_, value] = words[..] else {
            return Err(EnvFileError::WrongArgCount {
                path: path.to_path_buf(),
                line,
                keyword,
                found: words.len() - 1,
                usage: "one count, e.g. 'state 38' or 'action 8'",
            });
        };
        let size = parse_size(path, line, keyword, value)?;
        *slot = Some((size, line));
    }
    let missing = |keyword, example| EnvFileError::MissingLine {
        path: path.to_path_buf(),
        keyword,
        example,
    };
    let (n_states, _) = states.ok_or_else(|| missing("state", "state 38"))?;
    let (n_actions, _) = actions.ok_or_else(|| missing("action", "action 8"))?;
    match n_states.checked_mul(n_actions) {
        Some(pairs) if pairs <= MAX_PAIRS => Ok((n_states, n_actions)),
        _ => Err(EnvFileError::TooManyPairs {
            path: path.to_path_buf(),
            n_states,
            n_actions,
        }),
    }
}

/// Parses the count of a `state` or `action` line: an integer in `1..=MAX_PAIRS`.
fn parse_size(
    path: &Path,
    line: usize,
    keyword: &'static str,
    text: &str,
) -> Result<usize, EnvFileError> {
    match text.parse::<usize>() {
        Ok(0) => Err(EnvFileError::ZeroSize {
            path: path.to_path_buf(),
            line,
            keyword,
        }),
        Ok(size) if size <= MAX_PAIRS => Ok(size),
        // Only digits, yet unparsable or above the limit: too large rather than malformed.
        _ if is_digits(text.strip_prefix('+').unwrap_or(text)) => {
            Err(EnvFileError::SpaceTooLarge {
                path: path.to_path_buf(),
                line,
                keyword,
                value: text.to_string(),
            })
        }
        _ => Err(EnvFileError::BadNumber {
            path: path.to_path_buf(),
            line,
            text: text.to_string(),
            expected: format!("the number of {keyword}s, a positive integer"),
        }),
    }
}

/// What `keyStates.txt` says.
struct KeyStates {
    initial: Vec<StateId>,
    goal: StateId,
    reward: f64,
    /// The lines scheduling changes during a run (`new_goal`, `del_trans`), with their line
    /// numbers: not applied (a run's changes are its `--change` events, SPEC 10).
    scheduled: Vec<(usize, String)>,
}

/// Reads `keyStates.txt`, checking its states against the state space.
fn read_key_states(path: &Path, n_states: usize) -> Result<KeyStates, EnvFileError> {
    let text = read_text(path, TEXT_EXPECTED)?;
    let mut initial: Option<(Vec<StateId>, usize)> = None;
    let mut goal: Option<(StateId, f64, usize)> = None;
    let mut scheduled = Vec::new();
    for (line, words) in content_lines(&text) {
        let keyword = match words[0] {
            "init" => "init",
            "goal" => "goal",
            // SPEC 2.3: read, not applied; a run's changes are its own schedule (SPEC 10).
            "new_goal" | "del_trans" => {
                scheduled.push((line, words.join(" ")));
                continue;
            }
            word => {
                return Err(EnvFileError::UnknownKeyword {
                    path: path.to_path_buf(),
                    line,
                    word: word.to_string(),
                    suggestion: closest(word, &["init", "goal", "new_goal", "del_trans"]),
                    accepted: KEY_STATES_KEYWORDS,
                });
            }
        };
        let first_line = if keyword == "init" {
            initial.as_ref().map(|&(_, l)| l)
        } else {
            goal.as_ref().map(|&(_, _, l)| l)
        };
        if let Some(first_line) = first_line {
            return Err(EnvFileError::RepeatedLine {
                path: path.to_path_buf(),
                line,
                keyword,
                first_line,
            });
        }
        let values = &words[1..];
        if keyword == "init" {
            if values.is_empty() {
                return Err(EnvFileError::WrongArgCount {
                    path: path.to_path_buf(),
                    line,
                    keyword,
                    found: 0,
                    usage: "one or more state ids, e.g. 'init 0 32'",
                });
            }
            let mut states: Vec<StateId> = Vec::with_capacity(values.len());
            // A flag per state, not a search of the list: a long 'init' line stays linear.
            let mut seen = vec![false; n_states];
            for text in values {
                let state = parse_key_state(path, line, "initial", text, n_states)?;
                if std::mem::replace(&mut seen[state as usize], true) {
                    return Err(EnvFileError::DuplicateInitial {
                        path: path.to_path_buf(),
                        line,
                        state,
                    });
                }
                states.push(state);
            }
            initial = Some((states, line));
        } else {
            let [state, reward] = values else {
                return Err(EnvFileError::WrongArgCount {
                    path: path.to_path_buf(),
                    line,
                    keyword,
                    found: values.len(),
                    usage: "a state id and its reward, e.g. 'goal 18 1'",
                });
            };
            let state = parse_key_state(path, line, "goal", state, n_states)?;
            let value = reward.parse::<f64>().map_err(|_| EnvFileError::BadNumber {
                path: path.to_path_buf(),
                line,
                text: reward.to_string(),
                expected: "the goal reward, a number such as 1 or 0.5".to_string(),
            })?;
            if !value.is_finite() {
                return Err(EnvFileError::NonFiniteReward {
                    path: path.to_path_buf(),
                    line,
                    text: reward.to_string(),
                });
            }
            goal = Some((state, value, line));
        }
    }
    let missing = |keyword, example| EnvFileError::MissingLine {
        path: path.to_path_buf(),
        keyword,
        example,
    };
    let (initial, init_line) = initial.ok_or_else(|| missing("init", "init 0"))?;
    let (goal, reward, goal_line) = goal.ok_or_else(|| missing("goal", "goal 18 1"))?;
    if initial.contains(&goal) {
        return Err(EnvFileError::GoalIsInitial {
            path: path.to_path_buf(),
            goal_line,
            init_line,
            state: goal,
        });
    }
    Ok(KeyStates {
        initial,
        goal,
        reward,
        scheduled,
    })
}

/// Parses a state id of `keyStates.txt`.
fn parse_key_state(
    path: &Path,
    line: usize,
    role: &'static str,
    text: &str,
    n_states: usize,
) -> Result<StateId, EnvFileError> {
    let out_of_range = || EnvFileError::KeyStateOutOfRange {
        path: path.to_path_buf(),
        line,
        role,
        state: text.to_string(),
        n_states,
    };
    match text.parse::<u64>() {
        Ok(id) if id < n_states as u64 => StateId::try_from(id).map_err(|_| out_of_range()),
        Ok(_) => Err(out_of_range()),
        // A negative or huge integer is a state that does not exist, not a malformed number.
        Err(_) if text.parse::<i128>().is_ok() || is_digits(text) => Err(out_of_range()),
        Err(_) => Err(EnvFileError::BadNumber {
            path: path.to_path_buf(),
            line,
            text: text.to_string(),
            expected: format!(
                "an {role} state id, an integer from 0 to {}",
                n_states.saturating_sub(1)
            ),
        }),
    }
}

/// The text is one or more ASCII digits.
fn is_digits(text: &str) -> bool {
    !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit())
}

/// An integer id read from the JSON.
enum JsonId {
    /// In range.
    Valid(usize),
    /// An integer outside the range, as written.
    OutOfRange(String),
    /// Not an integer.
    NotInteger,
}

/// Reads `value` as an id in `0..len`.
fn json_id(value: &Value, len: usize) -> JsonId {
    let Value::Number(number) = value else {
        return JsonId::NotInteger;
    };
    if let Some(id) = number.as_u64() {
        match usize::try_from(id) {
            Ok(id) if id < len => JsonId::Valid(id),
            _ => JsonId::OutOfRange(number.to_string()),
        }
    } else if number.is_i64() {
        JsonId::OutOfRange(number.to_string())
    } else {
        JsonId::NotInteger
    }
}

/// A short description of a JSON value for error messages.
fn describe(value: &Value) -> String {
    match value {
        Value::Null => "null".to_string(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) if s.chars().count() > 40 => {
            let head: String = s.chars().take(40).collect();
            format!("the string {head:?}...")
        }
        Value::String(s) => format!("the string {s:?}"),
        Value::Array(items) => format!("an array of {} item(s)", items.len()),
        Value::Object(_) => "an object".to_string(),
    }
}

/// A [`EnvFileError::WrongType`] for the value `found`, called `what`, at `at`.
fn wrong_type(
    path: &Path,
    at: String,
    what: &str,
    found: &Value,
    expected: &'static str,
) -> EnvFileError {
    EnvFileError::WrongType {
        path: path.to_path_buf(),
        at,
        what: what.to_string(),
        found: describe(found),
        expected,
    }
}

/// The value of `key` in `object`, or a [`EnvFileError::MissingKey`] located by `at`.
fn get<'v>(
    path: &Path,
    object: &'v Map<String, Value>,
    key: &'static str,
    at: impl Fn() -> String,
) -> Result<&'v Value, EnvFileError> {
    object.get(key).ok_or_else(|| EnvFileError::MissingKey {
        path: path.to_path_buf(),
        at: at(),
        key,
    })
}

/// Reads the JSON model: per pair `s * n_actions + a`, the listed `(next state, count)` outcomes.
fn read_model(
    path: &Path,
    n_states: usize,
    n_actions: usize,
) -> Result<Vec<Vec<(StateId, f64)>>, EnvFileError> {
    let text = read_text(path, MODEL_EXPECTED)?;
    let root: Value = serde_json::from_str(&text).map_err(|error| EnvFileError::JsonSyntax {
        path: path.to_path_buf(),
        error,
    })?;
    let Value::Object(top) = &root else {
        return Err(wrong_type(
            path,
            "top level".into(),
            "the document",
            &root,
            "an object with the key \"transitionActions\"",
        ));
    };
    let entries_value = get(path, top, "transitionActions", || "top level".into())?;
    let Value::Array(entries) = entries_value else {
        return Err(wrong_type(
            path,
            "top level".into(),
            "\"transitionActions\"",
            entries_value,
            "an array of {\"state\": S, \"transitions\": [...]} objects",
        ));
    };

    let mut outcomes: Vec<Vec<(StateId, f64)>> = vec![Vec::new(); n_states * n_actions];
    let mut listed_at: Vec<Option<usize>> = vec![None; n_states];
    for (entry_index, entry) in entries.iter().enumerate() {
        let entry_at = || format!("transitionActions[{entry_index}]");
        let Value::Object(entry) = entry else {
            return Err(wrong_type(
                path,
                entry_at(),
                "the entry",
                entry,
                "an object {\"state\": S, \"transitions\": [...]}",
            ));
        };
        let state_value = get(path, entry, "state", entry_at)?;
        let state = match json_id(state_value, n_states) {
            JsonId::Valid(s) => s,
            JsonId::OutOfRange(state) => {
                return Err(EnvFileError::StateOutOfRange {
                    path: path.to_path_buf(),
                    entry: entry_index,
                    state,
                    n_states,
                });
            }
            JsonId::NotInteger => {
                return Err(wrong_type(
                    path,
                    entry_at(),
                    "\"state\"",
                    state_value,
                    "an integer state id",
                ));
            }
        };
        if let Some(first) = listed_at[state] {
            return Err(EnvFileError::DuplicateState {
                path: path.to_path_buf(),
                state,
                first,
                second: entry_index,
            });
        }
        listed_at[state] = Some(entry_index);
        let state_at = || format!("state {state} (transitionActions[{entry_index}])");
        let list_value = get(path, entry, "transitions", state_at)?;
        let Value::Array(list) = list_value else {
            return Err(wrong_type(
                path,
                state_at(),
                "\"transitions\"",
                list_value,
                "an array of {\"action\": A, \"state\": NEXT, \"prob\": COUNT} objects",
            ));
        };
        for (index, transition) in list.iter().enumerate() {
            let (action, next, count) =
                read_transition(path, state, index, transition, n_states, n_actions)?;
            outcomes[state * n_actions + action].push((next, count));
        }
    }

    for (sa, list) in outcomes.iter_mut().enumerate() {
        let (state, action) = (sa / n_actions, sa % n_actions);
        if !list.iter().map(|&(_, w)| w).sum::<f64>().is_finite() {
            return Err(EnvFileError::CountTotalOverflow {
                path: path.to_path_buf(),
                state,
                action,
            });
        }
        if list.len() > MAX_OUTCOMES_PER_PAIR {
            // Stable, so repeated next states keep the file's order for `from_outcomes`.
            list.sort_by_key(|&(s, _)| s);
            let count = 1 + list.windows(2).filter(|w| w[0].0 != w[1].0).count();
            if count > MAX_OUTCOMES_PER_PAIR {
                return Err(EnvFileError::TooManyOutcomes {
                    path: path.to_path_buf(),
                    state,
                    action,
                    count,
                });
            }
        }
    }
    Ok(outcomes)
}

/// Reads one transition `{"action": A, "state": NEXT, "prob": COUNT}` of `state`'s list:
/// `(action, next state, count)`.
fn read_transition(
    path: &Path,
    state: usize,
    index: usize,
    transition: &Value,
    n_states: usize,
    n_actions: usize,
) -> Result<(usize, StateId, f64), EnvFileError> {
    let transition_at = || format!("state {state}, transitions[{index}]");
    let Value::Object(transition) = transition else {
        return Err(wrong_type(
            path,
            transition_at(),
            "the transition",
            transition,
            "an object {\"action\": A, \"state\": NEXT, \"prob\": COUNT}",
        ));
    };
    let action_value = get(path, transition, "action", transition_at)?;
    let action = match json_id(action_value, n_actions) {
        JsonId::Valid(a) => a,
        JsonId::OutOfRange(action) => {
            return Err(EnvFileError::ActionOutOfRange {
                path: path.to_path_buf(),
                state,
                index,
                action,
                n_actions,
            });
        }
        JsonId::NotInteger => {
            return Err(wrong_type(
                path,
                transition_at(),
                "\"action\"",
                action_value,
                "an integer action id",
            ));
        }
    };
    let action_at = || format!("state {state}, action {action} (transitions[{index}])");
    let next_value = get(path, transition, "state", action_at)?;
    let next = match json_id(next_value, n_states) {
        JsonId::Valid(next) => next,
        JsonId::OutOfRange(next) => {
            return Err(EnvFileError::NextStateOutOfRange {
                path: path.to_path_buf(),
                state,
                action,
                next,
                n_states,
            });
        }
        JsonId::NotInteger => {
            return Err(wrong_type(
                path,
                action_at(),
                "the next \"state\"",
                next_value,
                "an integer state id",
            ));
        }
    };
    let count_value = get(path, transition, "prob", action_at)?;
    let Some(count) = count_value.as_f64() else {
        return Err(EnvFileError::NonNumericCount {
            path: path.to_path_buf(),
            state,
            action,
            next,
            found: describe(count_value),
        });
    };
    if !(count > 0.0 && count.is_finite()) {
        return Err(EnvFileError::NonPositiveCount {
            path: path.to_path_buf(),
            state,
            action,
            next,
            count,
        });
    }
    // `next < n_states <= MAX_PAIRS`, so it fits a StateId.
    Ok((action, next as StateId, count))
}

/// Writes `spec` in the authors' format into `dir` (created if needed): `<name>.json`,
/// `keyStates.txt` and `spaces.txt`, each replaced atomically (temporary file, then rename).
///
/// `<name>` is the spec's name without a `json:` prefix, folders or `.json` suffix, with
/// characters other than letters, digits, `-`, `_` and `.` replaced by `_`. Loading the returned
/// paths gives back `spec` except its name, provided the spec is what [`load`] (or
/// [`Spec::from_outcomes`] with validated input and `s{id}` names) builds.
pub fn export(spec: &Spec, dir: &Path) -> Result<JsonPaths, EnvFileError> {
    let invalid = |reason| EnvFileError::InvalidSpec {
        name: spec.name.clone(),
        reason,
    };
    let goal = check_exportable(spec).map_err(invalid)?;
    let model = model_text(spec).map_err(invalid)?;
    fs::create_dir_all(dir).map_err(|error| EnvFileError::Write {
        path: dir.to_path_buf(),
        error,
    })?;
    let paths = export_paths(spec, dir);
    write_atomic(&paths.model, &model)?;
    write_atomic(&paths.key_states, &key_states_text(spec, goal))?;
    write_atomic(&paths.spaces, &spaces_text(spec))?;
    Ok(paths)
}

/// The three files [`export`] writes for `spec` into `dir`.
pub fn export_paths(spec: &Spec, dir: &Path) -> JsonPaths {
    JsonPaths {
        model: dir.join(format!("{}.json", export_stem(&spec.name))),
        key_states: dir.join("keyStates.txt"),
        spaces: dir.join("spaces.txt"),
    }
}

/// Checks that `spec` is consistent and would pass [`load`]'s validation, so that [`export`]
/// never indexes out of bounds nor writes files that do not load back.
fn check_exportable(spec: &Spec) -> Result<Goal, String> {
    let (n_states, n_actions) = (spec.n_states, spec.n_actions);
    if n_states == 0 || n_actions == 0 {
        return Err(format!(
            "{n_states} states x {n_actions} actions: both must be positive"
        ));
    }
    let pairs = match n_states.checked_mul(n_actions) {
        Some(pairs) if pairs <= MAX_PAIRS => pairs,
        _ => return Err(format!("more than {MAX_PAIRS} state-action pairs")),
    };
    let n_outcomes = spec.outcome_state.len();
    if spec.outcome_start.len() != pairs + 1
        || spec.outcome_start.first() != Some(&0)
        || spec.outcome_start.last().map(|&end| end as usize) != Some(n_outcomes)
        || spec.outcome_weight.len() != n_outcomes
    {
        return Err("its outcome tables have inconsistent lengths".to_string());
    }
    for sa in 0..pairs {
        let (state, action) = (sa / n_actions, sa % n_actions);
        let (start, end) = (
            spec.outcome_start[sa] as usize,
            spec.outcome_start[sa + 1] as usize,
        );
        if start >= end || end > n_outcomes || end - start > MAX_OUTCOMES_PER_PAIR {
            return Err(format!(
                "state {state}, action {action} has {} outcomes, expected 1 to {MAX_OUTCOMES_PER_PAIR}",
                end.saturating_sub(start)
            ));
        }
        let states = &spec.outcome_state[start..end];
        if states.iter().any(|&s| s as usize >= n_states) || states.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(format!(
                "state {state}, action {action}: next states must be distinct, ascending and below {n_states}"
            ));
        }
        let weights = &spec.outcome_weight[start..end];
        if weights.iter().any(|&w| !(w > 0.0 && w.is_finite()))
            || !weights.iter().sum::<f64>().is_finite()
        {
            return Err(format!(
                "state {state}, action {action}: weights must be positive and finite, with a finite sum"
            ));
        }
    }
    let initial = &spec.initial_states;
    if initial.is_empty() {
        return Err("it has no initial state".to_string());
    }
    if let Some(&s) = initial.iter().find(|&&s| s as usize >= n_states) {
        return Err(format!("initial state {s} is not below {n_states}"));
    }
    let mut sorted = initial.clone();
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return Err("an initial state is listed twice".to_string());
    }
    // The authors' format has one goal and one fixed reward: a task whose outcomes carry their
    // own rewards has no such file.
    let Some(goal) = spec.goal else {
        return Err("it has no single goal state (the format has one goal and its reward)".into());
    };
    if goal.state as usize >= n_states || initial.contains(&goal.state) {
        return Err(format!(
            "goal {} must be a state below {n_states} that is not initial",
            goal.state
        ));
    }
    if !goal.reward.is_finite() {
        return Err(format!("goal reward {} is not finite", goal.reward));
    }
    Ok(goal)
}

/// The file name (without `.json`) under which [`export`] writes a spec's model.
fn export_stem(name: &str) -> String {
    let name = name.strip_prefix("json:").unwrap_or(name);
    let last = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let last = last.strip_suffix(".json").unwrap_or(last);
    let stem: String = last
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.chars().all(|c| c == '.') {
        "model".to_string()
    } else {
        stem
    }
}

/// The JSON model, laid out as the authors' files (tabs, one transition per line), or the reason
/// it cannot be written exactly.
fn model_text(spec: &Spec) -> Result<String, String> {
    let mut text =
        String::from("{\n\t\"timecount\":0,\n\t\"actioncount\":0,\n\n\t\"transitionActions\":[\n");
    for s in 0..spec.n_states {
        text.push_str(&format!("\t\t{{ \"state\":{s},\n\t\t\"transitions\":[\n"));
        let mut lines = Vec::new();
        for a in 0..spec.n_actions {
            for o in spec.outcomes(spec.sa(s, a)) {
                let weight = spec.outcome_weight[o];
                let count = count_text(weight).ok_or_else(|| {
                    format!(
                        "state {s}, action {a}: weight {weight:e} does not read back exactly with \
                         this build's JSON parser (enable serde_json's float_roundtrip feature)"
                    )
                })?;
                lines.push(format!(
                    "\t\t\t{{ \"action\": {a}, \"state\": {}, \"prob\": {count}}}",
                    spec.outcome_state[o]
                ));
            }
        }
        text.push_str(&lines.join(",\n"));
        text.push_str("]\n\n\t\t}");
        text.push_str(if s + 1 < spec.n_states { ",\n" } else { "\n" });
    }
    text.push_str("\t]\n}\n");
    Ok(text)
}

/// `x` as a short decimal that reads back to exactly `x`: plain notation (integers without a
/// decimal point, as the authors' counts) for moderate magnitudes, exponent notation otherwise.
fn number_text(x: f64) -> String {
    if x == 0.0 || (1e-5..1e16).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A text for the count `w` that serde_json, as compiled, reads back to exactly `w`.
///
/// NOTE: without serde_json's `float_roundtrip` feature its float parsing is not correctly
/// rounded, so the shortest decimal of about one non-integer weight in ten reads back one unit
/// in the last place off. Longer decimals fix most of those; integers below 2^53 are always
/// exact.
fn count_text(w: f64) -> Option<String> {
    std::iter::once(number_text(w))
        .chain((15..=20).map(|digits| format!("{w:.digits$e}")))
        .find(|text| serde_json::from_str::<f64>(text).ok() == Some(w))
}

/// `keyStates.txt` with the authors' comments.
fn key_states_text(spec: &Spec, goal: Goal) -> String {
    let initial: Vec<String> = spec.initial_states.iter().map(|s| s.to_string()).collect();
    format!(
        "# {} in the authors' transition-model format, written by mbmf\n\
         # The states where the agent starts the experiment and comes back after obtaining the reward\n\
         init {}\n\
         # The state which gives reward / the value of the reward\n\
         goal {} {}\n",
        spec.name.replace('\n', " "),
        initial.join(" "),
        goal.state,
        number_text(goal.reward)
    )
}

/// `spaces.txt` with the authors' comments.
fn spaces_text(spec: &Spec) -> String {
    format!(
        "# State space\nstate {}\n# Action space\naction {}\n",
        spec.n_states, spec.n_actions
    )
}

/// Writes `text` over `path` atomically (see [`crate::whole_file`]).
fn write_atomic(path: &Path, text: &str) -> Result<(), EnvFileError> {
    crate::whole_file::write_atomic(path, text.as_bytes())
        .map_err(|(path, error)| EnvFileError::Write { path, error })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// A fresh folder under the system's temporary directory, removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(label: &str) -> TempDir {
            static NEXT: AtomicU64 = AtomicU64::new(0);
            let unique = NEXT.fetch_add(1, Ordering::Relaxed);
            let dir = std::env::temp_dir()
                .join(format!("mbmf-json-{}-{unique}-{label}", std::process::id()));
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).expect("cannot create a temporary folder");
            TempDir(dir)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    /// Three states, two actions; state 1 lacks action 0 and state 2 is not listed at all.
    const MODEL: &str = r#"{"timecount": 5, "transitionActions": [
        {"state": 0, "transitions": [
            {"action": 0, "state": 1, "prob": 3},
            {"action": 0, "state": 0, "prob": 1},
            {"action": 1, "state": 2, "prob": 1}]},
        {"state": 1, "transitions": [
            {"action": 1, "state": 2, "prob": 2}]}
    ]}"#;
    const KEY_STATES: &str = "init 0\ngoal 2 1\n";
    const SPACES: &str = "state 3\naction 2\n";

    /// A world written to disk; the files live as long as it does.
    struct World {
        _dir: TempDir,
        paths: JsonPaths,
    }

    fn world(model: &str, key_states: &str, spaces: &str) -> World {
        let dir = TempDir::new("world");
        let paths = JsonPaths::beside(dir.0.join("world.json"));
        fs::write(&paths.model, model).expect("write model");
        fs::write(&paths.key_states, key_states).expect("write keyStates.txt");
        fs::write(&paths.spaces, spaces).expect("write spaces.txt");
        World { _dir: dir, paths }
    }

    fn load_error(model: &str, key_states: &str, spaces: &str) -> EnvFileError {
        let world = world(model, key_states, spaces);
        load(&world.paths, "test").expect_err("the world should be rejected")
    }

    /// Asserts that the error's message contains every part.
    fn assert_mentions(error: &EnvFileError, parts: &[&str]) {
        let message = error.to_string();
        for part in parts {
            assert!(
                message.contains(part),
                "'{part}' is missing from: {message}"
            );
        }
    }

    /// Weight of the outcome `(s, a) -> next`, if the spec has it.
    fn weight(spec: &Spec, s: usize, a: usize, next: StateId) -> Option<f64> {
        spec.outcomes(spec.sa(s, a))
            .find(|&o| spec.outcome_state[o] == next)
            .map(|o| spec.outcome_weight[o])
    }

    /// Every pair has outcomes with ascending distinct next states and cumulative probabilities
    /// rising to exactly 1.
    fn assert_well_formed(spec: &Spec) {
        for sa in 0..spec.n_states * spec.n_actions {
            let range = spec.outcomes(sa);
            assert!(!range.is_empty(), "pair {sa} has no outcome");
            let cum = &spec.outcome_cum[range.clone()];
            assert!(cum.windows(2).all(|w| w[0] < w[1]), "pair {sa}: {cum:?}");
            assert_eq!(cum.last(), Some(&1.0), "pair {sa}");
            let states = &spec.outcome_state[range];
            assert!(
                states.windows(2).all(|w| w[0] < w[1]),
                "pair {sa}: {states:?}"
            );
        }
    }

    fn tidy1_paths() -> JsonPaths {
        JsonPaths::beside(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/tidy1/tidy1.json"
        ))
    }

    #[test]
    fn loads_the_tidy1_fixture_with_112_states_7_actions_and_goal_90() {
        let spec = load(&tidy1_paths(), "json:tidy1").expect("tidy1 fixture loads");
        assert_eq!((spec.n_states, spec.n_actions), (112, 7));
        assert_eq!(spec.initial_states, vec![0]);
        assert_eq!(
            spec.goal,
            Some(Goal {
                state: 90,
                reward: 1.0
            })
        );
        assert_eq!(spec.name, "json:tidy1");
        assert_eq!(spec.max_branching(), 1, "tidy task 1 is deterministic");
        assert_well_formed(&spec);
    }

    #[test]
    fn a_small_world_loads_with_sorted_outcomes_and_self_loops() {
        let world = world(MODEL, KEY_STATES, SPACES);
        let spec = load(&world.paths, "small").expect("small world loads");
        assert_eq!(spec.outcome_start, vec![0, 2, 3, 4, 5, 6, 7]);
        assert_eq!(spec.outcome_state, vec![0, 1, 2, 1, 2, 2, 2]);
        assert_eq!(spec.outcome_weight, vec![1.0, 3.0, 1.0, 1.0, 2.0, 1.0, 1.0]);
        assert_eq!(spec.outcome_cum, vec![0.25, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(spec.state_names, vec!["s0", "s1", "s2"]);
    }

    #[test]
    fn repeated_outcomes_have_their_counts_added() {
        let model = r#"{"transitionActions": [{"state": 0, "transitions": [
            {"action": 0, "state": 1, "prob": 2}, {"action": 0, "state": 2, "prob": 1},
            {"action": 0, "state": 1, "prob": 5}]}]}"#;
        let world = world(model, KEY_STATES, SPACES);
        let spec = load(&world.paths, "test").expect("repeated outcomes are accepted");
        assert_eq!(weight(&spec, 0, 0, 1), Some(7.0));
        assert_eq!(spec.outcome_cum[spec.outcomes(0)], [0.875, 1.0]);
    }

    #[test]
    fn comments_blank_lines_and_environment_change_lines_are_ignored_and_the_changes_kept() {
        let key_states = "\u{feff}# start\r\n\r\ninit 1 0   # two starts\r\n  goal 2 -0.5\r\n\
                          new_goal 1601 34 1\r\ndel_trans 1601 20-21 6-7";
        let spaces = "# sizes\n\nstate 3 # three\n   \naction 2";
        let world = world(MODEL, key_states, spaces);
        let spec = load(&world.paths, "test").expect("comments are accepted");
        assert_eq!(spec.initial_states, vec![1, 0]);
        assert_eq!(
            spec.goal,
            Some(Goal {
                state: 2,
                reward: -0.5
            })
        );
        // Not applied, but named for the warning of a run without a schedule.
        assert_eq!(
            spec.unapplied,
            [format!(
                "{} (line 5: 'new_goal 1601 34 1', line 6: 'del_trans 1601 20-21 6-7')",
                world.paths.key_states.display()
            )]
        );
        let plain = super::tests::world(MODEL, "init 1\ngoal 2 1\n", spaces);
        assert!(load(&plain.paths, "test").unwrap().unapplied.is_empty());
    }

    #[test]
    fn decimal_counts_and_extra_keys_are_accepted() {
        let model = r#"{"extra": [1, 2], "transitionActions": [{"state": 0, "note": "x",
            "transitions": [{"action": 0, "state": 1, "prob": 0.5, "seen": true},
            {"action": 0, "state": 2, "prob": 1.5e0}]}]}"#;
        let world = world(model, "init 0\ngoal 2 2.5\n", SPACES);
        let spec = load(&world.paths, "test").expect("decimals are accepted");
        assert_eq!(spec.outcome_cum[spec.outcomes(0)], [0.25, 1.0]);
        assert_eq!(spec.goal.map(|g| g.reward), Some(2.5));
    }

    #[test]
    fn a_missing_file_is_reported_with_its_path() {
        let world = world(MODEL, KEY_STATES, SPACES);
        for missing in [
            &world.paths.model,
            &world.paths.key_states,
            &world.paths.spaces,
        ] {
            fs::rename(missing, missing.with_extension("gone")).expect("hide the file");
            let error = load(&world.paths, "test").expect_err("a missing file is an error");
            assert!(matches!(error, EnvFileError::Read { .. }), "{error}");
            assert_mentions(&error, &["cannot read", &missing.display().to_string()]);
            fs::rename(missing.with_extension("gone"), missing).expect("restore the file");
        }
    }

    #[test]
    fn a_missing_model_is_reported_before_its_neighbours() {
        let dir = TempDir::new("no-model");
        let paths = JsonPaths::beside(dir.0.join("world.json"));
        let error = load(&paths, "test").expect_err("nothing to load");
        assert_mentions(&error, &["cannot read", "world.json"]);
    }

    #[test]
    fn a_folder_or_a_device_as_model_is_rejected_with_what_to_give() {
        let dir = TempDir::new("folder-model");
        let error = load(&JsonPaths::beside(&dir.0), "test").expect_err("a folder");
        assert!(matches!(error, EnvFileError::NotAFile { .. }), "{error}");
        assert_mentions(
            &error,
            &["is a folder, not a file", "transition-model file"],
        );
        #[cfg(unix)]
        {
            let error = load(&JsonPaths::beside("/dev/zero"), "test").expect_err("a device");
            assert_mentions(
                &error,
                &["/dev/zero is a device, pipe or socket, not a file"],
            );
        }
    }

    #[test]
    fn a_long_init_line_is_checked_for_repeats_in_linear_time() {
        // 200,000 distinct initial states: a quadratic check would take minutes.
        let n = 200_001;
        let init: Vec<String> = (1..n).map(|s| s.to_string()).collect();
        let world = world(
            r#"{"transitionActions": []}"#,
            &format!("init {}\ngoal 0 1\n", init.join(" ")),
            &format!("state {n}\naction 1\n"),
        );
        let spec = load(&world.paths, "test").expect("a valid world");
        assert_eq!(spec.initial_states.len(), n - 1);
        let world = world_with_init_repeat(n);
        let error = load(&world.paths, "test").expect_err("a repeat");
        assert_mentions(&error, &["initial state 5 is listed twice"]);
    }

    fn world_with_init_repeat(n: usize) -> World {
        let mut init: Vec<String> = (1..n).map(|s| s.to_string()).collect();
        init.push("5".into());
        world(
            r#"{"transitionActions": []}"#,
            &format!("init {}\ngoal 0 1\n", init.join(" ")),
            &format!("state {n}\naction 1\n"),
        )
    }

    #[test]
    fn invalid_json_is_reported_with_line_and_column() {
        let model = "{\"transitionActions\": [\n  {\"state\": 0 \"transitions\": []}\n]}";
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(error, EnvFileError::JsonSyntax { .. }), "{error}");
        assert_mentions(&error, &["world.json", "invalid JSON", "line 2 column 15"]);
    }

    #[test]
    fn a_count_too_large_for_a_float_is_a_json_error_with_line_and_column() {
        let model = "{\"transitionActions\": [{\"state\": 0, \"transitions\": [\n\
                     {\"action\": 0, \"state\": 1, \"prob\": 1e400}]}]}";
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(error, EnvFileError::JsonSyntax { .. }), "{error}");
        assert_mentions(&error, &["world.json", "number out of range", "line 2"]);
    }

    #[test]
    fn a_missing_key_is_reported_with_its_location() {
        let error = load_error(r#"{"transitions": []}"#, KEY_STATES, SPACES);
        assert!(matches!(
            error,
            EnvFileError::MissingKey {
                key: "transitionActions",
                ..
            }
        ));
        assert_mentions(
            &error,
            &["world.json", "top level", "\"transitionActions\""],
        );

        let model = r#"{"transitionActions": [{"state": 1, "transitions": [
            {"action": 1, "state": 2}]}]}"#;
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(
            matches!(error, EnvFileError::MissingKey { key: "prob", .. }),
            "{error}"
        );
        assert_mentions(
            &error,
            &["world.json", "state 1, action 1", "missing key \"prob\""],
        );

        let error = load_error(
            r#"{"transitionActions": [{"state": 1}]}"#,
            KEY_STATES,
            SPACES,
        );
        assert_mentions(
            &error,
            &["state 1 (transitionActions[0])", "\"transitions\""],
        );
    }

    #[test]
    fn a_value_of_the_wrong_type_is_reported() {
        let cases = [
            (r#"[1, 2]"#, "the document is an array of 2 item(s)"),
            (
                r#"{"transitionActions": 7}"#,
                "\"transitionActions\" is the number 7",
            ),
            (
                r#"{"transitionActions": [3]}"#,
                "transitionActions[0]: the entry is the number 3",
            ),
            (
                r#"{"transitionActions": [{"state": 1.5, "transitions": []}]}"#,
                "\"state\" is the number 1.5, expected an integer state id",
            ),
            (
                r#"{"transitionActions": [{"state": 1, "transitions": {}}]}"#,
                "state 1 (transitionActions[0]): \"transitions\" is an object",
            ),
            (
                r#"{"transitionActions": [{"state": 1, "transitions": [
                    {"action": "1", "state": 2, "prob": 1}]}]}"#,
                "state 1, transitions[0]: \"action\" is the string \"1\"",
            ),
            (
                r#"{"transitionActions": [{"state": 1, "transitions": [
                    {"action": 1, "state": null, "prob": 1}]}]}"#,
                "state 1, action 1 (transitions[0]): the next \"state\" is null",
            ),
        ];
        for (model, expected) in cases {
            let error = load_error(model, KEY_STATES, SPACES);
            assert!(matches!(error, EnvFileError::WrongType { .. }), "{error}");
            assert_mentions(&error, &["world.json", expected]);
        }
    }

    #[test]
    fn a_state_outside_the_state_space_is_rejected() {
        for bad in ["3", "-1", "18446744073709551615"] {
            let model =
                format!(r#"{{"transitionActions": [{{"state": {bad}, "transitions": []}}]}}"#);
            let error = load_error(&model, KEY_STATES, SPACES);
            assert!(
                matches!(error, EnvFileError::StateOutOfRange { .. }),
                "{error}"
            );
            assert_mentions(
                &error,
                &["world.json", &format!("state {bad} is outside"), "0 to 2"],
            );
        }
    }

    #[test]
    fn a_state_listed_twice_is_rejected() {
        let model = r#"{"transitionActions": [{"state": 1, "transitions": []},
            {"state": 0, "transitions": []}, {"state": 1, "transitions": []}]}"#;
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(
            error,
            EnvFileError::DuplicateState {
                state: 1,
                first: 0,
                second: 2,
                ..
            }
        ));
        assert_mentions(
            &error,
            &[
                "world.json",
                "state 1 is listed twice",
                "transitionActions[2]",
            ],
        );
    }

    #[test]
    fn an_action_outside_the_action_space_is_rejected() {
        let model = r#"{"transitionActions": [{"state": 1, "transitions": [
            {"action": 0, "state": 2, "prob": 1}, {"action": 2, "state": 2, "prob": 1}]}]}"#;
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(
            error,
            EnvFileError::ActionOutOfRange {
                state: 1,
                index: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["world.json", "state 1", "action 2 is outside", "0 to 1"],
        );
    }

    #[test]
    fn a_next_state_outside_the_state_space_is_rejected() {
        let model = r#"{"transitionActions": [{"state": 1, "transitions": [
            {"action": 1, "state": 5, "prob": 1}]}]}"#;
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(
            error,
            EnvFileError::NextStateOutOfRange {
                state: 1,
                action: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["world.json", "state 1, action 1", "next state 5", "0 to 2"],
        );
    }

    #[test]
    fn zero_and_negative_counts_are_rejected() {
        for (count, shown) in [
            ("0", "count 0 "),
            ("-2", "count -2 "),
            ("1e-400", "count 0 "),
        ] {
            let model = format!(
                r#"{{"transitionActions": [{{"state": 1, "transitions": [
                    {{"action": 0, "state": 2, "prob": {count}}}]}}]}}"#
            );
            let error = load_error(&model, KEY_STATES, SPACES);
            assert!(
                matches!(error, EnvFileError::NonPositiveCount { .. }),
                "{error}"
            );
            assert_mentions(
                &error,
                &["world.json", "state 1, action 0, next state 2", shown],
            );
        }
    }

    #[test]
    fn a_non_numeric_count_is_rejected() {
        for (count, shown) in [
            ("\"5\"", "the string \"5\""),
            ("null", "null"),
            ("[1]", "an array"),
        ] {
            let model = format!(
                r#"{{"transitionActions": [{{"state": 1, "transitions": [
                    {{"action": 0, "state": 2, "prob": {count}}}]}}]}}"#
            );
            let error = load_error(&model, KEY_STATES, SPACES);
            assert!(
                matches!(error, EnvFileError::NonNumericCount { .. }),
                "{error}"
            );
            assert_mentions(
                &error,
                &["world.json", "state 1, action 0, next state 2", shown],
            );
        }
    }

    #[test]
    fn counts_adding_up_to_infinity_are_rejected() {
        let model = r#"{"transitionActions": [{"state": 1, "transitions": [
            {"action": 0, "state": 2, "prob": 1.7e308}, {"action": 0, "state": 0, "prob": 1.7e308}]}]}"#;
        let error = load_error(model, KEY_STATES, SPACES);
        assert!(matches!(
            error,
            EnvFileError::CountTotalOverflow {
                state: 1,
                action: 0,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["world.json", "state 1, action 0", "scale them down"],
        );
    }

    #[test]
    fn a_pair_with_more_than_65535_distinct_outcomes_is_rejected() {
        let spaces = "state 70000\naction 1\n";
        let model_with = |n: usize| {
            let transitions: Vec<String> = (0..n)
                .map(|next| format!(r#"{{"action": 0, "state": {next}, "prob": 1}}"#))
                .collect();
            format!(
                r#"{{"transitionActions": [{{"state": 3, "transitions": [{}]}}]}}"#,
                transitions.join(",")
            )
        };
        let world = world(&model_with(MAX_OUTCOMES_PER_PAIR), KEY_STATES, spaces);
        let spec = load(&world.paths, "test").expect("65,535 outcomes are accepted");
        assert_eq!(spec.max_branching(), MAX_OUTCOMES_PER_PAIR);

        let error = load_error(&model_with(MAX_OUTCOMES_PER_PAIR + 1), KEY_STATES, spaces);
        assert!(matches!(
            error,
            EnvFileError::TooManyOutcomes {
                state: 3,
                action: 0,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["world.json", "state 3, action 0", "65536 distinct", "65535"],
        );
    }

    #[test]
    fn a_goal_state_that_does_not_exist_is_rejected() {
        let error = load_error(MODEL, "init 0\n\ngoal 3 1\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::KeyStateOutOfRange {
                line: 3,
                role: "goal",
                ..
            }
        ));
        assert_mentions(
            &error,
            &[
                "keyStates.txt, line 3",
                "goal state 3 does not exist",
                "0 to 2",
            ],
        );
    }

    #[test]
    fn an_initial_state_that_does_not_exist_is_rejected() {
        for bad in ["7", "-1", "99999999999999999999999"] {
            let error = load_error(MODEL, &format!("goal 2 1\ninit 0 {bad}\n"), SPACES);
            assert!(matches!(
                error,
                EnvFileError::KeyStateOutOfRange {
                    role: "initial",
                    ..
                }
            ));
            assert_mentions(
                &error,
                &[
                    "keyStates.txt, line 2",
                    &format!("initial state {bad} does not exist"),
                ],
            );
        }
    }

    #[test]
    fn a_goal_that_is_also_initial_is_rejected() {
        let error = load_error(MODEL, "init 0 2\ngoal 2 1\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::GoalIsInitial {
                state: 2,
                goal_line: 2,
                init_line: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &[
                "keyStates.txt, line 2",
                "goal state 2 is also an initial state",
            ],
        );
    }

    #[test]
    fn missing_init_or_goal_lines_are_rejected() {
        let error = load_error(MODEL, "# nothing\ngoal 2 1\n", SPACES);
        assert!(
            matches!(
                error,
                EnvFileError::MissingLine {
                    keyword: "init",
                    ..
                }
            ),
            "{error}"
        );
        assert_mentions(&error, &["keyStates.txt", "no 'init' line"]);
        let error = load_error(MODEL, "init 0\nnew_goal 1601 34 1\n", SPACES);
        assert!(
            matches!(
                error,
                EnvFileError::MissingLine {
                    keyword: "goal",
                    ..
                }
            ),
            "{error}"
        );
        assert_mentions(&error, &["keyStates.txt", "no 'goal' line", "goal 18 1"]);
    }

    #[test]
    fn an_unknown_keyword_suggests_the_closest_one() {
        let cases = [
            (
                "init 0\ngaol 2 1\n",
                "keyStates.txt, line 2",
                "'gaol'",
                "'goal'",
            ),
            (
                "Init 0\ngoal 2 1\n",
                "keyStates.txt, line 1",
                "'Init'",
                "'init'",
            ),
            (
                "init 0\ngoal 2 1\nnewgoal 5 1 1\n",
                "keyStates.txt, line 3",
                "'newgoal'",
                "'new_goal'",
            ),
        ];
        for (key_states, at, word, suggestion) in cases {
            let error = load_error(MODEL, key_states, SPACES);
            assert!(
                matches!(error, EnvFileError::UnknownKeyword { .. }),
                "{error}"
            );
            assert_mentions(&error, &[at, word, suggestion, KEY_STATES_KEYWORDS]);
        }
        let error = load_error(MODEL, KEY_STATES, "states 3\naction 2\n");
        assert!(matches!(
            &error,
            EnvFileError::UnknownKeyword { suggestion, .. } if suggestion == "did you mean 'state'? "
        ));
        assert_mentions(
            &error,
            &["spaces.txt, line 1", "'states'", "'state'", SPACES_KEYWORDS],
        );
    }

    #[test]
    fn malformed_numbers_are_rejected_with_what_is_accepted() {
        let error = load_error(MODEL, "init 0 x1\ngoal 2 1\n", SPACES);
        assert!(
            matches!(error, EnvFileError::BadNumber { line: 1, .. }),
            "{error}"
        );
        assert_mentions(
            &error,
            &["keyStates.txt, line 1", "'x1'", "integer from 0 to 2"],
        );
        let error = load_error(MODEL, "init 0\ngoal 2 one\n", SPACES);
        assert!(
            matches!(error, EnvFileError::BadNumber { line: 2, .. }),
            "{error}"
        );
        assert_mentions(&error, &["keyStates.txt, line 2", "'one'", "goal reward"]);
        let error = load_error(MODEL, KEY_STATES, "state 3\naction two\n");
        assert!(
            matches!(error, EnvFileError::BadNumber { line: 2, .. }),
            "{error}"
        );
        assert_mentions(
            &error,
            &["spaces.txt, line 2", "'two'", "number of actions"],
        );
        let error = load_error(MODEL, KEY_STATES, "state -3\naction 2\n");
        assert_mentions(&error, &["spaces.txt, line 1", "'-3'", "positive integer"]);
    }

    #[test]
    fn a_non_finite_goal_reward_is_rejected() {
        for reward in ["inf", "NaN", "-infinity", "1e999"] {
            let error = load_error(MODEL, &format!("init 0\ngoal 2 {reward}\n"), SPACES);
            assert!(
                matches!(error, EnvFileError::NonFiniteReward { line: 2, .. }),
                "{error}"
            );
            assert_mentions(&error, &["keyStates.txt, line 2", reward, "not finite"]);
        }
    }

    #[test]
    fn lines_with_the_wrong_number_of_values_are_rejected() {
        let error = load_error(MODEL, "init\ngoal 2 1\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::WrongArgCount {
                keyword: "init",
                found: 0,
                ..
            }
        ));
        assert_mentions(&error, &["keyStates.txt, line 1", "one or more state ids"]);
        let error = load_error(MODEL, "init 0\ngoal 2\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::WrongArgCount {
                keyword: "goal",
                found: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["keyStates.txt, line 2", "a state id and its reward"],
        );
        let error = load_error(MODEL, KEY_STATES, "state 3 4\naction 2\n");
        assert!(matches!(
            error,
            EnvFileError::WrongArgCount {
                keyword: "state",
                found: 2,
                ..
            }
        ));
        assert_mentions(&error, &["spaces.txt, line 1", "one count"]);
    }

    #[test]
    fn repeated_lines_are_rejected() {
        let error = load_error(MODEL, "goal 2 1\ninit 0\ngoal 1 1\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::RepeatedLine {
                line: 3,
                first_line: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["keyStates.txt, line 3", "second 'goal' line", "line 1"],
        );
        let error = load_error(MODEL, KEY_STATES, "state 3\naction 2\naction 2\n");
        assert!(matches!(
            error,
            EnvFileError::RepeatedLine {
                line: 3,
                first_line: 2,
                ..
            }
        ));
        assert_mentions(&error, &["spaces.txt, line 3", "second 'action' line"]);
    }

    #[test]
    fn a_repeated_initial_state_is_rejected() {
        let error = load_error(MODEL, "init 0 1 0\ngoal 2 1\n", SPACES);
        assert!(matches!(
            error,
            EnvFileError::DuplicateInitial {
                line: 1,
                state: 0,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["keyStates.txt, line 1", "initial state 0 is listed twice"],
        );
    }

    #[test]
    fn missing_state_or_action_lines_are_rejected() {
        let error = load_error(MODEL, KEY_STATES, "# State space\naction 2\n");
        assert!(
            matches!(
                error,
                EnvFileError::MissingLine {
                    keyword: "state",
                    ..
                }
            ),
            "{error}"
        );
        assert_mentions(&error, &["spaces.txt", "no 'state' line", "state 38"]);
        let error = load_error(MODEL, KEY_STATES, "state 3\n");
        assert!(
            matches!(
                error,
                EnvFileError::MissingLine {
                    keyword: "action",
                    ..
                }
            ),
            "{error}"
        );
        assert_mentions(&error, &["spaces.txt", "no 'action' line"]);
    }

    #[test]
    fn zero_states_or_actions_are_rejected() {
        let error = load_error(MODEL, KEY_STATES, "state 0\naction 2\n");
        assert!(matches!(
            error,
            EnvFileError::ZeroSize {
                keyword: "state",
                line: 1,
                ..
            }
        ));
        assert_mentions(
            &error,
            &["spaces.txt, line 1", "'state 0'", "at least one state"],
        );
        let error = load_error(MODEL, KEY_STATES, "state 3\naction 0\n");
        assert!(matches!(
            error,
            EnvFileError::ZeroSize {
                keyword: "action",
                line: 2,
                ..
            }
        ));
        assert_mentions(&error, &["spaces.txt, line 2", "at least one action"]);
    }

    #[test]
    fn too_many_state_action_pairs_are_rejected() {
        let error = load_error(
            MODEL,
            KEY_STATES,
            "state 99999999999999999999999\naction 2\n",
        );
        assert!(
            matches!(error, EnvFileError::SpaceTooLarge { line: 1, .. }),
            "{error}"
        );
        assert_mentions(
            &error,
            &["spaces.txt, line 1", "99999999999999999999999", "too large"],
        );
        let error = load_error(MODEL, KEY_STATES, "state 100000\naction 1000\n");
        assert!(
            matches!(error, EnvFileError::TooManyPairs { .. }),
            "{error}"
        );
        assert_mentions(
            &error,
            &["spaces.txt", "100000 states x 1000 actions", "16777216"],
        );
    }

    #[test]
    fn mangled_files_never_make_the_loader_panic() {
        let paths = tidy1_paths();
        let originals: Vec<Vec<u8>> = [&paths.model, &paths.key_states, &paths.spaces]
            .iter()
            .map(|p| fs::read(p).expect("read the tidy1 fixture"))
            .collect();
        let dir = TempDir::new("mangled");
        let target = JsonPaths::beside(dir.0.join("tidy1.json"));
        let targets = [&target.model, &target.key_states, &target.spaces];
        let pieces: &[&[u8]] = &[
            b"0",
            b"9",
            b"-",
            b".",
            b"e",
            b"\"",
            b"{",
            b"}",
            b"[",
            b"]",
            b",",
            b":",
            b" ",
            b"#",
            b"\n",
            b"\xff",
            b"99999999999",
            b"-1",
            b"1e400",
            b"null",
        ];
        // A fixed-seed xorshift: the same 300 mangled worlds on every run.
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        let mut next = |bound: usize| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % bound.max(1) as u64) as usize
        };
        let (mut loaded, mut rejected) = (0, 0);
        for _ in 0..300 {
            let which = next(3);
            let mut bytes = originals[which].clone();
            for _ in 0..1 + next(3) {
                let at = next(bytes.len() + 1);
                match next(3) {
                    0 => {
                        let piece = pieces[next(pieces.len())];
                        let end = (at + next(4)).min(bytes.len());
                        bytes.splice(at..end, piece.iter().copied());
                    }
                    1 => {
                        let end = (at + next(40)).min(bytes.len());
                        bytes.drain(at..end);
                    }
                    _ => {
                        let end = (at + next(60)).min(bytes.len());
                        let copy = bytes[at..end].to_vec();
                        let to = next(bytes.len() + 1);
                        bytes.splice(to..to, copy);
                    }
                }
            }
            for (i, path) in targets.iter().enumerate() {
                fs::write(path, if i == which { &bytes } else { &originals[i] }).expect("write");
            }
            match load(&target, "mangled") {
                Ok(spec) => {
                    assert_well_formed(&spec);
                    loaded += 1;
                }
                Err(error) => {
                    assert!(!error.to_string().is_empty());
                    rejected += 1;
                }
            }
        }
        assert!(
            rejected > 150,
            "only {rejected} of 300 mangled worlds were rejected"
        );
        assert!(loaded > 0);
    }

    /// A spec as `load` would build it, with awkward weights.
    fn hand_built_spec() -> Spec {
        let outcomes = vec![
            vec![(1, 3.0), (0, 1.0)],
            vec![(2, 0.5), (1, 2.25), (0, 1e-7)],
            vec![(0, 1.0 / 3.0), (2, 0.1 + 0.2)],
            vec![],
            vec![(3, 1e20), (0, 7.0)],
            vec![(1, 1.0)],
            vec![],
            vec![(2, 2.0 / 3.0)],
        ];
        let names = (0..4).map(|s| format!("s{s}")).collect();
        Spec::from_outcomes(
            "hand".into(),
            4,
            2,
            outcomes,
            vec![2, 0],
            Goal {
                state: 3,
                reward: -0.125,
            },
            names,
            None,
        )
    }

    #[test]
    fn export_then_load_gives_back_a_hand_built_spec() {
        let spec = hand_built_spec();
        let dir = TempDir::new("export-hand");
        let paths = export(&spec, &dir.0.join("nested")).expect("export");
        assert_eq!(paths.model, dir.0.join("nested").join("hand.json"));
        let back = load(&paths, "json:hand").expect("the export loads");
        assert_eq!(
            back,
            Spec {
                name: "json:hand".into(),
                ..spec.clone()
            }
        );

        // Exporting again over the same files replaces them and leaves no temporary file.
        export(&spec, &dir.0.join("nested")).expect("export again");
        let mut names: Vec<String> = fs::read_dir(dir.0.join("nested"))
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["hand.json", "keyStates.txt", "spaces.txt"]);
    }

    #[test]
    fn export_then_load_gives_back_the_tidy1_fixture_and_its_model_file() {
        let paths = tidy1_paths();
        let spec = load(&paths, "json:tidy1").expect("tidy1 fixture loads");
        let dir = TempDir::new("export-tidy1");
        let exported = export(&spec, &dir.0).expect("export");
        assert_eq!(exported.model, dir.0.join("tidy1.json"));
        assert_eq!(
            load(&exported, "json:tidy1").expect("the export loads"),
            spec
        );
        let written = fs::read_to_string(&exported.model).expect("read export");
        let fixture = fs::read_to_string(&paths.model).expect("read fixture");
        assert_eq!(
            written, fixture,
            "the export should use the authors' layout"
        );
        let key_states = fs::read_to_string(&exported.key_states).expect("read keyStates.txt");
        assert!(key_states.lines().any(|l| l == "init 0"), "{key_states}");
        assert!(key_states.lines().any(|l| l == "goal 90 1"), "{key_states}");
    }

    #[test]
    fn export_names_the_model_after_the_spec() {
        assert_eq!(
            export_stem("json:../data/navworld/realisticNavWorld.json"),
            "realisticNavWorld"
        );
        assert_eq!(export_stem("tidy1"), "tidy1");
        assert_eq!(export_stem("my world:2"), "my_world_2");
        assert_eq!(export_stem("json:"), "model");
        assert_eq!(export_stem("json:dir/.."), "model");
    }

    #[test]
    fn export_refuses_a_spec_that_would_not_load_back() {
        let dir = TempDir::new("export-bad");
        let good = hand_built_spec();
        let cases = [
            (
                Spec {
                    goal: Some(Goal {
                        state: 2,
                        reward: -0.125,
                    }),
                    ..good.clone()
                },
                "not initial",
            ),
            (
                Spec {
                    initial_states: vec![],
                    ..good.clone()
                },
                "no initial state",
            ),
            (
                Spec {
                    goal: Some(Goal {
                        state: 3,
                        reward: f64::NAN,
                    }),
                    ..good.clone()
                },
                "not finite",
            ),
            (
                Spec {
                    outcome_start: vec![0, 1],
                    ..good.clone()
                },
                "inconsistent lengths",
            ),
            (
                Spec {
                    n_actions: 0,
                    ..good.clone()
                },
                "must be positive",
            ),
        ];
        for (spec, reason) in cases {
            let error = export(&spec, &dir.0.join("out")).expect_err("export should refuse");
            assert!(matches!(error, EnvFileError::InvalidSpec { .. }), "{error}");
            assert_mentions(&error, &["'hand'", reason]);
        }
        let mut negative = good.clone();
        negative.outcome_weight[0] = -1.0;
        let error = export(&negative, &dir.0.join("out")).expect_err("export should refuse");
        assert_mentions(&error, &["state 0, action 0", "positive and finite"]);
        let mut jumbled = good.clone();
        jumbled.outcome_start[1] = 100;
        let error = export(&jumbled, &dir.0.join("out")).expect_err("export should refuse");
        assert_mentions(&error, &["state 0, action 0", "outcomes"]);
        assert!(
            !dir.0.join("out").exists(),
            "nothing is written for a refused spec"
        );
    }

    #[test]
    fn export_reports_a_folder_it_cannot_create() {
        let dir = TempDir::new("export-blocked");
        let file = dir.0.join("a-file");
        fs::write(&file, "x").expect("write");
        let error = export(&hand_built_spec(), &file.join("sub")).expect_err("cannot create");
        assert!(matches!(error, EnvFileError::Write { .. }), "{error}");
        assert_mentions(&error, &["cannot write", "a-file"]);
    }
}
