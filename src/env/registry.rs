//! The task registry: every task the simulator knows, with what the rest of the program asks of
//! a task (how to build it, its defaults, which humans and schedule events it allows, its task
//! parameters and extra metrics). Help texts, error messages, default steps, schedule checks
//! and the refusal of interactions all read this table; nothing else lists tasks.
//!
//! Adding a task is writing its file in `src/env/` with one `pub const` [`Task`], and adding
//! one line to the `tasks!` list in `src/env/mod.rs`.

use crate::env::{EnvError, Spec};
use crate::params::{Interaction, PARAMS, Params, RewardSource};

/// One task, or a family of tasks named `PREFIX:ARGUMENT` (`grid:N`, `json:PATH`).
#[derive(Debug)]
pub struct Task {
    /// The name, or the pattern of a family: the part up to and including `:` is matched, the
    /// rest (in capitals here) is the argument.
    pub name: &'static str,
    /// One line for help texts.
    pub help: &'static str,
    /// Builds the task's world from the task as given (`json:data/w.json`, not the pattern).
    pub build: fn(&str) -> Result<Spec, EnvError>,
    /// Experiment steps when none are given (SPEC 7).
    pub default_steps: u32,
    /// Babbling steps when none are given.
    pub default_babbling: u32,
    /// The interaction types a human may have here (besides `none`).
    pub interactions: &'static [Interaction],
    /// Whether the human may be the one who brings the reward (SPEC 11.1).
    pub human_reward: bool,
    /// The schedule events on the world this task accepts (`world`, `goal`, `boxes`,
    /// `delete`); the human's events are accepted wherever the human is.
    pub events: &'static [&'static str],
    /// Why an event is refused, where the task has more to say than that it is not accepted.
    pub refusals: &'static [(&'static str, &'static str)],
    /// The task parameters (rows of the parameter registry declared by `task_params!`) that
    /// this task reads; the others must keep their defaults.
    pub params: &'static [&'static str],
    /// The world a run starts in when its task parameters are not all defaults: `None` where
    /// they change nothing, an error message where they cannot apply.
    pub configure: fn(&Params) -> Result<Option<Spec>, String>,
    /// The metric columns the task reports besides the common ones (null for other tasks),
    /// computed from its run's tally ([`crate::env::Tally`]).
    pub metrics: &'static [Metric],
    /// The metrics `mbmf run` summarises per controller under its table (heading, metric name),
    /// and a line saying where to go further with them.
    pub headline: &'static [(&'static str, &'static str)],
    /// See [`Task::headline`].
    pub headline_note: &'static str,
}

/// A metric column of a task (SPEC 13's stay probabilities): a runs-table column, null for the
/// runs of other tasks, whose value the task computes from a run's tally at the end.
#[derive(Debug)]
pub struct Metric {
    /// The column's name.
    pub name: &'static str,
    /// What it means (the column's description and the schema page's).
    pub doc: &'static str,
    /// Its unit ("" for none).
    pub unit: &'static str,
    /// Its value for a run with this tally; `None` (null) where undefined.
    pub value: fn(&[f64]) -> Option<f64>,
}

/// Every task's metric columns, in task order then the task's order (the order of the columns).
pub fn metrics() -> impl Iterator<Item = &'static Metric> {
    crate::env::TASKS.iter().flat_map(|t| t.metrics.iter())
}

/// The metric column `name`, if a task reports it.
pub fn metric(name: &str) -> Option<&'static Metric> {
    metrics().find(|m| m.name == name)
}

/// What a task is unless it says otherwise: the paper's 10,000 steps after 1,000 of babbling,
/// no interaction (the human may still bring the reward), no schedule event on its world, no
/// task parameter and no extra metric. An entry writes `..DEFAULTS` after what differs.
pub const DEFAULTS: Task = Task {
    name: "",
    help: "",
    build: |task| Err(EnvError::UnknownTask(task.to_string())),
    default_steps: 10_000,
    default_babbling: 1_000,
    interactions: &[],
    human_reward: true,
    events: &[],
    refusals: &[],
    params: &[],
    configure: unconfigured,
    metrics: &[],
    headline: &[],
    headline_note: "",
};

/// [`Task::configure`] of a task whose parameters change nothing.
pub fn unconfigured(_: &Params) -> Result<Option<Spec>, String> {
    Ok(None)
}

