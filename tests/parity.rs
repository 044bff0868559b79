//! The batch engine against the naive reference of `tests/naive`, bit for bit: every result of
//! `RunStats`, every checkpoint row, both final Q tables, the averaged distributions and the
//! learned transition model, for every controller and selection, on every environment, with
//! every kind of human, and for heterogeneous batches.
//!
//! The engine evaluates the formulas in the SPEC's literal floating-point order, so the reference
//! runs in that order ([`ORDER`]). The reference can also run in an older engine order (softmax
//! by reciprocals, P(MB) as e / (1 + e), EC's kappa * C / max C left to right); a test checks that
//! the two orders differ only by rounding.

mod naive;

use std::path::Path;
use std::sync::Arc;

use mbmf::batch::{Batch, RunConfig};
use mbmf::env::tidy::Boxes;
use mbmf::env::twostep::{self, RC, RR, UC, UR};
use mbmf::env::{self, Spec};
use mbmf::params::{
    Combine, CongratulationEffect, Controller, HumanParams, Interaction, Params, RewardSource,
    Selection,
};
use mbmf::schedule::Schedule;
use naive::{Arithmetic, NaiveRun};

/// Evaluation order of the reference in the bit-for-bit tests: the SPEC's, as the engine's.
const ORDER: Arithmetic = Arithmetic::Spec;

const NAVWORLD: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/data/navworld/realisticNavWorld.json"
);
const TIDY1_FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tidy1/tidy1.json");

fn spec(task: &str) -> Arc<Spec> {
    Arc::new(env::load(task).unwrap_or_else(|e| panic!("cannot load {task}: {e}")))
}

/// The authors' navigation world, or `None` (with a note) when their data is not present.
fn navworld() -> Option<Arc<Spec>> {
    if !Path::new(NAVWORLD).exists() {
        eprintln!("skipped: {NAVWORLD} is absent (the authors' data is not in the repository)");
        return None;
    }
    Some(spec(&format!("json:{NAVWORLD}")))
}

/// Short runs: babbling 200, 2,000 steps, a checkpoint every 100.
fn short(controller: Controller, selection: Selection) -> Params {
    Params {
        controller,
        selection,
        babbling: 200,
        steps: 2000,
        checkpoint: 100,
        ..Params::default()
    }
}

fn human(interaction: Interaction, budget: u32) -> HumanParams {
    HumanParams {
        interaction,
        budget,
        forget_prob: 0.1,
        zeta: 0.1,
    }
}

/// Every (params, seed) pair as a run, with run indices 0, 1, ...
fn runs(params: &[Params], seeds: &[u64]) -> Vec<RunConfig> {
    let mut configs = Vec::new();
    for &p in params {
        for &seed in seeds {
            configs.push(RunConfig {
                params: p,
                seed,
                run_index: configs.len() as u64,
            });
        }
    }
    configs
}

fn all_controllers(selection: Selection) -> Vec<Params> {
    Controller::ALL
        .iter()
        .map(|&c| short(c, selection))
        .collect()
}

/// Whether two floats are the same value (NaN equals NaN; 0.0 equals -0.0).
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Collects mismatches between run `r` of a batch and a naive run in the same position.
struct Diff {
    lines: Vec<String>,
    /// Relative tolerance on floats; 0 for bit-for-bit (integers are always exact).
    tolerance: f64,
}

impl Diff {
    fn new() -> Diff {
        Diff {
            lines: Vec::new(),
            tolerance: 0.0,
        }
    }

    fn f64(&mut self, run: &str, field: &str, batch: f64, naive: f64) {
        let close = (batch - naive).abs() <= self.tolerance * batch.abs().max(naive.abs());
        if !(same(batch, naive) || close) {
            self.lines.push(format!(
                "{run}: {field}: batch {batch:?} != naive {naive:?}"
            ));
        }
    }

    fn int(&mut self, run: &str, field: &str, batch: u64, naive: u64) {
        if batch != naive {
            self.lines
                .push(format!("{run}: {field}: batch {batch} != naive {naive}"));
        }
    }

    fn assert_empty(&self, what: &str) {
        if !self.lines.is_empty() {
            let shown: Vec<&str> = self.lines.iter().take(25).map(String::as_str).collect();
            panic!(
                "{what}: {} mismatches, first ones:\n{}",
                self.lines.len(),
                shown.join("\n")
            );
        }
    }
}

fn describe(config: &RunConfig) -> String {
    let p = &config.params;
    format!(
        "run {} ({} {:?}, {:?} budget {}, q_init {}, N {}, seed {})",
        config.run_index,
        p.controller.name(),
        p.selection,
        p.human.interaction,
        p.human.budget,
        p.q_init,
        p.window_n,
        config.seed
    )
}

