//! Schedules of changes during a run (SPEC 10): events at experiment steps that swap the world,
//! move the goal (or, in `tidy1`, change the box assignment), delete transitions or change the
//! human.
//!
//! A [`Schedule`] is what the user wrote, with a canonical text form (`1601:goal=34;
//! 1601:world=json:PATH`); [`compile`] checks it against the task before the first step and
//! turns it into a [`Plan`]: the worlds the run can meet, loaded once, and the events as cheap
//! actions on a run's cursor. The batch applies them per run at the start of their step.

use std::fmt;
use std::sync::Arc;

use thiserror::Error;

use crate::env::tidy::Boxes;
use crate::env::{self, Goal, Spec, StateId, registry};
use crate::params::{Interaction, Params, Profile, RewardSource};

/// What changes at one step.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// `world=json:PATH`: another transition table of the same spaces (`json:` tasks).
    World(String),
    /// `goal=S` or `goal=S:R`: the rewarded state moves to S (its reward becomes R if given).
    Goal {
        /// The new goal state.
        state: StateId,
        /// The new goal reward; unchanged when `None`.
        reward: Option<f64>,
    },
    /// `boxes=PERM`: `tidy1`'s box assignment.
    Boxes(Boxes),
    /// `delete=S-T,...`: every outcome S -> T of the listed ordered pairs is removed (`json:`).
    Delete(Vec<(StateId, StateId)>),
    /// The human changes.
    Human(HumanChange),
}

/// The value of `values` whose `name` is `value`.
fn named<T: Copy>(values: &[T], name: impl Fn(T) -> &'static str, value: &str) -> Option<T> {
    values.iter().copied().find(|&v| name(v) == value)
}

/// One event at experiment step `step` (1-based, babbling not counted).
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    /// The step at whose start the event applies.
    pub step: u32,
    /// What changes.
    pub event: Event,
}

/// The changes of a run, in the order given (events at one step apply in this order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Schedule {
    /// The changes.
    pub changes: Vec<Change>,
}

/// A schedule that cannot be read or does not fit the task. The message names the event.
#[derive(Debug, Error, PartialEq)]
#[error("invalid change '{event}': {reason}")]
pub struct ScheduleError {
    /// The event as written (or canonically, once parsed).
    pub event: String,
    /// What is wrong, and what is accepted.
    pub reason: String,
}

fn fail(event: impl fmt::Display, reason: impl Into<String>) -> ScheduleError {
    ScheduleError {
        event: event.to_string(),
        reason: reason.into(),
    }
}

/// The keys an event may set, as written in its text form.
pub const EVENT_KEYS: &[&str] = &[
    "world",
    "goal",
    "boxes",
    "delete",
    "interaction",
    "budget",
    "forget",
    "error_prob",
    "zeta",
    "profile",
    "reward_source",
];

const FORM: &str = "expected STEP:KEY=VALUE, e.g. 1601:goal=34, 1601:world=json:PATH, \
                    1601:delete=20-21,21-20, 5000:boxes=brg, 3000:interaction=none, 2000:budget=50";

