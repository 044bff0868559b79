//! Invariants of the batch engine observed during real runs, advanced a few steps at a time:
//! probabilities, entropies, the learned model, costs and values stay well formed; the reset
//! step, babbling, the first-decision rule and the MF cost behave as SPEC 2.1, 3.4, 4, 6 and 7
//! say; with q_init = 0 every controller acts uniformly at random until the first reward.

mod common;

use std::sync::Arc;

use mbmf::batch::{Batch, RunConfig};
use mbmf::env::{self, Spec};
use mbmf::params::{Controller, HumanParams, Interaction, Params, Selection};

fn spec(task: &str) -> Arc<Spec> {
    Arc::new(env::load(task).unwrap_or_else(|e| panic!("cannot load {task}: {e}")))
}

fn short(controller: Controller) -> Params {
    Params {
        controller,
        babbling: 200,
        steps: 1500,
        checkpoint: 100,
        ..Params::default()
    }
}

fn configs(params: &[Params], seed: u64) -> Vec<RunConfig> {
    params
        .iter()
        .enumerate()
        .map(|(i, &params)| RunConfig {
            params,
            seed,
            run_index: i as u64,
        })
        .collect()
}

fn human(interaction: Interaction, budget: u32) -> HumanParams {
    HumanParams {
        interaction,
        budget,
        ..HumanParams::default()
    }
}

/// Base-2 entropy over log2(|A|), without any clamping.
fn normalised_entropy(p: &[f64]) -> f64 {
    let bits: f64 = p.iter().filter(|&&x| x > 0.0).map(|&x| -x * x.log2()).sum();
    bits / (p.len() as f64).log2()
}

/// Checks every invariant of run `r` at the current pause.
fn check_invariants(batch: &Batch, r: usize, previous_cost: &mut (f64, f64)) {
    let spec = batch.spec();
    let config = &batch.configs()[r];
    let p = &config.params;
    let at = format!(
        "run {r} ({} {:?} {:?}) at t = {}",
        p.controller.name(),
        p.selection,
        p.human.interaction,
        batch.cursors()[r].t
    );
    let (avg_mf, avg_mb) = batch.averaged_probabilities(r);
    for s in 0..spec.n_states {
        for (name, avg) in [("MF", avg_mf.row(s)), ("MB", avg_mb.row(s))] {
            let row: Vec<f64> = avg.to_vec();
            let sum: f64 = row.iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-12,
                "{at}: {name} averaged row {s} sums to {sum}"
            );
            assert!(
                row.iter().all(|&x| x >= 0.0),
                "{at}: {name} row {s} has a negative"
            );
            let h = normalised_entropy(&row);
            assert!(
                (0.0..=1.0 + 1e-12).contains(&h),
                "{at}: {name} normalised entropy {h} in state {s}"
            );
            let engine_h = mbmf::expert::normalised_entropy(&row);
            assert!(
                (engine_h - h).abs() < 1e-12,
                "{at}: engine entropy {engine_h} vs {h}"
            );
        }
    }
    let t = batch.transition_model(r);
    let mut tried = 0;
    for s in 0..spec.n_states {
        for a in 0..spec.n_actions {
            let row = t.slice(ndarray::s![s, a, ..]);
            let sum: f64 = row.sum();
            if sum == 0.0 {
                continue;
            }
            tried += 1;
            assert!(
                (sum - 1.0).abs() < 1e-12,
                "{at}: T({s}, {a}, .) sums to {sum}"
            );
            let possible: Vec<u32> = spec
                .outcomes(spec.sa(s, a))
                .map(|o| spec.outcome_state[o])
                .collect();
            for (next, &x) in row.iter().enumerate() {
                assert!(x >= 0.0);
                if x > 0.0 {
                    assert!(
                        possible.contains(&(next as u32)),
                        "{at}: T({s}, {a}, {next}) = {x} but the world cannot go there"
                    );
                }
            }
        }
    }
    if p.controller.runs_mb() && batch.cursors()[r].t > 10 {
        assert!(tried > 0, "{at}: MB learned nothing");
    }
    let stats = &batch.stats()[r];
    assert!(
        stats.cost_mf >= 0.0 && stats.cost_mb >= 0.0,
        "{at}: negative cost"
    );
    assert!(
        stats.cost_mf >= previous_cost.0 && stats.cost_mb >= previous_cost.1,
        "{at}: cost decreased"
    );
    *previous_cost = (stats.cost_mf, stats.cost_mb);
    assert!(stats.mb_decisions <= stats.decisions);
    assert!(stats.p_mb_sum >= 0.0 && stats.p_mb_sum <= stats.decisions as f64);
    assert!(stats.entropy_sum >= 0.0 && stats.entropy_sum <= stats.decisions as f64 + 1e-9);
    assert!(stats.interactions() <= p.human.budget);
    // Rewards are 0 or 1 and the goal is terminal: every value stays in [0, 1] from q_init 0.
    for (name, q) in [("MF", batch.q_mf(r)), ("MB", batch.q_mb(r))] {
        for (&v, (s, a)) in q
            .iter()
            .zip((0..spec.n_states).flat_map(|s| (0..spec.n_actions).map(move |a| (s, a))))
        {
            assert!(v.is_finite(), "{at}: {name} Q({s}, {a}) = {v}");
            assert!(
                (0.0..=1.0).contains(&v),
                "{at}: {name} Q({s}, {a}) = {v} outside [0, 1]"
            );
        }
    }
}

