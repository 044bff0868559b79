//! Tasks of the task registry run end to end: `chain`, the smallest registered task, through
//! `mbmf run` with the Parquet read back, its registry defaults, and its refusals.

mod common;

use common::{Row, rows, run, run_quiet};

/// The runs table of `mbmf run ARGS` written to a temporary folder.
fn runs_of(args: &[&str]) -> Vec<Row> {
    let dir = tempfile::tempdir().unwrap();
    run_quiet(dir.path(), args);
    let runs = rows(dir.path(), &[]);
    runs.into_iter()
        .filter(|r| !r.contains_key("step"))
        .collect()
}

fn number(row: &Row, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} = {} is not a number", row[column]))
}

#[test]
fn chain_runs_end_to_end_and_its_reward_is_bounded_by_the_reset_steps() {
    let runs = runs_of(&[
        "--task",
        "chain",
        "--controller",
        "mf,mb,ec",
        "--runs",
        "3",
        "--steps",
        "400",
        "--babbling",
        "50",
    ]);
    assert_eq!(runs.len(), 9);
    for row in &runs {
        assert_eq!(row["task"], "chain");
        assert_eq!(row["steps"], "400");
        let reward = number(row, "total_reward");
        // Every reward is an arrival in the goal and the next step is the reset step, so at
        // most one step in two is rewarded: 200 in 400 steps (reward 1 each).
        assert!(reward <= 200.0, "{row:?}");
        assert_eq!(reward, reward.round(), "rewards are whole: {row:?}");
        // One action of two reaches the goal: any learner gets most of the possible reward.
        assert!(reward >= 150.0, "{row:?}");
        assert!(number(row, "first_reward_step") >= 1.0, "{row:?}");
    }
}

#[test]
fn chain_takes_its_steps_and_babbling_from_the_registry() {
    let runs = runs_of(&["--task", "chain", "--controller", "mf", "--runs", "1"]);
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["steps"], "1000");
    assert_eq!(runs[0]["babbling"], "100");
    // tidy1 keeps the paper's.
    let runs = runs_of(&[
        "--task",
        "tidy1",
        "--controller",
        "mf",
        "--runs",
        "1",
        "--steps",
        "10",
    ]);
    assert_eq!(runs[0]["babbling"], "1000");
}

#[test]
fn chain_refuses_interactions_and_tidy_parameters() {
    for (flags, message) in [
        (
            &["--interaction", "takeover", "--budget", "5"][..],
            "interaction 'takeover' is not defined for task 'chain'",
        ),
        (
            &["--boxes", "brg"][..],
            "boxes is a parameter of tidy1, not of task 'chain'",
        ),
    ] {
        let mut args = vec![
            "run",
            "--task",
            "chain",
            "--quiet",
            "--out",
            "/nonexistent/x",
        ];
        args.extend_from_slice(flags);
        let out = run(&args);
        // A usage error: exit code 2, and the message names the task.
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(message), "{stderr}");
    }
}

#[test]
fn a_drawn_reward_is_given_at_about_its_probability_and_a_fixed_one_always() {
    use std::sync::Arc;

    use mbmf::batch::{Batch, RunConfig};
    use mbmf::env::{Chance, chain};
    use mbmf::params::{Controller, Params};

    // The chain with its goal rewarded with probability 0.3: `mf` runs reach the goal nearly
    // every other step, so the reward per arrival estimates p.
    let spec = chain::build();
    let mut arrivals = spec.arrival.clone();
    for arrival in arrivals.iter_mut().filter(|a| a.terminal()) {
        arrival.chance = Chance::Drawn(0.3);
    }
    let spec = spec.with_arrivals(arrivals);
    let params = Params {
        controller: Controller::Mf,
        steps: 2_000,
        babbling: 0,
        ..Params::default()
    };
    let configs = (0..20)
        .map(|r| RunConfig {
            params,
            seed: 7,
            run_index: r,
        })
        .collect();
    let mut batch = Batch::new(Arc::new(spec), configs).unwrap();
    assert_eq!(batch.spec().goal, None);
    batch.run_to_end();
    // Every step but the reset steps decides, and every reset step follows an arrival in the
    // goal (the last arrival's may fall beyond the end): arrivals = steps - decisions, + 0 or 1.
    let (mut rewarded, mut arrivals) = (0.0, 0u64);
    for stats in batch.stats() {
        rewarded += stats.total_reward;
        arrivals += 2_000 - stats.decisions;
    }
    // About 18,000 arrivals (action 1 is preferred once learnt): the rewarded share's sd is
    // sqrt(0.3 x 0.7 / 18,000) = 0.0034; 0.02 is about 6 sd, and the +1 per run is 0.001.
    assert!(arrivals > 10_000, "{arrivals}");
    let share = rewarded / arrivals as f64;
    assert!(
        (share - 0.3).abs() < 0.02,
        "{rewarded} rewards in {arrivals} arrivals"
    );
}
