//! One step of one run, in the order of SPEC 3.4.
//!
//! Random draws, in this order and only when needed: the human's attentiveness at a takeover
//! opportunity; the MC's draw (`rnd`, softmax selection, or an argmax tie); the action; the
//! environment's outcome (pairs with several outcomes only); the reward (drawn rewards only);
//! the human's attentiveness at a nuisance opportunity (SPEC 11.2); at a human-reward
//! opportunity (11.1); at a congratulation or punishment opportunity. A reset step draws an initial state only when the environment has
//! several.
//!
//! The events of the run's schedule due at an experiment step apply first, before anything of
//! that step (SPEC 10); from then on the step reads the world and human from the cursor.

use std::time::Instant;

use super::{Checkpoint, RunView, Settled, initial_state, uniform};
use crate::env::{Chance, End, Spec};
use crate::expert::{draw, ema, ema_into, entropy_bits, max_of, mf, softmax_biased};
use crate::human::{self, Encounter};
use crate::meta;
use crate::params::{
    CongratulationEffect, Controller, CostModel, HumanParams, Interaction, Params, RewardSource,
};
use crate::schedule::{Action, HumanChange, Plan};

/// Advances one run by one step: a babbling step while `cursor.t < babbling`, then an experiment
/// step. At the end of babbling the environment is reset to an initial state (not a step).
#[inline]
pub fn step(spec: &Spec, params: &Params, window_cap: usize, run: &mut RunView<'_>) {
    let end = run.cursor.t + 1;
    run_until(spec, params, window_cap, run, end);
}

/// Controller kinds as const-generic parameters (stable Rust has no enum const generics).
const MF: u8 = 0;
const MB: u8 = 1;
const RND: u8 = 2;
const EC: u8 = 3;
const ENTROPY: u8 = 4;

/// The controller a const-generic kind stands for; folded at compile time.
#[inline(always)]
const fn controller(kind: u8) -> Controller {
    match kind {
        MF => Controller::Mf,
        MB => Controller::Mb,
        RND => Controller::Rnd,
        EC => Controller::Ec,
        _ => Controller::Entropy,
    }
}

/// Advances one run until `cursor.t` reaches `end` (or the run ends): babbling, then the
/// experiment, each as its own loop of a step compiled for the run's controller and for whether a
/// human (or a schedule) can act at all, so none of that is branched on per step.
pub(super) fn run_until(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    end: u64,
) {
    // Without a schedule, a human that never interacts and the environment's own reward, no
    // human function can do anything: the steps skip them.
    let human = run.plan.is_some()
        || params.human.interaction != Interaction::None
        || params.reward_source != RewardSource::Environment;
    // The tidy tasks' 7 actions get their own copy, whose rows have a length known at compile
    // time (loops unrolled, no remainder handling); other action counts share a generic one.
    if spec.n_actions == 7 {
        by_kind::<7>(spec, params, window_cap, run, end, human);
    } else {
        by_kind::<0>(spec, params, window_cap, run, end, human);
    }
}

/// [`run_until`] for `NA` actions (0: read from the spec): the controller and human mode.
#[inline(always)]
fn by_kind<const NA: usize>(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    end: u64,
    human: bool,
) {
    let (p, w) = (params, window_cap);
    match (params.controller, human) {
        (Controller::Mf, false) => run_loop::<MF, false, NA>(spec, p, w, run, end),
        (Controller::Mf, true) => run_loop::<MF, true, NA>(spec, p, w, run, end),
        (Controller::Mb, false) => run_loop::<MB, false, NA>(spec, p, w, run, end),
        (Controller::Mb, true) => run_loop::<MB, true, NA>(spec, p, w, run, end),
        (Controller::Rnd, false) => run_loop::<RND, false, NA>(spec, p, w, run, end),
        (Controller::Rnd, true) => run_loop::<RND, true, NA>(spec, p, w, run, end),
        (Controller::Ec, false) => run_loop::<EC, false, NA>(spec, p, w, run, end),
        (Controller::Ec, true) => run_loop::<EC, true, NA>(spec, p, w, run, end),
        (Controller::Entropy, false) => run_loop::<ENTROPY, false, NA>(spec, p, w, run, end),
        (Controller::Entropy, true) => run_loop::<ENTROPY, true, NA>(spec, p, w, run, end),
    }
}

