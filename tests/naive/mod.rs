//! A deliberately naive reference implementation of SPEC sections 2–7: one run at a time, nested
//! `Vec`s, a `VecDeque` window per state-action pair and a `HashMap` reward memory, with every
//! formula written in the SPEC's literal arithmetic order. It is written from the SPEC, not from
//! `src/`, and is meant to be obviously correct rather than fast.
//!
//! It shares with the engine only what is a contract rather than a computation: the environment
//! tables ([`Spec`]), the parameters ([`Params`]), the result records ([`RunStats`],
//! [`Checkpoint`]) and the random stream: [`run_rng`], [`uniform`], [`Spec::pick_outcome`] and the
//! draw order documented at the top of `src/batch/step.rs`:
//!
//! 1. the human's attentiveness at a takeover opportunity,
//! 2. the MC's draw (`rnd`, softmax selection, or an argmax tie),
//! 3. the action,
//! 4. the environment's outcome (pairs with several outcomes only),
//! 5. the human's attentiveness at a nuisance opportunity (SPEC 11.2),
//! 6. the human's attentiveness at a human-reward opportunity (SPEC 11.1),
//! 7. the human's attentiveness at a congratulation or punishment opportunity, then (with
//!    `error_prob` above 0, when every action is one) the human's judgment (SPEC 15);
//!
//! plus one draw for an initial state (at creation, at a reset step and at the end of babbling)
//! when the environment has several. So a run simulated here can be compared bit for bit with the
//! same run in a [`mbmf::batch::Batch`].
//!
//! Three formulas can be evaluated in another floating-point order than the SPEC writes them,
//! with the same mathematical value but different last bits; [`Arithmetic`] selects which order.
//! [`NaiveRun::new`] follows the SPEC literally.
//!
//! The two-step task (SPEC 13) is simulated from its own rules here, not from the engine's
//! arrivals: its four reward probabilities (drawn after the initial state, drawn again when the
//! experiment starts, a reward draw after a second-stage outcome, four normals of drift after
//! it), its terminal second stage without reset step, and its stay probabilities from the list
//! of the experiment's trials.
//!
//! Schedules of changes (SPEC 10) are read from their parsed events ([`Schedule`]) and applied
//! here directly to the run's own copy of the environment, goal and human.
//!
//! Included by tests and benches with `#[path = "../tests/naive/mod.rs"] mod naive;` (from
//! `benches/`) or `mod naive;` (from `tests/`).
#![allow(dead_code)]

use std::collections::{BTreeMap, HashMap, VecDeque};

use mbmf::batch::{Checkpoint, RunStats, run_rng, uniform};
use mbmf::env::tidy::{self, Variant};
use mbmf::env::{NO_NUISANCE, NO_TAKEOVER, Spec};
use mbmf::params::{
    Combine, CongratulationEffect, Controller, CostModel, HumanParams, Interaction, Params,
    RewardSource, Selection,
};
use mbmf::schedule::{Change, Event, HumanChange, Schedule};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Divisor of the EC costs when both are 0 (SPEC 4: "a tiny constant"; the costs divided are
/// then 0, so its value does not matter).
const TINY: f64 = 1e-12;

/// Floating-point evaluation order of the three formulas where the engine's order differs from
/// the SPEC's literal one. Both give the same mathematical value; only the last bits differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arithmetic {
    /// The SPEC's formulas as written: softmax divides by tau and by the sum; P(MB) =
    /// 1 / (1 + exp((v_mf - v_mb) / tau)); EC value -(H + kappa * (C / max C)).
    Spec,
    /// The engine's order (src/expert/mod.rs, src/meta.rs at the time of writing): softmax
    /// multiplies by 1 / tau and by 1 / sum; P(MB) = e / (1 + e) with e = exp(-z) when
    /// z = (v_mf - v_mb) / tau > 0; EC value -(H + (kappa * C) / max C).
    Engine,
}

/// One run of SPEC 3.4 / 7, simulated naively.
pub struct NaiveRun {
    spec: Spec,
    params: Params,
    arithmetic: Arithmetic,
    rng: Xoshiro256PlusPlus,
    /// Current environment state.
    state: usize,
    /// The last arrival was terminal: the next step is the reset step.
    arrived_at_goal: bool,
    /// Steps taken, babbling included.
    t: u64,
    /// Interactions the human may still give.
    budget_left: u32,
    /// The rewarded state now.
    goal: usize,
    /// Its reward now.
    goal_reward: f64,
    /// The human now.
    human: HumanParams,
    /// Who brings the goal's reward now.
    reward_source: RewardSource,
    /// The schedule's changes, by step (stable), and how many were applied.
    changes: Vec<Change>,
    applied: usize,
    /// MF action values `q_mf[s][a]`.
    q_mf: Vec<Vec<f64>>,
    /// MB action values `q_mb[s][a]`.
    q_mb: Vec<Vec<f64>>,
    /// Moving average of the MF's action probabilities per state.
    avg_p_mf: Vec<Vec<f64>>,
    /// Moving average of the MB's action probabilities per state.
    avg_p_mb: Vec<Vec<f64>>,
    /// Moving average of the MF's inference cost per state.
    avg_cost_mf: Vec<f64>,
    /// Moving average of the MB's inference cost per state.
    avg_cost_mb: Vec<f64>,
    /// Whether the robot has already decided in each state (first-decision rule, SPEC 4).
    decided_in: Vec<bool>,
    /// G(s, a) of Eq. 8.
    g: Vec<Vec<bool>>,
    /// Next states of the last N executions of each (s, a), oldest first (Eq. 1).
    window: Vec<Vec<VecDeque<usize>>>,
    /// Most recent reward received on each (s, a, s').
    last_reward: HashMap<(usize, usize, usize), f64>,
    /// Whether the most recent arrival on each (s, a, s') was terminal (SPEC 10).
    last_terminal: HashMap<(usize, usize, usize), bool>,
    stats: RunStats,
    series: Vec<Checkpoint>,
    /// Sum of P(MB) over the decisions since the last checkpoint.
    window_p_mb: f64,
    /// Decisions since the last checkpoint.
    window_decisions: u32,
    /// SPEC 12.3: the run's P_MB, the MF's mean |RPE| (Omega) and the SPE classes of the last
    /// `rel_memory` transitions, oldest first (0 zero, 1 positive, 2 negative).
    rel_p_mb: f64,
    rel_omega: f64,
    rel_classes: VecDeque<usize>,
    /// SPEC 12.4: the Kalman MF's variances `var_mf[s][a]` and the average reward.
    var_mf: Vec<Vec<f64>>,
    rbar: f64,
    /// SPEC 3.1: the MF's eligibility trace `e[s][a]` (used when lambda_mf > 0).
    e: Vec<Vec<f64>>,
    /// SPEC 13: the two-step task's reward probabilities p(1,0), p(1,1), p(2,0), p(2,1), when
    /// the task is `twostep`.
    twostep: Option<[f64; 4]>,
    /// The experiment's two-step trials: (first-stage action, common transition, rewarded once
    /// the second stage is done).
    trials: Vec<(usize, bool, Option<bool>)>,
}

