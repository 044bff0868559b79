//! The simulated human (SPEC 5): congratulation, takeover, punishment, forgetting,
//! budgets and the babbling protocol, checked step by step on the real step kernel.

use std::sync::Arc;

use mbmf::batch::{
    Batch, Checkpoint, Cursor, RunConfig, RunStats, RunView, Settled, run_rng, step,
};
use mbmf::env::NO_NUISANCE;
use mbmf::env::tidy::{Place, TidyState, Variant, enumerate};
use mbmf::env::{self, Spec};
use mbmf::expert::mb::{Observable, OwnedModel};
use mbmf::params::{
    CongratulationEffect, Controller, HumanParams, Interaction, Params, RewardSource,
};
use rand_xoshiro::Xoshiro256PlusPlus;

/// One run with owned arrays, stepped by the engine's own `step`, so tests can set the state and
/// read every table between steps.
struct Solo {
    spec: Spec,
    params: Params,
    q_mf: Vec<f64>,
    q_mb: Vec<f64>,
    pavg_mf: Vec<f64>,
    pavg_mb: Vec<f64>,
    entropy_mf: Vec<f64>,
    entropy_mb: Vec<f64>,
    max_mf: Vec<f64>,
    settled: Vec<Settled>,
    cost_mf: Vec<f64>,
    cost_mb: Vec<f64>,
    visited: Vec<bool>,
    bonus: Vec<u8>,
    model: OwnedModel,
    scratch: Vec<f64>,
    rng: Xoshiro256PlusPlus,
    cursor: Cursor,
    stats: RunStats,
    series: Vec<Checkpoint>,
}

impl Solo {
    fn new(task: &str, params: Params) -> Solo {
        let spec = env::load(task).unwrap();
        let sa = spec.n_states * spec.n_actions;
        let a = spec.n_actions;
        Solo {
            q_mf: vec![params.q_init; sa],
            q_mb: vec![params.q_init; sa],
            pavg_mf: vec![1.0 / a as f64; sa],
            pavg_mb: vec![1.0 / a as f64; sa],
            entropy_mf: vec![f64::NAN; spec.n_states],
            entropy_mb: vec![f64::NAN; spec.n_states],
            max_mf: vec![params.q_init; spec.n_states],
            settled: vec![Settled::default(); spec.n_states],
            cost_mf: vec![0.0; spec.n_states],
            cost_mb: vec![0.0; spec.n_states],
            visited: vec![false; spec.n_states],
            bonus: vec![0; sa],
            // The model can observe what a nuisance leaves, too (SPEC 11.2).
            model: OwnedModel::over(
                Arc::new(observable_with_nuisance(&spec)),
                params.window_n as usize,
            ),
            scratch: vec![0.0; 2 * a],
            rng: run_rng(7, 0),
            cursor: Cursor::start(&spec, &params, 0),
            stats: RunStats::default(),
            series: vec![Checkpoint::default(); mbmf::batch::checkpoint_count(&params)],
            spec,
            params,
        }
    }

    fn step(&mut self) {
        let mut view = RunView {
            q_mf: &mut self.q_mf,
            q_mb: &mut self.q_mb,
            pavg_mf: &mut self.pavg_mf,
            pavg_mb: &mut self.pavg_mb,
            entropy_mf: &mut self.entropy_mf,
            entropy_mb: &mut self.entropy_mb,
            // A run with a human keeps no softmax between steps.
            kept_p_mf: &mut [],
            kept_owner_mf: &mut [],
            kept_p_mb: &mut [],
            kept_owner_mb: &mut [],
            max_mf: &mut self.max_mf,
            settled: &mut self.settled,
            cost_mf: &mut self.cost_mf,
            cost_mb: &mut self.cost_mb,
            // Nor a mixed distribution's entropy.
            entropy_mix: &mut [],
            weight_mix: &mut [],
            visited: &mut self.visited,
            bonus: &mut self.bonus,
            arbiter_run: &mut [],
            arbiter_pairs: &mut [],
            model: self.model.view(),
            scratch: &mut self.scratch,
            task_state: &mut [],
            eligibility: &mut [],
            eligible: &mut [],
            tally: &mut [],
            rng: &mut self.rng,
            cursor: &mut self.cursor,
            stats: &mut self.stats,
            series: &mut self.series,
            trace: Default::default(),
            plan: None,
        };
        step(&self.spec, &self.params, &mut view);
    }