/// Compares everything observable of run `r` of `batch` with `naive`.
fn compare_run(diff: &mut Diff, batch: &Batch, r: usize, naive: &NaiveRun) {
    let run = describe(&batch.configs()[r]);
    let (b, n) = (&batch.stats()[r], naive.stats());
    macro_rules! floats {
        ($($f:ident),*) => { $( diff.f64(&run, stringify!($f), b.$f, n.$f); )* };
    }
    macro_rules! ints {
        ($($f:ident),*) => { $( diff.int(&run, stringify!($f), b.$f as u64, n.$f as u64); )* };
    }
    floats!(
        total_reward,
        reward_last10,
        cost_mf,
        cost_mb,
        p_mb_sum,
        entropy_sum
    );
    ints!(
        first_reward_step,
        decisions,
        mb_decisions,
        congratulations,
        takeovers,
        punishments,
        forgotten,
        budget_exhausted_step,
        vi_calls,
        vi_sweeps,
        vi_capped
    );
    let cursor = &batch.cursors()[r];
    diff.int(&run, "state", u64::from(cursor.state), naive.state() as u64);
    diff.int(&run, "t", cursor.t, naive.t());
    diff.int(
        &run,
        "budget_left",
        u64::from(cursor.budget_left),
        u64::from(naive.budget_left()),
    );

    let (bs, ns) = (batch.series(r), naive.series());
    // The batch preallocates every row; compare the ones written so far.
    let written = cursor.checkpoints_written as usize;
    diff.int(&run, "checkpoint rows", written as u64, ns.len() as u64);
    for (i, (x, y)) in bs[..written.min(bs.len())].iter().zip(ns).enumerate() {
        diff.int(
            &run,
            &format!("series[{i}].step"),
            x.step.into(),
            y.step.into(),
        );
        diff.f64(
            &run,
            &format!("series[{i}].cum_reward"),
            x.cum_reward,
            y.cum_reward,
        );
        diff.f64(
            &run,
            &format!("series[{i}].cum_cost_mf"),
            x.cum_cost_mf,
            y.cum_cost_mf,
        );
        diff.f64(
            &run,
            &format!("series[{i}].cum_cost_mb"),
            x.cum_cost_mb,
            y.cum_cost_mb,
        );
        diff.f64(
            &run,
            &format!("series[{i}].p_mb_mean"),
            x.p_mb_mean,
            y.p_mb_mean,
        );
        diff.int(
            &run,
            &format!("series[{i}].decisions"),
            x.decisions.into(),
            y.decisions.into(),
        );
        diff.int(
            &run,
            &format!("series[{i}].interactions"),
            x.interactions.into(),
            y.interactions.into(),
        );
    }

    let spec = batch.spec();
    let (q_mf, q_mb) = (batch.q_mf(r), batch.q_mb(r));
    let (avg_mf, avg_mb) = batch.averaged_probabilities(r);
    let (navg_mf, navg_mb) = naive.averaged_probabilities();
    let t = batch.transition_model(r);
    for s in 0..spec.n_states {
        for a in 0..spec.n_actions {
            diff.f64(
                &run,
                &format!("q_mf[{s}][{a}]"),
                q_mf[[s, a]],
                naive.q_mf()[s][a],
            );
            diff.f64(
                &run,
                &format!("q_mb[{s}][{a}]"),
                q_mb[[s, a]],
                naive.q_mb()[s][a],
            );
            diff.f64(
                &run,
                &format!("avg_p_mf[{s}][{a}]"),
                avg_mf[[s, a]],
                navg_mf[s][a],
            );
            diff.f64(
                &run,
                &format!("avg_p_mb[{s}][{a}]"),
                avg_mb[[s, a]],
                navg_mb[s][a],
            );
            for next in 0..spec.n_states {
                let (x, y) = (t[[s, a, next]], naive.transition(s, a, next));
                if x != y {
                    diff.f64(&run, &format!("T[{s}][{a}][{next}]"), x, y);
                }
            }
        }
    }
}