impl NaiveRun {
    /// A fresh run: Q = q_init, uniform averaged distributions, zero costs, empty model, placed
    /// in an initial state (SPEC 3.3, 7). The SPEC's literal arithmetic.
    pub fn new(spec: &Spec, params: Params, seed: u64, run_index: u64) -> NaiveRun {
        NaiveRun::with_arithmetic(spec, params, seed, run_index, Arithmetic::Spec)
    }

    /// As [`NaiveRun::new`], following `schedule` (SPEC 10; assumed valid for the task).
    pub fn with_schedule(
        spec: &Spec,
        params: Params,
        seed: u64,
        run_index: u64,
        schedule: &Schedule,
    ) -> NaiveRun {
        let mut run = NaiveRun::with_arithmetic(spec, params, seed, run_index, Arithmetic::Spec);
        run.changes = schedule.changes.clone();
        run.changes.sort_by_key(|c| c.step);
        run
    }

    /// As [`NaiveRun::new`], with the given evaluation order of the three formulas concerned.
    pub fn with_arithmetic(
        spec: &Spec,
        params: Params,
        seed: u64,
        run_index: u64,
        arithmetic: Arithmetic,
    ) -> NaiveRun {
        assert_eq!(
            params.cost_model,
            CostModel::Ops,
            "the naive reference measures cost in ops only"
        );
        let (n_s, n_a) = (spec.n_states, spec.n_actions);
        let mut rng = run_rng(seed, run_index);
        // A tidy1 run with its own box assignment lives in that task from the start.
        let spec = if spec.name == "tidy1" {
            tidy::build_with(Variant::Task1, params.boxes)
        } else {
            spec.clone()
        };
        let state = draw_initial_state(&spec, &mut rng);
        let twostep = (spec.name == "twostep").then(|| twostep_start(&mut rng));
        NaiveRun {
            goal: spec.goal_state().map_or(usize::MAX, |g| g as usize),
            // The two-step task has no goal; its largest reward (SPEC 12.3's R_max) is 1.
            goal_reward: spec.goal.map_or(1.0, |g| g.reward),
            spec,
            params,
            arithmetic,
            rng,
            state,
            arrived_at_goal: false,
            t: 0,
            budget_left: params.human.budget,
            human: params.human,
            reward_source: params.reward_source,
            changes: Vec::new(),
            applied: 0,
            q_mf: vec![vec![params.q_init; n_a]; n_s],
            q_mb: vec![vec![params.q_init; n_a]; n_s],
            avg_p_mf: vec![vec![1.0 / n_a as f64; n_a]; n_s],
            avg_p_mb: vec![vec![1.0 / n_a as f64; n_a]; n_s],
            avg_cost_mf: vec![0.0; n_s],
            avg_cost_mb: vec![0.0; n_s],
            decided_in: vec![false; n_s],
            g: vec![vec![false; n_a]; n_s],
            window: vec![vec![VecDeque::new(); n_a]; n_s],
            last_reward: HashMap::new(),
            last_terminal: HashMap::new(),
            stats: RunStats::default(),
            series: Vec::new(),
            window_p_mb: 0.0,
            window_decisions: 0,
            rel_p_mb: params.rel_p0,
            rel_omega: 0.0,
            rel_classes: VecDeque::new(),
            var_mf: vec![vec![params.kalman_v0; n_a]; n_s],
            rbar: 0.0,
            e: vec![vec![0.0; n_a]; n_s],
            twostep,
            trials: Vec::new(),
        }
    }

    /// Babbling plus experiment steps.
    pub fn total_steps(&self) -> u64 {
        u64::from(self.params.babbling) + u64::from(self.params.steps)
    }

    /// Whether every step has been taken.
    pub fn finished(&self) -> bool {
        self.t >= self.total_steps()
    }

    /// Takes one step (babbling or experiment); returns false, doing nothing, once finished.
    pub fn step(&mut self) -> bool {
        if self.finished() {
            return false;
        }
        let babbling_len = u64::from(self.params.babbling);
        let babbling = self.t < babbling_len;
        self.t += 1;
        let t_exp = if babbling {
            0
        } else {
            (self.t - babbling_len) as u32
        };

        // SPEC 10: the events of this step apply before anything else of it.
        while !babbling
            && self.applied < self.changes.len()
            && self.changes[self.applied].step == t_exp
        {
            if self.applied == 0 {
                self.stats.first_change_step = t_exp;
                self.stats.reward_before_change = self.stats.total_reward;
            }
            let event = self.changes[self.applied].event.clone();
            self.apply(event);
            self.applied += 1;
        }

        if self.arrived_at_goal {
            // SPEC 2.1: the reset step. Time passes; nothing is decided or learned.
            self.arrived_at_goal = false;
            self.state = draw_initial_state(&self.spec, &mut self.rng);
            self.clear_trace();
        } else {
            self.act(babbling, t_exp);
        }

        if babbling && self.t == babbling_len {
            // SPEC 7: end of babbling, back to an initial state (not a step).
            self.arrived_at_goal = false;
            self.state = draw_initial_state(&self.spec, &mut self.rng);
            self.clear_trace();
            // SPEC 13: the reward probabilities are drawn afresh for the experiment.
            if self.twostep.is_some() {
                self.twostep = Some(twostep_start(&mut self.rng));
            }
        }
        if !babbling {
            self.maybe_checkpoint(t_exp);
        }
        true
    }