    /// Makes `action` the MF expert's near-certain choice in `state` (Q gap of 1 at tau 0.02).
    fn prefer(&mut self, state: usize, action: usize) {
        let a = self.spec.n_actions;
        for b in 0..a {
            self.q_mf[state * a + b] = if b == action { 1.0 } else { 0.0 };
        }
        // The row changed behind the step's back: what was kept from it no longer holds.
        self.settled[state] = Settled::default();
        self.max_mf[state] = 1.0;
    }

    fn state_of(&self, tidy: TidyState, variant: Variant) -> usize {
        enumerate(variant).iter().position(|&s| s == tidy).unwrap()
    }
}

/// The spec's outcomes plus those a nuisance human can produce.
fn observable_with_nuisance(spec: &Spec) -> Observable {
    let extra: Vec<(usize, u32)> = spec
        .human
        .as_ref()
        .map(|h| {
            h.nuisance
                .iter()
                .enumerate()
                .filter(|&(_, &n)| n != NO_NUISANCE)
                .map(|(sa, &n)| (sa, n))
                .collect()
        })
        .unwrap_or_default();
    Observable::union([spec], extra)
}

fn human(interaction: Interaction, budget: u32, forget_prob: f64) -> Params {
    Params {
        controller: Controller::Mf,
        babbling: 0,
        steps: 1_000_000,
        checkpoint: 0,
        human: HumanParams {
            interaction,
            budget,
            forget_prob,
            zeta: 0.1,
            error_prob: 0.0,
        },
        ..Params::default()
    }
}

fn holding_red() -> TidyState {
    let mut s = TidyState::START;
    s.places[0] = Place::Hand;
    s
}

#[test]
fn a_congratulated_action_carries_exactly_zeta_next_time_and_nothing_after_an_uncongratulated_execution()
 {
    let mut solo = Solo::new("tidy1", human(Interaction::Congratulation, 1, 0.0));
    let s = solo.state_of(holding_red(), Variant::Task1);
    let put_red = 3;
    let sa = s * 7 + put_red;

    // Put red in the red box: relevant, the attentive human congratulates, spending the budget.
    solo.prefer(s, put_red);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.bonus[sa], 1);
    assert_eq!(solo.stats.congratulations, 1);
    assert_eq!(solo.cursor.budget_left, 0);

    // Back in s with equal Q values: the softmax sees exactly +zeta on the put (Eq. 8):
    // p(put) = e^(0.1/0.02) / (e^(0.1/0.02) + 6).
    for b in 0..7 {
        solo.q_mf[s * 7 + b] = 0.25;
    }
    solo.cursor.state = s as u32;
    solo.step();
    let e5 = 5f64.exp();
    let p = &solo.scratch[..7];
    assert!((p[put_red] - e5 / (e5 + 6.0)).abs() < 1e-12, "p = {p:?}");
    assert!((p[0] - 1.0 / (e5 + 6.0)).abs() < 1e-12);
    // The Q values themselves are untouched by the bonus (only learning moves them).

    // Execute the put again with the budget spent: no congratulation, so G is reset to 0 ...
    solo.prefer(s, put_red);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.bonus[sa], 0);
    // ... and the next softmax in s has no bonus.
    for b in 0..7 {
        solo.q_mf[s * 7 + b] = 0.25;
    }
    solo.cursor.state = s as u32;
    solo.step();
    for &x in &solo.scratch[..7] {
        assert!((x - 1.0 / 7.0).abs() < 1e-12);
    }
}

