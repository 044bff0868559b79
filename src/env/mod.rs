//! Environments: every task is compiled once into a read-only [`Spec`] of flat tables that all
//! runs of a batch share (SPEC section 2).
//!
//! The transition model is stored in CSR form: the outcomes of the state-action pair
//! `sa = s * n_actions + a` are `outcome_start[sa]..outcome_start[sa + 1]`, sorted by next state.
//! The MB expert's learned model reuses this indexing (it can only ever observe outcomes the
//! environment can produce), which keeps its memory proportional to the real branching factor.

pub mod registry;

/// Declares the task modules and lists their [`registry::Task`]s, in the order help texts
/// show them: `module => CONST, ...;`.
macro_rules! tasks {
    ($($module:ident => $($task:ident),+;)*) => {
        $(pub mod $module;)*

        /// Every registered task (see [`registry`]).
        pub const TASKS: &[registry::Task] = &[$($($module::$task),+),*];
    };
}

// The task registry: a new task is its file and one line here.
tasks! {
    tidy => TIDY1, TIDY2;
    grid => GRID;
    json => JSON;
    chain => CHAIN;
    twostep => TWOSTEP;
}

use std::path::PathBuf;

/// Index of a state in a [`Spec`] (the environment's own ids).
pub type StateId = u32;

/// Marker in [`HumanTables::takeover_action`] for states where the human has nothing to put.
pub const NO_TAKEOVER: u8 = u8::MAX;

/// Marker in [`HumanTables::nuisance`] for pairs a nuisance human leaves alone.
pub const NO_NUISANCE: StateId = StateId::MAX;

/// What the simulated human needs to know about a task (SPEC 5). Only the tidy tasks define it.
#[derive(Debug, Clone, PartialEq)]
pub struct HumanTables {
    /// Per `sa`: the action is the one the human congratulates (task 1: a cube into its own box;
    /// task 2: a put that lights an LED).
    pub relevant: Vec<bool>,
    /// Per `sa`: the action is an error, the target of punishment.
    pub error: Vec<bool>,
    /// Per state: the human's put when the robot holds a cube, or [`NO_TAKEOVER`].
    pub takeover_action: Vec<u8>,
    /// Per `sa`: the state a nuisance human leaves after the relevant action `sa` (the cube
    /// taken back out onto the table, SPEC 11.2), or [`NO_NUISANCE`].
    pub nuisance: Vec<StateId>,
}

/// The rewarded, terminal state of a goal task and its reward (SPEC 2: every arrival in it is
/// rewarded and followed by the reset step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// The state.
    pub state: StateId,
    /// The reward of an arrival in it.
    pub reward: f64,
}

/// How an arrival's reward is had.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Chance {
    /// Always: no random draw.
    Always,
    /// With probability `p`: one uniform draw at every arrival (babbling included, where the
    /// reward is then withheld), the reward given when the draw is below `p`.
    Drawn(f64),
    /// As [`Drawn`](Chance::Drawn), with `p` read from slot `slot` of the run's task state
    /// ([`Dynamics`]): SPEC 13's drifting Bernoulli rewards.
    DrawnFrom(usize),
}

impl Chance {
    /// The probability of the reward when it is drawn (`None`: always had, no draw), reading
    /// a [`DrawnFrom`](Chance::DrawnFrom) slot of the run's task state `state`.
    #[inline(always)]
    pub fn p(self, state: &[f64]) -> Option<f64> {
        match self {
            Chance::Always => None,
            Chance::Drawn(p) => Some(p),
            Chance::DrawnFrom(slot) => Some(state[slot]),
        }
    }
}

/// A task hook on a run's task state: the dynamics, the run's state (`len` values) and the
/// run's own random stream (a hook's draws are the run's, in the order it makes them).
pub type Hook = fn(&Dynamics, &mut [f64], &mut rand_xoshiro::Xoshiro256PlusPlus);

/// Per-run task state, declared with the task: `len` values per run (a flat array of the batch,
/// zero-length for a task without dynamics), written by `start` when the run starts and again
/// when the experiment starts after babbling, and changed by `after_episode` after every
/// terminal arrival (babbling included), after every other draw of that step. Arrivals read it
/// through [`Chance::DrawnFrom`].
#[derive(Debug, Clone)]
pub struct Dynamics {
    /// Values per run.
    pub len: usize,
    /// The task's constants the hooks read (e.g. twostep's `drift_sd`).
    pub constants: Vec<f64>,
    /// Writes a run's initial state.
    pub start: Hook,
    /// Changes a run's state after a terminal arrival.
    pub after_episode: Hook,
}