    /// Takes every remaining step.
    pub fn run_to_end(&mut self) {
        while self.step() {}
    }

    /// The run's results so far (`wall_time_s` is always 0 here).
    pub fn stats(&self) -> &RunStats {
        &self.stats
    }

    /// Checkpoint rows written so far.
    pub fn series(&self) -> &[Checkpoint] {
        &self.series
    }

    /// MF action values, `[state][action]`.
    pub fn q_mf(&self) -> &[Vec<f64>] {
        &self.q_mf
    }

    /// MB action values, `[state][action]`.
    pub fn q_mb(&self) -> &[Vec<f64>] {
        &self.q_mb
    }

    /// Averaged action probabilities (MF, MB), `[state][action]`.
    pub fn averaged_probabilities(&self) -> (&[Vec<f64>], &[Vec<f64>]) {
        (&self.avg_p_mf, &self.avg_p_mb)
    }

    /// Per-state inference cost averages (MF, MB).
    pub fn cost_averages(&self) -> (&[f64], &[f64]) {
        (&self.avg_cost_mf, &self.avg_cost_mb)
    }

    /// The learned T(s, a, s') (Eq. 1); 0 for an untried pair.
    pub fn transition(&self, s: usize, a: usize, next: usize) -> f64 {
        let kept = &self.window[s][a];
        if kept.is_empty() {
            return 0.0;
        }
        let count = kept.iter().filter(|&&x| x == next).count();
        count as f64 / kept.len() as f64
    }

    /// Current environment state.
    pub fn state(&self) -> usize {
        self.state
    }

    /// Steps taken, babbling included.
    pub fn t(&self) -> u64 {
        self.t
    }

    /// Interactions the human may still give.
    pub fn budget_left(&self) -> u32 {
        self.budget_left
    }

    /// One event of SPEC 10.
    fn apply(&mut self, event: Event) {
        match event {
            Event::World(task) => {
                let mut world = mbmf::env::load(&task).expect("a valid world");
                world.initial_states = self.spec.initial_states.clone();
                self.spec = world;
            }
            Event::Goal { state, reward } => {
                self.goal = state as usize;
                if let Some(r) = reward {
                    self.goal_reward = r;
                }
            }
            Event::Boxes(boxes) => {
                self.spec = tidy::build_with(Variant::Task1, boxes);
                self.goal = self.spec.goal_state().expect("a goal task") as usize;
            }
            Event::Delete(pairs) => {
                let spec = &self.spec;
                let mut lists = Vec::new();
                for s in 0..spec.n_states {
                    for a in 0..spec.n_actions {
                        let sa = s * spec.n_actions + a;
                        let kept: Vec<_> = spec
                            .outcomes(sa)
                            .map(|o| (spec.outcome_state[o], spec.outcome_weight[o]))
                            .filter(|&(next, _)| !pairs.contains(&(s as u32, next)))
                            .collect();
                        lists.push(kept);
                    }
                }
                self.spec = Spec::from_outcomes(
                    spec.name.clone(),
                    spec.n_states,
                    spec.n_actions,
                    lists,
                    spec.initial_states.clone(),
                    spec.goal.expect("a goal task"),
                    spec.state_names.clone(),
                    spec.human.clone(),
                );
            }
            Event::Human(HumanChange::Interaction(i)) => self.human.interaction = i,
            Event::Human(HumanChange::Budget(n)) => self.budget_left = n,
            Event::Human(HumanChange::Forget(p)) => self.human.forget_prob = p,
            Event::Human(HumanChange::ErrorProb(e)) => self.human.error_prob = e,
            Event::Human(HumanChange::Zeta(z)) => self.human.zeta = z,
            Event::Human(HumanChange::Profile(p)) => {
                if let Some(h) = p.human(self.params.controller) {
                    self.human = h;
                    self.budget_left = h.budget;
                }
                if let Some(r) = p.reward_source() {
                    self.reward_source = r;
                }
            }
            Event::Human(HumanChange::RewardSource(r)) => self.reward_source = r,
        }
    }

