//! A vector of independent copies of a task's world, stepped by an agent of the caller's own
//! (the EnvPool / gymnax shape): `reset` gives each copy's state, `step` takes one action per
//! copy and gives the next states, rewards, whether an episode ended or was cut, and what the
//! simulated human did. The world and the human are the engine's (`env`, `human`): the same
//! transitions, arrivals, drawn rewards, task dynamics (twostep's drift) and human kernels in
//! the order of SPEC 3.4, with the decision left to the caller. No learner is involved.
//!
//! Differences from a run of the engine, which a caller's agent makes its own: no babbling
//! (every step is an experiment step, the human acts from the first), no schedule of changes,
//! and auto-reset: a terminal arrival ends the episode and the returned state is already the
//! next episode's start (the engine's reset step of SPEC 2.1 is folded into the terminal step;
//! the state arrived in is `final_obs`). The human's budget is the copy's, over every episode
//! since `reset`, as a run's is over its episodes.

use std::sync::Arc;

use rand_xoshiro::Xoshiro256PlusPlus;

use crate::env::{End, HumanTables, Spec};
use crate::human::Encounter;
use crate::params::{ConfigError, HumanParams, Interaction, Params, RewardSource};
use crate::rng::{run_rng, uniform};
use crate::run_stats::RunStats;

/// Why a vector of environments cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum VecEnvError {
    /// A parameter out of range, or a human the task does not allow.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A task parameter the task refuses (`name=value`, why).
    #[error("invalid {0}: {1}")]
    Task(String, String),
    /// No copy.
    #[error("invalid num_envs = 0: expected a whole number >= 1")]
    NoEnvs,
}

impl crate::error::Usage for VecEnvError {
    fn is_usage(&self) -> bool {
        true
    }
}

/// Actions that cannot be taken; nothing was stepped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ActionError {
    /// One action per copy is needed.
    #[error("expected {expected} actions (one per environment), got {got}")]
    Count {
        /// The number of copies.
        expected: usize,
        /// Actions given.
        got: usize,
    },
    /// An action outside the task's actions.
    #[error("action {action} at index {index} is out of range: expected 0 to {last}")]
    OutOfRange {
        /// The copy whose action it is.
        index: usize,
        /// The action given.
        action: i64,
        /// The largest action.
        last: usize,
    },
}

impl crate::error::Usage for ActionError {
    fn is_usage(&self) -> bool {
        true
    }
}

/// One copy: its state, its human's budget and counters, its random stream.
#[derive(Debug, Clone)]
struct Copy {
    state: u32,
    budget_left: u32,
    stats: RunStats,
    /// Steps since `reset` (the human's experiment step, 1-based once stepped).
    t: u32,
    /// Steps since the episode began.
    episode_t: u32,
    rng: Xoshiro256PlusPlus,
}

/// What one `step` gave, one entry per copy (buffers reused from step to step).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Steps {
    /// The state now: after an episode ended, the next episode's start.
    pub obs: Vec<u32>,
    /// The reward of the step (SPEC 2.1: the arrival's, drawn where it is drawn; with the
    /// human as reward source, 0 unless the human gave it).
    pub reward: Vec<f64>,
    /// The step ended the episode by a terminal arrival.
    pub terminated: Vec<bool>,
    /// The episode reached `max_episode_steps` without a terminal arrival.
    pub truncated: Vec<bool>,
    /// The state arrived in, before any auto-reset (equal to `obs` when the episode goes on).
    pub final_obs: Vec<u32>,
    /// The action executed: the human's put on a takeover, else the agent's.
    pub action: Vec<u32>,
    /// The human took over (SPEC 5: the agent's action was not executed).
    pub takeover: Vec<bool>,
    /// The human congratulated the executed action (G = 1 of Eq. 8).
    pub congratulation: Vec<bool>,
    /// The human punished the executed action (G = 1 of Eq. 8, weighted -zeta).
    pub punishment: Vec<bool>,
    /// The human undid the action (SPEC 11.2): the state is where it left the cube.
    pub nuisance: Vec<bool>,
    /// The human gave the reward (reward source `human`, SPEC 11.1).
    pub human_reward: Vec<bool>,
    /// The human missed an opportunity by forgetting.
    pub forgotten: Vec<bool>,
    /// Interactions the human may still give.
    pub budget_left: Vec<u32>,
}