/// [`run_until`] for one controller kind and human mode.
fn run_loop<const KIND: u8, const HUMAN: bool, const NA: usize>(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    end: u64,
) {
    let babbling = u64::from(params.babbling);
    let end = end.min(babbling + u64::from(params.steps));
    let babble_end = end.min(babbling);
    if run.cursor.t < babble_end {
        while run.cursor.t < babble_end {
            one_step::<KIND, HUMAN, NA, true>(spec, params, window_cap, run, 0);
        }
        if run.cursor.t == babbling {
            // End of babbling: back to the start; a pending reset step is dropped (SPEC 7).
            let world = world(spec, run);
            run.cursor.pending_reset = false;
            run.cursor.state = initial_state(world, run.rng);
        }
    }
    if run.cursor.t >= end {
        return;
    }
    // Experiment step numbers are 1-based; a row is written every `checkpoint` steps and at the
    // last step, counted down rather than found by a division per step.
    let mut t_exp = (run.cursor.t - babbling) as u32;
    let last = params.steps;
    let every = params.checkpoint;
    let next_row = |t: u32| {
        t.checked_div(every)
            .map_or(u32::MAX, |k| (k + 1).saturating_mul(every).min(last))
    };
    let mut row_at = next_row(t_exp);
    while run.cursor.t < end {
        t_exp += 1;
        one_step::<KIND, HUMAN, NA, false>(spec, params, window_cap, run, t_exp);
        if t_exp == row_at {
            record_checkpoint(run, t_exp);
            row_at = next_row(t_exp);
        }
    }
}

/// The number of actions: `NA` when the step was compiled for it, else the spec's.
#[inline(always)]
fn actions<const NA: usize>(spec: &Spec) -> usize {
    debug_assert!(NA == 0 || NA == spec.n_actions);
    if NA > 0 { NA } else { spec.n_actions }
}

/// The world the run is in now: the batch's, or its plan's current one.
#[inline(always)]
fn world<'s>(spec: &'s Spec, run: &RunView<'s>) -> &'s Spec {
    run.plan
        .map_or(spec, |p| &*p.worlds[usize::from(run.cursor.world)])
}

/// One step (SPEC 3.4) at experiment step `t_exp` (0 while babbling).
#[inline(always)]
fn one_step<const KIND: u8, const HUMAN: bool, const NA: usize, const BABBLING: bool>(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    t_exp: u32,
) {
    let s = run.cursor.state as usize;
    run.cursor.t += 1;
    let spec = if HUMAN {
        if let Some(plan) = run.plan {
            apply_due(plan, params, run, t_exp);
        }
        world(spec, run)
    } else {
        spec
    };

    if run.cursor.pending_reset {
        // 1. The reset step: time passes, nothing is decided or learned (SPEC 2.1). Whether
        // this is one was decided by the previous arrival, even if the goal has since moved.
        run.cursor.pending_reset = false;
        run.cursor.state = initial_state(spec, run.rng);
    } else {
        act::<KIND, HUMAN, NA, BABBLING>(spec, params, window_cap, run, s, t_exp);
    }
}