    /// Steps 2 to 8 of SPEC 3.4 in a state that is not the goal.
    fn act(&mut self, babbling: bool, t_exp: u32) {
        let s = self.state;
        let human_present = !babbling && self.budget_left > 0;
        let interaction = self.human.interaction;

        // 2. Takeover: the human puts the held cube instead of the robot.
        let mut human_action = None;
        let put = self.takeover_put(s);
        if let (true, Interaction::Takeover, Some(put)) = (human_present, interaction, put) {
            if self.human_is_attentive() {
                human_action = Some(put);
                self.stats.takeovers += 1;
                self.spend_budget(t_exp);
            } else {
                self.stats.forgotten += 1;
            }
        }
        let a = match human_action {
            Some(a) => a,
            None => self.decide(s, babbling),
        };

        // 6. Environment.
        let mut next = self.environment(s, a);
        // SPEC 11.2: a nuisance undoes a relevant action; the robot observes the undone state.
        if human_present
            && self.budget_left > 0
            && interaction == Interaction::Nuisance
            && self.is_relevant(s, a)
        {
            let undone = self.spec.human.as_ref().unwrap().nuisance[s * self.spec.n_actions + a];
            if undone != NO_NUISANCE {
                if self.human_is_attentive() {
                    next = undone as usize;
                    self.stats.nuisances += 1;
                    self.spend_budget(t_exp);
                } else {
                    self.stats.forgotten += 1;
                }
            }
        }
        let at_goal = next == self.goal;
        let mut reward = if babbling {
            0.0
        } else if at_goal {
            self.goal_reward
        } else {
            0.0
        };
        // SPEC 13: a second-stage action is rewarded with probability p(s, a) (drawn in
        // babbling too, where the reward is withheld) and ends the trial.
        let second_stage = self.twostep.is_some() && s != 0;
        if let Some(p) = self.twostep {
            if second_stage {
                let rewarded = uniform(&mut self.rng) < p[(s - 1) * 2 + a];
                reward = if rewarded && !babbling { 1.0 } else { 0.0 };
                if !babbling && let Some(trial) = self.trials.last_mut() {
                    trial.2 = Some(rewarded);
                }
            } else if !babbling {
                self.trials.push((a, next == a + 1, None));
            }
        }
        // SPEC 11.1: only an attentive human with budget left brings the goal's reward.
        if !babbling && at_goal && self.reward_source == RewardSource::Human {
            let given = self.budget_left > 0
                && if self.human_is_attentive() {
                    true
                } else {
                    self.stats.forgotten += 1;
                    false
                };
            if given {
                self.stats.rewards_given += 1;
                self.spend_budget(t_exp);
            } else {
                reward = 0.0;
            }
        }

        // 7. Feedback: G(s, a) = 1 after an attentive congratulation (or punishment), else 0.
        let mut given = false;
        if human_present && self.budget_left > 0 {
            let merits = match interaction {
                Interaction::Congratulation => self.is_relevant(s, a),
                Interaction::Punishment => self.is_error(s, a),
                // A person's feedback is not drawn: the reference simulates humans only.
                Interaction::None
                | Interaction::Takeover
                | Interaction::Nuisance
                | Interaction::Person => false,
            };
            let judging = matches!(
                interaction,
                Interaction::Congratulation | Interaction::Punishment
            );
            // SPEC 15: with an error probability every action is an opportunity; the attentive
            // human then judges, wrongly with probability error_prob.
            let e = self.human.error_prob;
            let opportunity = if e > 0.0 { judging } else { merits };
            if opportunity {
                if self.human_is_attentive() {
                    given = if e > 0.0 {
                        let wrong = uniform(&mut self.rng) < e;
                        if wrong { !merits } else { merits }
                    } else {
                        true
                    };
                    if given {
                        if interaction == Interaction::Congratulation {
                            self.stats.congratulations += 1;
                        } else {
                            self.stats.punishments += 1;
                        }
                        self.spend_budget(t_exp);
                    }
                } else {
                    self.stats.forgotten += 1;
                }
            }
        }
        // SPEC 11.3: a congratulation that shapes the reward is learned as r + zeta and never
        // biases the softmax.
        let shaping = interaction == Interaction::Congratulation
            && self.params.congratulation_effect == CongratulationEffect::Reward;
        let learned = if shaping && given {
            reward + self.human.zeta
        } else {
            reward
        };
        self.g[s][a] = given && !shaping;

        // 8. Learning. The arrival is terminal when it is the goal at this time (SPEC 10), or
        // ends a two-step trial (then with no reset step: it is already the next first stage).
        let terminal = at_goal || second_stage;
        self.arrived_at_goal = at_goal;
        // SPEC 12.3 and 12.4: the arbiter sees the transition before the experts learn it.
        match self.params.controller {
            Controller::Reliability => self.reliability_update(s, a, learned, next, terminal),
            Controller::Vpi => {
                let rate = self.params.rbar_rate;
                self.rbar = (1.0 - rate) * self.rbar + rate * learned;
            }
            _ => {}
        }
        if self.params.controller == Controller::Vpi {
            self.kalman_learn(s, a, learned, next, terminal);
        } else if self.runs_mf() {
            self.mf_learn(s, a, learned, next, terminal);
        }
        if self.runs_mb() {
            self.mb_learn(s, a, learned, next, terminal);
        }

        if !babbling {
            self.stats.total_reward += reward;
            if reward != 0.0 {
                if self.stats.first_reward_step == 0 {
                    self.stats.first_reward_step = t_exp;
                }
                if self.stats.first_change_step > 0 && self.stats.first_reward_after_change == 0 {
                    self.stats.first_reward_after_change = t_exp;
                }
                let steps = self.params.steps;
                if t_exp > steps - steps / 10 {
                    self.stats.reward_last10 += reward;
                }
            }
        }
        self.state = next;
        // SPEC 13: after every trial each p takes a reflected Gaussian step, in slot order.
        if second_stage && let Some(p) = &mut self.twostep {
            let sd = self.params.drift_sd;
            for p in p.iter_mut() {
                let u1 = 1.0 - uniform(&mut self.rng);
                let u2 = uniform(&mut self.rng);
                let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                let mut x = *p + sd * z;
                while !(0.25..=0.75).contains(&x) {
                    x = if x > 0.75 { 1.5 - x } else { 0.5 - x };
                }
                *p = x;
            }
        }
    }