/// Runs `configs` as one batch and each run naively in `order`, and asserts every observable is
/// equal (floats within the relative `tolerance`; 0 for bit for bit).
fn assert_close(spec: &Arc<Spec>, configs: Vec<RunConfig>, order: Arithmetic, tolerance: f64) {
    let mut batch = Batch::new(Arc::clone(spec), configs.clone()).expect("valid configs");
    batch.run_to_end();
    let mut diff = Diff::new();
    diff.tolerance = tolerance;
    for (r, config) in configs.iter().enumerate() {
        let mut naive =
            NaiveRun::with_arithmetic(spec, config.params, config.seed, config.run_index, order);
        naive.run_to_end();
        compare_run(&mut diff, &batch, r, &naive);
    }
    diff.assert_empty(&format!(
        "{} against the naive reference ({order:?} order)",
        spec.name
    ));
}

/// Bit for bit, with the reference in [`ORDER`].
fn assert_parity(spec: &Arc<Spec>, configs: Vec<RunConfig>) {
    assert_close(spec, configs, ORDER, 0.0);
}

/// A mix of every controller, selection and human on tidy1 and the navigation world.
fn literal_order_cases() -> Vec<(Arc<Spec>, Vec<RunConfig>)> {
    let mut params = all_controllers(Selection::Softmax);
    params.push(short(Controller::Ec, Selection::Argmax));
    params.push(short(Controller::Entropy, Selection::Argmax));
    params.push(Params {
        human: human(Interaction::Congratulation, 50),
        ..short(Controller::Ec, Selection::Softmax)
    });
    let mut cases = vec![(spec("tidy1"), runs(&params, &[1, 2]))];
    if let Some(nav) = navworld() {
        cases.push((nav, runs(&all_controllers(Selection::Softmax), &[3])));
    }
    cases
}

#[test]
fn every_controller_matches_the_naive_reference_in_the_specs_literal_order_bit_for_bit() {
    for (spec, configs) in literal_order_cases() {
        assert_close(&spec, configs, Arithmetic::Spec, 0.0);
    }
}

#[test]
fn the_older_engine_order_changes_only_the_last_bits() {
    // Same trajectories, decisions and counts; floats within 1e-9 relative.
    for (spec, configs) in literal_order_cases() {
        assert_close(&spec, configs, Arithmetic::Engine, 1e-9);
    }
}

#[test]
fn every_controller_and_selection_on_tidy1_matches_the_naive_reference() {
    let spec = spec("tidy1");
    let mut params = all_controllers(Selection::Softmax);
    params.extend(all_controllers(Selection::Argmax));
    assert_parity(&spec, runs(&params, &[1, 2]));
}

#[test]
fn fixed_weights_with_either_selection_match_the_naive_reference() {
    // Never MB, a fair coin, mostly MB, always MB; argmax at 1/2 draws, elsewhere it does not.
    let mut params = Vec::new();
    for selection in [Selection::Softmax, Selection::Argmax] {
        for w_mb in [0.0, 0.5, 0.8, 1.0] {
            params.push(Params {
                w_mb,
                ..short(Controller::Fixed, selection)
            });
        }
    }
    params.push(Params {
        w_mb: 0.3,
        human: human(Interaction::Congratulation, 50),
        ..short(Controller::Fixed, Selection::Softmax)
    });
    let configs = runs(&params, &[1, 2]);
    let spec = spec("tidy1");
    let mut batch = Batch::new(Arc::clone(&spec), configs.clone()).expect("valid configs");
    batch.run_to_end();
    // P(MB) is reported as w_mb at every decision; MB acts never at 0 and always at 1.
    for (r, config) in configs.iter().enumerate() {
        let (p, stats) = (&config.params, &batch.stats()[r]);
        let mean = stats.p_mb_sum / stats.decisions as f64;
        assert!(
            (mean - p.w_mb).abs() < 1e-12,
            "{}: {mean}",
            describe(config)
        );
        if p.w_mb == 0.0 {
            assert_eq!(stats.mb_decisions, 0);
        }
        if p.w_mb == 1.0 || (p.w_mb == 0.8 && p.selection == Selection::Argmax) {
            assert_eq!(stats.mb_decisions, stats.decisions);
        }
    }
    assert_parity(&spec, configs);
}

/// Every controller with `combine = mix` (ignored by mf, mb and vpi), with either selection
/// (mix draws no expert, so selection changes nothing there), and with a congratulating and a
/// taking-over human.
fn mixed() -> Vec<Params> {
    let mut params = Vec::new();
    for selection in [Selection::Softmax, Selection::Argmax] {
        for p in all_controllers(selection) {
            params.push(Params {
                combine: Combine::Mix,
                ..p
            });
        }
    }
    for interaction in [Interaction::Congratulation, Interaction::Takeover] {
        for controller in [Controller::Fixed, Controller::Ec, Controller::Reliability] {
            params.push(Params {
                combine: Combine::Mix,
                w_mb: 0.3,
                human: human(interaction, 50),
                ..short(controller, Selection::Softmax)
            });
        }
    }
    params
}