/// Steps 2 to 8 of SPEC 3.4 in a non-goal state.
#[inline(always)]
fn act<const KIND: u8, const HUMAN: bool, const NA: usize, const BABBLING: bool>(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    s: usize,
    t_exp: u32,
) {
    let babbling = BABBLING;
    let controller = controller(KIND);
    let n_a = actions::<NA>(spec);
    let human = run.cursor.human;
    let human = &human;
    let human_active = HUMAN && !babbling && run.cursor.budget_left > 0;

    // 2. Takeover.
    let action = if human_active {
        encounter(spec, human, run, t_exp).takeover(s)
    } else {
        None
    };
    let a = match action {
        Some(a) => a,
        None => decide::<KIND, HUMAN, NA, BABBLING>(spec, params, run, s),
    };

    // 6. Environment.
    let sa = spec.sa(s, a);
    let outcomes = spec.outcomes(sa);
    let o = if outcomes.len() == 1 {
        outcomes.start
    } else {
        spec.pick_outcome(sa, uniform(run.rng))
    };
    let mut next = spec.outcome_state[o] as usize;
    // Most outcomes bring nothing: one byte says so, and only the others are read.
    let (mut terminal, mut reset, mut arrival_reward) = (false, false, 0.0);
    if spec.eventful[o] {
        let arrival = spec.arrival[o];
        terminal = arrival.terminal();
        reset = arrival.end == End::Reset;
        arrival_reward = arrival.reward;
        // A drawn reward: its draw comes right after the outcome's (a fixed one draws nothing).
        if let Chance::Drawn(p) = arrival.chance
            && uniform(run.rng) >= p
        {
            arrival_reward = 0.0;
        }
    }
    // 11.2: a nuisance human undoes a relevant action before anything learns from it; the
    // cube back on the table is never a goal, so the arrival brings nothing.
    if human_active && let Some(undone) = encounter(spec, human, run, t_exp).nuisance(sa) {
        next = undone;
        (terminal, reset) = (false, false);
    }
    let mut reward = if babbling || !terminal {
        0.0
    } else {
        arrival_reward
    };
    // 11.1: where only the human brings reward, an arrival in the goal is an opportunity.
    if HUMAN && terminal && !babbling && run.cursor.reward_source == RewardSource::Human {
        reward = encounter(spec, human, run, t_exp).reward(reward);
    }

    // 7. Feedback: G(s, a) is set by an attentive human with budget, reset otherwise (Eq. 8).
    let g = if human_active {
        encounter(spec, human, run, t_exp).feedback(sa)
    } else {
        0
    };
    // 11.3: a congratulation that shapes the reward is learned, not shown to the softmax.
    let shaped = HUMAN
        && g == 1
        && human.interaction == Interaction::Congratulation
        && params.congratulation_effect == CongratulationEffect::Reward;
    let learned = if shaped { reward + human.zeta } else { reward };
    run.bonus[sa] = if shaped { 0 } else { g };

    // 8. Learning, by every expert the controller runs. The arrival is terminal when the world
    // at this time says so (SPEC 10): both experts learn that from the transition itself.
    run.cursor.pending_reset = reset;
    if controller.runs_mf() {
        // An `mf` run without a human keeps each Q row's maximum; other runs read the row.
        let future = match (KIND == MF && !HUMAN, terminal) {
            (_, true) => 0.0,
            (true, false) => run.max_mf[next],
            (false, false) => mf::future(run.q_mf, n_a, next, false),
        };
        let before = run.q_mf[sa];
        mf::learn(
            run.q_mf,
            n_a,
            s,
            a,
            learned,
            future,
            params.alpha_mf,
            params.gamma_mf,
        );
        // A new value in the row makes what was kept from it stale.
        if !HUMAN && run.q_mf[sa].to_bits() != before.to_bits() {
            run.settled[s] &= !(Settled::SOFTMAX | Settled::AVERAGE);
            if KIND == MF {
                run.max_mf[s] = max_of(&run.q_mf[s * n_a..(s + 1) * n_a]);
            }
        }
    }
    if controller.runs_mb() {
        run.model.learn(
            window_cap,
            params.window_n as usize,
            s,
            a,
            next,
            learned,
            terminal,
        );
    }

    if !babbling {
        run.stats.total_reward += reward;
        if reward != 0.0 {
            if run.stats.first_reward_step == 0 {
                run.stats.first_reward_step = t_exp;
            }
            if run.stats.first_change_step > 0 && run.stats.first_reward_after_change == 0 {
                run.stats.first_reward_after_change = t_exp;
            }
            if t_exp > params.steps - params.steps / 10 {
                run.stats.reward_last10 += reward;
            }
        }
    }
    run.cursor.state = next as u32;
}

/// The run's side of an opportunity of its human `human` in world `spec` at step `t_exp`.
#[inline(always)]
fn encounter<'r>(
    spec: &'r Spec,
    human: &'r HumanParams,
    run: &'r mut RunView<'_>,
    t_exp: u32,
) -> Encounter<'r> {
    Encounter {
        human,
        tables: spec.human.as_ref(),
        budget_left: &mut run.cursor.budget_left,
        stats: run.stats,
        t_exp,
        rng: run.rng,
    }
}