    /// Steps 3 to 5 of SPEC 3.4: MC choice, inference, softmax, averaging, action draw.
    fn decide(&mut self, s: usize, babbling: bool) -> usize {
        let n_a = self.spec.n_actions;

        // 3. The MC chooses from what earlier visits stored. With `combine = mix` (SPEC 12.1) it
        // only weighs the experts (no draw); `vpi` (12.4) values each action by one expert.
        let mix = self.mixes();
        let vpi = self.params.controller == Controller::Vpi;
        let mut by_mb = vec![false; n_a];
        let (use_mb, p_mb) = if vpi {
            by_mb = self.vpi_planned(s);
            let planned = by_mb.iter().filter(|&&b| b).count();
            (planned > 0, planned as f64 / n_a as f64)
        } else if mix {
            let w = self.mb_weight(s);
            (w > 0.5, w)
        } else {
            self.choose_expert(s)
        };
        let mut chosen_entropy = normalised_entropy(if use_mb {
            &self.avg_p_mb[s]
        } else {
            &self.avg_p_mf[s]
        });

        // 4. Inference: the chosen expert; both at a two-expert controller's first decision in s
        // and at every decision with mix; with vpi, MF always and MB when it values an action.
        let first_decision_here = !self.decided_in[s];
        self.decided_in[s] = true;
        let both = (first_decision_here && self.two_experts()) || mix;
        let alpha = self.params.filter_alpha;
        let mut cost_mf = 0.0;
        let mut cost_mb = 0.0;
        if self.runs_mf() && (!use_mb || both || vpi) {
            cost_mf = n_a as f64; // reads the row Q(s, .) (SPEC 6)
            self.avg_cost_mf[s] = ema(self.avg_cost_mf[s], cost_mf, alpha);
        }
        if self.runs_mb() && (use_mb || both) {
            cost_mb = self.value_iteration() as f64;
            self.avg_cost_mb[s] = ema(self.avg_cost_mb[s], cost_mb, alpha);
        }

        // 5. Each running expert computes its (biased) softmax and folds it into its average
        // (SPEC 3.3's, which the MC reads; `vpi` neither reads nor reports them: its averages
        // stay as they started).
        let mut p_mf = Vec::new();
        let mut p_mb_dist = Vec::new();
        if self.runs_mf() {
            p_mf = self.policy(&self.q_mf[s], s);
            if !vpi {
                for (avg, &p) in self.avg_p_mf[s].iter_mut().zip(&p_mf) {
                    *avg = ema(*avg, p, alpha);
                }
            }
        }
        if self.runs_mb() {
            p_mb_dist = self.policy(&self.q_mb[s], s);
            if !vpi {
                for (avg, &p) in self.avg_p_mb[s].iter_mut().zip(&p_mb_dist) {
                    *avg = ema(*avg, p, alpha);
                }
            }
        }
        let u = uniform(&mut self.rng);
        let a = if mix || vpi {
            let values: Vec<f64> = (0..n_a)
                .map(|b| {
                    if mix {
                        p_mb * self.q_mb[s][b] + (1.0 - p_mb) * self.q_mf[s][b]
                    } else if by_mb[b] {
                        self.q_mb[s][b]
                    } else {
                        self.q_mf[s][b]
                    }
                })
                .collect();
            let p = self.policy(&values, s);
            chosen_entropy = normalised_entropy(&p);
            draw_index(&p, u)
        } else {
            draw_index(if use_mb { &p_mb_dist } else { &p_mf }, u)
        };

        if !babbling {
            self.stats.cost_mf += cost_mf;
            self.stats.cost_mb += cost_mb;
            self.stats.decisions += 1;
            if use_mb {
                self.stats.mb_decisions += 1;
            }
            self.stats.p_mb_sum += p_mb;
            self.stats.entropy_sum += chosen_entropy;
            self.window_p_mb += p_mb;
            self.window_decisions += 1;
        }
        a
    }

    /// SPEC 4: (MB controls this step, softmax probability of MB).
    fn choose_expert(&mut self, s: usize) -> (bool, f64) {
        match self.params.controller {
            Controller::Mf => (false, 0.0),
            Controller::Mb => (true, 1.0),
            Controller::Rnd => (uniform(&mut self.rng) < 0.5, 0.5),
            // SPEC 12.2: P(MB) = w_mb; argmax takes MB iff w_mb > 1/2, a fair draw at 1/2.
            Controller::Fixed => {
                let w = self.params.w_mb;
                let use_mb = match self.params.selection {
                    Selection::Softmax => uniform(&mut self.rng) < w,
                    Selection::Argmax if w == 0.5 => uniform(&mut self.rng) < 0.5,
                    Selection::Argmax => w > 0.5,
                };
                (use_mb, w)
            }
            // SPEC 12.3: the run's P_MB, drawn or compared with 1/2 like fixed's weight.
            Controller::Reliability => {
                let w = self.rel_p_mb;
                let use_mb = match self.params.selection {
                    Selection::Softmax => uniform(&mut self.rng) < w,
                    Selection::Argmax if w == 0.5 => uniform(&mut self.rng) < 0.5,
                    Selection::Argmax => w > 0.5,
                };
                (use_mb, w)
            }
            Controller::Vpi => unreachable!("vpi values each action (vpi_planned)"),
            Controller::Ec | Controller::Entropy => {
                let (v_mf, v_mb) = self.expert_values(s);
                let p_mb = self.ec_p_mb(v_mf, v_mb);
                let use_mb = match self.params.selection {
                    Selection::Softmax => uniform(&mut self.rng) < p_mb,
                    Selection::Argmax => {
                        if v_mb > v_mf {
                            true
                        } else if v_mf > v_mb {
                            false
                        } else {
                            uniform(&mut self.rng) < 0.5
                        }
                    }
                };
                (use_mb, p_mb)
            }
        }
    }

    /// P(MB) of Eq. 6's two values.
    fn ec_p_mb(&self, v_mf: f64, v_mb: f64) -> f64 {
        let z = (v_mf - v_mb) / self.params.tau;
        match self.arithmetic {
            Arithmetic::Spec => 1.0 / (1.0 + z.exp()),
            Arithmetic::Engine if z > 0.0 => (-z).exp() / (1.0 + (-z).exp()),
            Arithmetic::Engine => 1.0 / (1.0 + z.exp()),
        }
    }

    /// SPEC 12.1, `combine = mix`: the controller's P(MB), without any draw.
    fn mb_weight(&self, s: usize) -> f64 {
        match self.params.controller {
            Controller::Rnd => 0.5,
            Controller::Fixed => self.params.w_mb,
            Controller::Reliability => self.rel_p_mb,
            Controller::Ec | Controller::Entropy => {
                let (v_mf, v_mb) = self.expert_values(s);
                self.ec_p_mb(v_mf, v_mb)
            }
            Controller::Mf | Controller::Mb | Controller::Vpi => unreachable!("not mixed"),
        }
    }