#[test]
fn combine_mix_matches_the_naive_reference_on_tidy1_and_a_json_world() {
    let configs = runs(&mixed(), &[1, 2]);
    let tidy1 = spec("tidy1");
    assert_parity(&tidy1, configs.clone());
    let json = spec(&format!("json:{TIDY1_FIXTURE}"));
    // json worlds define no interaction: their runs are the ones without a human.
    let alone: Vec<Params> = mixed()
        .into_iter()
        .filter(|p| p.human.interaction == Interaction::None)
        .collect();
    assert_parity(&json, runs(&alone, &[7]));

    // Mixing draws no expert: mb_decisions counts weights above 1/2 (never for fixed at 0.3,
    // every decision for reliability before P_MB falls, never for rnd's exact 1/2), and both
    // experts pay their cost at every decision.
    let mut batch = Batch::new(Arc::clone(&tidy1), configs.clone()).expect("valid configs");
    batch.run_to_end();
    for (r, config) in configs.iter().enumerate() {
        let (p, stats) = (&config.params, &batch.stats()[r]);
        match p.controller {
            Controller::Rnd => {
                assert_eq!(stats.mb_decisions, 0, "{}", describe(config));
                assert_eq!(stats.p_mb_sum, 0.5 * stats.decisions as f64);
            }
            Controller::Fixed if p.w_mb < 0.5 => assert_eq!(stats.mb_decisions, 0),
            Controller::Ec | Controller::Entropy | Controller::Fixed | Controller::Reliability => {
                assert!(
                    stats.cost_mf > 0.0 && stats.cost_mb > 0.0,
                    "{}",
                    describe(config)
                );
                // MB infers at every decision, babbling's included.
                assert!(stats.vi_calls > stats.decisions, "{}", describe(config));
            }
            _ => {}
        }
    }
}

#[test]
fn reliability_and_vpi_with_humans_and_argmax_match_the_naive_reference() {
    let mut params = Vec::new();
    for controller in [Controller::Reliability, Controller::Vpi] {
        for interaction in [
            Interaction::Congratulation,
            Interaction::Takeover,
            Interaction::Punishment,
        ] {
            params.push(Params {
                human: human(interaction, 50),
                ..short(controller, Selection::Softmax)
            });
        }
        params.push(short(controller, Selection::Argmax));
    }
    // A reliability arbiter that stays MB-leaning, and a vpi that plans less.
    params.push(Params {
        rel_a_mf_mb: 5.0,
        rel_b_mf_mb: -2.0,
        rel_memory: 3,
        spe_threshold: 0.2,
        ..short(Controller::Reliability, Selection::Softmax)
    });
    params.push(Params {
        vpi_tau: 2.0,
        kalman_v0: 0.1,
        q_init: 1.0,
        ..short(Controller::Vpi, Selection::Softmax)
    });
    assert_parity(&spec("tidy1"), runs(&params, &[1, 2]));
    assert_parity(&spec("tidy2"), runs(&params, &[3]));
}

#[test]
fn every_controller_on_tidy2_matches_the_naive_reference() {
    let spec = spec("tidy2");
    let mut params = all_controllers(Selection::Softmax);
    params.push(short(Controller::Ec, Selection::Argmax));
    params.push(short(Controller::Entropy, Selection::Argmax));
    assert_parity(&spec, runs(&params, &[3, 4]));
}

#[test]
fn every_controller_on_the_navigation_world_matches_the_naive_reference() {
    let Some(spec) = navworld() else { return };
    let mut params = all_controllers(Selection::Softmax);
    params.push(short(Controller::Ec, Selection::Argmax));
    params.push(short(Controller::Entropy, Selection::Argmax));
    assert_parity(&spec, runs(&params, &[5, 6]));
}

#[test]
fn every_controller_on_the_tidy1_json_fixture_matches_the_naive_reference() {
    let spec = spec(&format!("json:{TIDY1_FIXTURE}"));
    let mut params = all_controllers(Selection::Softmax);
    params.push(short(Controller::Ec, Selection::Argmax));
    assert_parity(&spec, runs(&params, &[7]));
}