#[test]
fn punishment_gives_minus_zeta_on_an_error_only() {
    let mut solo = Solo::new("tidy1", human(Interaction::Punishment, 10, 0.0));
    let s = solo.state_of(holding_red(), Variant::Task1);
    // Red into the green box is an error.
    solo.prefer(s, 4);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.bonus[s * 7 + 4], 1);
    assert_eq!(solo.stats.punishments, 1);
    for b in 0..7 {
        solo.q_mf[s * 7 + b] = 0.0;
    }
    solo.cursor.state = s as u32;
    solo.step();
    let em5 = (-5f64).exp();
    assert!((solo.scratch[4] - em5 / (em5 + 6.0)).abs() < 1e-12);
    // The right put is not an error: no punishment spent on it.
    let before = solo.stats.punishments;
    solo.prefer(s, 3);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.punishments, before);
}

#[test]
fn the_budget_is_never_exceeded_and_its_exhaustion_step_is_recorded() {
    let spec = Arc::new(env::load("tidy1").unwrap());
    for interaction in [
        Interaction::Congratulation,
        Interaction::Takeover,
        Interaction::Punishment,
    ] {
        for budget in [0, 1, 5, 40] {
            let params = Params {
                steps: 3000,
                babbling: 200,
                human: HumanParams {
                    interaction,
                    budget,
                    forget_prob: 0.1,
                    zeta: 0.1,
                    error_prob: 0.0,
                },
                ..Params::default()
            };
            let configs = (0..8)
                .map(|i| RunConfig {
                    params,
                    seed: 3,
                    run_index: i,
                })
                .collect();
            let mut batch = Batch::new(Arc::clone(&spec), configs).unwrap();
            batch.run_to_end();
            for (r, stats) in batch.stats().iter().enumerate() {
                let given = stats.interactions();
                assert!(
                    given <= budget,
                    "{interaction:?} budget {budget}: run {r} gave {given}"
                );
                if given == budget && budget > 0 {
                    assert!(stats.budget_exhausted_step > 0);
                    let last = batch.series(r).last().unwrap();
                    assert_eq!(last.interactions, budget);
                } else {
                    assert_eq!(stats.budget_exhausted_step, 0);
                }
            }
        }
    }
}

#[test]
fn the_share_of_forgotten_opportunities_is_forget_prob_within_four_sigma() {
    // Takeover gives an opportunity at every step with a held cube: 20 runs x 5,000 steps give
    // several tens of thousands of opportunities.
    let spec = Arc::new(env::load("tidy1").unwrap());
    let forget_prob = 0.3;
    let params = Params {
        controller: Controller::Mf,
        steps: 5000,
        babbling: 0,
        human: HumanParams {
            interaction: Interaction::Takeover,
            budget: u32::MAX,
            forget_prob,
            zeta: 0.1,
            error_prob: 0.0,
        },
        ..Params::default()
    };
    let configs = (0..20)
        .map(|i| RunConfig {
            params,
            seed: 11,
            run_index: i,
        })
        .collect();
    let mut batch = Batch::new(spec, configs).unwrap();
    batch.run_to_end();
    let forgotten: u64 = batch.stats().iter().map(|s| u64::from(s.forgotten)).sum();
    let given: u64 = batch.stats().iter().map(|s| u64::from(s.takeovers)).sum();
    let n = (forgotten + given) as f64;
    assert!(n > 20_000.0, "only {n} opportunities");
    let share = forgotten as f64 / n;
    let sigma = (forget_prob * (1.0 - forget_prob) / n).sqrt();
    assert!(
        (share - forget_prob).abs() < 4.0 * sigma,
        "share {share} over {n} opportunities"
    );
}