fn check_invariants_while_running(spec: Arc<Spec>, params: &[Params]) {
    let mut batch = Batch::new(spec, configs(params, 21)).unwrap();
    let mut costs = vec![(0.0, 0.0); batch.len()];
    let longest = params
        .iter()
        .map(|p| u64::from(p.babbling + p.steps))
        .max()
        .unwrap();
    let mut t = 0;
    while t < longest {
        batch.advance(50);
        t += 50;
        for (r, cost) in costs.iter_mut().enumerate() {
            check_invariants(&batch, r, cost);
        }
    }
    assert!(
        batch.stats().iter().any(|s| s.total_reward > 0.0),
        "no run earned a reward: the invariants were checked on trivial runs"
    );
}

#[test]
fn probabilities_entropies_models_costs_and_values_stay_well_formed_during_tidy_runs() {
    let mut params: Vec<Params> = Controller::ALL.iter().map(|&c| short(c)).collect();
    params.push(Params {
        selection: Selection::Argmax,
        ..short(Controller::Ec)
    });
    params.push(Params {
        human: human(Interaction::Congratulation, 60),
        ..short(Controller::Ec)
    });
    params.push(Params {
        human: human(Interaction::Takeover, 60),
        ..short(Controller::Mf)
    });
    params.push(Params {
        human: human(Interaction::Punishment, 60),
        window_n: 2,
        ..short(Controller::Rnd)
    });
    check_invariants_while_running(spec("tidy1"), &params);
    // The paper's controllers, `entropy` and EC with argmax selection: the first of these runs
    // to earn a reward in tidy2's 1,500 steps shows the invariants were checked on real runs,
    // whatever controllers are added to the list.
    let paper = [
        Controller::Mf,
        Controller::Mb,
        Controller::Rnd,
        Controller::Ec,
        Controller::Entropy,
    ];
    let mut tidy2: Vec<Params> = paper.iter().map(|&c| short(c)).collect();
    tidy2.push(Params {
        selection: Selection::Argmax,
        ..short(Controller::Ec)
    });
    check_invariants_while_running(spec("tidy2"), &tidy2);
}

#[test]
fn probabilities_entropies_models_costs_and_values_stay_well_formed_in_a_stochastic_world() {
    let Some(nav) = common::navworld() else {
        return;
    };
    let mut params: Vec<Params> = Controller::ALL.iter().map(|&c| short(c)).collect();
    params.push(Params {
        window_n: 3,
        ..short(Controller::Ec)
    });
    check_invariants_while_running(nav, &params);
}

