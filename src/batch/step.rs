//! One step of one run, in the order of SPEC 3.4.
//!
//! Random draws, in this order and only when needed: the human's attentiveness at a takeover
//! opportunity; the MC's draw (`rnd`, softmax selection, or an argmax tie); the action; the
//! environment's outcome (pairs with several outcomes only); the human's attentiveness at a
//! nuisance opportunity (SPEC 11.2); at a human-reward opportunity (11.1); at a congratulation
//! or punishment opportunity. A reset step draws an initial state only when the environment has
//! several.
//!
//! The events of the run's schedule due at an experiment step apply first, before anything of
//! that step (SPEC 10); from then on the step reads the world, goal and human from the cursor.

use std::time::Instant;

use super::{Checkpoint, RunView, initial_state, uniform};
use crate::env::Spec;
use crate::expert::{draw, ema, ema_into, mf, softmax_biased};
use crate::human;
use crate::meta;
use crate::params::{CongratulationEffect, CostModel, Interaction, Params, RewardSource};
use crate::schedule::{Action, HumanChange, Plan};

/// Advances one run by one step: a babbling step while `cursor.t < babbling`, then an experiment
/// step. At the end of babbling the environment is reset to an initial state (not a step).
#[inline]
pub fn step(spec: &Spec, params: &Params, window_cap: usize, run: &mut RunView<'_>) {
    let babbling = run.cursor.t < u64::from(params.babbling);
    let s = run.cursor.state as usize;
    run.cursor.t += 1;
    // Experiment step number, 1-based (0 while babbling).
    let t_exp = if babbling {
        0
    } else {
        (run.cursor.t - u64::from(params.babbling)) as u32
    };
    let plan = run.plan;
    if let Some(plan) = plan {
        apply_due(plan, params, run, t_exp);
    }
    let spec = plan.map_or(spec, |p| &*p.worlds[usize::from(run.cursor.world)]);

    if run.cursor.pending_reset {
        // 1. The reset step: time passes, nothing is decided or learned (SPEC 2.1). Whether
        // this is one was decided by the previous arrival, even if the goal has since moved.
        run.cursor.pending_reset = false;
        run.cursor.state = initial_state(spec, run.rng);
    } else {
        act(spec, params, window_cap, run, s, babbling, t_exp);
    }

    if babbling && run.cursor.t == u64::from(params.babbling) {
        // End of babbling: back to the start; a pending reset step is dropped (SPEC 7).
        run.cursor.pending_reset = false;
        run.cursor.state = initial_state(spec, run.rng);
    }
    if !babbling {
        record_checkpoint(params, run, t_exp);
    }
}

/// Steps 2 to 8 of SPEC 3.4 in a non-goal state.
#[inline]
fn act(
    spec: &Spec,
    params: &Params,
    window_cap: usize,
    run: &mut RunView<'_>,
    s: usize,
    babbling: bool,
    t_exp: u32,
) {
    let n_a = spec.n_actions;
    let human = run.cursor.human;
    let human = &human;
    let human_active = !babbling && run.cursor.budget_left > 0;

    // 2. Takeover.
    let tables = spec.human.as_ref();
    let action = human::takeover(
        human,
        tables,
        human_active,
        s,
        &mut run.cursor.budget_left,
        run.stats,
        t_exp,
        run.rng,
    );
    let a = match action {
        Some(a) => a,
        None => decide(spec, params, run, s, babbling),
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
    // 11.2: a nuisance human undoes a relevant action before anything learns from it.
    if let Some(undone) = human::nuisance(
        human,
        tables,
        human_active,
        sa,
        &mut run.cursor.budget_left,
        run.stats,
        t_exp,
        run.rng,
    ) {
        next = undone;
    }
    let terminal = next == run.cursor.goal as usize;
    let mut reward = if babbling || !terminal {
        0.0
    } else {
        run.cursor.goal_reward
    };
    // 11.1: where only the human brings reward, an arrival in the goal is an opportunity.
    if terminal && !babbling && run.cursor.reward_source == RewardSource::Human {
        reward = human::reward(
            human,
            reward,
            &mut run.cursor.budget_left,
            run.stats,
            t_exp,
            run.rng,
        );
    }

    // 7. Feedback: G(s, a) is set by an attentive human with budget, reset otherwise (Eq. 8).
    let g = human::feedback(
        human,
        tables,
        human_active,
        sa,
        &mut run.cursor.budget_left,
        run.stats,
        t_exp,
        run.rng,
    );
    // 11.3: a congratulation that shapes the reward is learned, not shown to the softmax.
    let shaped = g == 1
        && human.interaction == Interaction::Congratulation
        && params.congratulation_effect == CongratulationEffect::Reward;
    let learned = if shaped { reward + human.zeta } else { reward };
    run.bonus[sa] = if shaped { 0 } else { g };

    // 8. Learning, by every expert the controller runs. The arrival is terminal when it is the
    // goal at this time (SPEC 10): both experts learn that from the transition itself.
    run.cursor.pending_reset = terminal;
    if params.controller.runs_mf() {
        mf::learn(
            run.q_mf,
            n_a,
            s,
            a,
            learned,
            next,
            terminal,
            params.alpha_mf,
            params.gamma_mf,
        );
    }
    if params.controller.runs_mb() {
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

/// Steps 3 to 5 of SPEC 3.4: the MC chooses, experts infer and compute their softmax, and the
/// action is drawn from the chosen expert's distribution.
#[inline]
fn decide(spec: &Spec, params: &Params, run: &mut RunView<'_>, s: usize, babbling: bool) -> usize {
    let n_a = spec.n_actions;
    let row = s * n_a..(s + 1) * n_a;
    let controller = params.controller;

    // 3. Selection, from what earlier visits stored.
    let rng = &mut *run.rng;
    let choice = meta::choose(
        params,
        &run.pavg_mf[row.clone()],
        &run.pavg_mb[row.clone()],
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
    }

    // 5. Decision: each expert the controller runs computes its (biased) softmax and folds it in.
    let bonus = human::bonus_weight(&run.cursor.human, params.congratulation_effect);
    let (p_mf, p_mb) = run.scratch.split_at_mut(n_a);
    let g = &run.bonus[row.clone()];
    if controller.runs_mf() {
        softmax_biased(&run.q_mf[row.clone()], g, bonus, params.tau, p_mf);
        ema_into(&mut run.pavg_mf[row.clone()], p_mf, params.filter_alpha);
    }
    if controller.runs_mb() {
        softmax_biased(&run.q_mb[row.clone()], g, bonus, params.tau, p_mb);
        ema_into(&mut run.pavg_mb[row], p_mb, params.filter_alpha);
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
            Action::World { world, goal } => {
                cursor.world = world;
                cursor.goal = goal;
            }
            Action::Goal { state, reward } => {
                cursor.goal = state;
                if let Some(r) = reward {
                    cursor.goal_reward = r;
                }
            }
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

/// Writes a checkpoint row every `checkpoint` experiment steps and at the last step.
#[inline]
fn record_checkpoint(params: &Params, run: &mut RunView<'_>, t_exp: u32) {
    if params.checkpoint == 0 || (!t_exp.is_multiple_of(params.checkpoint) && t_exp != params.steps)
    {
        return;
    }
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