impl PartialEq for Dynamics {
    fn eq(&self, other: &Dynamics) -> bool {
        self.len == other.len
            && self.constants == other.constants
            && std::ptr::fn_addr_eq(self.start, other.start)
            && std::ptr::fn_addr_eq(self.after_episode, other.after_episode)
    }
}

/// A task's tally of the experiment, what its metric columns are computed from
/// ([`registry::Metric`], e.g. twostep's stay probabilities, SPEC 13): `len` values per run
/// (a flat array of the batch, zero-length for a task without), zero when the run starts and
/// again when the experiment starts after babbling, and updated by `note` at every step the
/// robot acts (after the outcome and its reward draw, before the human's draws), with the
/// state, the action, the next state and the environment's reward of the arrival. It draws
/// nothing. A task with a tally has every outcome eventful ([`Landing`]), so that the step of a
/// task without one never tests for it.
#[derive(Debug, Clone)]
pub struct Tally {
    /// Values per run.
    pub len: usize,
    /// Counts one step: `(tally, s, a, next, reward)`.
    pub note: fn(&mut [f64], usize, usize, usize, f64),
}

impl PartialEq for Tally {
    fn eq(&self, other: &Tally) -> bool {
        self.len == other.len && std::ptr::fn_addr_eq(self.note, other.note)
    }
}

/// What an arrival does to the episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// It goes on.
    Continue,
    /// The arrival is terminal and the next step is the reset step (SPEC 2.1).
    Reset,
    /// The arrival is terminal and already the start of the next episode: no reset step
    /// (SPEC 13).
    Restart,
}

/// What arriving by one outcome brings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arrival {
    /// The reward (when drawn, the reward of a success; a failure gives 0).
    pub reward: f64,
    /// How the reward is had.
    pub chance: Chance,
    /// Whether and how the arrival ends the episode.
    pub end: End,
}

impl Arrival {
    /// No reward, the episode goes on.
    pub const NOTHING: Arrival = Arrival {
        reward: 0.0,
        chance: Chance::Always,
        end: End::Continue,
    };

    /// Whether the arrival is terminal: no future term for MF, and MB remembers it (SPEC 10).
    #[inline(always)]
    pub fn terminal(self) -> bool {
        self.end != End::Continue
    }
}

/// What the step reads of every outcome it draws, in one entry (one bounds check per step): the
/// next state ([`Spec::outcome_state`]) and whether the arrival is something other than
/// [`Arrival::NOTHING`]. Most outcomes bring nothing: only where `eventful` is set is the
/// arrival read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Landing {
    /// The next state.
    pub state: StateId,
    /// The arrival brings a reward or ends the episode.
    pub eventful: bool,
}

/// The landing of each outcome, from its next state and its arrival (every one eventful when
/// the task `tallies` its steps).
fn landings(outcome_state: &[StateId], arrivals: &[Arrival], tallies: bool) -> Vec<Landing> {
    outcome_state
        .iter()
        .zip(arrivals)
        .map(|(&state, &a)| Landing {
            state,
            eventful: tallies || a != Arrival::NOTHING,
        })
        .collect()
}

/// A compiled, validated, read-only tabular environment.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// The name the user gave (a task of the [`registry`], e.g. `tidy1` or `json:PATH`).
    pub name: String,
    /// Number of states |S|.
    pub n_states: usize,
    /// Number of actions |A|.
    pub n_actions: usize,
    /// CSR offsets, length `n_states * n_actions + 1`.
    pub outcome_start: Vec<u32>,
    /// Next state of each outcome, ascending within a state-action pair.
    pub outcome_state: Vec<StateId>,
    /// Relative weight (the authors' counts) of each outcome.
    pub outcome_weight: Vec<f64>,
    /// Cumulative probability of each outcome within its pair; the last one of a pair is 1.
    pub outcome_cum: Vec<f64>,
    /// States a run starts in and resets to (drawn uniformly when there are several).
    pub initial_states: Vec<StateId>,
    /// What arriving by each outcome brings: its reward model and whether it ends the episode.
    /// The step reads only this, never [`goal`](Spec::goal).
    pub arrival: Vec<Arrival>,
    /// Per outcome: its next state and whether its arrival brings anything, together (see
    /// [`Landing`]); set with the arrivals by [`with_arrivals`](Spec::with_arrivals).
    pub landing: Vec<Landing>,
    /// The largest reward magnitude any arrival can bring, kept with the arrivals so that a
    /// rule reading it at every step (`reliability`'s R_max, SPEC 12.3) does not scan them.
    max_abs_reward: f64,
    /// The goal of a task with one rewarded, terminal state (tidy, `grid:`, `json:`), from which
    /// [`arrival`](Spec::arrival) was built; `None` for a task whose outcomes say it themselves.
    pub goal: Option<Goal>,
    /// A readable name per state id.
    pub state_names: Vec<String>,
    /// Human-interaction tables; `None` where the task does not define them (`json:` worlds).
    pub human: Option<HumanTables>,
    /// Per-run task state and its hooks; `None` for a task without (no array, no draw).
    pub dynamics: Option<Dynamics>,
    /// The task's tally of the experiment; `None` for a task without (no array, no call).
    pub tally: Option<Tally>,
    /// The world's files that schedule changes during a run, with those lines (the authors'
    /// `keyStates.txt` `new_goal` and `del_trans`), which a run applies only from its own
    /// schedule (`--change`): `mbmf run` names them in a warning when it has none.
    pub unapplied: Vec<String>,
}