impl Steps {
    fn sized(n: usize) -> Steps {
        Steps {
            obs: vec![0; n],
            reward: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
            final_obs: vec![0; n],
            action: vec![0; n],
            takeover: vec![false; n],
            congratulation: vec![false; n],
            punishment: vec![false; n],
            nuisance: vec![false; n],
            human_reward: vec![false; n],
            forgotten: vec![false; n],
            budget_left: vec![0; n],
        }
    }
}

/// `num_envs` copies of one world with one human; see the module documentation.
#[derive(Debug, Clone)]
pub struct VecEnv {
    world: Arc<Spec>,
    human: HumanParams,
    reward_source: RewardSource,
    max_episode_steps: u32,
    seed: u64,
    copies: Vec<Copy>,
    /// The copies' task state ([`crate::env::Dynamics`]), `len` values each, one after the other.
    task_state: Vec<f64>,
    out: Steps,
}

impl VecEnv {
    /// `num_envs` copies of `spec`'s world as `params` configure it (task parameters, the
    /// human, the reward source; the learners' parameters are not read), checked as a run's
    /// are. Copy `i` draws from the stream of run `i` of master seed `seed`.
    /// `max_episode_steps` cuts an episode after that many steps (0: never). Call
    /// [`reset`](VecEnv::reset) before stepping.
    pub fn new(
        spec: Arc<Spec>,
        params: &Params,
        num_envs: usize,
        seed: u64,
        max_episode_steps: u32,
    ) -> Result<VecEnv, VecEnvError> {
        if num_envs == 0 {
            return Err(VecEnvError::NoEnvs);
        }
        crate::env::registry::check_params(&spec, params)?;
        let world = match crate::env::registry::configure(&spec, params) {
            Ok(Some(world)) => Arc::new(world),
            Ok(None) => spec,
            Err((name, why)) => return Err(VecEnvError::Task(name, why)),
        };
        let len = world.dynamics.as_ref().map_or(0, |d| d.len);
        let copy = Copy {
            state: 0,
            budget_left: 0,
            stats: RunStats::default(),
            t: 0,
            episode_t: 0,
            rng: run_rng(seed, 0),
        };
        let mut env = VecEnv {
            world,
            human: params.human,
            reward_source: params.reward_source,
            max_episode_steps,
            seed,
            copies: vec![copy; num_envs],
            task_state: vec![0.0; num_envs * len],
            out: Steps::sized(num_envs),
        };
        env.reset(Some(seed));
        Ok(env)
    }

    /// The number of copies.
    pub fn len(&self) -> usize {
        self.copies.len()
    }

    /// Never: a vector holds one copy at least.
    pub fn is_empty(&self) -> bool {
        self.copies.is_empty()
    }

    /// The world the copies are in.
    pub fn world(&self) -> &Spec {
        &self.world
    }

    /// Values of task state per copy (twostep: its four reward probabilities).
    pub fn task_state_len(&self) -> usize {
        self.world.dynamics.as_ref().map_or(0, |d| d.len)
    }

    /// The copies' task state, [`task_state_len`](VecEnv::task_state_len) values each.
    pub fn task_state(&self) -> &[f64] {
        &self.task_state
    }

    /// Starts every copy afresh: a drawn initial state, the human's whole budget, zero counters,
    /// and the task state's start. With `seed`, copy `i` restarts the stream of run `i` of
    /// that master seed (the same seed gives the same episodes for the same actions); without,
    /// the streams go on. Returns the states.
    pub fn reset(&mut self, seed: Option<u64>) -> &[u32] {
        if let Some(seed) = seed {
            self.seed = seed;
        }
        let len = self.task_state_len();
        for (i, copy) in self.copies.iter_mut().enumerate() {
            if seed.is_some() {
                copy.rng = run_rng(self.seed, i as u64);
            }
            copy.budget_left = self.human.budget;
            copy.stats = RunStats::default();
            copy.t = 0;
            copy.episode_t = 0;
            copy.state = crate::batch::initial_state(&self.world, &mut copy.rng);
            if let Some(d) = &self.world.dynamics {
                (d.start)(
                    d,
                    &mut self.task_state[i * len..(i + 1) * len],
                    &mut copy.rng,
                );
            }
            self.out.obs[i] = copy.state;
            self.out.budget_left[i] = copy.budget_left;
        }
        &self.out.obs
    }