/// Steps 3 to 5 of SPEC 3.4: the MC chooses, experts infer and compute their softmax, and the
/// action is drawn from the chosen expert's distribution.
///
/// What a decision computes from rows that have not changed since the last decision in the
/// state is taken from then, bit for bit the same: the entropies of the averaged distributions
/// (kept per state until a moving average changes the row) and, without a human, each expert's
/// softmax and moving average while its Q row is unchanged (see [`Settled`] and [`Fold`]; an
/// `mf` run keeps the softmax itself). Once Q-learning has converged in a state, none of them
/// changes: about 19 decisions in 20 of a 3,000-step tidy1 `mf` run.
#[inline(always)]
fn decide<const KIND: u8, const HUMAN: bool, const NA: usize, const BABBLING: bool>(
    spec: &Spec,
    params: &Params,
    run: &mut RunView<'_>,
    s: usize,
) -> usize {
    let babbling = BABBLING;
    let n_a = actions::<NA>(spec);
    let row = s * n_a..(s + 1) * n_a;
    let controller = controller(KIND);

    // 3. Selection, from what earlier visits stored.
    let rng = &mut *run.rng;
    // The batch may hold no tables for an expert the controller does not run: each is indexed
    // only when the controller asks for its entropy.
    let (pavg_mf, pavg_mb) = (&*run.pavg_mf, &*run.pavg_mb);
    let (entropy_mf, entropy_mb) = (&mut *run.entropy_mf, &mut *run.entropy_mb);
    let choice = meta::choose(
        params,
        controller,
        n_a,
        || entropy_bits_kept(&mut entropy_mf[s], &pavg_mf[row.clone()]),
        || entropy_bits_kept(&mut entropy_mb[s], &pavg_mb[row.clone()]),
        run.cost_mf[s],
        run.cost_mb[s],
        || uniform(rng),
    );

    // 4. Inference: the chosen expert, and both at a first decision of a two-expert controller.
    let first = !run.visited[s];
    run.visited[s] = true;
    let both = first && controller.is_dual();
    let wallclock = params.cost_model == CostModel::Wallclock;
    let mut cost_mf = 0.0;
    let mut cost_mb = 0.0;
    if controller.runs_mf() && (!choice.use_mb || both) {
        let started = wallclock.then(Instant::now);
        // MF inference is reading its row, which the softmax below does.
        std::hint::black_box(&run.q_mf[row.clone()]);
        cost_mf = match started {
            Some(t) => t.elapsed().as_secs_f64(),
            None => mf::inference_ops(n_a) as f64,
        };
        run.cost_mf[s] = ema(run.cost_mf[s], cost_mf, params.filter_alpha);
    }
    if controller.runs_mb() && (choice.use_mb || both) {
        let started = wallclock.then(Instant::now);
        // Only value iteration writes the MB's Q table, so its cached row maxima stay valid.
        let report = run.model.value_iteration_cached(
            run.q_mb,
            params.gamma_mb,
            params.vi_epsilon,
            params.vi_max_sweeps,
        );
        cost_mb = match started {
            Some(t) => t.elapsed().as_secs_f64(),
            None => report.ops as f64,
        };
        run.cost_mb[s] = ema(run.cost_mb[s], cost_mb, params.filter_alpha);
        run.stats.vi_calls += 1;
        run.stats.vi_sweeps += u64::from(report.sweeps);
        // NOTE: `if`, not `+= u64::from(bool)`: rustc 1.95 at opt-level >= 2 miscompiles a
        // bool-to-integer add whose bool is branched on again (a minimal repro counts 0).
        if report.capped {
            run.stats.vi_capped += 1;
        }
        if !HUMAN && report.changed {
            for flags in run.settled.iter_mut() {
                *flags &= !(Settled::MB_SOFTMAX | Settled::MB_AVERAGE);
            }
        }
    }

    // 5. Decision: each expert the controller runs computes its (biased) softmax and folds it in.
    let bonus = if HUMAN {
        human::bonus_weight(&run.cursor.human, params.congratulation_effect)
    } else {
        0.0
    };
    // An `mf` run without a human keeps its softmax of each state in `p_mf`; other runs compute
    // theirs into scratch space.
    let keeps_softmax = KIND == MF && !HUMAN;
    let (scratch_mf, p_mb) = run.scratch.split_at_mut(n_a);
    let p_mf = if keeps_softmax {
        &mut run.p_mf[row.clone()]
    } else {
        scratch_mf
    };
    // Without a human, flags say which folds would change nothing.
    let mut none = 0;
    let settled = if HUMAN {
        &mut none
    } else {
        &mut run.settled[s]
    };
    let g = &run.bonus[row.clone()];
    let (tau, alpha) = (params.tau, params.filter_alpha);
    if controller.runs_mf() {
        let fold = Fold {
            softmax: Settled::SOFTMAX,
            average: Settled::AVERAGE,
            drawn: !choice.use_mb,
            kept: keeps_softmax,
        };
        let avg = &mut run.pavg_mf[row.clone()];
        let q = &run.q_mf[row.clone()];
        fold.run(
            q,
            g,
            bonus,
            tau,
            p_mf,
            avg,
            alpha,
            settled,
            &mut run.entropy_mf[s],
        );
    }
    if controller.runs_mb() {
        let fold = Fold {
            softmax: Settled::MB_SOFTMAX,
            average: Settled::MB_AVERAGE,
            drawn: choice.use_mb,
            kept: false,
        };
        let avg = &mut run.pavg_mb[row.clone()];
        let q = &run.q_mb[row.clone()];
        fold.run(
            q,
            g,
            bonus,
            tau,
            p_mb,
            avg,
            alpha,
            settled,
            &mut run.entropy_mb[s],
        );
    }
    let a = draw(if choice.use_mb { p_mb } else { p_mf }, uniform(run.rng));

    if !babbling {
        let stats = &mut *run.stats;
        stats.cost_mf += cost_mf;
        stats.cost_mb += cost_mb;
        stats.decisions += 1;
        if choice.use_mb {
            stats.mb_decisions += 1;
        }
        stats.p_mb_sum += choice.p_mb;
        stats.entropy_sum += choice.chosen_entropy;
        run.cursor.window_p_mb += choice.p_mb;
        run.cursor.window_decisions += 1;
    }
    a
}