impl Spec {
    /// Index of the state-action pair `(s, a)` in per-pair tables.
    #[inline(always)]
    pub fn sa(&self, s: usize, a: usize) -> usize {
        s * self.n_actions + a
    }

    /// Whether some action leads to another state. A world whose model lists no transition at
    /// all is only self-loops (added for every pair without one): the robot can never move.
    pub fn can_move(&self) -> bool {
        (0..self.n_states).any(|s| {
            (0..self.n_actions).any(|a| {
                self.outcomes(self.sa(s, a))
                    .any(|o| self.outcome_state[o] as usize != s)
            })
        })
    }

    /// Range of outcome indices of the pair `sa`.
    #[inline(always)]
    pub fn outcomes(&self, sa: usize) -> std::ops::Range<usize> {
        self.outcome_start[sa] as usize..self.outcome_start[sa + 1] as usize
    }

    /// The largest number of outcomes of any state-action pair.
    pub fn max_branching(&self) -> usize {
        self.outcome_start
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .max()
            .unwrap_or(0)
    }

    /// Picks the outcome of `sa` for a uniform draw `u` in [0, 1): returns the global outcome index.
    #[inline(always)]
    pub fn pick_outcome(&self, sa: usize, u: f64) -> usize {
        let range = self.outcomes(sa);
        let last = range.end - 1;
        for o in range {
            if u < self.outcome_cum[o] {
                return o;
            }
        }
        last
    }

    /// The goal's state, for a goal task.
    pub fn goal_state(&self) -> Option<StateId> {
        self.goal.map(|g| g.state)
    }

    /// The largest reward magnitude any arrival can bring (what value bounds are computed from).
    pub fn max_abs_reward(&self) -> f64 {
        self.max_abs_reward
    }

    /// This world with its goal moved to `goal` (SPEC 10): every arrival in `goal.state` is
    /// rewarded with `goal.reward` and followed by the reset step, every other one is nothing.
    pub fn with_goal(self, goal: Goal) -> Spec {
        let arrivals = goal_arrivals(&self.outcome_state, goal);
        let mut spec = self.with_arrivals(arrivals);
        spec.goal = Some(goal);
        spec
    }

    /// This world with the tally `tally` (every outcome eventful, so that the step counts it).
    pub fn with_tally(mut self, tally: Tally) -> Spec {
        self.tally = Some(tally);
        self.landing = landings(&self.outcome_state, &self.arrival, true);
        self
    }

    /// This world with the arrivals `arrivals` (one per outcome) and no single goal: what a task
    /// whose outcomes carry their own rewards builds.
    pub fn with_arrivals(mut self, arrivals: Vec<Arrival>) -> Spec {
        assert_eq!(
            arrivals.len(),
            self.outcome_state.len(),
            "one arrival per outcome"
        );
        self.landing = landings(&self.outcome_state, &arrivals, self.tally.is_some());
        self.max_abs_reward = largest_reward(&arrivals);
        self.arrival = arrivals;
        self.goal = None;
        self
    }