    /// One step of every copy with its action (`actions[i]` for copy `i`), in SPEC 3.4's order:
    /// the human's takeover, the outcome and its drawn reward, the nuisance, the reward a human
    /// gives, the congratulation or punishment, the task's dynamics after a terminal arrival;
    /// then the auto-reset of an ended episode. Every action is checked before any copy moves.
    pub fn step(&mut self, actions: &[i64]) -> Result<&Steps, ActionError> {
        if actions.len() != self.copies.len() {
            return Err(ActionError::Count {
                expected: self.copies.len(),
                got: actions.len(),
            });
        }
        let n_actions = self.world.n_actions;
        if let Some((index, &action)) = actions
            .iter()
            .enumerate()
            .find(|&(_, &a)| a < 0 || a as u64 >= n_actions as u64)
        {
            return Err(ActionError::OutOfRange {
                index,
                action,
                last: n_actions - 1,
            });
        }
        let len = self.task_state_len();
        for (i, (copy, &action)) in self.copies.iter_mut().zip(actions).enumerate() {
            let task_state = &mut self.task_state[i * len..(i + 1) * len];
            step_one(
                &self.world,
                &self.human,
                self.reward_source,
                self.max_episode_steps,
                copy,
                task_state,
                action as usize,
                &mut self.out,
                i,
            );
        }
        Ok(&self.out)
    }
}