impl Change {
    /// Parses one event, `STEP:KEY=VALUE`.
    pub fn parse(text: &str) -> Result<Change, ScheduleError> {
        let text = text.trim();
        let (step, rest) = text.split_once(':').ok_or_else(|| fail(text, FORM))?;
        let step: u32 = step.trim().parse().map_err(|_| {
            fail(
                text,
                format!(
                    "the step '{}' is not a whole number >= 1; {FORM}",
                    step.trim()
                ),
            )
        })?;
        let (key, value) = rest.split_once('=').ok_or_else(|| fail(text, FORM))?;
        let key = key.trim().to_lowercase().replace('-', "_");
        let value = value.trim();
        let number = |what: &str| -> Result<f64, ScheduleError> {
            value
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| fail(text, format!("{key} '{value}' is not {what}")))
        };
        let state = |v: &str| -> Result<StateId, ScheduleError> {
            v.trim()
                .parse::<StateId>()
                .map_err(|_| fail(text, format!("'{}' is not a state id", v.trim())))
        };
        let event = match key.as_str() {
            "world" => {
                if !value.starts_with("json:") {
                    return Err(fail(
                        text,
                        format!("world '{value}' is not a json:PATH transition-model file"),
                    ));
                }
                Event::World(value.to_string())
            }
            "goal" => {
                let (s, r) = match value.split_once(':') {
                    Some((s, r)) => (s, Some(r)),
                    None => (value, None),
                };
                let reward = match r {
                    Some(r) => Some(
                        r.trim()
                            .parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite())
                            .ok_or_else(|| {
                                fail(
                                    text,
                                    format!("goal reward '{}' is not a finite number", r.trim()),
                                )
                            })?,
                    ),
                    None => None,
                };
                Event::Goal {
                    state: state(s)?,
                    reward,
                }
            }
            "boxes" => Event::Boxes(Boxes::parse(value).map_err(|e| fail(text, e))?),
            "delete" => {
                let mut pairs = Vec::new();
                for pair in value.split(',') {
                    let (a, b) = pair.split_once('-').ok_or_else(|| {
                        fail(
                            text,
                            format!(
                                "'{}' is not an ordered pair FROM-TO (e.g. delete=20-21,21-20)",
                                pair.trim()
                            ),
                        )
                    })?;
                    pairs.push((state(a)?, state(b)?));
                }
                Event::Delete(pairs)
            }
            "interaction" => Event::Human(HumanChange::Interaction(
                named(Interaction::VALUES, Interaction::name, value).ok_or_else(|| {
                    fail(
                        text,
                        format!(
                            "interaction '{value}' is not one of none, congratulation, \
                                 takeover, punishment, nuisance"
                        ),
                    )
                })?,
            )),
            "budget" => Event::Human(HumanChange::Budget(value.parse().map_err(|_| {
                fail(
                    text,
                    format!("budget '{value}' is not a whole number from 0 to 4294967295"),
                )
            })?)),
            "forget" | "forget_prob" => {
                let p = number("a probability in [0, 1]")?;
                if !(0.0..=1.0).contains(&p) {
                    return Err(fail(text, format!("forget '{value}' is not in [0, 1]")));
                }
                Event::Human(HumanChange::Forget(p))
            }
            "error_prob" => {
                let e = number("a probability in [0, 1]")?;
                if !(0.0..=1.0).contains(&e) {
                    return Err(fail(text, format!("error_prob '{value}' is not in [0, 1]")));
                }
                Event::Human(HumanChange::ErrorProb(e))
            }
            "zeta" => {
                let z = number("a number from 0 to 1e12")?;
                if !(0.0..=crate::params::MAGNITUDE_MAX).contains(&z) {
                    return Err(fail(text, format!("zeta '{value}' is not from 0 to 1e12")));
                }
                Event::Human(HumanChange::Zeta(z))
            }
            "profile" => Event::Human(HumanChange::Profile(
                named(&Profile::PRESETS, Profile::name, value).ok_or_else(|| {
                    let names: Vec<&str> = Profile::PRESETS.iter().map(|p| p.name()).collect();
                    fail(
                        text,
                        format!(
                            "profile '{value}' is not one of {} (sweep-file profiles \
                                 cannot be events)",
                            names.join(", ")
                        ),
                    )
                })?,
            )),
            "reward_source" => Event::Human(HumanChange::RewardSource(
                named(RewardSource::VALUES, RewardSource::name, value).ok_or_else(|| {
                    fail(
                        text,
                        format!("reward_source '{value}' is not environment or human"),
                    )
                })?,
            )),
            _ => {
                let hint = crate::suggest::hint(&key, EVENT_KEYS.iter().copied());
                return Err(fail(
                    text,
                    format!(
                        "unknown key '{key}': {hint}expected one of {}",
                        EVENT_KEYS.join(", ")
                    ),
                ));
            }
        };
        Ok(Change { step, event })
    }
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::World(task) => write!(f, "world={task}"),
            Event::Goal {
                state,
                reward: None,
            } => write!(f, "goal={state}"),
            Event::Goal {
                state,
                reward: Some(r),
            } => write!(f, "goal={state}:{r}"),
            Event::Boxes(b) => write!(f, "boxes={b}"),
            Event::Delete(pairs) => {
                f.write_str("delete=")?;
                for (i, (a, b)) in pairs.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    write!(f, "{a}-{b}")?;
                }
                Ok(())
            }
            Event::Human(h) => write!(f, "{h}"),
        }
    }
}