impl Task {
    /// The part of the name a task given by the user starts with: the whole name, or the
    /// prefix of a family (`json:`).
    fn prefix(&self) -> &'static str {
        match self.name.find(':') {
            Some(i) => &self.name[..=i],
            None => self.name,
        }
    }

    /// Whether `task` names this task (or one of its family).
    pub fn matches(&self, task: &str) -> bool {
        if self.name.contains(':') {
            task.starts_with(self.prefix())
        } else {
            task == self.name
        }
    }

    /// Whether schedules may carry the event `key` on this task's world.
    pub fn accepts_event(&self, key: &str) -> bool {
        self.events.contains(&key)
    }

    /// Why the event `key` (described as `what`, e.g. "a world swap") is refused on `task`.
    pub fn refusal(&self, key: &str, what: &str, task: &str) -> String {
        if let Some((_, reason)) = self.refusals.iter().find(|(k, _)| *k == key) {
            return (*reason).to_string();
        }
        let takers: Vec<&str> = crate::env::TASKS
            .iter()
            .filter(|t| t.accepts_event(key))
            .map(|t| t.name)
            .collect();
        format!(
            "{what} is defined for {}, not for '{task}'",
            if takers.is_empty() {
                "no task".to_string()
            } else {
                or_list(&takers)
            }
        )
    }
}

/// The registered task that `task` names.
pub fn find(task: &str) -> Option<&'static Task> {
    crate::env::TASKS.iter().find(|t| t.matches(task))
}

/// "a, b or c".
fn or_list(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => (*one).to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// Every task name or pattern, as help texts and errors list them: "tidy1, tidy2, ... or chain".
pub fn names() -> String {
    let names: Vec<&str> = crate::env::TASKS.iter().map(|t| t.name).collect();
    or_list(&names)
}

/// The names of the tasks without an argument (what a misspelt name is compared with).
pub fn plain_names() -> impl Iterator<Item = &'static str> {
    crate::env::TASKS
        .iter()
        .filter(|t| !t.name.contains(':'))
        .map(|t| t.name)
}

/// The short `--task` help: the tasks' names.
pub fn short_help() -> String {
    format!("The task: {}", names())
}

/// The long `--task` help: every task with its line.
pub fn help() -> String {
    let mut text = format!("The task: {}.", names());
    for t in crate::env::TASKS {
        text.push_str(&format!("\n- {}: {}", t.name, t.help));
    }
    text
}

/// Experiment steps when none are given (SPEC 7): the task's default, 10,000 for a name no
/// task matches (it fails to load anyway).
pub fn default_steps(task: &str) -> u32 {
    find(task).map_or(Params::default().steps, |t| t.default_steps)
}

/// Babbling steps when none are given.
pub fn default_babbling(task: &str) -> u32 {
    find(task).map_or(Params::default().babbling, |t| t.default_babbling)
}

/// Checks that `params` make sense for the world `spec`: every scalar, values that stay finite
/// with its rewards, and a human its task allows (SPEC 5, 11.1). Task parameters are checked
/// where they configure the world ([`configure`]).
pub fn check_params(spec: &Spec, params: &Params) -> Result<(), crate::params::ConfigError> {
    if params.human.interaction == Interaction::Person {
        return Err(crate::params::ConfigError::InteractionUnsupported {
            task: spec.name.clone(),
            interaction: "person".to_string(),
            accepted: "a real person teaches only through `mbmf teach`; a simulated human is \
                       none, congratulation, takeover, punishment or nuisance"
                .to_string(),
        });
    }
    check_world(spec, params)
}

/// [`check_params`] for a run a real person teaches (SPEC 15): any robot, on a task whose
/// world says where a takeover or feedback can happen, with the softmax bonus (a person's
/// feedback comes after the step has learned, so it cannot shape that step's reward) and the
/// environment's reward.
pub fn check_person(spec: &Spec, params: &Params) -> Result<(), crate::params::ConfigError> {
    use crate::params::{ConfigError, CongratulationEffect};
    let refuse = |accepted: &str| {
        Err(ConfigError::InteractionUnsupported {
            task: spec.name.clone(),
            interaction: "person".to_string(),
            accepted: accepted.to_string(),
        })
    };
    if params.human.interaction != Interaction::Person {
        return refuse("a person's session has the interaction `person`");
    }
    if spec.human.is_none() {
        return refuse("a person teaches a task with cubes to judge and take: tidy1 or tidy2");
    }
    if params.congratulation_effect != CongratulationEffect::Bias {
        return refuse(
            "a person's feedback arrives after the step has learned: congratulation_effect bias",
        );
    }
    if params.reward_source != RewardSource::Environment {
        return refuse("a person gives feedback, not the goal's reward: reward_source environment");
    }
    check_world(spec, params)
}

