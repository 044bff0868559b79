//! One step of one run, in the order of SPEC 3.4.
//!
//! Random draws, in this order and only when needed: the human's attentiveness at a takeover
//! opportunity; the MC's draw (`rnd`, softmax selection, or an argmax tie); the action; the
//! environment's outcome (pairs with several outcomes only); the reward (drawn rewards only);
//! the human's attentiveness at a nuisance opportunity (SPEC 11.2); at a human-reward
//! opportunity (11.1); at a congratulation or punishment opportunity, then, with `error_prob`
//! above 0, the human's judgment there (SPEC 15). A reset step draws an initial state only when
//! the environment has several.
//!
//! The events of the run's schedule due at an experiment step apply first, before anything of
//! that step (SPEC 10); from then on the step reads the world and human from the cursor.

use std::time::Instant;

use super::settled::{Expert, Fold, Kept};
use super::storage::kept_slot;
use super::trace::{self, Actor, HumanEvent};
use super::{Checkpoint, RunView, Settled, initial_state, uniform};
use crate::arbiter::{self, Arbiter, Draw, Inputs, Mixed, Own, Transition, Visit};
use crate::env::{End, Spec};
use crate::expert::mf::Eligibility;
use crate::expert::{draw, ema, entropy_bits, max_of, mf, normalise_bits, softmax_graded_by};
use crate::human::{self, Encounter};
use crate::params::{
    Combine, CongratulationEffect, CostModel, HumanParams, Interaction, Params, RewardSource,
};
use crate::schedule::{Action, HumanChange, Plan};

/// Advances one run by one step: a babbling step while `cursor.t < babbling`, then an experiment
/// step. At the end of babbling the environment is reset to an initial state (not a step).
#[inline]
pub fn step(spec: &Spec, params: &Params, run: &mut RunView<'_>) {
    let end = run.cursor.t + 1;
    run_until(spec, params, run, end);
}

/// Advances one run until `cursor.t` reaches `end` (or the run ends): babbling, then the
/// experiment, each as its own loop of a step compiled for the run's controller and for whether a
/// human (or a schedule) can act at all, so none of that is branched on per step.
pub(super) fn run_until(spec: &Spec, params: &Params, run: &mut RunView<'_>, end: u64) {
    // Without a schedule, a human that never interacts and the environment's own reward, no
    // human function can do anything: the steps skip them.
    let human = run.plan.is_some() || params.human_may_act();
    // A traced run records a row per experiment step: its own compiled loop.
    let trace = !run.trace.is_empty();
    let code = Loop {
        spec,
        params,
        run,
        end,
        human,
        trace,
    };
    arbiter::dispatch(params.controller, code);
}

/// [`run_until`]'s arguments, waiting for the run's arbitration rule.
struct Loop<'r, 'v> {
    spec: &'r Spec,
    params: &'r Params,
    run: &'r mut RunView<'v>,
    end: u64,
    human: bool,
    trace: bool,
}

impl Visit for Loop<'_, '_> {
    type Output = ();

    /// The loop for rule `A`, the human mode, the action count, the MF's eligibility trace and
    /// the per-step trace. The tidy tasks' 7 actions get their own copy, whose rows have a
    /// length known at compile time (loops unrolled, no remainder handling); other action counts
    /// share a generic one (`NA` 0: read from the spec), and so do runs with an eligibility trace
    /// (`ELIGIBILITY`, `lambda_mf` > 0).
    /// A rule that gives a weight runs as [`Mixed`] under `combine = mix`; others ignore it.
    #[inline(always)]
    fn visit<A: Arbiter>(self) {
        if A::COMBINES && self.params.combine == Combine::Mix {
            self.loops::<Mixed<A>>();
        } else {
            self.loops::<A>();
        }
    }
}