#[test]
fn the_tidy1_json_fixture_gives_the_same_runs_as_the_built_in_tidy1() {
    let configs = runs(&all_controllers(Selection::Softmax), &[8]);
    let mut builtin = Batch::new(spec("tidy1"), configs.clone()).unwrap();
    let mut fixture = Batch::new(spec(&format!("json:{TIDY1_FIXTURE}")), configs).unwrap();
    builtin.run_to_end();
    fixture.run_to_end();
    for (r, (x, y)) in builtin.stats().iter().zip(fixture.stats()).enumerate() {
        let (x, y) = (
            mbmf::batch::RunStats {
                wall_time_s: 0.0,
                ..*x
            },
            mbmf::batch::RunStats {
                wall_time_s: 0.0,
                ..*y
            },
        );
        assert_eq!(x, y, "run {r}: built-in tidy1 and the json fixture differ");
        assert_eq!(
            builtin.q_mb(r),
            fixture.q_mb(r),
            "run {r}: MB Q tables differ"
        );
    }
}

#[test]
fn congratulation_takeover_and_punishment_with_budgets_match_the_naive_reference() {
    for task in ["tidy1", "tidy2"] {
        let spec = spec(task);
        let mut params = Vec::new();
        for interaction in [
            Interaction::Congratulation,
            Interaction::Takeover,
            Interaction::Punishment,
        ] {
            // A budget that runs out mid-run and one that lasts.
            for (controller, budget) in [
                (Controller::Mf, 40),
                (Controller::Mb, 1000),
                (Controller::Rnd, 25),
                (Controller::Ec, 60),
                (Controller::Entropy, 1000),
            ] {
                params.push(Params {
                    human: human(interaction, budget),
                    ..short(controller, Selection::Softmax)
                });
            }
        }
        params.push(Params {
            human: human(Interaction::Congratulation, 50),
            ..short(Controller::Ec, Selection::Argmax)
        });
        assert_parity(&spec, runs(&params, &[9]));
    }
}

/// SPEC 3.1's eligibility trace: MF, EC, fixed with mix, reliability and MB (which ignores it)
/// at lambda 0, 0.5 and 1, in one batch each.
fn traced(base: Params) -> Vec<Params> {
    let mut params = Vec::new();
    for lambda_mf in [0.0, 0.5, 1.0] {
        for (controller, combine) in [
            (Controller::Mf, Combine::Select),
            (Controller::Ec, Combine::Select),
            (Controller::Fixed, Combine::Mix),
            (Controller::Reliability, Combine::Select),
            (Controller::Mb, Combine::Select),
        ] {
            params.push(Params {
                controller,
                combine,
                lambda_mf,
                ..base
            });
        }
    }
    params
}

#[test]
fn eligibility_traces_on_tidy1_match_the_naive_reference() {
    let mut params = traced(short(Controller::Mf, Selection::Softmax));
    // With a human too (the step then keeps nothing between decisions).
    params.push(Params {
        lambda_mf: 0.9,
        human: human(Interaction::Congratulation, 50),
        ..short(Controller::Ec, Selection::Softmax)
    });
    params.push(Params {
        lambda_mf: 0.9,
        human: human(Interaction::Takeover, 50),
        ..short(Controller::Mf, Selection::Softmax)
    });
    assert_parity(&spec("tidy1"), runs(&params, &[1, 2]));
}

#[test]
fn the_two_step_task_with_and_without_traces_matches_the_naive_reference() {
    // Babbling 101 ends mid-trial: the trace is cleared and the p drawn afresh there.
    let base = Params {
        tau: 0.2,
        babbling: 101,
        steps: 1000,
        checkpoint: 100,
        ..Params::default()
    };
    let mut params = traced(base);
    params.push(Params {
        controller: Controller::Vpi,
        ..base
    });
    params.push(Params {
        babbling: 0,
        steps: 403,
        lambda_mf: 1.0,
        ..base
    });
    let spec = spec("twostep");
    let configs = runs(&params, &[1, 2]);
    assert_parity(&spec, configs.clone());

    // The stay probabilities of the runs table from the engine's tally equal those counted
    // from the naive run's list of trials.
    let mut batch = Batch::new(Arc::clone(&spec), configs.clone()).expect("valid configs");
    batch.run_to_end();
    for (r, config) in configs.iter().enumerate() {
        let mut naive = NaiveRun::new(&spec, config.params, config.seed, config.run_index);
        naive.run_to_end();
        let tally = batch.tally(r);
        let engine = [RC, RR, UC, UR].map(|kind| twostep::stay(tally, kind));
        assert_eq!(engine, naive.stays(), "{}", describe(config));
        assert!(engine.iter().all(Option::is_some), "{}", describe(config));
    }
}