    /// Whether this run mixes the experts: `combine = mix` for a controller with a weight
    /// (it does not apply to mf, mb, vpi).
    fn mixes(&self) -> bool {
        self.params.combine == Combine::Mix
            && !matches!(
                self.params.controller,
                Controller::Mf | Controller::Mb | Controller::Vpi
            )
    }

    /// SPEC 12.4: which actions of s take MB's value (VPI >= vpi_tau * Rbar).
    fn vpi_planned(&self, s: usize) -> Vec<bool> {
        let q = &self.q_mf[s];
        let n = q.len();
        let threshold = self.params.vpi_tau * self.rbar;
        if n < 2 {
            return vec![0.0 >= threshold; n];
        }
        // a1 the best mean, a2 the second; ties by the lower index.
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&x, &y| q[y].partial_cmp(&q[x]).unwrap().then(x.cmp(&y)));
        let (a1, a2) = (order[0], order[1]);
        (0..n)
            .map(|a| {
                let sigma = self.var_mf[s][a].sqrt();
                let value = if sigma == 0.0 {
                    0.0 // the limit: a certain value brings no information
                } else if a == a1 {
                    let x = (q[a2] - q[a1]) / sigma;
                    (q[a2] - q[a1]) * phi_cdf(x) + sigma * phi_pdf(x)
                } else {
                    let x = (q[a1] - q[a]) / sigma;
                    (q[a] - q[a1]) * (1.0 - phi_cdf(x)) + sigma * phi_pdf(x)
                };
                value >= threshold
            })
            .collect()
    }

    /// SPEC 12.3: SPE and RPE on the tables before learning, then the class memory, Omega and
    /// P_MB.
    fn reliability_update(&mut self, s: usize, a: usize, r: f64, next: usize, terminal: bool) {
        let p = &self.params;
        let spe = 1.0 - self.transition(s, a, next);
        let future = if terminal { 0.0 } else { max(&self.q_mf[next]) };
        let rpe = r + p.gamma_mf * future - self.q_mf[s][a];
        let class = if spe.abs() < p.spe_threshold {
            0
        } else if spe >= p.spe_threshold {
            1
        } else {
            2
        };
        self.rel_classes.push_back(class);
        if self.rel_classes.len() > p.rel_memory as usize {
            self.rel_classes.pop_front();
        }
        let big_k = 3.0;
        let n = self.rel_classes.len() as f64;
        let ratio = |k: usize| {
            let n_k = self.rel_classes.iter().filter(|&&c| c == k).count() as f64;
            let mean = (1.0 + n_k) / (big_k + n);
            let var = (1.0 + n_k) * (big_k + n - 1.0 - n_k)
                / ((big_k + n) * (big_k + n) * (big_k + n + 1.0));
            mean / var
        };
        let chi_mb = ratio(0) / (ratio(0) + ratio(1) + ratio(2));
        self.rel_omega += p.rel_eta * (rpe.abs() - self.rel_omega);
        // The largest |reward| of the world in force: a goal task rewards only its goal.
        let r_max = self.goal_reward.abs();
        let chi_mf = if r_max > 0.0 {
            ((r_max - self.rel_omega) / r_max).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let alpha = p.rel_a_mf_mb / (1.0 + (p.rel_b_mf_mb * chi_mf).exp());
        let beta = p.rel_a_mb_mf / (1.0 + (p.rel_b_mb_mf * chi_mb).exp());
        if alpha + beta > 0.0 {
            let p_inf = alpha / (alpha + beta);
            self.rel_p_mb = p_inf + (self.rel_p_mb - p_inf) * (-0.1 * (alpha + beta)).exp();
        }
    }

    /// SPEC 12.4's Kalman MF in place of Eq. 4.
    fn kalman_learn(&mut self, s: usize, a: usize, r: f64, next: usize, terminal: bool) {
        let p = &self.params;
        let future = if terminal { 0.0 } else { max(&self.q_mf[next]) };
        let v = self.var_mf[s][a] * (1.0 + p.kalman_eta);
        let y = r + p.gamma_mf * future;
        let k = v / (v + p.kalman_noise);
        self.q_mf[s][a] += k * (y - self.q_mf[s][a]);
        self.var_mf[s][a] = (1.0 - k) * v;
    }

    /// Eqs. 6–7: (value of MF, value of MB) in state s.
    fn expert_values(&self, s: usize) -> (f64, f64) {
        let bits_mf = entropy_bits(&self.avg_p_mf[s]);
        let bits_mb = entropy_bits(&self.avg_p_mb[s]);
        let (h_mf, h_mb) = if self.params.normalise_entropy {
            (
                normalised_entropy(&self.avg_p_mf[s]),
                normalised_entropy(&self.avg_p_mb[s]),
            )
        } else {
            (bits_mf, bits_mb)
        };
        if self.params.controller == Controller::Entropy {
            return (-h_mf, -h_mb);
        }
        let kappa = (-self.params.kappa_coeff * bits_mf).exp();
        let largest = self.avg_cost_mf[s].max(self.avg_cost_mb[s]);
        let scale = if largest > 0.0 { largest } else { TINY };
        let (c_mf, c_mb) = (self.avg_cost_mf[s], self.avg_cost_mb[s]);
        match self.arithmetic {
            Arithmetic::Spec => (
                -(h_mf + kappa * (c_mf / scale)),
                -(h_mb + kappa * (c_mb / scale)),
            ),
            Arithmetic::Engine => (
                -(h_mf + kappa * c_mf / scale),
                -(h_mb + kappa * c_mb / scale),
            ),
        }
    }

    /// Eqs. 3 and 8: softmax of Q(s, a) + bonus * G(s, a).
    fn policy(&self, q_row: &[f64], s: usize) -> Vec<f64> {
        let bonus = match self.human.interaction {
            Interaction::Congratulation => self.human.zeta,
            Interaction::Punishment => -self.human.zeta,
            Interaction::Person => self.human.zeta,
            Interaction::None | Interaction::Takeover | Interaction::Nuisance => 0.0,
        };
        let biased: Vec<f64> = q_row
            .iter()
            .zip(&self.g[s])
            .map(|(&q, &g)| q + bonus * if g { 1.0 } else { 0.0 })
            .collect();
        softmax(&biased, self.params.tau, self.arithmetic)
    }

    /// MB inference (Eq. 2): in-place value iteration over the learned model; returns its cost in
    /// ops (SPEC 6).
    fn value_iteration(&mut self) -> u64 {
        let (n_s, n_a) = (self.spec.n_states, self.spec.n_actions);
        let gamma = self.params.gamma_mb;
        let mut ops = 0;
        let mut sweeps = 0;
        loop {
            let mut change = 0.0;
            for s in 0..n_s {
                if !self.is_known(s) {
                    continue;
                }
                for a in 0..n_a {
                    if self.window[s][a].is_empty() {
                        continue; // untried: keeps its value
                    }
                    let t = self.transition_row(s, a);
                    let mut r_sa = 0.0;
                    for (&next, &p) in &t {
                        r_sa += p * self.last_reward[&(s, a, next)];
                    }
                    let mut value = 0.0;
                    for (&next, &p) in &t {
                        let future = if self.last_terminal[&(s, a, next)] {
                            0.0
                        } else {
                            max(&self.q_mb[next])
                        };
                        value += p * (r_sa + gamma * future);
                        ops += 1 + n_a as u64;
                    }
                    change += (value - self.q_mb[s][a]).abs();
                    self.q_mb[s][a] = value;
                }
            }
            sweeps += 1;
            if change < self.params.vi_epsilon {
                break;
            }
            if sweeps >= self.params.vi_max_sweeps {
                self.stats.vi_capped += 1;
                break;
            }
        }
        self.stats.vi_calls += 1;
        self.stats.vi_sweeps += u64::from(sweeps);
        ops
    }

    /// T(s, a, .) from the window: s' (ascending) -> count / kept, for the s' with T > 0.
    fn transition_row(&self, s: usize, a: usize) -> BTreeMap<usize, f64> {
        let kept = &self.window[s][a];
        let mut counts: BTreeMap<usize, u32> = BTreeMap::new();
        for &next in kept {
            *counts.entry(next).or_insert(0) += 1;
        }
        counts
            .into_iter()
            .map(|(next, c)| (next, f64::from(c) / kept.len() as f64))
            .collect()
    }

    /// A state is known once some learned transition starts there.
    fn is_known(&self, s: usize) -> bool {
        self.window[s].iter().any(|w| !w.is_empty())
    }

    /// Eq. 4; no future term after a terminal arrival. With lambda_mf > 0 (SPEC 3.1): e(s, a)
    /// = 1, every pair with e > 0 moves by alpha * delta * e, then every e decays by gamma *
    /// lambda, or all are cleared after a terminal arrival.
    fn mf_learn(&mut self, s: usize, a: usize, r: f64, next: usize, terminal: bool) {
        let future = if terminal { 0.0 } else { max(&self.q_mf[next]) };
        let q = self.q_mf[s][a];
        let p = self.params;
        if p.lambda_mf == 0.0 {
            self.q_mf[s][a] = q + p.alpha_mf * (r + p.gamma_mf * future - q);
            return;
        }
        let delta = r + p.gamma_mf * future - q;
        self.e[s][a] = 1.0;
        for (qs, es) in self.q_mf.iter_mut().zip(&self.e) {
            for (q, &e) in qs.iter_mut().zip(es) {
                if e > 0.0 {
                    *q += p.alpha_mf * delta * e;
                }
            }
        }
        if terminal {
            self.clear_trace();
        } else {
            for e in self.e.iter_mut().flatten() {
                *e *= p.gamma_mf * p.lambda_mf;
            }
        }
    }

    /// SPEC 3.1: no pair keeps a trace (after a terminal arrival, at a reset step, at the end of
    /// babbling).
    fn clear_trace(&mut self) {
        for e in self.e.iter_mut().flatten() {
            *e = 0.0;
        }
    }

    /// SPEC 13: the probability that the first-stage action repeats the previous trial's,
    /// after a previous trial (rewarded, common) of each kind, in the order rc, rr, uc, ur;
    /// `None` where no trial followed one of that kind.
    pub fn stays(&self) -> [Option<f64>; 4] {
        let mut counts = [(0u32, 0u32); 4];
        for pair in self.trials.windows(2) {
            let ((a0, common, rewarded), (a1, _, _)) = (pair[0], pair[1]);
            let Some(rewarded) = rewarded else { continue };
            let kind = match (rewarded, common) {
                (true, true) => 0,
                (true, false) => 1,
                (false, true) => 2,
                (false, false) => 3,
            };
            counts[kind].0 += 1;
            if a1 == a0 {
                counts[kind].1 += 1;
            }
        }
        counts.map(|(n, stay)| (n > 0).then(|| f64::from(stay) / f64::from(n)))
    }

    /// SPEC 3.2 and 10: keep the last N outcomes of (s, a), and the last reward of (s, a, s') and
    /// whether that arrival was terminal.
    fn mb_learn(&mut self, s: usize, a: usize, r: f64, next: usize, terminal: bool) {
        let kept = &mut self.window[s][a];
        kept.push_back(next);
        if kept.len() > self.params.window_n as usize {
            kept.pop_front();
        }
        self.last_reward.insert((s, a, next), r);
        self.last_terminal.insert((s, a, next), terminal);
    }

    /// The environment's answer to (s, a): one draw only when several outcomes are possible.
    fn environment(&mut self, s: usize, a: usize) -> usize {
        let sa = s * self.spec.n_actions + a;
        let outcomes = self.spec.outcomes(sa);
        let o = if outcomes.len() == 1 {
            outcomes.start
        } else {
            self.spec.pick_outcome(sa, uniform(&mut self.rng))
        };
        self.spec.outcome_state[o] as usize
    }

    fn human_is_attentive(&mut self) -> bool {
        uniform(&mut self.rng) >= self.human.forget_prob
    }

    fn spend_budget(&mut self, t_exp: u32) {
        self.budget_left -= 1;
        if self.budget_left == 0 {
            self.stats.budget_exhausted_step = t_exp;
        }
    }

    fn takeover_put(&self, s: usize) -> Option<usize> {
        let put = self.spec.human.as_ref()?.takeover_action[s];
        (put != NO_TAKEOVER).then_some(put as usize)
    }

    fn is_relevant(&self, s: usize, a: usize) -> bool {
        let sa = s * self.spec.n_actions + a;
        self.spec.human.as_ref().is_some_and(|h| h.relevant[sa])
    }

    fn is_error(&self, s: usize, a: usize) -> bool {
        let sa = s * self.spec.n_actions + a;
        self.spec.human.as_ref().is_some_and(|h| h.error[sa])
    }

    fn runs_mf(&self) -> bool {
        self.params.controller != Controller::Mb
    }

    fn runs_mb(&self) -> bool {
        self.params.controller != Controller::Mf
    }

    fn two_experts(&self) -> bool {
        matches!(
            self.params.controller,
            Controller::Rnd
                | Controller::Ec
                | Controller::Entropy
                | Controller::Fixed
                | Controller::Reliability
        )
    }

    /// A checkpoint row every `checkpoint` experiment steps and at the last step (SPEC 8).
    fn maybe_checkpoint(&mut self, t_exp: u32) {
        let k = self.params.checkpoint;
        if k == 0 || !(t_exp.is_multiple_of(k) || t_exp == self.params.steps) {
            return;
        }
        let p_mb_mean = if self.window_decisions > 0 {
            self.window_p_mb / f64::from(self.window_decisions)
        } else {
            f64::NAN
        };
        self.series.push(Checkpoint {
            step: t_exp,
            cum_reward: self.stats.total_reward,
            cum_cost_mf: self.stats.cost_mf,
            cum_cost_mb: self.stats.cost_mb,
            p_mb_mean,
            decisions: self.window_decisions,
            interactions: self.stats.congratulations
                + self.stats.takeovers
                + self.stats.punishments
                + self.stats.rewards_given
                + self.stats.nuisances,
        });
        self.window_p_mb = 0.0;
        self.window_decisions = 0;
    }
}