/// The checks of [`check_params`] that hold for any human.
fn check_world(spec: &Spec, params: &Params) -> Result<(), crate::params::ConfigError> {
    use crate::params::ConfigError;
    params.validate()?;
    params.validate_for_reward(spec.max_abs_reward())?;
    if params.lambda_mf > 0.0 && params.controller == crate::params::Controller::Vpi {
        return Err(ConfigError::Incompatible {
            name: "lambda_mf",
            value: crate::params::show(params.lambda_mf),
            with: "controller",
            with_value: params.controller.name().to_string(),
            why: "vpi's MF is a Kalman Q-learner without an eligibility trace (SPEC 12.4); \
                  set lambda_mf to 0 or use another controller",
        });
    }
    let interaction = params.human.interaction;
    if interaction != Interaction::None
        && interaction != Interaction::Person
        && params.human.budget > 0
        && !allows_interaction(spec, interaction)
    {
        return Err(ConfigError::InteractionUnsupported {
            task: spec.name.clone(),
            interaction: interaction.name().to_string(),
            accepted: interactions_of(spec),
        });
    }
    if params.reward_source == RewardSource::Human
        && !find(&spec.name).is_none_or(|t| t.human_reward)
    {
        return Err(ConfigError::InteractionUnsupported {
            task: spec.name.clone(),
            interaction: "reward_source human".to_string(),
            accepted: "the human cannot bring this task's reward".to_string(),
        });
    }
    Ok(())
}

/// Whether the human of a run in `spec` may have the interaction type `interaction`: what its
/// task allows, or, for a world no task names (built by hand), whether it has human tables.
pub fn allows_interaction(spec: &Spec, interaction: Interaction) -> bool {
    match find(&spec.name) {
        Some(task) => task.interactions.contains(&interaction),
        None => spec.human.is_some(),
    }
}

/// Whether schedules may carry the event `key` on `spec`'s world (a world no task names
/// accepts those of a file world).
pub fn accepts_event(spec: &Spec, key: &str) -> bool {
    find(&spec.name)
        .unwrap_or(&crate::env::json::JSON)
        .accepts_event(key)
}

/// Why the event `key` (described as `what`) is refused on `spec`'s world.
pub fn refusal(spec: &Spec, key: &str, what: &str) -> String {
    find(&spec.name)
        .unwrap_or(&crate::env::json::JSON)
        .refusal(key, what, &spec.name)
}

/// What the human of `spec`'s task can do, for error messages.
pub fn interactions_of(spec: &Spec) -> String {
    let interactions = find(&spec.name).map_or(&[][..], |t| t.interactions);
    let names: Vec<&str> = interactions.iter().map(|i| i.name()).collect();
    if names.is_empty() {
        "it defines no relevant action, error or place for a held cube".to_string()
    } else {
        format!("it accepts {}", or_list(&names))
    }
}

/// The first task parameter set away from its default that `task` does not read.
fn foreign_param(task: &Task, params: &Params) -> Option<&'static crate::params::Param> {
    PARAMS
        .iter()
        .filter(|p| p.task && !task.params.contains(&p.name))
        .find(|p| (p.get)(params) != p.default_value())
}

/// The tasks that read the task parameter `name`.
fn takers_of(name: &str) -> Vec<&'static str> {
    crate::env::TASKS
        .iter()
        .filter(|t| t.params.contains(&name))
        .map(|t| t.name)
        .collect()
}

/// The values of every task parameter of `params`, in registry order (what distinguishes the
/// worlds runs of one task start in).
pub fn task_param_values(params: &Params) -> Vec<crate::params::Value> {
    PARAMS
        .iter()
        .filter(|p| p.task)
        .map(|p| (p.get)(params))
        .collect()
}

/// Whether every task parameter of `params` has its default.
pub fn task_params_default(params: &Params) -> bool {
    PARAMS
        .iter()
        .filter(|p| p.task)
        .all(|p| (p.get)(params) == p.default_value())
}

/// The world a run of `spec`'s task starts in with `params`: the task's own (`None`), or the
/// one its task parameters configure. An error is (`name=value` of the parameter, reason).
pub fn configure(spec: &Spec, params: &Params) -> Result<Option<Spec>, (String, String)> {
    if task_params_default(params) {
        return Ok(None);
    }
    let task = find(&spec.name).unwrap_or(&crate::env::json::JSON);
    if let Some(p) = foreign_param(task, params) {
        return Err((
            format!("{}={}", p.name, (p.get)(params)),
            format!(
                "{} is a parameter of {}, not of task '{}'",
                p.name,
                or_list(&takers_of(p.name)),
                spec.name
            ),
        ));
    }
    (task.configure)(params).map_err(|reason| (task.name.to_string(), reason))
}