impl fmt::Display for HumanChange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HumanChange::Interaction(i) => write!(f, "interaction={}", i.name()),
            HumanChange::Budget(n) => write!(f, "budget={n}"),
            HumanChange::Forget(p) => write!(f, "forget={p}"),
            HumanChange::ErrorProb(e) => write!(f, "error_prob={e}"),
            HumanChange::Zeta(z) => write!(f, "zeta={z}"),
            HumanChange::Profile(p) => write!(f, "profile={}", p.name()),
            HumanChange::RewardSource(r) => write!(f, "reward_source={}", r.name()),
        }
    }
}

impl fmt::Display for Change {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.step, self.event)
    }
}

impl fmt::Display for Schedule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, c) in self.changes.iter().enumerate() {
            if i > 0 {
                f.write_str(";")?;
            }
            write!(f, "{c}")?;
        }
        Ok(())
    }
}

impl Schedule {
    /// Parses events joined by `;` (the canonical column form); blanks between are ignored.
    pub fn parse(text: &str) -> Result<Schedule, ScheduleError> {
        Schedule::from_events(text.split(';'))
    }

    /// Parses one event per item (the repeatable `--change` flag).
    pub fn from_events<'a>(
        events: impl IntoIterator<Item = &'a str>,
    ) -> Result<Schedule, ScheduleError> {
        let mut changes = Vec::new();
        for e in events {
            if !e.trim().is_empty() {
                changes.push(Change::parse(e)?);
            }
        }
        Ok(Schedule { changes })
    }

    /// Whether there is no change.
    pub fn is_empty(&self) -> bool {
        self.changes.is_empty()
    }

    /// The step of the earliest change, if any.
    pub fn first_step(&self) -> Option<u32> {
        self.changes.iter().map(|c| c.step).min()
    }
}

/// A change of the human (SPEC 10 "Human"), applied to the run's own copy of its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HumanChange {
    /// `interaction=TYPE`.
    Interaction(Interaction),
    /// `budget=N`: the budget left from this step on.
    Budget(u32),
    /// `forget=P`: the human's forget probability.
    Forget(f64),
    /// `error_prob=E`: the probability the attentive human misjudges an action (SPEC 15).
    ErrorProb(f64),
    /// `zeta=Z`: the congratulation (or punishment) weight.
    Zeta(f64),
    /// `profile=NAME`: a built-in human (type, budget left, forget, zeta, reward source),
    /// resolved for the run's controller when applied.
    Profile(Profile),
    /// `reward_source=environment|human` (SPEC 11.1).
    RewardSource(RewardSource),
}

/// A compiled event: what it does to a run's cursor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// The run now lives in this world of the plan (an index into [`Plan::worlds`]): a world
    /// swap, a deletion, a moved goal or, in `tidy1`, a box assignment.
    World(u16),
    /// The human changes.
    Human(HumanChange),
}

/// A schedule checked against a task: the worlds a run can meet and the events as actions,
/// sorted by step (stable, so events at one step keep their order).
#[derive(Debug, Clone)]
pub struct Plan {
    /// The schedule's canonical text (the `schedule` column).
    pub text: String,
    /// Step of the first change; 0 without changes.
    pub first_change: u32,
    /// World 0 is the run's world at the start; the others come from events.
    pub worlds: Vec<Arc<Spec>>,
    /// (step, action), ascending by step.
    pub actions: Vec<(u32, Action)>,
    /// Whether the human can be a nuisance in this run (the model then needs the outcomes a
    /// nuisance produces).
    pub nuisance: bool,
}

impl Plan {
    /// The plan of a run without changes in `spec`.
    pub fn none(spec: Arc<Spec>) -> Plan {
        Plan {
            text: String::new(),
            first_change: 0,
            worlds: vec![spec],
            actions: Vec::new(),
            nuisance: false,
        }
    }
}

/// Adds `world` to the plan's worlds: the action that moves a run into it.
fn enter(worlds: &mut Vec<Arc<Spec>>, world: Arc<Spec>) -> Action {
    worlds.push(world);
    Action::World((worlds.len() - 1) as u16)
}