impl Loop<'_, '_> {
    /// [`Visit::visit`] once the rule's type is final.
    #[inline(always)]
    fn loops<A: Arbiter>(self) {
        let Loop {
            spec,
            params: p,
            run,
            end,
            human,
            trace,
        } = self;
        let eligibility = A::RUNS_MF && !A::LEARNS_MF && p.uses_eligibility();
        match (
            spec.n_actions == 7 && !eligibility,
            human,
            eligibility,
            trace,
        ) {
            (true, false, _, false) => run_loop::<A, false, 7, false, false>(spec, p, run, end),
            (true, true, _, false) => run_loop::<A, true, 7, false, false>(spec, p, run, end),
            (true, false, _, true) => run_loop::<A, false, 7, false, true>(spec, p, run, end),
            (true, true, _, true) => run_loop::<A, true, 7, false, true>(spec, p, run, end),
            (false, false, false, false) => {
                run_loop::<A, false, 0, false, false>(spec, p, run, end)
            }
            (false, true, false, false) => run_loop::<A, true, 0, false, false>(spec, p, run, end),
            (false, false, false, true) => run_loop::<A, false, 0, false, true>(spec, p, run, end),
            (false, true, false, true) => run_loop::<A, true, 0, false, true>(spec, p, run, end),
            (false, false, true, false) => run_loop::<A, false, 0, true, false>(spec, p, run, end),
            (false, true, true, false) => run_loop::<A, true, 0, true, false>(spec, p, run, end),
            (false, false, true, true) => run_loop::<A, false, 0, true, true>(spec, p, run, end),
            (false, true, true, true) => run_loop::<A, true, 0, true, true>(spec, p, run, end),
        }
    }
}

/// [`run_until`] for one arbitration rule, human mode, action count, MF eligibility trace
/// and per-step trace mode.
fn run_loop<
    A: Arbiter,
    const HUMAN: bool,
    const NA: usize,
    const ELIGIBILITY: bool,
    const TRACE: bool,