/// SPEC 13: the four reward probabilities, uniform in [0.25, 0.75], in slot order.
fn twostep_start(rng: &mut Xoshiro256PlusPlus) -> [f64; 4] {
    [(); 4].map(|_| 0.25 + (0.75 - 0.25) * uniform(rng))
}

/// An initial state, uniformly (one draw only when there are several).
pub fn draw_initial_state(spec: &Spec, rng: &mut Xoshiro256PlusPlus) -> usize {
    let n = spec.initial_states.len();
    if n == 1 {
        return spec.initial_states[0] as usize;
    }
    let i = ((uniform(rng) * n as f64) as usize).min(n - 1);
    spec.initial_states[i] as usize
}

/// Numerically stable softmax: subtract the max, exp((v - max) / tau), divide by the sum
/// (or, with [`Arithmetic::Engine`], multiply by the reciprocals of tau and of the sum).
pub fn softmax(values: &[f64], tau: f64, arithmetic: Arithmetic) -> Vec<f64> {
    let m = max(values);
    let exps: Vec<f64> = match arithmetic {
        Arithmetic::Spec => values.iter().map(|&v| ((v - m) / tau).exp()).collect(),
        Arithmetic::Engine => values
            .iter()
            .map(|&v| ((v - m) * (1.0 / tau)).exp())
            .collect(),
    };
    let mut sum = 0.0;
    for &e in &exps {
        sum += e;
    }
    match arithmetic {
        Arithmetic::Spec => exps.iter().map(|&e| e / sum).collect(),
        Arithmetic::Engine => exps.iter().map(|&e| e * (1.0 / sum)).collect(),
    }
}