/// Steps a one-run batch one step at a time and checks the reset step at every goal.
fn check_reset_steps(spec: Arc<Spec>, params: Params) -> usize {
    let mut batch = Batch::new(Arc::clone(&spec), configs(&[params], 22)).unwrap();
    let goal = spec.goal_state().unwrap();
    let mut resets = 0;
    for _ in 0..params.babbling + params.steps {
        let before = batch.cursors()[0];
        if before.state != goal {
            batch.advance(1);
            continue;
        }
        let stats = batch.stats()[0];
        let (q_mf, q_mb) = (batch.q_mf(0).to_owned(), batch.q_mb(0).to_owned());
        let (avg_mf, avg_mb) = batch.averaged_probabilities(0);
        let (avg_mf, avg_mb) = (avg_mf.to_owned(), avg_mb.to_owned());
        let model = batch.transition_model(0);
        batch.advance(1);
        let after = batch.cursors()[0];
        let at = format!("{} reset step at t = {}", spec.name, after.t);
        assert_eq!(
            after.t,
            before.t + 1,
            "{at}: the reset step counts as a step"
        );
        assert!(
            spec.initial_states.contains(&after.state),
            "{at}: back to {}",
            after.state
        );
        let now = batch.stats()[0];
        assert_eq!(now.decisions, stats.decisions, "{at}: no decision");
        assert_eq!(
            (now.cost_mf, now.cost_mb),
            (stats.cost_mf, stats.cost_mb),
            "{at}: no cost"
        );
        assert_eq!(now.vi_calls, stats.vi_calls, "{at}: no inference");
        assert_eq!(now.total_reward, stats.total_reward, "{at}: no reward");
        assert_eq!(batch.q_mf(0), q_mf, "{at}: no MF learning");
        assert_eq!(batch.q_mb(0), q_mb, "{at}: no MB learning");
        let (a, b) = batch.averaged_probabilities(0);
        assert!(a == avg_mf && b == avg_mb, "{at}: no action probabilities");
        assert_eq!(batch.transition_model(0), model, "{at}: no model update");
        resets += 1;
    }
    // The goal is terminal: its own values are never learned.
    let g = goal as usize;
    assert!(batch.q_mf(0).row(g).iter().all(|&v| v == params.q_init));
    assert!(batch.q_mb(0).row(g).iter().all(|&v| v == params.q_init));
    resets
}

#[test]
fn the_step_after_the_goal_returns_to_the_start_without_decision_cost_or_learning() {
    let resets = check_reset_steps(spec("tidy1"), short(Controller::Ec));
    assert!(resets >= 5, "only {resets} goals reached");
    let resets = check_reset_steps(
        spec("tidy1"),
        Params {
            q_init: 0.5,
            ..short(Controller::Mb)
        },
    );
    assert!(resets >= 5, "only {resets} goals reached");
    if let Some(nav) = common::navworld() {
        let resets = check_reset_steps(nav, short(Controller::Rnd));
        assert!(resets >= 5, "only {resets} goals reached in navworld");
    }
}

#[test]
fn a_transition_into_the_goal_is_backed_up_with_its_reward_only() {
    // q_init = 0.5: if the goal's own values counted, a transition into it would be worth
    // 1 + gamma * 0.5 > 1.
    let spec = spec("tidy1");
    let params = Params {
        q_init: 0.5,
        steps: 3000,
        ..short(Controller::Rnd)
    };
    let mut batch = Batch::new(Arc::clone(&spec), configs(&[params], 23)).unwrap();
    batch.run_to_end();
    assert!(batch.stats()[0].total_reward > 0.0);
    let mut into_goal = Vec::new();
    for s in 0..spec.n_states {
        for a in 0..spec.n_actions {
            let o = spec.outcomes(spec.sa(s, a)).start;
            if s != spec.goal_state().unwrap() as usize
                && spec.outcome_state[o] == spec.goal_state().unwrap()
            {
                into_goal.push((s, a));
            }
        }
    }
    assert_eq!(
        into_goal.len(),
        3,
        "three states put the last cube in place"
    );
    let (q_mf, q_mb) = (batch.q_mf(0), batch.q_mb(0));
    for &(s, a) in &into_goal {
        assert!(q_mf[[s, a]] <= 1.0, "MF Q({s}, {a}) = {}", q_mf[[s, a]]);
        // MB: untried keeps q_init; tried gives exactly its last reward (1, or 0 from babbling).
        let v = q_mb[[s, a]];
        assert!(v == 0.5 || v == 1.0 || v == 0.0, "MB Q({s}, {a}) = {v}");
    }
    assert!(into_goal.iter().any(|&(s, a)| q_mb[[s, a]] == 1.0));
    assert!(into_goal.iter().any(|&(s, a)| q_mf[[s, a]] > 0.9));
}