/// One expert's step 5 in a state: its softmax, and the fold of that softmax into its averaged
/// distribution, each skipped where the state's [`Settled`] flags (`softmax` and `average`, this
/// expert's bits) say it would give what it gave last time.
struct Fold {
    softmax: u8,
    average: u8,
    /// The action is drawn from this expert's softmax, so it is needed whatever the flags say.
    drawn: bool,
    /// The softmax is written where it stays between decisions (an `mf` run's `p_mf`), so while
    /// the row is unchanged it is there already.
    kept: bool,
}

impl Fold {
    /// Writes the softmax of `q` (with bonus `bonus * g`, temperature `tau`) into `p` when it is
    /// needed, folds it into `avg` unless that is known to change nothing, and updates `settled`;
    /// a changed `avg` makes its kept `entropy` unknown (NaN). Returns whether `avg` changed.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn run(
        &self,
        q: &[f64],
        g: &[u8],
        bonus: f64,
        tau: f64,
        p: &mut [f64],
        avg: &mut [f64],
        alpha: f64,
        settled: &mut u8,
        entropy: &mut f64,
    ) -> bool {
        let both = self.softmax | self.average;
        let unchanged = *settled & both == both;
        let fresh = self.kept && *settled & self.softmax != 0;
        if !fresh && (self.drawn || !unchanged) {
            softmax_biased(q, g, bonus, tau, p);
        }
        if unchanged {
            return false;
        }
        let changed = ema_into(avg, p, alpha);
        *settled = (*settled & !both) | if changed { self.softmax } else { both };
        if changed {
            *entropy = f64::NAN;
        }
        changed
    }
}

/// The entropy in bits of `row`, an averaged distribution, from `kept` unless that is NaN (not
/// known since the row last changed), in which case it is computed and kept.
#[inline(always)]
fn entropy_bits_kept(kept: &mut f64, row: &[f64]) -> f64 {
    if kept.is_nan() {
        *kept = entropy_bits(row);
    }
    *kept
}

/// Applies the actions of `plan` due at experiment step `t_exp` (none while babbling), in order.
#[inline]
fn apply_due(plan: &Plan, params: &Params, run: &mut RunView<'_>, t_exp: u32) {
    while let Some(&(step, action)) = plan.actions.get(usize::from(run.cursor.next_action)) {
        if step != t_exp {
            break;
        }
        if run.cursor.next_action == 0 {
            run.stats.first_change_step = t_exp;
            run.stats.reward_before_change = run.stats.total_reward;
        }
        run.cursor.next_action += 1;
        let cursor = &mut *run.cursor;
        match action {
            Action::World(world) => cursor.world = world,
            Action::Human(change) => match change {
                HumanChange::Interaction(i) => cursor.human.interaction = i,
                HumanChange::Budget(n) => cursor.budget_left = n,
                HumanChange::Forget(p) => cursor.human.forget_prob = p,
                HumanChange::Zeta(z) => cursor.human.zeta = z,
                HumanChange::Profile(p) => {
                    if let Some(h) = p.human(params.controller) {
                        cursor.human = h;
                        cursor.budget_left = h.budget;
                    }
                    if let Some(source) = p.reward_source() {
                        cursor.reward_source = source;
                    }
                }
                HumanChange::RewardSource(source) => cursor.reward_source = source,
            },
        }
    }
}