#[test]
fn takeover_in_task_1_always_puts_the_held_cube_in_its_own_box() {
    let states = enumerate(Variant::Task1);
    for (id, tidy) in states.iter().enumerate() {
        let Some(cube) = tidy.held() else { continue };
        let params = Params {
            controller: Controller::Ec,
            ..human(Interaction::Takeover, 1, 0.0)
        };
        let mut solo = Solo::new("tidy1", params);
        solo.cursor.state = id as u32;
        solo.step();
        let after = states[solo.cursor.state as usize];
        assert_eq!(after.places[cube], Place::Box(cube as u8), "from {tidy:?}");
        // Both experts learned from the human's action: the model holds the put.
        assert_eq!(solo.model.ring_len[id * 7 + 3 + cube], 1);
        assert_eq!(solo.stats.takeovers, 1);
        assert_eq!(
            solo.stats.decisions, 0,
            "the robot does not decide on a takeover step"
        );
        assert_eq!(solo.stats.cost_mf, 0.0, "a takeover costs no inference");
        assert!(
            solo.visited.iter().all(|&v| !v),
            "no decision was made anywhere"
        );
    }
}

#[test]
fn takeover_in_task_2_lights_the_next_led_or_puts_on_the_table() {
    let states = enumerate(Variant::Task2);
    let mut lit = 0;
    let mut tabled = 0;
    for (id, tidy) in states.iter().enumerate() {
        let Some(cube) = tidy.held() else { continue };
        let mut solo = Solo::new("tidy2", human(Interaction::Takeover, 1, 0.0));
        solo.cursor.state = id as u32;
        solo.step();
        let after = states[solo.cursor.state as usize];
        if tidy.leds as usize == cube {
            assert_eq!(after.places[cube], Place::Box(cube as u8));
            assert_eq!(after.leds, tidy.leds + 1);
            lit += 1;
        } else {
            assert_eq!(after.places[cube], Place::Table);
            assert_eq!(after.leds, tidy.leds, "a table put is not an error");
            tabled += 1;
        }
    }
    assert!(lit > 0 && tabled > 0);
}

#[test]
fn task_2_led_rules_on_a_hand_made_sequence() {
    let v = Variant::Task2;
    let mut s = TidyState::START;
    // take red, put red in red box: LED 1; take green, put in green box: LED 2.
    for (action, leds, relevant, error) in [
        (0, 0, false, false),
        (3, 1, true, false),
        (1, 1, false, false),
        (4, 2, true, false),
        // Take red (lit) out of its box: an error, all LEDs off.
        (0, 0, false, true),
        // Red into the blue box: an error (k stays 0).
        (5, 0, false, true),
    ] {
        let e = s.apply(action, v);
        assert_eq!(
            (e.next.leds, e.relevant, e.error),
            (leds, relevant, error),
            "action {action}"
        );
        s = e.next;
    }
    // Blue into its box at k = 0 is out of order: an error.
    let mut t = TidyState::START;
    t = t.apply(2, v).next;
    let e = t.apply(5, v);
    assert!(e.error && e.next.leds == 0);
    let spec = env::load("tidy2").unwrap();
    assert_eq!(
        spec.state_names[spec.goal_state().unwrap() as usize],
        "R:redbox G:greenbox B:bluebox LED:3"
    );
}

#[test]
fn babbling_counts_no_reward_no_cost_and_no_interaction() {
    let spec = Arc::new(env::load("tidy1").unwrap());
    let params = Params {
        controller: Controller::Ec,
        steps: 0,
        babbling: 3000,
        human: HumanParams {
            interaction: Interaction::Takeover,
            budget: 1000,
            forget_prob: 0.0,
            zeta: 0.1,
            error_prob: 0.0,
        },
        ..Params::default()
    };
    let configs = (0..4)
        .map(|i| RunConfig {
            params,
            seed: 5,
            run_index: i,
        })
        .collect();
    let mut batch = Batch::new(spec, configs).unwrap();
    batch.run_to_end();
    for (r, stats) in batch.stats().iter().enumerate() {
        assert_eq!(stats.total_reward, 0.0);
        assert_eq!(stats.interactions(), 0);
        assert_eq!(stats.forgotten, 0);
        assert_eq!(stats.cost_total(), 0.0);
        assert_eq!(stats.decisions, 0);
        // Yet the robot explored and learned: the model knows transitions.
        assert!(batch.transition_model(r).iter().any(|&t| t > 0.0));
        assert!(stats.vi_calls > 0);
    }
}