/// One step of one copy; writes entry `i` of `out`.
#[allow(clippy::too_many_arguments)]
fn step_one(
    world: &Spec,
    human: &HumanParams,
    reward_source: RewardSource,
    max_episode_steps: u32,
    copy: &mut Copy,
    task_state: &mut [f64],
    agent_action: usize,
    out: &mut Steps,
    i: usize,
) {
    copy.t = copy.t.saturating_add(1);
    copy.episode_t = copy.episode_t.saturating_add(1);
    let forgotten = copy.stats.forgotten;
    let (takeovers, congratulations, punishments, nuisances, rewards) = (
        copy.stats.takeovers,
        copy.stats.congratulations,
        copy.stats.punishments,
        copy.stats.nuisances,
        copy.stats.rewards_given,
    );
    let tables: Option<&HumanTables> = world.human.as_ref();
    let s = copy.state as usize;
    let active = human.interaction != Interaction::None && copy.budget_left > 0;
    macro_rules! encounter {
        () => {
            Encounter {
                human,
                tables,
                budget_left: &mut copy.budget_left,
                stats: &mut copy.stats,
                t_exp: copy.t,
                rng: &mut copy.rng,
                put: &mut { crate::human::NO_PUT },
            }
        };
    }
    let put = if active {
        encounter!().takeover(s)
    } else {
        None
    };
    let a = put.unwrap_or(agent_action);
    let sa = world.sa(s, a);
    let outcomes = world.outcomes(sa);
    let o = if outcomes.len() == 1 {
        outcomes.start
    } else {
        world.pick_outcome(sa, uniform(&mut copy.rng))
    };
    let landing = world.landing[o];
    let mut next = landing.state as usize;
    let (mut terminal, mut end, mut reward) = (false, End::Continue, 0.0);
    if landing.eventful {
        let arrival = world.arrival[o];
        terminal = arrival.terminal();
        end = arrival.end;
        reward = arrival.reward;
        if let Some(p) = arrival.chance.p(task_state)
            && uniform(&mut copy.rng) >= p
        {
            reward = 0.0;
        }
    }
    if active && let Some(undone) = encounter!().nuisance(sa) {
        next = undone;
        (terminal, end) = (false, End::Continue);
    }
    if !terminal {
        reward = 0.0;
    }
    if terminal && reward_source == RewardSource::Human {
        reward = encounter!().reward(reward);
    }
    if active {
        encounter!().feedback(sa);
    }
    if terminal && let Some(d) = &world.dynamics {
        (d.after_episode)(d, task_state, &mut copy.rng);
    }
    let truncated = !terminal && max_episode_steps > 0 && copy.episode_t >= max_episode_steps;
    out.final_obs[i] = next as u32;
    copy.state = next as u32;
    if terminal || truncated {
        copy.episode_t = 0;
        // A terminal arrival that restarts is already the next start; any other end draws it.
        if end != End::Restart {
            copy.state = crate::batch::initial_state(world, &mut copy.rng);
        }
    }
    let stats = &copy.stats;
    out.obs[i] = copy.state;
    out.reward[i] = reward;
    out.terminated[i] = terminal;
    out.truncated[i] = truncated;
    out.action[i] = a as u32;
    out.takeover[i] = stats.takeovers > takeovers;
    out.congratulation[i] = stats.congratulations > congratulations;
    out.punishment[i] = stats.punishments > punishments;
    out.nuisance[i] = stats.nuisances > nuisances;
    out.human_reward[i] = stats.rewards_given > rewards;
    out.forgotten[i] = stats.forgotten > forgotten;
    out.budget_left[i] = copy.budget_left;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Interaction;

    fn env(task: &str, set: impl FnOnce(&mut Params), n: usize, seed: u64) -> VecEnv {
        let spec = Arc::new(crate::env::load(task).unwrap());
        let mut params = Params::default();
        set(&mut params);
        VecEnv::new(spec, &params, n, seed, 0).unwrap()
    }

    /// Runs `steps` steps of constant actions `a`, collecting every `Steps`.
    fn roll(env: &mut VecEnv, a: i64, steps: usize) -> Vec<Steps> {
        let actions = vec![a; env.len()];
        (0..steps)
            .map(|_| env.step(&actions).unwrap().clone())
            .collect()
    }

    #[test]
    fn the_chain_reaches_its_goal_and_starts_again() {
        let mut e = env("chain", |_| {}, 2, 1);
        assert_eq!(e.reset(None), [0, 0]);
        let s = e.step(&[1, 0]).unwrap();
        assert_eq!(s.final_obs, [1, 0]);
        // Copy 0 reached the goal: reward 1, terminated, and back at the start already.
        assert_eq!(s.obs, [0, 0]);
        assert_eq!(s.reward, [1.0, 0.0]);
        assert_eq!(s.terminated, [true, false]);
        assert_eq!(s.truncated, [false, false]);
        assert_eq!(s.action, [1, 0]);
    }

    #[test]
    fn episodes_are_cut_at_max_episode_steps() {
        let spec = Arc::new(crate::env::load("chain").unwrap());
        let mut e = VecEnv::new(spec, &Params::default(), 1, 1, 3).unwrap();
        let steps = roll(&mut e, 0, 6);
        let cut: Vec<bool> = steps.iter().map(|s| s.truncated[0]).collect();
        assert_eq!(cut, [false, false, true, false, false, true]);
        assert!(steps.iter().all(|s| !s.terminated[0]));
    }

    #[test]
    fn bad_actions_are_refused_naming_the_index_and_nothing_moves() {
        let mut e = env("chain", |_| {}, 3, 1);
        let before = e.clone().step(&[1, 1, 1]).unwrap().clone();
        assert_eq!(
            e.step(&[0, 2, -1]).unwrap_err(),
            ActionError::OutOfRange {
                index: 1,
                action: 2,
                last: 1
            }
        );
        assert_eq!(
            e.step(&[0]).unwrap_err(),
            ActionError::Count {
                expected: 3,
                got: 1
            }
        );
        assert!(
            e.step(&[0, 1, -1])
                .unwrap_err()
                .to_string()
                .contains("index 2")
        );
        assert_eq!(e.step(&[1, 1, 1]).unwrap(), &before);
    }

    #[test]
    fn the_human_takes_over_until_the_budget_is_spent() {
        let mut e = env(
            "tidy1",
            |p| {
                p.human.interaction = Interaction::Takeover;
                p.human.budget = 3;
                p.human.forget_prob = 0.0;
            },
            1,
            7,
        );
        let tables = e.world().human.clone().unwrap();
        let steps = roll(&mut e, 0, 200);
        let taken: Vec<usize> = (0..steps.len()).filter(|&t| steps[t].takeover[0]).collect();
        assert_eq!(taken.len(), 3, "an attentive human spends the whole budget");
        let mut state = e.clone().reset(Some(7))[0];
        for (t, s) in steps.iter().enumerate() {
            if s.takeover[0] {
                // The human's put in that state was executed instead of the agent's 0.
                assert_eq!(
                    s.action[0],
                    u32::from(tables.takeover_action[state as usize])
                );
            } else {
                assert_eq!(s.action[0], 0, "step {t}");
            }
            state = s.obs[0];
        }
        assert_eq!(steps[taken[2]].budget_left[0], 0);
        assert_eq!(steps.last().unwrap().budget_left[0], 0);
    }

    #[test]
    fn an_inattentive_human_forgets_and_spends_nothing() {
        let mut e = env(
            "tidy1",
            |p| {
                p.human.interaction = Interaction::Takeover;
                p.human.budget = 5;
                p.human.forget_prob = 1.0;
            },
            1,
            3,
        );
        let steps = roll(&mut e, 0, 50);
        assert!(
            steps
                .iter()
                .all(|s| !s.takeover[0] && s.budget_left[0] == 5)
        );
        assert!(steps.iter().any(|s| s.forgotten[0]));
    }

    #[test]
    fn the_same_seed_gives_the_same_episodes_and_copies_differ() {
        let make = || {
            env(
                "tidy1",
                |p| {
                    p.human.interaction = Interaction::Congratulation;
                    p.human.budget = 50;
                    p.human.forget_prob = 0.5;
                },
                4,
                11,
            )
        };
        let (mut a, mut b) = (make(), make());
        let actions: Vec<Vec<i64>> = (0..300).map(|t| vec![t % 7, (t * 3) % 7, 2, 5]).collect();
        let run = |e: &mut VecEnv| -> Vec<Steps> {
            actions.iter().map(|x| e.step(x).unwrap().clone()).collect()
        };
        let first = run(&mut a);
        assert_eq!(first, run(&mut b));
        // Reseeding replays it.
        a.reset(Some(11));
        assert_eq!(first, run(&mut a));
        // Another seed draws other episodes.
        a.reset(Some(12));
        assert_ne!(first, run(&mut a));
    }

    #[test]
    fn twostep_trials_restart_and_the_reward_probabilities_drift() {
        let mut e = env("twostep", |_| {}, 2, 5);
        assert_eq!(e.task_state_len(), 4);
        let start = e.task_state().to_vec();
        assert!(start.iter().all(|p| (0.25..=0.75).contains(p)));
        let steps = roll(&mut e, 0, 2);
        // First stage, then a second-stage choice that ends the trial back in state 0.
        assert!(steps[0].obs.iter().all(|&s| s == 1 || s == 2));
        assert_eq!(steps[1].terminated, [true, true]);
        assert_eq!(steps[1].obs, [0, 0]);
        assert_eq!(steps[1].final_obs, [0, 0]);
        assert_ne!(e.task_state(), start, "the drift moved after the trials");
    }

    #[test]
    fn a_human_the_task_refuses_is_an_error() {
        let spec = Arc::new(crate::env::load("chain").unwrap());
        let mut params = Params::default();
        params.human.interaction = Interaction::Takeover;
        params.human.budget = 5;
        let e = VecEnv::new(spec, &params, 1, 1, 0).unwrap_err();
        assert!(e.to_string().contains("chain"), "{e}");
        let spec = Arc::new(crate::env::load("chain").unwrap());
        assert!(matches!(
            VecEnv::new(spec, &Params::default(), 0, 1, 0),
            Err(VecEnvError::NoEnvs)
        ));
    }
}