    /// Builds a spec of a goal task from per-pair outcome lists `(next_state, weight)`, filling
    /// the CSR arrays and cumulative probabilities. Pairs with no outcome become self-loops
    /// (SPEC 2.3). A task whose outcomes are not goal arrivals sets [`arrival`](Spec::arrival)
    /// (and clears [`goal`](Spec::goal)) afterwards.
    pub fn from_outcomes(
        name: String,
        n_states: usize,
        n_actions: usize,
        mut outcomes: Vec<Vec<(StateId, f64)>>,
        initial_states: Vec<StateId>,
        goal: Goal,
        state_names: Vec<String>,
        human: Option<HumanTables>,
    ) -> Spec {
        assert_eq!(outcomes.len(), n_states * n_actions);
        let mut outcome_start = Vec::with_capacity(outcomes.len() + 1);
        let mut outcome_state = Vec::new();
        let mut outcome_weight = Vec::new();
        let mut outcome_cum = Vec::new();
        outcome_start.push(0u32);
        for (sa, list) in outcomes.iter_mut().enumerate() {
            if list.is_empty() {
                list.push(((sa / n_actions) as StateId, 1.0));
            }
            list.sort_by_key(|&(s, _)| s);
            // Repeated next states have their counts added (SPEC 2.3).
            let mut merged: Vec<(StateId, f64)> = Vec::with_capacity(list.len());
            for &(s, w) in list.iter() {
                match merged.last_mut() {
                    Some(last) if last.0 == s => last.1 += w,
                    _ => merged.push((s, w)),
                }
            }
            let total: f64 = merged.iter().map(|&(_, w)| w).sum();
            let mut cum = 0.0;
            let n = merged.len();
            for (i, &(s, w)) in merged.iter().enumerate() {
                cum += w / total;
                outcome_state.push(s);
                outcome_weight.push(w);
                outcome_cum.push(if i + 1 == n { 1.0 } else { cum });
            }
            outcome_start.push(outcome_state.len() as u32);
        }
        let arrival = goal_arrivals(&outcome_state, goal);
        let landing = landings(&outcome_state, &arrival, false);
        let max_abs_reward = largest_reward(&arrival);
        Spec {
            name,
            n_states,
            n_actions,
            outcome_start,
            outcome_state,
            outcome_weight,
            outcome_cum,
            initial_states,
            arrival,
            landing,
            max_abs_reward,
            goal: Some(goal),
            state_names,
            human,
            dynamics: None,
            tally: None,
            unapplied: Vec::new(),
        }
    }
}

/// The largest reward magnitude of `arrivals`.
fn largest_reward(arrivals: &[Arrival]) -> f64 {
    arrivals.iter().map(|a| a.reward.abs()).fold(0.0, f64::max)
}

/// The arrivals of a goal task: the goal's reward and the reset step for every outcome arriving
/// in it, nothing for the others.
fn goal_arrivals(outcome_state: &[StateId], goal: Goal) -> Vec<Arrival> {
    outcome_state
        .iter()
        .map(|&next| {
            if next == goal.state {
                Arrival {
                    reward: goal.reward,
                    chance: Chance::Always,
                    end: End::Reset,
                }
            } else {
                Arrival::NOTHING
            }
        })
        .collect()
}

/// Where a `json:` environment's three files are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JsonPaths {
    /// The transition model (`realisticNavWorld.json`).
    pub model: PathBuf,
    /// Initial and goal states (`keyStates.txt`), by default beside the model.
    pub key_states: PathBuf,
    /// State and action counts (`spaces.txt`), by default beside the model.
    pub spaces: PathBuf,
}

impl JsonPaths {
    /// The model file with `keyStates.txt` and `spaces.txt` taken from the same folder.
    pub fn beside(model: impl Into<PathBuf>) -> JsonPaths {
        let model = model.into();
        let dir = model.parent().map(PathBuf::from).unwrap_or_default();
        JsonPaths {
            key_states: dir.join("keyStates.txt"),
            spaces: dir.join("spaces.txt"),
            model,
        }
    }
}

/// Failure to build an environment.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The task name is none of the known ones.
    #[error(
        "unknown task '{0}': {hint}expected {names}",
        hint = task_hint(.0),
        names = registry::names()
    )]
    UnknownTask(String),
    /// A `grid:N` task whose N is not an accepted number of states.
    #[error("invalid task '{task}': {error}")]
    Grid {
        /// The task as given.
        task: String,
        /// What is wrong with N.
        error: grid::GridError,
    },
    /// A `json:` environment's files are malformed.
    #[error(transparent)]
    File(#[from] crate::env::json::EnvFileError),
}

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
        None => crate::suggest::closest(&lower, registry::plain_names()).map(str::to_string),
    };
    guess.map_or_else(String::new, |g| format!("did you mean '{g}'? "))
}

/// Builds the environment named by `task`, a task of the [`registry`].
pub fn load(task: &str) -> Result<Spec, EnvError> {
    match registry::find(task) {
        Some(t) => (t.build)(task),
        None => Err(EnvError::UnknownTask(task.to_string())),
    }
}

#[cfg(test)]
mod error_tests {
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
        assert!(message.contains(&format!("expected {}", registry::names())));
    }
}