#[test]
fn the_cli_runs_ec_with_takeover_and_the_stingy_profile_and_reports_interactions() {
    use arrow::array::{Array, Int64Array, StringArray};
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let dir = tempfile::tempdir().unwrap();
    for (name, extra) in [
        (
            "takeover",
            vec!["--interaction", "takeover", "--budget", "50"],
        ),
        ("stingy", vec!["--profile", "stingy"]),
    ] {
        let out = dir.path().join(name);
        let mut args = vec![
            "run",
            "--controller",
            "ec",
            "--runs",
            "3",
            "--steps",
            "2000",
            "--quiet",
        ];
        args.extend(extra);
        args.extend(["--out", out.to_str().unwrap()]);
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(&args)
            .status()
            .unwrap();
        assert!(status.success(), "mbmf {args:?}");
        let file = std::fs::File::open(out.join("runs.parquet")).unwrap();
        let batch = ParquetRecordBatchReaderBuilder::try_new(file)
            .unwrap()
            .build()
            .unwrap()
            .next()
            .unwrap()
            .unwrap();
        let col = |n: &str| batch.column(batch.schema().index_of(n).unwrap()).clone();
        let interactions = col("interactions");
        let interactions = interactions.as_any().downcast_ref::<Int64Array>().unwrap();
        let profile = col("profile");
        let profile = profile.as_any().downcast_ref::<StringArray>().unwrap();
        assert_eq!(batch.num_rows(), 3);
        for i in 0..3 {
            assert!(interactions.value(i) > 0, "{name}: no interaction reported");
        }
        if name == "stingy" {
            assert_eq!(profile.value(0), "stingy");
            let budget = col("budget");
            assert_eq!(
                budget
                    .as_any()
                    .downcast_ref::<Int64Array>()
                    .unwrap()
                    .value(0),
                300
            );
        } else {
            assert!(interactions.value(0) <= 50);
            assert_eq!(profile.value(0), "custom");
        }
    }
}

/// Red in the hand, green and blue already in their boxes: putting red in the red box reaches
/// the goal.
fn one_put_from_the_goal() -> TidyState {
    let mut s = holding_red();
    s.places[1] = Place::Box(1);
    s.places[2] = Place::Box(2);
    s
}

#[test]
fn a_nuisance_takes_the_cube_back_out_so_the_goal_is_not_reached_and_the_robot_learns_that() {
    let mut solo = Solo::new("tidy1", human(Interaction::Nuisance, 1, 0.0));
    let s = solo.state_of(one_put_from_the_goal(), Variant::Task1);
    let mut undone = one_put_from_the_goal();
    undone.places[0] = Place::Table;
    let undone = solo.state_of(undone, Variant::Task1);
    let put_red = 3;
    solo.prefer(s, put_red);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(
        solo.cursor.state as usize, undone,
        "the cube is back on the table"
    );
    assert_eq!(solo.stats.nuisances, 1);
    assert_eq!(solo.stats.interactions(), 1);
    assert_eq!(solo.cursor.budget_left, 0);
    assert_eq!(
        solo.stats.total_reward, 0.0,
        "no reward: the goal was not reached"
    );
    assert!(!solo.cursor.pending_reset);
    // MF learned (s, put, r 0, undone): 1 + 0.6 * (0 + 0.9 * max Q(undone) = 0 - 1) = 0.4.
    assert!((solo.q_mf[s * 7 + put_red] - 0.4).abs() < 1e-12);
    // With the budget spent, the same put reaches the goal and is rewarded.
    solo.prefer(s, put_red);
    solo.cursor.pending_reset = false;
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.total_reward, 1.0);
    assert!(solo.cursor.pending_reset, "the next step is the reset step");
    assert_eq!(solo.stats.nuisances, 1);
    // The model's index space holds both outcomes of the put (the parity tests check that MB
    // learns them as a stochastic pair).
    let obs = &solo.model.obs;
    let next: Vec<usize> = obs
        .outcomes(s * 7 + put_red)
        .map(|o| obs.next_state(o))
        .collect();
    assert!(next.contains(&undone) && next.len() == 2, "{next:?}");
}