/// Writes the checkpoint row of experiment step `t_exp` (every `checkpoint` steps and the last;
/// the caller counts down to it).
#[inline(never)]
fn record_checkpoint(run: &mut RunView<'_>, t_exp: u32) {
    let cursor = &mut *run.cursor;
    let stats = &*run.stats;
    let decisions = cursor.window_decisions;
    run.series[cursor.checkpoints_written as usize] = Checkpoint {
        step: t_exp,
        cum_reward: stats.total_reward,
        cum_cost_mf: stats.cost_mf,
        cum_cost_mb: stats.cost_mb,
        p_mb_mean: if decisions > 0 {
            cursor.window_p_mb / f64::from(decisions)
        } else {
            f64::NAN
        },
        decisions,
        interactions: stats.interactions(),
    };
    cursor.checkpoints_written += 1;
    cursor.window_p_mb = 0.0;
    cursor.window_decisions = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    const MF_BITS: u8 = Settled::SOFTMAX | Settled::AVERAGE;
    const G: [u8; 3] = [0; 3];

    /// One state's MF softmax buffer, averaged distribution, flags and kept entropy.
    struct State {
        p: [f64; 3],
        avg: [f64; 3],
        settled: u8,
        entropy: f64,
    }

    impl State {
        /// [`Fold::run`] of the MF expert on row `q` (temperature 0.5, alpha 0.6, no bonus).
        fn fold(&mut self, q: &[f64; 3], drawn: bool, kept: bool) -> bool {
            let fold = Fold {
                softmax: Settled::SOFTMAX,
                average: Settled::AVERAGE,
                drawn,
                kept,
            };
            let (p, avg) = (&mut self.p, &mut self.avg);
            fold.run(
                q,
                &G,
                0.0,
                0.5,
                p,
                avg,
                0.6,
                &mut self.settled,
                &mut self.entropy,
            )
        }
    }

    fn softmax(q: &[f64; 3]) -> [f64; 3] {
        let mut p = [0.0; 3];
        softmax_biased(q, &G, 0.0, 0.5, &mut p);
        p
    }

    #[test]
    fn a_settled_fold_is_skipped_and_its_softmax_only_computed_when_drawn() {
        let q = [0.0, 1.0, 0.5];
        // A kept entropy of the average; folding that moves the average makes it unknown.
        let mut st = State {
            p: [0.0; 3],
            avg: [1.0 / 3.0; 3],
            settled: 0,
            entropy: 1.0,
        };
        // The first fold moves the average: only SOFTMAX is set, and it says so.
        assert!(st.fold(&q, false, false));
        assert_eq!(st.settled, Settled::SOFTMAX);
        assert!(st.entropy.is_nan());
        assert_eq!(st.p, softmax(&q));
        // Folding the same softmax converges (the moving average reaches a fixed point).
        let folds = (1..200).find(|_| {
            st.fold(&q, false, false);
            st.settled & MF_BITS == MF_BITS
        });
        assert!(folds.expect("the average settles") > 1);
        let settled_avg = st.avg;
        st.entropy = 2.0;
        // Settled and not drawn: neither the softmax nor the average (nor its entropy) is touched.
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, false, false));
        assert!(st.p.iter().all(|x| x.is_nan()));
        assert_eq!((st.avg, st.entropy), (settled_avg, 2.0));
        // Drawn from: the softmax is computed again (bit for bit the same), the fold still not.
        assert!(!st.fold(&q, true, false));
        assert_eq!(st.p, softmax(&q));
        assert_eq!(st.avg, settled_avg);
        // Kept where it stays (an mf run's p_mf): not even the drawn softmax is recomputed.
        st.p = [f64::NAN; 3];
        assert!(!st.fold(&q, true, true));
        assert!(st.p.iter().all(|x| x.is_nan()));
        // A changed row (learning clears the flags) is computed and folded again.
        st.settled &= !MF_BITS;
        let q2 = [2.0, 1.0, 0.5];
        assert!(st.fold(&q2, false, false));
        assert_eq!(st.p, softmax(&q2));
        assert_eq!(st.settled & MF_BITS, Settled::SOFTMAX);
    }

    #[test]
    fn the_other_expert_s_flags_are_left_alone() {
        let mut st = State {
            p: [0.0; 3],
            avg: [0.5, 0.25, 0.25],
            settled: Settled::MB_SOFTMAX | Settled::MB_AVERAGE,
            entropy: 0.0,
        };
        st.fold(&[0.3, 0.1, 0.0], false, false);
        assert_eq!(
            st.settled,
            Settled::MB_SOFTMAX | Settled::MB_AVERAGE | Settled::SOFTMAX
        );
    }
}