/// Base-2 entropy, 0 log 0 = 0 (Eq. 5).
pub fn entropy_bits(p: &[f64]) -> f64 {
    let mut h = 0.0;
    for &x in p {
        if x > 0.0 {
            h -= x * x.log2();
        }
    }
    h
}

/// Entropy divided by log2(|A|), so that it lies in [0, 1] (SPEC 3.3): rounding can put a
/// near-uniform averaged distribution a hair above log2(|A|) bits (an average of uniform
/// distributions that is not exactly 1/|A|, as in a state first decided in after a goal change),
/// so the quotient is clamped to the interval the SPEC gives it.
pub fn normalised_entropy(p: &[f64]) -> f64 {
    (entropy_bits(p) / (p.len() as f64).log2()).clamp(0.0, 1.0)
}

/// Moving average: (1 - alpha) * old + alpha * new.
pub fn ema(old: f64, new: f64, alpha: f64) -> f64 {
    (1.0 - alpha) * old + alpha * new
}

/// The action of distribution `p` for a uniform `u`: the first index whose cumulative
/// probability (over positive entries) exceeds `u`; if rounding leaves the total just under `u`,
/// the last index with a positive probability.
pub fn draw_index(p: &[f64], u: f64) -> usize {
    let mut cumulative = 0.0;
    let mut last_positive = 0;
    for (i, &x) in p.iter().enumerate() {
        if x > 0.0 {
            cumulative += x;
            last_positive = i;
            if u < cumulative {
                return i;
            }
        }
    }
    last_positive
}

/// The standard normal CDF, 0.5 erfc(-x / sqrt 2) with the crate's erfc (a contract, like the
/// random stream: a different erfc would differ in the last bits).
fn phi_cdf(x: f64) -> f64 {
    mbmf::analysis::stats::normal_cdf(x)
}

/// The standard normal density.
fn phi_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

fn max(row: &[f64]) -> f64 {
    row.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}