/// Checks `schedule` against the task `spec` (named `task`) for a run with `params`, loading
/// every world it names, before anything runs (SPEC 10): steps in 1..=steps, worlds with the
/// same spaces, goals that exist and are not initial states, deletions of pairs the world has,
/// and only the events, task parameters and interactions the task's registry entry allows.
pub fn compile(
    spec: &Arc<Spec>,
    schedule: &Schedule,
    params: &Params,
) -> Result<Plan, ScheduleError> {
    let mut worlds: Vec<Arc<Spec>> = Vec::new();
    let start = match registry::configure(spec, params) {
        Ok(Some(world)) => Arc::new(world),
        Ok(None) => Arc::clone(spec),
        Err((event, reason)) => return Err(fail(event, reason)),
    };
    worlds.push(Arc::clone(&start));
    // The task decides which events it accepts and why it refuses the others.
    let refuse = |key: &str, what: &str| -> Option<String> {
        (!registry::accepts_event(spec, key)).then(|| registry::refusal(spec, key, what))
    };
    let mut nuisance = params.human.interaction == Interaction::Nuisance;
    let mut actions = Vec::with_capacity(schedule.changes.len());
    for change in &schedule.changes {
        let event = change.to_string();
        if change.step == 0 || change.step > params.steps {
            return Err(fail(
                &event,
                format!(
                    "step {} is outside the experiment: expected 1 to {} (the run's steps; \
                     babbling is not counted)",
                    change.step, params.steps
                ),
            ));
        }
        let action = match &change.event {
            Event::World(name) => {
                if let Some(reason) = refuse("world", "a world swap") {
                    return Err(fail(&event, reason));
                }
                let loaded = env::load(name).map_err(|e| fail(&event, e.to_string()))?;
                let here = &worlds[worlds.len() - 1];
                if (loaded.n_states, loaded.n_actions) != (here.n_states, here.n_actions) {
                    return Err(fail(
                        &event,
                        format!(
                            "the world has {} states and {} actions, the task {} and {}: a \
                             world change keeps the spaces",
                            loaded.n_states, loaded.n_actions, here.n_states, here.n_actions
                        ),
                    ));
                }
                // The goal, its reward and the initial states stay as they were (SPEC 10).
                let mut world = match here.goal {
                    Some(goal) => loaded.with_goal(goal),
                    None => loaded,
                };
                world.initial_states = here.initial_states.clone();
                enter(&mut worlds, Arc::new(world))
            }
            Event::Goal { state, reward } => {
                if let Some(reason) = refuse("goal", "moving the goal") {
                    return Err(fail(&event, reason));
                }
                let here = &worlds[worlds.len() - 1];
                if *state as usize >= here.n_states {
                    return Err(fail(
                        &event,
                        format!(
                            "goal {state} does not exist: states are 0 to {}",
                            here.n_states - 1
                        ),
                    ));
                }
                if here.initial_states.contains(state) {
                    return Err(fail(
                        &event,
                        format!(
                            "goal {state} is an initial state (initial states: {:?}); a run \
                             would reset forever",
                            here.initial_states
                        ),
                    ));
                }
                if let Some(r) = reward {
                    params
                        .validate_for_reward(*r)
                        .map_err(|e| fail(&event, e.to_string()))?;
                }
                // The moved goal is another world of the same transitions: the step reads
                // every arrival's reward from its world.
                let reward = match (reward, here.goal) {
                    (Some(r), _) => *r,
                    (None, Some(g)) => g.reward,
                    (None, None) => return Err(fail(&event, "the task has no goal to move")),
                };
                let world = Spec::clone(here).with_goal(Goal {
                    state: *state,
                    reward,
                });
                enter(&mut worlds, Arc::new(world))
            }
            Event::Boxes(boxes) => {
                if let Some(reason) = refuse("boxes", "a box assignment") {
                    return Err(fail(&event, reason));
                }
                // The task parameter takes its new value: the world it configures.
                let changed = Params {
                    boxes: *boxes,
                    ..*params
                };
                let world = match registry::configure(spec, &changed) {
                    Ok(Some(world)) => world,
                    Ok(None) => Spec::clone(spec),
                    Err((_, reason)) => return Err(fail(&event, reason)),
                };
                enter(&mut worlds, Arc::new(world))
            }
            Event::Delete(pairs) => {
                if let Some(reason) = refuse("delete", "deleting transitions") {
                    return Err(fail(&event, reason));
                }
                let world =
                    delete(&worlds[worlds.len() - 1], pairs).map_err(|r| fail(&event, r))?;
                enter(&mut worlds, Arc::new(world))
            }
            Event::Human(h @ HumanChange::Interaction(i)) => {
                if *i != Interaction::None && !registry::allows_interaction(spec, *i) {
                    return Err(fail(&event, no_human(spec, i.name())));
                }
                nuisance |= *i == Interaction::Nuisance;
                Action::Human(*h)
            }
            Event::Human(h @ HumanChange::Profile(p)) => {
                let human = p.human(params.controller).unwrap_or_default();
                let i = human.interaction;
                if i != Interaction::None && !registry::allows_interaction(spec, i) {
                    return Err(fail(&event, no_human(spec, i.name())));
                }
                nuisance |= human.interaction == Interaction::Nuisance;
                Action::Human(*h)
            }
            Event::Human(h @ HumanChange::Zeta(z)) => {
                let changed = Params {
                    human: crate::params::HumanParams {
                        zeta: *z,
                        ..params.human
                    },
                    ..*params
                };
                changed
                    .validate_for_reward(start.max_abs_reward())
                    .map_err(|e| fail(&event, e.to_string()))?;
                Action::Human(*h)
            }
            Event::Human(human) => Action::Human(*human),
        };
        actions.push((change.step, action));
    }
    if worlds.len() > usize::from(u16::MAX) {
        return Err(fail(schedule, "too many world changes in one schedule"));
    }
    actions.sort_by_key(|&(step, _)| step);
    Ok(Plan {
        text: schedule.to_string(),
        first_change: schedule.first_step().unwrap_or(0),
        worlds,
        actions,
        nuisance,
    })
}