>(
    spec: &Spec,
    params: &Params,
    run: &mut RunView<'_>,
    end: u64,
) {
    let babbling = u64::from(params.babbling);
    let end = end.min(babbling + u64::from(params.steps));
    let babble_end = end.min(babbling);
    if run.cursor.t < babble_end {
        while run.cursor.t < babble_end {
            one_step::<A, HUMAN, NA, ELIGIBILITY, true, false>(spec, params, run, 0);
        }
        if run.cursor.t == babbling {
            // End of babbling: back to the start; a pending reset step is dropped (SPEC 7).
            let world = world(spec, run);
            run.cursor.pending_reset = false;
            run.cursor.state = initial_state(world, run.rng);
            // The task's state is drawn afresh for the experiment (SPEC 13).
            if let Some(d) = &world.dynamics {
                (d.start)(d, run.task_state, run.rng);
            }
            // The tally counts the experiment only; the trace ends with the episode (SPEC 3.1).
            run.tally.fill(0.0);
            if ELIGIBILITY {
                eligibility(run).clear();
            }
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
        one_step::<A, HUMAN, NA, ELIGIBILITY, false, TRACE>(spec, params, run, t_exp);
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

/// The run's MF eligibility trace (runs with `lambda_mf` > 0 only).
#[inline(always)]
fn eligibility<'r>(run: &'r mut RunView<'_>) -> Eligibility<'r> {
    Eligibility {
        e: run.eligibility,
        pairs: run.eligible,
        len: &mut run.cursor.eligible,
    }
}

/// One step (SPEC 3.4) at experiment step `t_exp` (0 while babbling), recording its trace row
/// when `TRACE` (never while babbling).
#[inline(always)]
fn one_step<
    A: Arbiter,
    const HUMAN: bool,
    const NA: usize,
    const ELIGIBILITY: bool,
    const BABBLING: bool,
    const TRACE: bool,
>(
    spec: &Spec,
    params: &Params,
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
        if TRACE {
            run.trace.record(
                t_exp,
                trace::Row {
                    state: s as u32,
                    action: trace::NO_ACTION,
                    next_state: run.cursor.state,
                    reward: 0.0,
                    terminal: false,
                    actor: Actor::Reset,
                    p_mb: f64::NAN,
                    event: HumanEvent::None,
                },
            );
        }
        if ELIGIBILITY {
            eligibility(run).clear();
        }
    } else {
        act::<A, HUMAN, NA, ELIGIBILITY, BABBLING, TRACE>(spec, params, run, s, t_exp);
    }
}

/// Steps 2 to 8 of SPEC 3.4 in a non-goal state.
#[inline(always)]
fn act<
    A: Arbiter,
    const HUMAN: bool,
    const NA: usize,
    const ELIGIBILITY: bool,
    const BABBLING: bool,
    const TRACE: bool,
>(
    spec: &Spec,
    params: &Params,
    run: &mut RunView<'_>,
    s: usize,
    t_exp: u32,
) {
    let babbling = BABBLING;
    let n_a = actions::<NA>(spec);
    let human = run.cursor.human;
    let human = &human;
    let human_active = HUMAN && !babbling && run.cursor.budget_left > 0;
    // The trace tells the step's interaction from the counters it moved.
    let counted = if TRACE && HUMAN {
        Some(*run.stats)
    } else {
        None
    };

    // 2. Takeover.
    let action = if human_active {
        encounter(spec, human, run, t_exp).takeover(s)
    } else {
        None
    };
    let (a, actor, p_mb) = match action {
        Some(a) => (a, Actor::Human, f64::NAN),
        None => decide::<A, HUMAN, NA, BABBLING>(spec, params, run, s),
    };

    // 6. Environment.
    let sa = spec.sa(s, a);
    let outcomes = spec.outcomes(sa);
    let o = if outcomes.len() == 1 {
        outcomes.start
    } else {
        spec.pick_outcome(sa, uniform(run.rng))
    };
    // Most outcomes bring nothing: their landing says so, and only the others' arrival is read.
    let landing = spec.landing[o];
    let mut next = landing.state as usize;
    let (mut terminal, mut reset, mut arrival_reward) = (false, false, 0.0);
    if landing.eventful {
        let arrival = spec.arrival[o];
        terminal = arrival.terminal();
        reset = arrival.end == End::Reset;
        arrival_reward = arrival.reward;
        // A drawn reward: its draw comes right after the outcome's (a fixed one draws nothing).
        if let Some(p) = arrival.chance.p(run.task_state)
            && uniform(run.rng) >= p
        {
            arrival_reward = 0.0;
        }
        // A task that tallies its steps marks every outcome eventful (no other task pays).
        if let Some(tally) = &spec.tally {
            (tally.note)(run.tally, s, a, next, arrival_reward);
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
    // Without a human, G stays 0 from the start.
    if HUMAN {
        run.bonus[sa] = if shaped { 0 } else { g };
    }

    // 8. Learning, by every expert the rule runs (after the rule has seen the transition). The arrival is
    // terminal when the world at this time says so (SPEC 10): both experts learn that from the transition itself.
    run.cursor.pending_reset = reset;
    let t = Transition {
        s,
        a,
        r: learned,
        next,
        terminal,
        n_actions: n_a,
        r_max: spec.max_abs_reward(),
    };
    if A::OBSERVES {
        let mut own = Own {
            run: run.arbiter_run,
            pairs: run.arbiter_pairs,
        };
        A::observe(params, &mut own, &t, run.q_mf, &run.model);
    }
    if A::LEARNS_MF {
        let before = run.q_mf[sa];
        let mut own = Own {
            run: run.arbiter_run,
            pairs: run.arbiter_pairs,
        };
        A::learn_mf(params, &mut own, &t, run.q_mf);
        if !HUMAN && run.q_mf[sa].to_bits() != before.to_bits() {
            run.settled[s].q_changed(Expert::Mf);
        }
    } else if A::RUNS_MF && ELIGIBILITY {
        // SPEC 3.1 with lambda_mf > 0: the TD error of (s, a) goes to every traced pair.
        let future = mf::future(run.q_mf, n_a, next, terminal);
        let delta = learned + params.gamma_mf * future - run.q_mf[sa];
        let decay = params.gamma_mf * params.lambda_mf;
        let settled = &mut *run.settled;
        let mut trace = Eligibility {
            e: run.eligibility,
            pairs: run.eligible,
            len: &mut run.cursor.eligible,
        };
        trace.learn(
            run.q_mf,
            sa,
            delta,
            params.alpha_mf,
            decay,
            terminal,
            |pair| {
                if !HUMAN {
                    settled[pair / n_a].q_changed(Expert::Mf);
                }
            },
        );
    } else if A::RUNS_MF {
        // An `mf` run without a human keeps each Q row's maximum; other runs read the row.
        let future = match (mf_alone::<A>() && !HUMAN, terminal) {
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
            run.settled[s].q_changed(Expert::Mf);
            if mf_alone::<A>() {
                run.max_mf[s] = max_of(&run.q_mf[s * n_a..(s + 1) * n_a]);
            }
        }
    }
    if A::RUNS_MB {
        run.model
            .learn(params.window_n as usize, s, a, next, learned, terminal);
    }

    if TRACE {
        run.trace.record(
            t_exp,
            trace::Row {
                state: s as u32,
                action: a as u16,
                next_state: next as u32,
                reward,
                terminal,
                actor,
                p_mb,
                event: counted.map_or(HumanEvent::None, |before| {
                    HumanEvent::between(&before, run.stats)
                }),
            },
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
    // The task's own dynamics after a terminal arrival, after every other draw of the step.
    if terminal && let Some(d) = &spec.dynamics {
        (d.after_episode)(d, run.task_state, run.rng);
    }
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
        put: &mut run.cursor.person_put,
    }
}

/// Steps 3 to 5 of SPEC 3.4: the MC chooses, experts infer and compute their softmax, and the
/// action is drawn from the chosen expert's distribution. Returns the action, who chose it
/// (SPEC 14's `actor`) and the decision's P(MB).
///
/// What a decision computes from rows that have not changed since the last decision in the
/// state is taken from then, bit for bit the same: the entropies of the averaged distributions
/// (kept per state until a moving average changes the row) and, without a human, each expert's
/// softmax and moving average while its Q row is unchanged (see [`Settled`]; the softmax
/// itself while its kept slot still holds it, [`kept_or`]). Once Q-learning has converged in a
/// state, none of them changes: about 19 decisions in 20 of a 3,000-step tidy1 `mf` run.
#[inline(always)]
fn decide<A: Arbiter, const HUMAN: bool, const NA: usize, const BABBLING: bool>(
    spec: &Spec,
    params: &Params,
    run: &mut RunView<'_>,
    s: usize,
) -> (usize, Actor, f64) {
    let babbling = BABBLING;
    let n_a = actions::<NA>(spec);
    let row = s * n_a..(s + 1) * n_a;

    // 3. Selection, from what earlier visits stored. The batch may hold no tables for an expert
    // the rule does not run: each is indexed only when the rule asks for its entropy.
    let mut inputs = Inputs {
        params,
        n_actions: n_a,
        state: s,
        own: Own {
            run: run.arbiter_run,
            pairs: run.arbiter_pairs,
        },
        row: row.clone(),
        costs_mf: run.cost_mf,
        costs_mb: run.cost_mb,
        q_mf: run.q_mf,
        pavg_mf: run.pavg_mf,
        pavg_mb: run.pavg_mb,
        entropy_mf: run.entropy_mf,
        entropy_mb: run.entropy_mb,
        rng: run.rng,
    };
    let mut choice = A::choose(&mut inputs);

    // 4. Inference: the chosen expert, and both at a first decision of a two-expert controller.
    let first = !run.visited[s];
    run.visited[s] = true;
    // Mix: both experts infer at every decision; per action: MF always, MB when asked.
    let both = (first && A::FIRST_DECISION_BOTH) || A::DRAW == Draw::Mix;
    let mf_infers = !choice.use_mb || both || A::DRAW == Draw::PerAction;
    let wallclock = params.cost_model == CostModel::Wallclock;
    let mut cost_mf = 0.0;
    let mut cost_mb = 0.0;
    if A::RUNS_MF && mf_infers {
        let started = wallclock.then(Instant::now);
        // MF inference is reading its row, which the softmax below does.
        std::hint::black_box(&run.q_mf[row.clone()]);
        cost_mf = match started {
            Some(t) => t.elapsed().as_secs_f64(),
            None => mf::inference_ops(n_a) as f64,
        };
        if A::WEIGHS_COST {
            run.cost_mf[s] = ema(run.cost_mf[s], cost_mf, params.filter_alpha);
        }
    }
    if A::RUNS_MB && (choice.use_mb || both) {
        let started = wallclock.then(Instant::now);
        // Only value iteration writes the MB's Q table, so its cached row maxima stay valid;
        // without a human, a state whose row it changed must compute MB's softmax again.
        let settled = &mut *run.settled;
        let report = run.model.value_iteration_noting(
            run.q_mb,
            params.gamma_mb,
            params.vi_epsilon,
            params.vi_max_sweeps,
            |changed| {
                if !HUMAN {
                    settled[changed].q_changed(Expert::Mb);
                }
            },
        );
        cost_mb = match started {
            Some(t) => t.elapsed().as_secs_f64(),
            None => report.ops as f64,
        };
        if A::WEIGHS_COST {
            run.cost_mb[s] = ema(run.cost_mb[s], cost_mb, params.filter_alpha);
        }
        run.stats.vi_calls += 1;
        run.stats.vi_sweeps += u64::from(report.sweeps);
        // NOTE: `if`, not `+= u64::from(bool)`: rustc 1.95 at opt-level >= 2 miscompiles a
        // bool-to-integer add whose bool is branched on again (a minimal repro counts 0).
        if report.capped {
            run.stats.vi_capped += 1;
        }
    }

    // 5. Decision: each expert the rule runs computes its (biased) softmax and folds it in.
    let bonus = if HUMAN {
        human::bonus_weight(&run.cursor.human, params.congratulation_effect)
    } else {
        0.0
    };
    // A run without a human that folds keeps its experts' softmaxes between decisions where the
    // batch holds slots for them; other runs compute theirs into scratch space.
    let keeps = A::AVERAGES && !HUMAN;
    let (scratch_mf, scratch_mb) = run.scratch.split_at_mut(n_a);
    let (p_mf, kept_mf) = kept_or(keeps, run.kept_p_mf, run.kept_owner_mf, s, scratch_mf);
    let (p_mb, kept_mb) = kept_or(keeps, run.kept_p_mb, run.kept_owner_mb, s, scratch_mb);
    // Without a human, flags say which folds would change nothing.
    let mut none = Settled::default();
    let settled = if HUMAN {
        &mut none
    } else {
        &mut run.settled[s]
    };
    let g = &run.bonus[row.clone()];
    // A person's G may be -1 (a punishment): read signed, in their runs only.
    let signed = HUMAN && run.cursor.human.interaction == Interaction::Person;
    let (tau, alpha) = (params.tau, params.filter_alpha);
    // Per action (vpi), a decision that values every action by one expert draws from that
    // expert's softmax as it is folded (the same function of the same row), not a copy of it.
    let per_action = A::DRAW == Draw::PerAction;
    let whole = if !per_action {
        None
    } else if !choice.use_mb && A::RUNS_MF {
        Some(Expert::Mf)
    } else if choice.p_mb == 1.0 && A::RUNS_MB {
        Some(Expert::Mb)
    } else {
        None
    };
    if A::RUNS_MF && !A::AVERAGES {
        if whole == Some(Expert::Mf) {
            softmax_graded_by(signed, &run.q_mf[row.clone()], g, bonus, tau, p_mf);
        }
    } else if A::RUNS_MF {
        let fold = Fold {
            expert: Expert::Mf,
            drawn: (A::DRAW == Draw::Expert && !choice.use_mb) || whole == Some(Expert::Mf),
            q: &run.q_mf[row.clone()],
            g,
            signed,
            bonus,
            tau,
            alpha,
        };
        settled.fold(
            &fold,
            p_mf,
            kept_mf,
            &mut run.pavg_mf[row.clone()],
            &mut run.entropy_mf[s],
        );
    }
    if A::RUNS_MB && !A::AVERAGES {
        if whole == Some(Expert::Mb) {
            softmax_graded_by(signed, &run.q_mb[row.clone()], g, bonus, tau, p_mb);
        }
    } else if A::RUNS_MB {
        let fold = Fold {
            expert: Expert::Mb,
            drawn: (A::DRAW == Draw::Expert && choice.use_mb) || whole == Some(Expert::Mb),
            q: &run.q_mb[row.clone()],
            g,
            signed,
            bonus,
            tau,
            alpha,
        };
        settled.fold(
            &fold,
            p_mb,
            kept_mb,
            &mut run.pavg_mb[row.clone()],
            &mut run.entropy_mb[s],
        );
    }
    let a = if A::DRAW == Draw::Expert {
        draw(if choice.use_mb { p_mb } else { p_mf }, uniform(run.rng))
    } else {
        let p: &[f64] = match whole {
            Some(Expert::Mb) => p_mb,
            Some(Expert::Mf) => p_mf,
            None => {
                // The experts' softmaxes are folded: their scratch space holds the values the
                // action is drawn from, then their softmax (with the Eq. 8 bonus).
                let (q_mf, q_mb) = (&run.q_mf[row.clone()], &run.q_mb[row.clone()]);
                let (p, values) = run.scratch.split_at_mut(n_a);
                if A::DRAW == Draw::Mix {
                    let w = choice.p_mb;
                    for ((v, &mb), &mf) in values.iter_mut().zip(q_mb).zip(q_mf) {
                        *v = w * mb + (1.0 - w) * mf;
                    }
                } else {
                    let own = Own {
                        run: run.arbiter_run,
                        pairs: run.arbiter_pairs,
                    };
                    A::action_values(&own, s, q_mf, q_mb, values);
                }
                softmax_graded_by(signed, values, g, bonus, tau, p);
                p
            }
        };
        // Unchanged rows mixed with an unchanged weight give the entropy kept at the last
        // decision in the state, wherever the batch holds the tables for it (which runs do is
        // decided with the batch's sizes: `storage::mixes_keeping_entropies`).
        let keeps_mix = A::DRAW == Draw::Mix
            && !HUMAN
            && !run.entropy_mix.is_empty()
            && (A::STEADY_WEIGHT || !run.weight_mix.is_empty());
        let bits = if keeps_mix {
            let settled = &mut run.settled[s];
            let w = choice.p_mb;
            let same_weight = A::STEADY_WEIGHT || run.weight_mix[s].to_bits() == w.to_bits();
            if !(settled.mix_kept() && same_weight) {
                run.entropy_mix[s] = entropy_bits(p);
                if !A::STEADY_WEIGHT {
                    run.weight_mix[s] = w;
                }
                settled.keep_mix();
            }
            run.entropy_mix[s]
        } else {
            entropy_bits(p)
        };
        choice.chosen_entropy = normalise_bits(bits, n_a);
        draw(p, uniform(run.rng))
    };

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
    let actor = match A::DRAW {
        Draw::Expert if choice.use_mb => Actor::Mb,
        Draw::Expert => Actor::Mf,
        Draw::Mix => Actor::Mix,
        // Per action (vpi): a mixture when MB valued at least one action.
        Draw::PerAction if choice.use_mb => Actor::Mix,
        Draw::PerAction => Actor::Mf,
    };
    (a, actor, choice.p_mb)
}

/// The row an expert's softmax in state `s` is written to: its kept slot among `rows` (with the
/// slot's `owners` entry, to tell whether it holds the state's softmax already) when the run
/// `keeps` softmaxes and the batch holds slots, else `scratch`.
#[inline(always)]
fn kept_or<'a>(
    keeps: bool,
    rows: &'a mut [f64],
    owners: &'a mut [u32],
    s: usize,
    scratch: &'a mut [f64],
) -> (&'a mut [f64], Option<Kept<'a>>) {
    let slots = owners.len();
    if !keeps || slots == 0 {
        return (scratch, None);
    }
    let n_a = scratch.len();
    let slot = kept_slot(s, slots);
    let kept = Kept {
        owner: &mut owners[slot],
        state: s as u32,
    };
    (&mut rows[slot * n_a..(slot + 1) * n_a], Some(kept))
}

/// Whether rule `A` runs the MF expert alone: such a run keeps each state's MF Q row maximum
/// between decisions (the batch holds that table for such runs only).
#[inline(always)]
const fn mf_alone<A: Arbiter>() -> bool {
    A::RUNS_MF && !A::RUNS_MB
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
                HumanChange::ErrorProb(e) => cursor.human.error_prob = e,
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