#[test]
fn q_init_one_and_a_window_of_three_match_the_naive_reference() {
    let spec = spec("tidy1");
    let mut params = Vec::new();
    for &controller in &Controller::ALL {
        params.push(Params {
            q_init: 1.0,
            ..short(controller, Selection::Softmax)
        });
        params.push(Params {
            window_n: 3,
            ..short(controller, Selection::Softmax)
        });
    }
    params.push(Params {
        q_init: 1.0,
        window_n: 3,
        human: human(Interaction::Takeover, 100),
        ..short(Controller::Ec, Selection::Argmax)
    });
    assert_parity(&spec, runs(&params, &[10]));
    if let Some(nav) = navworld() {
        // A window shorter than the branching factor of a stochastic world.
        let params: Vec<Params> = [Controller::Mb, Controller::Ec]
            .iter()
            .map(|&c| Params {
                q_init: 1.0,
                window_n: 3,
                ..short(c, Selection::Softmax)
            })
            .collect();
        assert_parity(&nav, runs(&params, &[11]));
    }
}

/// Different controllers, humans, lengths, windows and parameters in one batch.
fn heterogeneous() -> Vec<RunConfig> {
    let base = short(Controller::Ec, Selection::Softmax);
    let params = [
        Params {
            controller: Controller::Mf,
            steps: 1500,
            ..base
        },
        Params {
            controller: Controller::Mb,
            window_n: 3,
            babbling: 0,
            ..base
        },
        Params {
            controller: Controller::Rnd,
            human: human(Interaction::Takeover, 30),
            checkpoint: 77,
            ..base
        },
        Params {
            window_n: 25,
            kappa_coeff: 2.0,
            ..base
        },
        Params {
            selection: Selection::Argmax,
            q_init: 1.0,
            human: human(Interaction::Congratulation, 40),
            ..base
        },
        Params {
            controller: Controller::Entropy,
            tau: 0.1,
            alpha_mf: 0.3,
            filter_alpha: 0.9,
            normalise_entropy: false,
            human: human(Interaction::Punishment, 20),
            steps: 900,
            babbling: 350,
            ..base
        },
        Params {
            gamma_mb: 0.8,
            vi_epsilon: 0.001,
            checkpoint: 0,
            ..base
        },
    ];
    params
        .iter()
        .enumerate()
        .map(|(i, &params)| RunConfig {
            params,
            seed: 12 + i as u64 % 2,
            run_index: 3 * i as u64,
        })
        .collect()
}

#[test]
fn a_heterogeneous_batch_equals_each_run_simulated_alone() {
    let spec = spec("tidy1");
    let configs = heterogeneous();
    let mut together = Batch::new(Arc::clone(&spec), configs.clone()).unwrap();
    together.run_to_end();
    let mut diff = Diff::new();
    for (r, config) in configs.iter().enumerate() {
        let mut alone = Batch::new(Arc::clone(&spec), vec![*config]).unwrap();
        alone.run_to_end();
        let run = describe(config);
        let (x, y) = (&together.stats()[r], &alone.stats()[0]);
        let (x, y) = (
            mbmf::batch::RunStats {
                wall_time_s: 0.0,
                ..*x
            },
            mbmf::batch::RunStats {
                wall_time_s: 0.0,
                ..*y
            },
        );
        if x != y {
            diff.lines
                .push(format!("{run}: stats together {x:?} != alone {y:?}"));
        }
        let (sx, sy) = (together.series(r), alone.series(0));
        diff.int(&run, "series length", sx.len() as u64, sy.len() as u64);
        for (i, (a, b)) in sx.iter().zip(sy).enumerate() {
            let equal = a.step == b.step
                && same(a.cum_reward, b.cum_reward)
                && same(a.cum_cost_mf, b.cum_cost_mf)
                && same(a.cum_cost_mb, b.cum_cost_mb)
                && same(a.p_mb_mean, b.p_mb_mean)
                && a.decisions == b.decisions
                && a.interactions == b.interactions;
            if !equal {
                diff.lines
                    .push(format!("{run}: series[{i}] together {a:?} != alone {b:?}"));
            }
        }
        if together.q_mf(r) != alone.q_mf(0) || together.q_mb(r) != alone.q_mb(0) {
            diff.lines.push(format!("{run}: Q tables differ"));
        }
        if together.transition_model(r) != alone.transition_model(0) {
            diff.lines.push(format!("{run}: transition models differ"));
        }
    }
    diff.assert_empty("heterogeneous batch against runs alone");
    // And the batch as a whole against the naive reference.
    assert_parity(&spec, configs);
}