fn no_human(spec: &Spec, interaction: &str) -> String {
    format!(
        "interaction '{interaction}' is not defined for task '{}': {}",
        spec.name,
        registry::interactions_of(spec)
    )
}

/// `spec` without any outcome s -> t of the listed pairs (all actions of s); the remaining
/// counts are kept and a pair left without outcome becomes a self-loop (SPEC 10, 2.3).
pub fn delete(spec: &Spec, pairs: &[(StateId, StateId)]) -> Result<Spec, String> {
    let n_a = spec.n_actions;
    // The rebuilt world gets its arrivals from the goal: a task whose outcomes carry their own
    // rewards would lose them.
    let Some(goal) = spec.goal else {
        return Err(format!(
            "'{}' has no single goal to rebuild its world around",
            spec.name
        ));
    };
    for &(s, t) in pairs {
        if s as usize >= spec.n_states || t as usize >= spec.n_states {
            return Err(format!(
                "pair {s}-{t} names a state that does not exist: states are 0 to {}",
                spec.n_states - 1
            ));
        }
        let listed = (0..n_a).any(|a| {
            spec.outcomes(spec.sa(s as usize, a))
                .any(|o| spec.outcome_state[o] == t)
        });
        if !listed {
            return Err(format!(
                "the world has no transition {s} -> {t} (by any action) to delete"
            ));
        }
    }
    let mut outcomes = Vec::with_capacity(spec.n_states * n_a);
    for s in 0..spec.n_states {
        for a in 0..n_a {
            let sa = spec.sa(s, a);
            outcomes.push(
                spec.outcomes(sa)
                    .filter(|&o| !pairs.contains(&(s as StateId, spec.outcome_state[o])))
                    .map(|o| (spec.outcome_state[o], spec.outcome_weight[o]))
                    .collect(),
            );
        }
    }
    let names: Vec<String> = pairs.iter().map(|(a, b)| format!("{a}-{b}")).collect();
    Ok(Spec::from_outcomes(
        format!("{} without {}", spec.name, names.join(",")),
        spec.n_states,
        n_a,
        outcomes,
        spec.initial_states.clone(),
        goal,
        spec.state_names.clone(),
        spec.human.clone(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_parse_and_print_in_canonical_form() {
        let text = "1601:goal=34; 1601:world=json:a/b.json;1601:delete=20-21,21-20;5000:boxes=BRG;\
                    3000:interaction=none;2000:budget=50;10:forget=0.2;11:zeta=0.3;\
                    12:profile=stingy;13:reward-source=human;14:goal=3:2.5";
        let s = Schedule::parse(text).unwrap();
        assert_eq!(
            s.to_string(),
            "1601:goal=34;1601:world=json:a/b.json;1601:delete=20-21,21-20;5000:boxes=brg;\
             3000:interaction=none;2000:budget=50;10:forget=0.2;11:zeta=0.3;\
             12:profile=stingy;13:reward_source=human;14:goal=3:2.5"
        );
        assert_eq!(Schedule::parse(&s.to_string()).unwrap(), s);
        assert_eq!(s.first_step(), Some(10));
        assert!(Schedule::parse("").unwrap().is_empty());
    }

    #[test]
    fn parse_errors_name_the_event_and_what_is_accepted() {
        for (text, needle) in [
            ("goal=34", "expected STEP:KEY=VALUE"),
            ("x:goal=34", "not a whole number"),
            ("5:gaol=3", "did you mean 'goal'"),
            ("5:boxes=rrg", "permutation of 'rgb'"),
            ("5:delete=20", "ordered pair"),
            ("5:interaction=hug", "nuisance"),
            ("5:forget=2", "not in [0, 1]"),
            ("5:world=a.json", "json:PATH"),
        ] {
            let e = Change::parse(text).unwrap_err();
            assert_eq!(e.event, text);
            let message = e.to_string();
            assert!(
                message.contains(text) && message.contains(needle),
                "{message}"
            );
        }
    }

    #[test]
    fn compile_refuses_what_does_not_fit_the_task() {
        let tidy1 = Arc::new(env::load("tidy1").unwrap());
        let tidy2 = Arc::new(env::load("tidy2").unwrap());
        let p = Params::default();
        let err = |spec: &Arc<Spec>, text: &str| {
            compile(spec, &Schedule::parse(text).unwrap(), &p)
                .unwrap_err()
                .to_string()
        };
        assert!(err(&tidy1, "0:boxes=brg").contains("outside the experiment"));
        assert!(err(&tidy1, "10001:boxes=brg").contains("1 to 10000"));
        assert!(err(&tidy2, "5:boxes=brg").contains("tidy2 keeps"));
        assert!(err(&tidy1, "5:goal=3").contains("use boxes"));
        // Refusals without a task-specific reason name the tasks that accept the event.
        let message = err(&tidy1, "5:delete=0-1");
        assert!(
            message.contains(
                "deleting transitions is defined for grid:N or json:PATH, not for 'tidy1'"
            ),
            "{message}"
        );
        let mut boxed = p;
        boxed.boxes = Boxes::parse("brg").unwrap();
        let refused = compile(&tidy2, &Schedule::default(), &boxed).unwrap_err();
        assert_eq!(refused.event, "boxes=brg");
        assert!(
            refused
                .reason
                .contains("boxes is a parameter of tidy1, not of task 'tidy2'")
        );
        let plan = compile(&tidy1, &Schedule::parse("5000:boxes=brg").unwrap(), &p).unwrap();
        assert_eq!(plan.worlds.len(), 2);
        assert_eq!(plan.first_change, 5000);
        assert_ne!(plan.worlds[1].goal, tidy1.goal);
    }

    #[test]
    fn deletion_removes_the_pairs_keeps_the_other_counts_and_self_loops_what_is_left_empty() {
        // 0 -a0-> {1 (w 1), 2 (w 3)}; 0 -a1-> 1 only.
        let spec = Spec::from_outcomes(
            "toy".into(),
            3,
            2,
            vec![
                vec![(1, 1.0), (2, 3.0)],
                vec![(1, 1.0)],
                vec![(2, 1.0)],
                vec![(2, 1.0)],
                vec![(2, 1.0)],
                vec![(2, 1.0)],
            ],
            vec![0],
            crate::env::Goal {
                state: 2,
                reward: 1.0,
            },
            vec!["a".into(), "b".into(), "c".into()],
            None,
        );
        let cut = delete(&spec, &[(0, 1)]).unwrap();
        assert_eq!(
            cut.outcomes(0)
                .map(|o| cut.outcome_state[o])
                .collect::<Vec<_>>(),
            [2]
        );
        assert_eq!(cut.outcome_weight[cut.outcomes(0).start], 3.0);
        // (0, a1) had only 0 -> 1: now a self-loop.
        assert_eq!(
            cut.outcomes(1)
                .map(|o| cut.outcome_state[o])
                .collect::<Vec<_>>(),
            [0]
        );
        assert!(
            delete(&spec, &[(1, 0)])
                .unwrap_err()
                .contains("no transition 1 -> 0")
        );
    }
}