/// The task parameters: rows of the parameter registry (flags, sweep keys, Parquet columns, in
/// this order after the others) declared here, beside the tasks that read them, so that the
/// parameters module names no world. `task_params!(path::to::registry { ROWS })` invokes that
/// registry macro with `ROWS` followed by these rows.
macro_rules! task_params {
    ($($registry:ident)::+ { $($rows:tt)* }) => {
        $($registry)::+! {
            $($rows)*
            task boxes: $crate::env::tidy::Boxes = $crate::env::tidy::Boxes::RGB,
                "tidy1 box assignment at the start: position i gives cube i's box (rgb by default)";
            task common_prob: f64 = 0.7,
                "twostep: probability of the common first-stage transition" ("probability"),
                accepts "a probability in [0, 1]" if |x| (0.0..=1.0).contains(&x);
            task drift_sd: f64 = 0.025,
                "twostep: standard deviation of the reward probabilities' drift per trial",
                accepts "a standard deviation in [0, 1]" if |x| (0.0..=1.0).contains(&x);
        }
    };
}
pub(crate) use task_params;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_task_name_is_matched_by_its_own_entry_only() {
        for (task, name) in [
            ("tidy1", "tidy1"),
            ("tidy2", "tidy2"),
            ("grid:30", "grid:N"),
            ("json:a/b.json", "json:PATH"),
        ] {
            assert_eq!(find(task).map(|t| t.name), Some(name), "{task}");
            let matching = crate::env::TASKS.iter().filter(|t| t.matches(task)).count();
            assert_eq!(matching, 1, "{task}");
        }
        assert!(find("tidy").is_none());
        assert!(find("tidy12").is_none());
        assert!(find("grid").is_none());
    }

    /// The help of `--steps` and `--babbling` names every task whose default differs from
    /// the paper's, with that default (written by hand there: this keeps it true).
    #[test]
    fn the_steps_and_babbling_help_names_each_task_default_that_differs() {
        let help = |key| crate::params::param(key).unwrap().help;
        for t in crate::env::TASKS {
            for (key, value, paper) in [
                ("steps", t.default_steps, DEFAULTS.default_steps),
                ("babbling", t.default_babbling, DEFAULTS.default_babbling),
            ] {
                let named = help(key).contains(&format!("{value} for {}", t.name));
                assert_eq!(
                    named,
                    value != paper,
                    "--{key} of {}: {}",
                    t.name,
                    help(key)
                );
            }
        }
    }

    #[test]
    fn the_task_list_and_defaults_come_from_the_entries() {
        assert!(names().starts_with("tidy1, tidy2, grid:N"), "{}", names());
        for t in crate::env::TASKS {
            assert!(names().contains(t.name));
            assert!(help().contains(&format!("\n- {}: {}", t.name, t.help)));
        }
        assert_eq!(default_steps("tidy1"), 10_000);
        assert_eq!(default_steps("tidy2"), 20_000);
        assert_eq!(default_steps("json:x.json"), 10_000);
        assert_eq!(default_babbling("grid:9"), 1_000);
    }

    #[test]
    fn interactions_are_refused_where_the_task_defines_none() {
        let grid = crate::env::load("grid:9").unwrap();
        let mut p = Params::default();
        p.human.interaction = Interaction::Takeover;
        p.human.budget = 10;
        let message = check_params(&grid, &p).unwrap_err().to_string();
        assert!(
            message.contains("interaction 'takeover' is not defined for task 'grid:9'"),
            "{message}"
        );
        assert!(check_params(&crate::env::load("tidy2").unwrap(), &p).is_ok());
        // No budget: the human never acts, so nothing is refused.
        p.human.budget = 0;
        assert!(check_params(&grid, &p).is_ok());
    }

    #[test]
    fn task_parameters_are_rows_of_the_parameter_registry() {
        let boxes = crate::params::param("boxes").unwrap();
        assert!(boxes.task && boxes.flag);
        let task_params: Vec<&str> = PARAMS.iter().filter(|p| p.task).map(|p| p.name).collect();
        // Every task parameter is read by some task.
        for name in task_params {
            assert!(!takers_of(name).is_empty(), "{name}");
        }
    }
}