#[test]
fn advancing_in_uneven_chunks_matches_the_naive_reference_at_every_pause() {
    let spec = spec("tidy1");
    let configs = heterogeneous();
    let mut batch = Batch::new(Arc::clone(&spec), configs.clone()).unwrap();
    let mut naives: Vec<NaiveRun> = configs
        .iter()
        .map(|c| NaiveRun::with_arithmetic(&spec, c.params, c.seed, c.run_index, ORDER))
        .collect();
    let mut diff = Diff::new();
    for chunk in [1, 199, 1, 337, 1000, 5, 2000] {
        batch.advance(chunk);
        for (r, naive) in naives.iter_mut().enumerate() {
            for _ in 0..chunk {
                naive.step();
            }
            compare_run(&mut diff, &batch, r, naive);
        }
        diff.assert_empty(&format!("after advancing to step {}", naives[0].t()));
    }
    assert!(naives.iter().all(NaiveRun::finished));
}

/// As [`assert_parity`], run `r` following `schedules[run_schedule[r]]` (SPEC 10); also compares
/// the counters and change results of SPEC 10 and 11.
fn assert_parity_scheduled(
    spec: &Arc<Spec>,
    configs: Vec<RunConfig>,
    schedules: &[Schedule],
    run_schedule: &[usize],
) {
    let mut batch =
        Batch::with_schedules(Arc::clone(spec), configs.clone(), schedules, run_schedule)
            .expect("valid schedules");
    batch.run_to_end();
    let mut diff = Diff::new();
    for (r, config) in configs.iter().enumerate() {
        let none = Schedule::default();
        let schedule = run_schedule.get(r).map_or(&none, |&i| &schedules[i]);
        let mut naive =
            NaiveRun::with_schedule(spec, config.params, config.seed, config.run_index, schedule);
        naive.run_to_end();
        compare_run(&mut diff, &batch, r, &naive);
        let run = format!("{} [{schedule}]", describe(config));
        let (b, n) = (&batch.stats()[r], naive.stats());
        for (field, x, y) in [
            ("rewards_given", b.rewards_given, n.rewards_given),
            ("nuisances", b.nuisances, n.nuisances),
            (
                "first_change_step",
                b.first_change_step,
                n.first_change_step,
            ),
            (
                "first_reward_after_change",
                b.first_reward_after_change,
                n.first_reward_after_change,
            ),
        ] {
            diff.int(&run, field, x.into(), y.into());
        }
        diff.f64(
            &run,
            "reward_before_change",
            b.reward_before_change,
            n.reward_before_change,
        );
        assert_eq!(batch.schedule_text(r), schedule.to_string());
    }
    diff.assert_empty(&format!(
        "{} with schedules against the naive reference",
        spec.name
    ));
}

fn schedules(texts: &[&str]) -> Vec<Schedule> {
    texts
        .iter()
        .map(|t| Schedule::parse(t).unwrap_or_else(|e| panic!("{t}: {e}")))
        .collect()
}

/// Every (params, seed, schedule) as a run: configurations and their schedule indices.
fn scheduled_runs(
    params: &[Params],
    seeds: &[u64],
    n_schedules: usize,
) -> (Vec<RunConfig>, Vec<usize>) {
    let mut configs = Vec::new();
    let mut which = Vec::new();
    for i in 0..n_schedules {
        for c in runs(params, seeds) {
            configs.push(RunConfig {
                run_index: configs.len() as u64,
                ..c
            });
            which.push(i);
        }
    }
    (configs, which)
}

#[test]
fn box_assignments_and_human_changes_on_tidy1_match_the_naive_reference() {
    let tidy1 = spec("tidy1");
    let list = schedules(&[
        "",
        "1000:boxes=brg",
        "500:boxes=gbr;1500:boxes=rgb",
        "800:interaction=congratulation;800:budget=100;1400:interaction=takeover;1400:budget=40",
        "600:profile=nuisance;1200:interaction=punishment;1200:zeta=0.3;1700:forget=0",
        "700:reward_source=human;700:budget=60;1300:boxes=bgr;1600:profile=rewards-then-leaves",
    ]);
    let params: Vec<Params> = [Controller::Mf, Controller::Mb, Controller::Ec]
        .iter()
        .map(|&c| short(c, Selection::Softmax))
        .collect();
    let (configs, which) = scheduled_runs(&params, &[5], list.len());
    assert_parity_scheduled(&tidy1, configs, &list, &which);
}