#[test]
fn babbling_learns_but_counts_no_reward_no_cost_and_no_decision() {
    let spec = spec("tidy1");
    let babbling = 30_000;
    let params = Params {
        babbling,
        steps: 100,
        ..short(Controller::Rnd)
    };
    let mut batch = Batch::new(Arc::clone(&spec), configs(&[params], 24)).unwrap();
    let mut goals = 0;
    for _ in 0..babbling {
        if batch.cursors()[0].state == spec.goal_state().unwrap() {
            goals += 1;
        }
        batch.advance(1);
    }
    assert!(goals > 0, "the goal was never reached during babbling");
    let stats = batch.stats()[0];
    assert_eq!(stats.total_reward, 0.0);
    assert_eq!(stats.first_reward_step, 0);
    assert_eq!((stats.cost_mf, stats.cost_mb), (0.0, 0.0));
    assert_eq!((stats.decisions, stats.mb_decisions), (0, 0));
    assert_eq!((stats.p_mb_sum, stats.entropy_sum), (0.0, 0.0));
    assert!(stats.vi_calls > 0, "MB inferred during babbling");
    assert_eq!(batch.cursors()[0].checkpoints_written, 0);
    // Reward withheld: the experts learned from reward 0, so with q_init = 0 every value is 0.
    assert!(batch.q_mf(0).iter().all(|&v| v == 0.0));
    assert!(batch.q_mb(0).iter().all(|&v| v == 0.0));
    let learned: f64 = batch.transition_model(0).sum();
    assert!(learned > 100.0, "the model learned {learned} rows");
    // At the end of babbling the run is back at the start.
    assert_eq!(batch.cursors()[0].state, 0);
    // The experiment then counts decisions and costs.
    batch.run_to_end();
    let stats = batch.stats()[0];
    assert!(stats.decisions > 0 && stats.decisions <= 100);
    assert!(stats.cost_mf > 0.0);
}

/// Runs `params` (all with the same seed and run index) one step at a time until each has
/// earned its first reward; returns, per run, the states it was in before each step up to it.
fn trajectories_until_first_reward(spec: &Arc<Spec>, params: &[Params]) -> Vec<Vec<u32>> {
    let configs: Vec<RunConfig> = params
        .iter()
        .map(|&params| RunConfig {
            params,
            seed: 25,
            run_index: 7,
        })
        .collect();
    let mut batch = Batch::new(Arc::clone(spec), configs).unwrap();
    let mut paths = vec![Vec::new(); params.len()];
    let end = u64::from(params[0].babbling + params[0].steps);
    for _ in 0..end {
        let mut all_rewarded = true;
        for (r, path) in paths.iter_mut().enumerate() {
            if batch.stats()[r].first_reward_step == 0 {
                all_rewarded = false;
                path.push(batch.cursors()[r].state);
                // Before the first reward every value is still exactly q_init = 0 and every
                // averaged distribution uniform.
                assert!(
                    batch.q_mf(r).iter().all(|&v| v == 0.0),
                    "run {r}: MF learned"
                );
                assert!(
                    batch.q_mb(r).iter().all(|&v| v == 0.0),
                    "run {r}: MB learned"
                );
                let (a, b) = batch.averaged_probabilities(r);
                let uniform = 1.0 / spec.n_actions as f64;
                assert!(
                    a.iter()
                        .chain(b.iter())
                        .all(|&p| (p - uniform).abs() < 1e-15)
                );
            }
        }
        if all_rewarded {
            break;
        }
        batch.advance(1);
    }
    for (r, path) in paths.iter().enumerate() {
        let stats = &batch.stats()[r];
        assert!(stats.first_reward_step > 0, "run {r} earned no reward");
        assert_eq!(
            path.len() as u64,
            u64::from(params[r].babbling) + u64::from(stats.first_reward_step),
            "run {r}: path length"
        );
    }
    paths
}

#[test]
fn with_q_init_0_controllers_act_alike_until_the_first_reward() {
    // SPEC 7: with q_init = 0 every softmax is uniform until the first real reward, so the
    // choice of expert does not change the action drawn. Runs that consume the same random
    // numbers therefore follow the same path: `mf` and `mb` (action draw only), and `rnd`,
    // softmax `ec`, softmax and argmax `entropy` (one MC draw, then the action draw; argmax
    // `entropy` sees equal entropies, a tie, and draws). Argmax `ec` draws only on ties, which
    // its unequal costs break, so it consumes another stream.
    let spec = spec("tidy1");
    let base = Params {
        babbling: 200,
        steps: 30_000,
        ..Params::default()
    };
    let single: Vec<Params> = [Controller::Mf, Controller::Mb]
        .iter()
        .map(|&controller| Params { controller, ..base })
        .collect();
    let paths = trajectories_until_first_reward(&spec, &single);
    assert_eq!(
        paths[0], paths[1],
        "mf and mb diverged before the first reward"
    );

    let dual = vec![
        Params {
            controller: Controller::Rnd,
            ..base
        },
        Params {
            controller: Controller::Ec,
            ..base
        },
        Params {
            controller: Controller::Entropy,
            ..base
        },
        Params {
            controller: Controller::Entropy,
            selection: Selection::Argmax,
            ..base
        },
    ];
    let paths = trajectories_until_first_reward(&spec, &dual);
    for (r, path) in paths.iter().enumerate().skip(1) {
        assert_eq!(
            path, &paths[0],
            "run {r} diverged from rnd before the first reward"
        );
    }
}