#[test]
fn a_nuisance_in_task_2_turns_the_leds_off() {
    let mut solo = Solo::new("tidy2", human(Interaction::Nuisance, 5, 0.0));
    let s = solo.state_of(holding_red(), Variant::Task2);
    solo.prefer(s, 3);
    solo.cursor.state = s as u32;
    solo.step();
    let after = enumerate(Variant::Task2)[solo.cursor.state as usize];
    assert_eq!(after, TidyState::START);
    assert_eq!(solo.stats.nuisances, 1);
}

#[test]
fn when_only_the_human_rewards_an_arrival_is_rewarded_only_if_an_attentive_human_has_budget() {
    let params = Params {
        reward_source: RewardSource::Human,
        ..human(Interaction::None, 1, 0.0)
    };
    let mut solo = Solo::new("tidy1", params);
    let s = solo.state_of(one_put_from_the_goal(), Variant::Task1);
    solo.prefer(s, 3);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.total_reward, 1.0);
    assert_eq!(solo.stats.rewards_given, 1);
    assert_eq!(solo.stats.interactions(), 1);
    assert_eq!(solo.cursor.budget_left, 0);
    // Budget spent: the arrival gives 0 but still ends the episode, and it is terminal for
    // learning: Q(s, put) = 1 + 0.6 * (0 + 0 - 1) = 0.4, no future term.
    solo.prefer(s, 3);
    solo.cursor.pending_reset = false;
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.total_reward, 1.0);
    assert!(solo.cursor.pending_reset);
    assert!((solo.q_mf[s * 7 + 3] - 0.4).abs() < 1e-12);
    // An inattentive human forgets the reward (and spends nothing).
    let params = Params {
        reward_source: RewardSource::Human,
        ..human(Interaction::None, 1, 1.0)
    };
    let mut solo = Solo::new("tidy1", params);
    solo.prefer(s, 3);
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.total_reward, 0.0);
    assert_eq!(solo.stats.forgotten, 1);
    assert_eq!(solo.cursor.budget_left, 1);
}

#[test]
fn a_congratulation_that_shapes_the_reward_is_learned_as_r_plus_zeta_and_never_biases_the_choice() {
    let params = Params {
        congratulation_effect: CongratulationEffect::Reward,
        ..human(Interaction::Congratulation, 1, 0.0)
    };
    let mut solo = Solo::new("tidy1", params);
    let s = solo.state_of(holding_red(), Variant::Task1);
    let sa = s * 7 + 3;
    for b in 0..7 {
        solo.q_mf[s * 7 + b] = 0.0;
    }
    solo.q_mf[sa] = 1.0;
    solo.cursor.state = s as u32;
    solo.step();
    assert_eq!(solo.stats.congratulations, 1);
    assert_eq!(solo.bonus[sa], 0, "G is not used");
    // 1 + 0.6 * (0 + 0.1 + 0.9 * 0 - 1) = 0.46; the reported reward stays the task's, 0.
    assert!((solo.q_mf[sa] - 0.46).abs() < 1e-12, "{}", solo.q_mf[sa]);
    assert_eq!(solo.stats.total_reward, 0.0);
    // Back in s with equal values: no bias in the softmax.
    for b in 0..7 {
        solo.q_mf[s * 7 + b] = 0.25;
    }
    solo.cursor.state = s as u32;
    solo.step();
    for &x in &solo.scratch[..7] {
        assert!((x - 1.0 / 7.0).abs() < 1e-12);
    }
}