#[test]
fn nuisance_human_reward_and_reward_shaping_match_the_naive_reference() {
    let mut params = Vec::new();
    for controller in [
        Controller::Mf,
        Controller::Mb,
        Controller::Rnd,
        Controller::Ec,
    ] {
        let base = short(controller, Selection::Softmax);
        params.push(Params {
            human: human(Interaction::Nuisance, 80),
            ..base
        });
        params.push(Params {
            human: human(Interaction::None, 100),
            reward_source: RewardSource::Human,
            ..base
        });
        params.push(Params {
            human: human(Interaction::Congratulation, 200),
            reward_source: RewardSource::Human,
            ..base
        });
        params.push(Params {
            human: human(Interaction::Congratulation, 60),
            congratulation_effect: CongratulationEffect::Reward,
            ..base
        });
        params.push(Params {
            human: human(Interaction::Takeover, 30),
            boxes: Boxes::parse("brg").unwrap(),
            ..base
        });
    }
    let tidy1 = spec("tidy1");
    assert_parity_scheduled(&tidy1, runs(&params, &[8]), &[], &[]);
    // Task 2: a nuisance turns the LEDs off.
    let tidy2 = spec("tidy2");
    let two: Vec<Params> = params
        .iter()
        .filter(|p| p.boxes == Boxes::RGB)
        .take(8)
        .copied()
        .collect();
    assert_parity_scheduled(&tidy2, runs(&two, &[9]), &[], &[]);
}

/// The tidy1 fixture as a `json:` world, and a copy of it without a few transitions on the way
/// to the goal, exported to a temporary folder.
fn json_worlds() -> (Arc<Spec>, tempfile::TempDir, String, Vec<(u32, u32)>) {
    let base = spec(&format!("json:{TIDY1_FIXTURE}"));
    // The first outcome of action 0 in states 0 to 2, and the arrival in the goal from its first
    // predecessor.
    let mut pairs: Vec<(u32, u32)> = (0..3)
        .map(|s| {
            (
                s,
                base.outcome_state[base.outcomes(base.sa(s as usize, 0)).start],
            )
        })
        .collect();
    let into_goal = (0..base.n_states * base.n_actions)
        .find(|&sa| {
            base.outcomes(sa)
                .any(|o| Some(base.outcome_state[o]) == base.goal_state())
        })
        .unwrap();
    pairs.push((
        (into_goal / base.n_actions) as u32,
        base.goal_state().unwrap(),
    ));
    let cut = mbmf::schedule::delete(&base, &pairs).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let paths = env::json::export(&cut, dir.path()).unwrap();
    (base, dir, format!("json:{}", paths.model.display()), pairs)
}

#[test]
fn goal_moves_world_swaps_and_deletions_on_a_json_world_match_the_naive_reference() {
    let (base, _dir, cut, pairs) = json_worlds();
    let delete: Vec<String> = pairs.iter().map(|(a, b)| format!("{a}-{b}")).collect();
    // A goal the robot reaches often: a state next to the start.
    let near = base.outcome_state[base.outcomes(base.sa(0, 1)).start];
    let texts = [
        String::new(),
        format!("1000:goal={near}"),
        format!(
            "1000:goal={near}:2.5;1500:goal={}",
            base.goal_state().unwrap()
        ),
        format!("900:world={cut}"),
        format!("900:delete={}", delete.join(",")),
        format!(
            "700:delete={};1200:world=json:{TIDY1_FIXTURE};1200:goal={near}",
            delete[0]
        ),
        "800:reward_source=human;800:budget=30".to_string(),
    ];
    let texts: Vec<&str> = texts.iter().map(String::as_str).collect();
    let list = schedules(&texts);
    let params: Vec<Params> = Controller::ALL
        .iter()
        .map(|&c| short(c, Selection::Softmax))
        .collect();
    let (configs, which) = scheduled_runs(&params, &[4], list.len());
    assert_parity_scheduled(&base, configs, &list, &which);
}

#[test]
fn the_navigation_world_changes_of_the_authors_match_the_naive_reference() {
    let Some(nav) = navworld() else { return };
    let dir = Path::new(NAVWORLD).parent().unwrap().display().to_string();
    let texts = [
        String::new(),
        format!("1601:goal=34;1601:world=json:{dir}/realisticNavWorld_newGoal.json"),
        "1601:delete=20-21,21-20".to_string(),
        format!("1601:world=json:{dir}/realisticNavWorld_noTrans20-21.json"),
    ];
    let texts: Vec<&str> = texts.iter().map(String::as_str).collect();
    let list = schedules(&texts);
    let params: Vec<Params> = Controller::ALL
        .iter()
        .map(|&c| Params {
            steps: 3200,
            ..short(c, Selection::Softmax)
        })
        .collect();
    let (configs, which) = scheduled_runs(&params, &[6], list.len());
    assert_parity_scheduled(&nav, configs, &list, &which);
}