#[test]
fn an_mf_inference_costs_exactly_7_ops_on_tidy1() {
    let spec = spec("tidy1");
    let params: Vec<Params> = Controller::ALL.iter().map(|&c| short(c)).collect();
    let mut batch = Batch::new(Arc::clone(&spec), configs(&params, 26)).unwrap();
    batch.run_to_end();
    for (r, (config, stats)) in batch.configs().iter().zip(batch.stats()).enumerate() {
        let name = config.params.controller.name();
        let decisions = stats.decisions as f64;
        match config.params.controller {
            Controller::Mf => {
                assert_eq!(stats.cost_mf, 7.0 * decisions, "{name}");
                assert_eq!(stats.cost_mb, 0.0);
                let mut cumulative = 0;
                for row in batch.series(r) {
                    cumulative += row.decisions;
                    assert_eq!(
                        row.cum_cost_mf,
                        7.0 * f64::from(cumulative),
                        "{name} step {}",
                        row.step
                    );
                }
            }
            Controller::Mb => assert_eq!(stats.cost_mf, 0.0),
            _ => {
                // At most one MF inference per decision, and one at least where MF is chosen.
                assert_eq!(stats.cost_mf % 7.0, 0.0, "{name}");
                assert!(stats.cost_mf <= 7.0 * decisions, "{name}");
                assert!(
                    stats.cost_mf >= 7.0 * (decisions - stats.mb_decisions as f64),
                    "{name}"
                );
            }
        }
        // An MB term costs 1 + |A| = 8 ops.
        assert_eq!(stats.cost_mb % 8.0, 0.0, "{name}");
    }
}

#[test]
fn the_first_decision_in_a_state_makes_both_experts_infer() {
    let spec = spec("tidy1");
    let controllers = Controller::ALL;
    let params: Vec<Params> = controllers
        .iter()
        .map(|&controller| Params {
            controller,
            babbling: 0,
            steps: 1500,
            ..Params::default()
        })
        .collect();
    let mut batch = Batch::new(Arc::clone(&spec), configs(&params, 27)).unwrap();
    let mut decided = vec![vec![false; spec.n_states]; params.len()];
    let mut firsts = vec![0; params.len()];
    let mut repeats = vec![0; params.len()];
    for _ in 0..1500 {
        let before: Vec<_> = (0..batch.len())
            .map(|r| (batch.cursors()[r].state as usize, batch.stats()[r]))
            .collect();
        batch.advance(1);
        for (r, &(s, old)) in before.iter().enumerate() {
            let new = batch.stats()[r];
            if new.decisions == old.decisions {
                continue; // a reset step
            }
            let mf = (new.cost_mf - old.cost_mf) / 7.0;
            let mb = (new.vi_calls - old.vi_calls) as f64;
            let chose_mb = (new.mb_decisions - old.mb_decisions) as f64;
            let c = controllers[r];
            let at = format!("{} at t = {}, state {s}", c.name(), batch.cursors()[r].t);
            if c == Controller::Vpi {
                // SPEC 12.4: MF reads its row at every decision, MB infers when it values an
                // action, and mb_decisions counts those decisions.
                assert_eq!(mf, 1.0, "{at}: MF always infers");
                assert_eq!(mb, chose_mb, "{at}: MB infers iff it values an action");
                repeats[r] += 1;
            } else if !decided[r][s] && c.is_dual() {
                assert_eq!((mf, mb), (1.0, 1.0), "{at}: first decision, both infer");
                firsts[r] += 1;
            } else {
                assert_eq!(mf + mb, 1.0, "{at}: one inference");
                assert_eq!(mb, chose_mb, "{at}: the chosen expert infers");
                repeats[r] += 1;
            }
            decided[r][s] = true;
        }
    }
    for (r, c) in controllers.iter().enumerate() {
        if c.is_dual() {
            assert!(
                firsts[r] >= 20,
                "{}: {} first decisions",
                c.name(),
                firsts[r]
            );
        }
        assert!(
            repeats[r] >= 100,
            "{}: {} repeated decisions",
            c.name(),
            repeats[r]
        );
    }
}
